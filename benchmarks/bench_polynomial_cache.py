"""SM on a parallel polynomial: a selection with and without the polynomial fit cache, side by side.

Run:  .venv/bin/python benchmarks/bench_polynomial_cache.py [--quick]

What the benchmark's ``sm-parallel-poly`` selection does: several ``ParallelSetMembership``
candidates with ``parallel_degree=3, parallel_fit="simulation"`` on the same lags and data,
differing only in the SM map (noise bound, estimate). Each fit starts by fitting the same
polynomial for simulation (Levenberg-Marquardt, the costly part); ``PolynomialNARX.fit`` now
remembers its last fits per parameters and data, so the second and later candidates copy it.
Both ways are timed in one run on a Duffing-like oscillator, the cache cleared before every fit
for the old way; the candidates' free runs are checked identical. Read the ratio: the machine
is shared.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from neckid import IOData, Lags, ParallelSetMembership
from neckid.models.cache import POLYNOMIAL_FITS

CANDIDATES = (
    {"epsilon": 0.01, "estimate": "central"},
    {"epsilon": 0.03, "estimate": "central"},
    {"epsilon": 0.01, "estimate": "projection"},
    {"epsilon": 0.03, "estimate": "projection"},
)


def duffing(n: int, seed: int) -> IOData:
    """y(t) = 1.5 y(t-1) - 0.7 y(t-2) - 0.1 y(t-1)^3 + 0.4 u(t-1), measured with noise."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1.0, 1.0, n // 5 + 1), 5)[:n]
    x = np.zeros(n)
    for t in range(2, n):
        x[t] = 1.5 * x[t - 1] - 0.7 * x[t - 2] - 0.1 * x[t - 1] ** 3 + 0.4 * u[t - 1]
    return IOData(u, x + 0.01 * rng.normal(size=n), ts=0.01)


def select(train: IOData, test: IOData, clear: bool) -> tuple[float, list[np.ndarray]]:
    """Fit every candidate; return the wall time and each one's free run of ``test``."""
    POLYNOMIAL_FITS.clear()
    runs = []
    started = time.perf_counter()
    for params in CANDIDATES:
        if clear:
            POLYNOMIAL_FITS.clear()
        model = ParallelSetMembership(
            Lags.arx(2, 2, 1), parallel_degree=3, parallel_fit="simulation", **params
        ).fit(train)
        runs.append(model.simulate(test).y)
    return time.perf_counter() - started, runs


def main() -> None:
    """Time the selection both ways and print the ratio."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="5,000 samples instead of 30,000")
    args = parser.parse_args()
    n = 5_000 if args.quick else 30_000
    train, test = duffing(n, seed=1), duffing(2_000, seed=2)
    select(duffing(1_000, seed=3), test, clear=True)  # compile first
    old, old_runs = select(train, test, clear=True)
    new, new_runs = select(train, test, clear=False)
    for a, b in zip(old_runs, new_runs, strict=True):
        np.testing.assert_array_equal(a, b)
    print(
        f"{len(CANDIDATES)} SM-on-polynomial candidates, N = {n:,}, lags Lags.arx(2, 2, 1), degree 3"
    )
    print(f"  without the cache: {old:.2f} s")
    print(f"  with the cache:    {new:.2f} s")
    print(f"  ratio: {old / new:.2f}x (the same free run for every candidate)")


if __name__ == "__main__":
    main()
