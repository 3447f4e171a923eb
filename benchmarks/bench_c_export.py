"""Speed of a Set Membership free run exported to C against the Python free run (issue 44).

Run:  .venv/bin/python benchmarks/bench_c_export.py [--samples 10000] [--train 4000] [--repeat 5]

An SM model (``Lags.arx(2, 2)``, velocity command to inclination) is identified on a run of the
simulated neck, exported with ``neckid.export.c.write_c`` and compiled with the system's ``cc``
(``-O2 -std=c99``) beside a small timing program. Both then free-run the same ``--samples``-long
test run from the same initial rows:

- Python: ``model.simulate(test)`` (the compiled kd-tree free run and the run's checks), and the
  compiled kernel alone (``model.core_.free_run``); best of ``--repeat`` after a warm-up;
- C: the stepping loop alone (``NAME_reset`` then ``NAME_step_bounds`` per sample, timed with
  ``clock_gettime`` inside the program, best of ``--repeat`` passes), and the whole process
  (start, reading the log as text, stepping, printing), best of ``--repeat``.

The outputs are checked equal to the bit before the times are printed. The issue's floor: the C
run at least as fast as the Python free run (``simulate``), ratio >= 1.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from neckid import IOData, Lags, methods
from neckid.export.c import write_c
from neckid.plant import SoftNeck

_TIMER = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "sm.h"

int main(int argc, char **argv)
{
    size_t n, t, k;
    int pass, passes = argc > 1 ? atoi(argv[1]) : 5;
    double *u, *y, *lower, *upper, best = 1e300;
    if (scanf("%zu", &n) != 1) return 2;
    u = malloc(n * sizeof *u); y = malloc(n * sizeof *y);
    lower = malloc(n * sizeof *y); upper = malloc(n * sizeof *y);
    for (t = 0; t < n; ++t) if (scanf("%la %la", &u[t], &y[t]) != 2) return 2;
    for (pass = 0; pass < passes; ++pass) {
        struct timespec a, b;
        sm_state s;
        double seconds;
        clock_gettime(CLOCK_MONOTONIC, &a);
        sm_reset(&s, y, u);
        for (t = sm_INITIAL_ROWS; t < n; ++t) sm_step_bounds(&s, &u[t], &y[t], &lower[t], &upper[t]);
        clock_gettime(CLOCK_MONOTONIC, &b);
        seconds = (double)(b.tv_sec - a.tv_sec) + 1e-9 * (double)(b.tv_nsec - a.tv_nsec);
        if (seconds < best) best = seconds;
    }
    printf("%a\n", best);
    for (k = sm_INITIAL_ROWS; k < n; ++k) printf("%a\n", y[k]);
    return 0;
}
"""


def neck_run(n: int, seed: int) -> IOData:
    """The simulated neck under a random velocity staircase (held 0.5 s) with a small PRBS."""
    rng = np.random.default_rng(seed)
    steps = np.repeat(rng.uniform(-0.6, 0.6, size=n // 25 + 1), 25)[:n]
    commands = steps + 0.2 * rng.choice([-1.0, 1.0], size=n)
    log = SoftNeck().run(commands, ts=0.02)
    return log.select(inputs=["velocity_command"], outputs=["inclination"])


def best_of(function, repeat: int) -> tuple[float, object]:
    best, result = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=10_000)
    parser.add_argument("--train", type=int, default=4_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    cc = shutil.which("cc")
    if cc is None:
        print("no C compiler (cc) on PATH")
        return 1
    model = methods()["sm"].make(Lags.arx(2, 2)).fit(neck_run(args.train, 0))
    test = neck_run(args.samples, 1)
    m = model.max_lag_
    folder = Path(tempfile.mkdtemp(prefix="bench-c-"))
    write_c(model, folder, "sm")
    (folder / "timer.c").write_text(_TIMER)
    program = folder / "timer"
    subprocess.run(
        [cc, "-O2", "-std=c99", str(folder / "sm.c"), str(folder / "timer.c"), "-lm", "-o",
         str(program)], check=True,
    )  # fmt: skip
    text = f"{test.n_samples}\n" + "\n".join(
        f"{float(a).hex()} {float(b).hex()}"
        for a, b in zip(test.u[:, 0], test.y[:, 0], strict=True)
    )
    model.simulate(test)  # warm-up: the compiled kernels loaded
    t_simulate, result = best_of(lambda: model.simulate(test), args.repeat)
    y0 = np.array(test.y, dtype=np.float64)
    t_kernel, _ = best_of(lambda: model.core_.free_run(test.u, y0, model.lags_), args.repeat)

    def c_process(passes: int) -> str:
        return subprocess.run(
            [str(program), str(passes)], input=text, capture_output=True, text=True, check=True
        ).stdout

    t_process, _ = best_of(lambda: c_process(1), args.repeat)  # one pass: the whole process
    lines = c_process(args.repeat).split()  # best of --repeat passes of the loop, timed inside
    t_loop = float.fromhex(lines[0])
    y_c = np.array([float.fromhex(v) for v in lines[1:]])
    same = np.array_equal(y_c, result.y[m:, 0])  # type: ignore[attr-defined]
    print(f"SM model: {model.n_samples_} training points, {model.lags_.n_terms} terms; "
          f"test run {test.n_samples} samples; outputs equal to the bit: {same}")  # fmt: skip
    print(f"Python simulate (kd-tree free run + checks): {1e3 * t_simulate:8.2f} ms")
    print(f"Python compiled kernel alone (core_.free_run): {1e3 * t_kernel:8.2f} ms")
    print(f"C stepping loop (reset + step_bounds):       {1e3 * t_loop:8.2f} ms")
    print(f"C whole process (start, read text, step, print): {1e3 * t_process:8.2f} ms")
    print(f"ratio Python simulate / C loop: {t_simulate / t_loop:.1f}x; kernel / C loop:"
          f" {t_kernel / t_loop:.2f}x; simulate / C process: {t_simulate / t_process:.2f}x")  # fmt: skip
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
