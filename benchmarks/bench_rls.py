"""Speed of the CFF-RLS loop: compiled kernel vs the NumPy reference vs padasip's FilterRLS.

Run:  .venv/bin/python benchmarks/bench_rls.py [--samples 1000000] [--padasip-samples 100000]

padasip is optional (the ``bench`` extra: ``pip install -e .[bench]``); without it the padasip
column is skipped with a message. The three implementations run the same equations (Landau et al.,
2011) on the same 2-parameter ARX data, and the script checks that their final estimates agree
before it prints the speeds. Figures are samples per second, best of ``--repeat`` runs.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np
from scipy import signal

from neckid import IOData
from neckid.models.rls import RecursiveARX, rls_reference

FORGETTING_FACTOR = 0.98
INITIAL_COVARIANCE = 1e4


def make_data(n: int, seed: int = 0) -> IOData:
    """y(t) = 0.8 y(t-1) + 0.5 u(t-1) + e(t): a 2-parameter ARX system."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=n)
    y = signal.lfilter([0.0, 0.5], [1.0, -0.8], u) + 0.01 * rng.normal(size=n)
    return IOData(u, y, ts=0.02)


def best_time(function: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--reference-samples", type=int, default=50_000)
    parser.add_argument("--padasip-samples", type=int, default=50_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    data = make_data(args.samples)
    model = RecursiveARX(
        na=1, nb=1, forgetting_factor=FORGETTING_FACTOR, initial_covariance=INITIAL_COVARIANCE
    )
    model.fit(data[:1000])  # compile (cached on disk after the first run)
    compiled_s = best_time(lambda: model.fit(data), args.repeat)
    compiled_rate = args.samples / compiled_s
    print(f"RecursiveARX.fit (numba kernel), {args.samples} samples, 2 parameters:")
    print(f"  {compiled_s * 1e3:9.1f} ms   {compiled_rate / 1e6:8.2f} M samples/s")

    small = data[: args.reference_samples]
    phi, y = model.fit(small)._regressor(small)
    compiled_small = model.theta_.copy()
    reference_s = best_time(
        lambda: rls_reference(phi, y, FORGETTING_FACTOR, INITIAL_COVARIANCE * np.eye(2)),
        args.repeat,
    )
    history, *_ = rls_reference(phi, y, FORGETTING_FACTOR, INITIAL_COVARIANCE * np.eye(2))
    np.testing.assert_allclose(history[-1], compiled_small, rtol=1e-8)
    reference_rate = args.reference_samples / reference_s
    print(f"rls_reference (plain NumPy), {args.reference_samples} samples:")
    print(
        f"  {reference_s * 1e3:9.1f} ms   {reference_rate / 1e6:8.4f} M samples/s"
        f"   -> compiled is {compiled_rate / reference_rate:6.0f}x faster"
    )

    try:
        from padasip.filters import FilterRLS
    except ImportError:
        print(
            "padasip is not installed, so the padasip comparison is skipped. Install the benchmark"
            " extra with `pip install -e .[bench]` (or `pip install padasip`) and run again."
        )
        return
    n_pad = args.padasip_samples
    small = data[:n_pad]
    phi, y = model.fit(small)._regressor(small)
    compiled_pad = model.theta_.copy()

    def run_padasip() -> np.ndarray:
        filt = FilterRLS(n=2, mu=FORGETTING_FACTOR, eps=1.0 / INITIAL_COVARIANCE, w="zeros")
        filt.run(y, phi)
        return np.asarray(filt.w)

    padasip_s = best_time(run_padasip, args.repeat)
    np.testing.assert_allclose(run_padasip(), compiled_pad, rtol=1e-6)
    padasip_rate = n_pad / padasip_s
    print(f"padasip FilterRLS.run, {n_pad} samples (same equations, same final estimate):")
    print(
        f"  {padasip_s * 1e3:9.1f} ms   {padasip_rate / 1e6:8.4f} M samples/s"
        f"   -> compiled is {compiled_rate / padasip_rate:6.0f}x faster"
    )


if __name__ == "__main__":
    main()
