"""Wall time of a lag search on this machine vs on a 2-worker Dask cluster, and the same result.

Run:  .venv/bin/python benchmarks/bench_dask.py [--method nn] [--samples 2000] [--workers 2]

Needs the ``dask`` extra (``pip install -e .[dask]``). :func:`neckid.select_lags` ranks a grid of
lag sets (``lag_grid([1, 2, 3], [1, 2, 3], [1, 2])``: 18 candidates) by free-run fit, three times:

- locally, one process (``n_jobs=1``);
- locally, joblib's default process pool with ``--workers`` processes (``n_jobs=--workers``);
- on a ``distributed.LocalCluster`` of ``--workers`` single-threaded worker processes with
  ``NUMBA_NUM_THREADS=1`` (``backend="dask"``), the way it would run on a real cluster, first
  cold (the workers import neckid and load its compiled kernels), then warm.

The cluster's start-up time is printed apart. The script checks that the three tables are
equal (every column but the wall time ``fit_time_s``) before it prints the times and the speed-up
``local time / cluster time``. On a real cluster the gain grows with the number of workers and
with the cost of one fit (neural networks, Set Membership on long records); for a fit of a few
milliseconds (linear ARX) the scheduling overhead dominates.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np
import pandas as pd

from neckid import IOData, LinearARX, SetMembership
from neckid.models.neural.narx import NeuralNARX
from neckid.selection.lags import LagSelection, lag_grid, select_lags


def make_data(n: int, seed: int = 0) -> IOData:
    """A mildly nonlinear ARX system: y(t) = 0.7 y(t-1) - 0.1 y(t-2) + tanh(u(t-2)) + e(t)."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-2, 2, size=n)
    e = 0.01 * rng.normal(size=n)
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = 0.7 * y[t - 1] - 0.1 * y[t - 2] + np.tanh(u[t - 2]) + e[t]
    return IOData(u, y, ts=0.02)


def make_estimator(method: str) -> Any:
    if method == "arx":
        return LinearARX()
    if method == "sm":
        return SetMembership()
    return NeuralNARX(hidden_layer_sizes=(10,), max_iter=150, n_networks=1, random_state=0)


def run(data: IOData, method: str, **kwargs: Any) -> tuple[LagSelection, float]:
    split = int(0.75 * data.n_samples)
    grid = lag_grid([1, 2, 3], [1, 2, 3], [1, 2])
    start = time.perf_counter()
    result = select_lags(
        data[:split], data[split:], grid, make_estimator(method), progress=False, **kwargs
    )
    return result, time.perf_counter() - start


def scores(result: LagSelection) -> pd.DataFrame:
    return result.table.drop(columns=["fit_time_s"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", choices=["nn", "sm", "arx"], default="nn")
    parser.add_argument("--samples", type=int, default=2000)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise SystemExit("bench_dask needs the dask extra: pip install -e .[dask]") from None

    data = make_data(args.samples)
    print(f"select_lags, 18 candidates, {args.method}, {args.samples} samples")
    local, t_local = run(data, args.method, n_jobs=1)
    print(f"  local, n_jobs=1:                  {t_local:7.2f} s")
    pool, t_pool = run(data, args.method, n_jobs=args.workers)
    print(f"  local, n_jobs={args.workers} (loky):           {t_pool:7.2f} s")

    start = time.perf_counter()
    with (
        LocalCluster(
            n_workers=args.workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            # One numba thread per worker, as joblib's own processes get: the SM kernels are
            # numba-parallel, and 2 workers x 2 threads on 2 cores spin against each other.
            env={"NUMBA_NUM_THREADS": "1"},
        ) as cluster,
        Client(cluster),
    ):
        t_start = time.perf_counter() - start
        cold, t_cold = run(data, args.method, backend="dask")
        warm, t_warm = run(data, args.method, backend="dask")
    print(f"  Dask LocalCluster start-up:       {t_start:7.2f} s")
    print(f"  Dask, {args.workers} workers, cold:           {t_cold:7.2f} s")
    print(f"  Dask, {args.workers} workers, warm:           {t_warm:7.2f} s")
    print(f"  speed-up local n_jobs=1 / Dask warm: {t_local / t_warm:.2f}x")

    for name, other in (("loky", pool), ("Dask cold", cold), ("Dask warm", warm)):
        pd.testing.assert_frame_equal(scores(other), scores(local))
        assert other.best_lags == local.best_lags, name
    print(f"  identical tables (but fit_time_s); best lags {local.best_lags!r}")


if __name__ == "__main__":
    main()
