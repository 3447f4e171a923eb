"""Wall time of the first and the second ``neckid demo --quick`` after a fresh install (issue 18).

Run:  .venv/bin/python benchmarks/bench_first_run.py [--profile] [--keep]

A fresh install has the Python sources and their byte code but no compiled numba kernels. The
script imitates one honestly without touching the installed package: both runs get
``NUMBA_CACHE_DIR`` pointing at a new, empty folder, which numba consults before (and instead
of) any ``__pycache__`` beside the sources, so the first run compiles every kernel the demo
calls and writes it there, and the second run loads them. Each run is ``neckid demo --quick
--out <temporary folder> --force`` in its own process, timed from outside (interpreter start-up
included). The issue's floors: the second run at most 6 s on 2 cores, the first at most 10 s
slower than the second.

``--profile`` then runs the demo a third time (warm cache) under ``cProfile`` and prints the
functions with the largest cumulative time, and the slowest imports of ``python -X importtime``,
so that one can see where the second run's time goes.
"""

from __future__ import annotations

import argparse
import os
import pstats
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: The issue's floors, seconds.
SECOND_RUN_FLOOR = 6.0
FIRST_RUN_EXTRA_FLOOR = 10.0


def demo_command(work: Path) -> list[str]:
    """``neckid demo --quick`` through a two-line script (``cProfile`` runs scripts, not ``-c``)."""
    script = work / "neckid_demo.py"
    script.write_text("from neckid.cli import app\n\napp()\n", encoding="utf-8")
    return [sys.executable, str(script), "demo", "--quick", "--out", str(work / "demo"), "--force"]


def timed_run(command: list[str], env: dict[str, str]) -> float:
    start = time.perf_counter()
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    elapsed = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{done.stdout}\n{done.stderr}")
    return elapsed


def profile(work: Path, env: dict[str, str]) -> None:
    stats_file = work / "demo.prof"
    command = demo_command(work)
    profiled = [sys.executable, "-m", "cProfile", "-o", str(stats_file), *command[1:]]
    timed_run(profiled, env)
    print("\nwhere the time goes, warm cache (cProfile, cumulative seconds, top entries):")
    stats = pstats.Stats(str(stats_file))
    stats.sort_stats("cumulative")
    rows = []
    for (filename, line, name), (_, _, _, cumulative, _) in stats.stats.items():  # type: ignore[attr-defined]
        if "neckid" in filename or name in ("<built-in method time.sleep>",):
            short = filename.split("site-packages/")[-1].split("src/")[-1]
            rows.append((cumulative, f"{short}:{line}({name})"))
    for cumulative, where in sorted(rows, reverse=True)[:25]:
        print(f"  {cumulative:7.2f} s  {where}")
    importtime = subprocess.run(
        [sys.executable, "-X", "importtime", *command[1:]],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    imports = []
    for line in importtime.stderr.splitlines():
        fields = line.removeprefix("import time:").split("|")
        # top-level imports have one space before the name, nested ones two more per level
        if len(fields) == 3 and fields[1].strip().isdigit() and not fields[2].startswith("  "):
            imports.append((int(fields[1]), fields[2].strip()))
    print("\nslowest top-level imports (python -X importtime, cumulative):")
    for micros, name in sorted(imports, reverse=True)[:12]:
        print(f"  {micros / 1e6:7.2f} s  {name}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile", action="store_true", help="profile a third (warm) run")
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder")
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="neckid-first-run-"))
    try:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(work / "numba-cache"))
        first = timed_run(demo_command(work), env)
        second = timed_run(demo_command(work), env)
        kernels = len(list((work / "numba-cache").rglob("*.nbi")))
        print(f"neckid demo --quick with an empty numba cache ({kernels} kernels cached by run 1)")
        print(f"  first run   {first:6.1f} s")
        print(f"  second run  {second:6.1f} s   (floor {SECOND_RUN_FLOOR:.0f} s)")
        print(f"  difference  {first - second:6.1f} s   (floor {FIRST_RUN_EXTRA_FLOOR:.0f} s)")
        if args.profile:
            profile(work, env)
    finally:
        if args.keep:
            print(f"kept {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
