"""The benchmark's candidate fits one at a time against on every local core (issue 33).

Run:  .venv/bin/python benchmarks/bench_benchmark_parallel.py DATA [--only softneck,cascaded_tanks]

(without DATA it says so and stops: the benchmark needs the real logs and public data sets).

Runs ``run_benchmark`` twice in one process on the same data sets: ``n_jobs=1`` (the library's
default) and ``n_jobs=-1`` (the command line's default since issue 33), checks that the two
tables agree in every column but the times, and prints both wall times and their ratio. DATA
holds ``softneck/`` and ``benchmarks/NAME/``. On a shared machine read the ratio, not the times.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from pathlib import Path

import pandas as pd

from neckid.experiments.benchmark import run_benchmark


def timed(data: str, only: list[str], n_jobs: int, out: Path) -> tuple[float, pd.DataFrame]:
    """Wall time [s] and table of one benchmark run."""
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = run_benchmark(data, benchmarks=only, n_jobs=n_jobs, output_dir=out, force=True)
    return time.perf_counter() - start, report.table


def main() -> None:
    """Time both ways side by side and print the ratio."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="?", help="folder holding softneck/ and benchmarks/")
    parser.add_argument("--only", default="softneck,cascaded_tanks")
    args = parser.parse_args()
    if args.data is None:  # `make bench` runs every script without arguments
        print("bench_benchmark_parallel: give the data folder (e.g. ../shared/data) to time it")
        return
    only = args.only.split(",")
    with tempfile.TemporaryDirectory() as folder:
        serial, one = timed(args.data, only, 1, Path(folder) / "serial")
        parallel, many = timed(args.data, only, -1, Path(folder) / "parallel")
    kept = [c for c in one.columns if not c.endswith("time_s")]
    same = one[kept].equals(many[kept])
    print(f"benchmark {args.only} on {os.cpu_count()} cores")
    print(f"n_jobs=1:  {serial:8.1f} s")
    print(f"n_jobs=-1: {parallel:8.1f} s   ratio {serial / parallel:.2f}x   same table: {same}")


if __name__ == "__main__":
    main()
