"""Speed of the CFF-RLS loop: compiled kernel vs online update vs NumPy reference vs padasip.

Run:  .venv/bin/python benchmarks/bench_rls.py [--samples 1000000] [--update-samples 20000]

padasip is optional (the ``bench`` extra: ``pip install -e .[bench]``); without it the padasip
column is skipped with a message. The implementations run the same equations (Landau et al.,
2011) on the same ARX data, and the script checks that their estimates agree before it prints
the speeds. Figures are samples per second, best of ``--repeat`` runs.

Cases: one output (2 parameters) and two outputs of three inputs (``Lags.arx(2, 2)``: 10
parameters, one covariance shared by both outputs). ``RecursiveARX.update`` (one Python call per
sample, true online use) is timed beside ``fit`` (the compiled loop over a whole log), and the
ratio of their costs per sample printed; the number of times the history arrays were
re-allocated during the online loop shows that they grow by doubling, not per sample.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np
from scipy import signal

from neckid import IOData, Lags
from neckid.models.linear.rls import RecursiveARX, rls_reference

FORGETTING_FACTOR = 0.98
INITIAL_COVARIANCE = 1e4


def make_data(n: int, seed: int = 0) -> IOData:
    """y(t) = 0.8 y(t-1) + 0.5 u(t-1) + e(t): a 2-parameter ARX system."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=n)
    y = signal.lfilter([0.0, 0.5], [1.0, -0.8], u) + 0.01 * rng.normal(size=n)
    return IOData(u, y, ts=0.02)


def make_mimo_data(n: int, seed: int = 1) -> IOData:
    """Two coupled outputs driven by three inputs (stable), with a little noise."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 3))
    y = np.zeros((n, 2))
    e = 0.01 * rng.normal(size=(n, 2))
    for t in range(2, n):
        y[t, 0] = 0.6 * y[t - 1, 0] + 0.2 * y[t - 1, 1] + 0.5 * u[t - 1, 0] - 0.3 * u[t - 2, 2]
        y[t, 1] = -0.3 * y[t - 1, 0] + 0.7 * y[t - 1, 1] + 0.8 * u[t - 1, 1] + e[t, 1]
        y[t, 0] += e[t, 0]
    return IOData(u, y, ts=0.02)


def best_time(function: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def online_versus_batch(label: str, lags: Lags, data: IOData, n_online: int, repeat: int) -> None:
    """Time ``fit`` over ``data`` and ``update`` over its first ``n_online`` samples; print both."""
    model = RecursiveARX(
        lags, forgetting_factor=FORGETTING_FACTOR, initial_covariance=INITIAL_COVARIANCE
    )
    model.fit(data[:1000])  # compile (cached on disk after the first run)
    batch_s = best_time(lambda: model.fit(data), repeat)
    n_params = model.lags_.n_terms
    n_batch = data.n_samples
    batch_per_sample = batch_s / n_batch
    print(f"{label}: {n_params} parameters x {model.n_outputs_} output(s)")
    print(
        f"  fit (compiled loop), {n_batch} samples: {batch_s * 1e3:9.1f} ms"
        f"   {1 / batch_per_sample / 1e6:8.2f} M samples/s   {batch_per_sample * 1e9:8.1f} ns/sample"
    )
    part = data[:n_online]
    rows = list(zip(part.y if model.n_outputs_ > 1 else part.y[:, 0], part.u, strict=True))

    def run_online() -> tuple[RecursiveARX, int]:
        online = RecursiveARX(
            lags, forgetting_factor=FORGETTING_FACTOR, initial_covariance=INITIAL_COVARIANCE
        )
        online.update(*rows[0])
        buffer, allocations = online._history._theta, 1
        for y, u in rows[1:]:
            online.update(y, u)
            if online._history._theta is not buffer:
                buffer, allocations = online._history._theta, allocations + 1
        return online, allocations

    online_s = best_time(run_online, repeat)
    online, n_buffers = run_online()
    reference = RecursiveARX(
        lags, forgetting_factor=FORGETTING_FACTOR, initial_covariance=INITIAL_COVARIANCE
    ).fit(part)
    np.testing.assert_allclose(online.theta_history_, reference.theta_history_, rtol=1e-10)
    online_per_sample = online_s / n_online
    print(
        f"  update (one call per sample), {n_online} samples: {online_s * 1e3:9.1f} ms"
        f"   {1 / online_per_sample / 1e6:8.4f} M samples/s   {online_per_sample * 1e6:8.2f} us/sample"
        f"   -> {online_per_sample / batch_per_sample:6.0f}x the batch cost per sample"
    )
    print(
        f"  history arrays allocated {n_buffers} time(s) over {n_online} updates (doubling);"
        " update equals fit on the same record (rtol 1e-10)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--update-samples", type=int, default=20_000)
    parser.add_argument("--reference-samples", type=int, default=50_000)
    parser.add_argument("--padasip-samples", type=int, default=50_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    data = make_data(args.samples)
    model = RecursiveARX(
        Lags.arx(1, 1), forgetting_factor=FORGETTING_FACTOR, initial_covariance=INITIAL_COVARIANCE
    )
    model.fit(data[:1000])  # compile (cached on disk after the first run)
    compiled_s = best_time(lambda: model.fit(data), args.repeat)
    compiled_rate = args.samples / compiled_s
    print(f"RecursiveARX.fit (numba kernel), {args.samples} samples, 2 parameters:")
    print(f"  {compiled_s * 1e3:9.1f} ms   {compiled_rate / 1e6:8.2f} M samples/s")

    n_update = args.update_samples
    online_versus_batch("One output, Lags.arx(1, 1)", Lags.arx(1, 1), data, n_update, args.repeat)
    mimo = make_mimo_data(max(args.samples // 5, n_update))
    online_versus_batch(
        "Two outputs, three inputs, Lags.arx(2, 2)", Lags.arx(2, 2), mimo, n_update, args.repeat
    )

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
