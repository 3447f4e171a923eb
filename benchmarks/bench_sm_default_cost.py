"""The default Set Membership fit against the fit with ε and γ given: time and memory (issue 42).

Run:  .venv/bin/python benchmarks/bench_sm_default_cost.py [--sizes 100000,1000000] [--busy]
      [--repeat 1]

``SetMembership(Lags(outputs=3, inputs=[8]))`` (n = 6 terms) on the neck-like log of
``bench_sm_scaling.py --terms 6`` (``_systems.neck_like`` from sample 10 on), each size in a fresh
subprocess:

- ``default``: ε at the knee of the γ*(ε) curve, γ = 1.1 γ*(ε) (the default fit);
- ``given``: the ε and γ the default fit chose, given (``SetMembership(lags, epsilon=ε,
  gamma=γ)``: the fit checks γ >= γ*(ε) and builds the same model);
- ``noise``: ``bench_sm_scaling.py``'s ``given`` fit: ε = the simulated noise bound 1e-3 and
  γ = 1.1 γ*(ε) (γ*(ε) computed beforehand, not timed), the comparison of issues 33 and 42.

The two are timed side by side in the same subprocess, alternating, ``--repeat`` times each
(the median is reported). ``--busy`` starts a second process that keeps one core busy for the
whole run (a plain Python loop), so that the load average is 2 or more on a 2-core machine; the
load average is printed before and after.

Memory, in bytes per training sample, measured two ways in the same subprocess:

- ``HWM``: the growth of the process's peak resident set (``VmHWM``) over one default fit
  after a warm-up default fit: the garbage collected and ``malloc_trim(0)`` called, the peak
  reset to the current resident set (``/proc/self/clear_refs``), then the fit; the figure is
  ``VmHWM`` after it minus ``VmRSS`` before it. Without the trim the allocator's free pages
  left by the warm-up are reused, and the figure depends on what ran before (25 to 70 B/sample
  at 1e5 rows in a quick check);
- ``traced``: the peak of ``tracemalloc`` over another default fit (NumPy's allocations only:
  numba's own arrays and the threads' stacks are not traced), the measure of
  ``bench_sm_scaling.py``'s ``peak`` column.

Both are printed; the issue's figure (≤ 100 B/sample at 1e5 rows) is the ``HWM`` one.
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import json
import os
import statistics
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numba
import numpy as np
from _systems import NECK_LIKE_NOISE, neck_like

from neckid import Lags
from neckid.models.set_membership._kernels.gamma import gamma_star
from neckid.models.set_membership.narx import SetMembership

LAGS = Lags(outputs=3, inputs=[8])
SKIP = 10  # see bench_sm_scaling.SKIP


def _status_kib(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise RuntimeError(f"{field} not in /proc/self/status")


def hwm_growth(fit: object) -> int:
    """Bytes by which ``VmHWM`` grows over ``fit()`` from a trimmed heap (see the module)."""
    gc.collect()
    ctypes.CDLL("libc.so.6").malloc_trim(0)
    Path("/proc/self/clear_refs").write_text("5")  # VmHWM := VmRSS
    before = _status_kib("VmRSS")
    fit()  # type: ignore[operator]
    return (_status_kib("VmHWM") - before) * 1024


def traced_peak(fit: object) -> int:
    """Peak bytes of NumPy's allocations over ``fit()`` (tracemalloc)."""
    gc.collect()
    tracemalloc.start()
    start = tracemalloc.get_traced_memory()[0]
    fit()  # type: ignore[operator]
    peak = tracemalloc.get_traced_memory()[1] - start
    tracemalloc.stop()
    return peak


