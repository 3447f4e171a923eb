"""The benchmark's work one unit at a time against on every local core (issue 33).

Run:  .venv/bin/python benchmarks/bench_benchmark_parallel.py DATA [--only softneck,cascaded_tanks]
      [--methods arx,sm,...]

(without DATA it says so and stops: the benchmark needs the real logs and public data sets).

Runs ``run_benchmark`` twice in one process on the same data sets: ``n_jobs=1`` (the library's
default) and ``n_jobs=-1`` (the command line's default), checks that the two tables agree in every
column but the times and that the details agree, and prints both wall times, their ratio, the
seconds of work the units took (summed over workers: the time one core would need) and how
busy the cores were (work / (wall × cores)). DATA holds ``softneck/`` and ``benchmarks/NAME/``.
On a shared machine read the ratio and the work, not the wall times.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

from neckid.experiments.benchmark import run_benchmark


def timed(data: str, only: list[str], methods: list[str] | None, n_jobs: int, out: Path) -> Any:
    """Wall time [s] and report of one benchmark run."""
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = run_benchmark(
            data, methods, benchmarks=only, n_jobs=n_jobs, output_dir=out, force=True
        )
    return time.perf_counter() - start, report


def work(report: Any) -> float:
    """Seconds of work of every unit of the run (summed over the workers)."""
    return float(sum(stage["work_s"] for stage in report.timings["stages"]))


def main() -> None:
    """Time both ways side by side and print the ratio."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="?", help="folder holding softneck/ and benchmarks/")
    parser.add_argument("--only", default="softneck,cascaded_tanks")
    parser.add_argument("--methods", default=None, help="comma-separated; default every method")
    args = parser.parse_args()
    if args.data is None:  # `make bench` runs every script without arguments
        print("bench_benchmark_parallel: give the data folder (e.g. ../shared/data) to time it")
        return
    only = args.only.split(",")
    methods = args.methods.split(",") if args.methods else None
    with tempfile.TemporaryDirectory() as folder:
        serial, one = timed(args.data, only, methods, 1, Path(folder) / "serial")
        parallel, many = timed(args.data, only, methods, -1, Path(folder) / "parallel")
    kept = [c for c in one.table.columns if not c.endswith("time_s")]
    same = one.table[kept].equals(many.table[kept]) and one.details == many.details
    cores = os.cpu_count() or 1
    print(f"benchmark {args.only} on {cores} cores; load average {os.getloadavg()[0]:.2f}")
    print(f"n_jobs=1:  {serial:8.1f} s   work {work(one):8.1f} s")
    print(
        f"n_jobs=-1: {parallel:8.1f} s   work {work(many):8.1f} s   ratio"
        f" {serial / parallel:.2f}x   cores busy {work(many) / (parallel * cores):.0%}"
        f"   same table: {same}"
    )
    for i, stage in enumerate(many.timings["stages"], 1):
        print(
            f"  stage {i}: {stage['units']:4d} units  wall {stage['wall_time_s']:7.1f} s"
            f"  work {stage['work_s']:7.1f} s"
        )


if __name__ == "__main__":
    main()