def worker(n: int, repeat: int) -> dict:
    """Time and memory of the default and the given fit at N rows (run in its own process)."""
    warm = neck_like(25_000, seed=0)[SKIP:]
    first = SetMembership(LAGS, progress=False).fit(warm)  # compile / load the kernel caches
    SetMembership(
        LAGS, epsilon=first.epsilon_.tolist(), gamma=first.gamma_.tolist(), progress=False
    ).fit(warm)
    del warm, first
    data = neck_like(n + LAGS.max_lag + SKIP, seed=1)[SKIP:]
    model = SetMembership(LAGS, progress=False).fit(data)  # the warm-up default fit
    epsilon, gamma = model.epsilon_.tolist(), model.gamma_.tolist()
    del model

    x, y = LAGS.build(data)
    points = np.ascontiguousarray(x / x.std(axis=0))
    star = float(gamma_star(points, y, np.array([[NECK_LIKE_NOISE]]))[0, 0])
    del x, y, points

    def noise() -> None:
        SetMembership(LAGS, epsilon=NECK_LIKE_NOISE, gamma=1.1 * star, progress=False).fit(data)

    def default() -> None:
        SetMembership(LAGS, progress=False).fit(data)

    def given() -> None:
        fitted = SetMembership(LAGS, epsilon=epsilon, gamma=gamma, progress=False).fit(data)
        assert fitted.gamma_.tolist() == gamma

    hwm = hwm_growth(default)
    traced = traced_peak(default)
    times: dict[str, list[float]] = {"default": [], "given": [], "noise": []}
    loads = [os.getloadavg()[0]]
    for _ in range(repeat):
        for name, fit in (("default", default), ("given", given), ("noise", noise)):
            start = time.perf_counter()
            fit()
            times[name].append(time.perf_counter() - start)
            loads.append(os.getloadavg()[0])
    return {
        "n": n,
        "default": statistics.median(times["default"]),
        "given": statistics.median(times["given"]),
        "noise": statistics.median(times["noise"]),
        "hwm": hwm / n,
        "traced": traced / n,
        "epsilon": epsilon[0],
        "gamma": gamma[0],
        "load": [min(loads), max(loads)],
    }


def _spin() -> None:  # pragma: no cover - the busy process
    while True:
        pass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100000", help="comma-separated N (default 1e5)")
    parser.add_argument("--repeat", type=int, default=1, help="timed fits of each kind")
    parser.add_argument("--busy", action="store_true", help="keep one core busy meanwhile")
    parser.add_argument("--worker", nargs=2, metavar=("N", "REPEAT"), help=argparse.SUPPRESS)
    parser.add_argument("--spin", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.spin:
        _spin()
    if args.worker:
        print(json.dumps(worker(int(args.worker[0]), int(args.worker[1]))))
        return
    busy = None
    if args.busy:
        busy = subprocess.Popen([sys.executable, __file__, "--spin"])
        time.sleep(60)  # let the one-minute load average take it in
    try:
        print(
            f"SetMembership, n = 6, default fit vs (ε, γ) given; numba {numba.__version__},"
            f" {numba.get_num_threads()} threads, {os.cpu_count()} CPUs; busy process:"
            f" {'yes' if busy else 'no'}; load average {os.getloadavg()[0]:.2f}\n"
        )
        print(
            "| N | default [s] | given [s] | ratio | noise [s] | ratio | HWM growth [B/sample] |"
            " traced peak [B/sample] | load average |\n|---:|---:|---:|---:|---:|---:|---:|---:|---|"
        )
        for n in [int(float(v)) for v in args.sizes.split(",")]:
            command = [sys.executable, __file__, "--worker", str(n), str(args.repeat)]
            done = subprocess.run(command, capture_output=True, text=True, check=False)
            if done.returncode != 0:
                raise RuntimeError(f"worker N={n} failed:\n{done.stderr}")
            r = json.loads(done.stdout.strip().splitlines()[-1])
            print(
                f"| {n:,} | {r['default']:.2f} | {r['given']:.2f} |"
                f" {r['default'] / r['given']:.1f}x | {r['noise']:.2f} |"
                f" {r['default'] / r['noise']:.1f}x | {r['hwm']:.0f} | {r['traced']:.0f} |"
                f" {r['load'][0]:.1f}-{r['load'][1]:.1f} |",
                flush=True,
            )
        print(f"\nload average at the end: {os.getloadavg()[0]:.2f}")
    finally:
        if busy is not None:
            busy.kill()
            busy.wait()


if __name__ == "__main__":
    main()
