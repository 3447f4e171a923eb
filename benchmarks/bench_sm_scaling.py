"""Set Membership fit at scale: N → fit time and memory, and the prior check old vs new.

Run:  .venv/bin/python benchmarks/bench_sm_scaling.py [--quick] [--large] [--terms 6]
      [--sizes 100000,1000000] [--prior default given]

Each row is one fit of ``SetMembership`` on a neck-like system (``_systems.neck_like``: three
past outputs and three inputs at lags 8..10, n = 12 regressors; with ``--terms 6`` three past
outputs and the three inputs at lag 8, n = 6), in a fresh subprocess so that its peak memory is
its own. Three ways of choosing the prior:

- ``default``: ε at the knee of the γ*(ε) curve (48 ε values), γ = 1.1 γ*(ε);
- ``epsilon``: ε = the simulated noise bound 1e-3 given, with ``epsilons=[ε]`` so that γ*(ε)
  is computed at that ε only (not on the whole default grid), γ = 1.1 γ*(ε);
- ``given``: ε = 1e-3 and γ = 1.1 γ*(ε) given by the user (γ*(ε) is computed beforehand, not
  timed): the fit checks γ >= γ*(ε).

Columns: the fit time; the prior check of the old path (the bounds at all N training points,
``prior_holds_by_query``) and of the new one (branch and bound started at γ, ``prior_holds``;
``default`` and ``epsilon`` need none: γ = 1.1 γ*(ε) holds by construction), timed on the fitted tree
side by side, with their ratio; the fit's peak memory (tracemalloc, every NumPy and numba
allocation) and what the fitted model keeps, in bytes per training sample and as a multiple of
the raw regressor matrix (N·n·8 bytes); and the fit's peak resident set size above the process
before the fit (VmHWM after resetting it, from a heap trimmed by ``malloc_trim``, Linux). Targets (issue 18): N = 1e6 in < 60 s and
< 2 GB, memory <= 2x the raw regressor.

``--quick`` runs N = 1e4 and 3e4 (< 30 s); the default N = 1e4, 1e5, 1e6 (``--sizes`` picks
others); ``--large`` adds N = 1e7 without the default rule (its 48-ε curve is out of reach
there: see docs/scaling.md; the old check is extrapolated by N^1.4 from N = 1e6). ``--prior``
picks the ways of choosing the prior (all three by default). The memory target of issue 33:
the default fit's peak <= 100 bytes per sample at n = 6 (``--terms 6 --prior default``). On a
shared 2-core machine timings are noisy.
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import json
import os
import subprocess
import sys
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numba
import numpy as np
from _systems import NECK_LIKE_LAGS, NECK_LIKE_NOISE, neck_like

from neckid import Lags
from neckid.models.set_membership._kernels.gamma import gamma_star
from neckid.models.set_membership.narx import SetMembership
from neckid.models.set_membership.training import prior_holds

#: The regressor by number of terms: the neck-like 12, or three past outputs and the inputs at 8.
LAGS = {12: NECK_LIKE_LAGS, 6: Lags(outputs=3, inputs=[8])}
#: Samples dropped at the start of the log: its output is 0 until sample 10 and its inputs hold
#: their first value, so with six terms (lags 1-3 and 8) its first rows are identical regressors
#: with different targets, which would set ε (γ*(ε) infinite below half their spread).
SKIP = {12: 0, 6: 10}
MARGIN = 1.1
#: The ways of choosing (ε, γ), see the module docstring.
PRIORS = ("given", "epsilon", "default")
#: Above this N the old check (N queries, about N^1.4) is extrapolated, not run.
OLD_CHECK_LIMIT = 1_000_000


def _status_kib(field: str) -> int | None:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(field + ":"):
                return int(line.split()[1])
    except OSError:
        return None
    return None


def _reset_peak_rss() -> bool:
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        return False
    return True


def _old_check() -> Callable[..., Any]:
    """The previous prior check (the bounds at every training point), kept beside the tests."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from _sm_reference import prior_holds_by_query

    return prior_holds_by_query  # type: ignore[no-any-return]


def worker(n: int, mode: str, terms: int) -> dict:
    """One fit of N regressors; returns the measurements (run in its own process)."""
    lags = LAGS[terms]
    skip = SKIP[terms]
    warm = neck_like(25_000, seed=0)[skip:]  # above the tree's and the search's thresholds
    model = SetMembership(lags, progress=False).fit(warm)  # compile / load the kernel cache
    SetMembership(lags, epsilon=NECK_LIKE_NOISE, gamma=5.0, progress=False).fit(warm)
    tree = model._tree
    gamma_star(tree.points, tree.targets, model.gamma_curve_.epsilons, tree=tree, slopes="always")
    del model, tree
    data = neck_like(n + lags.max_lag + skip, seed=1)[skip:]
    kwargs: dict = {}
    if mode == "epsilon":
        kwargs = {"epsilon": NECK_LIKE_NOISE, "epsilons": [NECK_LIKE_NOISE]}
    elif mode == "given":
        x, y = lags.build(data)
        points = np.ascontiguousarray(x / x.std(axis=0))
        star = gamma_star(points, y, np.array([[NECK_LIKE_NOISE]]))[0, 0]
        kwargs = {"epsilon": NECK_LIKE_NOISE, "gamma": MARGIN * float(star)}
        del x, y, points
    raw = n * lags.resolve([data]).n_terms * 8
    # From a trimmed heap, as bench_sm_default_cost.py measures it (issue 42): otherwise the
    # allocator's free pages left by the warm-up are reused and the figure depends on them.
    gc.collect()
    ctypes.CDLL("libc.so.6").malloc_trim(0)
    rss_before = _status_kib("VmRSS")
    reset = _reset_peak_rss()
    tracemalloc.start()
    start_bytes = tracemalloc.get_traced_memory()[0]
    start = time.perf_counter()
    model = SetMembership(lags, progress=False, **kwargs).fit(data)
    fit_time = time.perf_counter() - start
    retained, peak = (v - start_bytes for v in tracemalloc.get_traced_memory())
    tracemalloc.stop()
    hwm = _status_kib("VmHWM")
    rss_peak = (hwm - rss_before) * 1024 if reset and hwm and rss_before else None

    tree, epsilon, gamma = model._tree, model.epsilon_, model.gamma_
    start = time.perf_counter()
    valid_new, _ = prior_holds(tree, epsilon, gamma)
    new_check = time.perf_counter() - start
    old_check: float | None = None
    if n <= OLD_CHECK_LIMIT:
        start = time.perf_counter()
        valid_old = _old_check()(tree, epsilon, gamma)
        old_check = time.perf_counter() - start
        assert np.array_equal(valid_old, valid_new), (valid_old, valid_new)
    return {
        "n": n,
        "mode": mode,
        "fit": fit_time,
        "new_check": new_check if mode == "given" else 0.0,
        "new_check_run": new_check,
        "old_check": old_check,
        "peak": peak,
        "retained": retained,
        "rss_peak": rss_peak,
        "raw": raw,
        "epsilon": float(epsilon[0]),
        "gamma": float(gamma[0]),
        "valid": bool(valid_new.all()),
    }


def run(n: int, mode: str, terms: int) -> dict:
    """:func:`worker` in a fresh interpreter."""
    command = [sys.executable, __file__, "--worker", str(n), mode, str(terms)]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"worker N={n} {mode} failed:\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _row(result: dict, old_fit: dict[str, tuple[int, float]]) -> str:
    n, raw = result["n"], result["raw"]
    old = result["old_check"]
    extrapolated = ""
    if old is None and result["mode"] in old_fit:  # N^1.4 from the largest N measured
        base_n, base_t = old_fit[result["mode"]]
        old, extrapolated = base_t * (n / base_n) ** 1.4, "~"
    new = result["new_check"]
    ratio = f"{old / new:6.0f}x" if old and new > 0 else "      -"
    old_text = f"{extrapolated}{old:.2f}" if old is not None else "-"
    new_text = f"{new:8.2f}" if result["mode"] == "given" else "    none"
    rss = f"{result['rss_peak'] / 2**20:8.0f}" if result["rss_peak"] is not None else "     n/a"
    return (
        f"{n:>10,} {result['mode']:>8} {result['fit']:8.2f} {old_text:>9} {new_text} {ratio}"
        f" {result['peak'] / n:8.0f} {result['retained'] / n:8.0f}"
        f" {result['peak'] / raw:6.2f}x {result['retained'] / raw:6.2f}x {rss}"
        f" {raw / 2**20:8.0f}"
    )


HEADER = (
    f"{'N':>10} {'prior':>8} {'fit s':>8} {'old chk':>9} {'new chk':>8} {'ratio':>7}"
    f" {'peak':>8} {'kept':>8} {'peak':>7} {'kept':>7} {'RSS pk':>8} {'raw':>8}\n"
    f"{'':>10} {'':>8} {'':>8} {'s':>9} {'s':>8} {'':>7}"
    f" {'B/sample':>8} {'B/sample':>8} {'/raw':>7} {'/raw':>7} {'MB':>8} {'MB':>8}"
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="N = 1e4 and 3e4 only (< 30 s)")
    parser.add_argument("--large", action="store_true", help="also N = 1e7 (not 'default')")
    parser.add_argument(
        "--prior", nargs="+", choices=PRIORS, default=list(PRIORS), help="which priors to run"
    )
    parser.add_argument("--terms", type=int, choices=sorted(LAGS), default=12, help="n")
    parser.add_argument("--sizes", help="comma-separated N (instead of the default sizes)")
    parser.add_argument("--worker", nargs=3, metavar=("N", "MODE", "TERMS"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(int(args.worker[0]), args.worker[1], int(args.worker[2]))))
        return
    sizes = [10_000, 30_000] if args.quick else [10_000, 100_000, 1_000_000]
    if args.sizes:
        sizes = [int(float(v)) for v in args.sizes.split(",")]
    jobs = [(n, mode) for n in sizes for mode in args.prior]
    if args.large:
        jobs += [(10_000_000, mode) for mode in args.prior if mode != "default"]
    print(
        f"SetMembership fit, neck-like system, n = {args.terms}; numba {numba.__version__},"
        f" {numba.get_num_threads()} threads, {os.cpu_count()} CPUs visible, load average"
        f" {os.getloadavg()[0]:.2f} (shared machine: timings are noisy)"
    )
    print("raw = N·n·8 bytes; 'kept' = what the fitted model holds; old chk = bounds at all N\n")
    print(HEADER)
    old_fit: dict[str, tuple[int, float]] = {}
    for n, mode in jobs:
        start = time.perf_counter()
        result = run(n, mode, args.terms)
        if result["old_check"] is not None:
            old_fit[mode] = (n, result["old_check"])
        print(_row(result, old_fit), flush=True)
        if not result["valid"]:
            print(
                f"{'':>10} prior check failed: epsilon={result['epsilon']} gamma={result['gamma']}"
            )
        if time.perf_counter() - start > 60:
            print(f"{'':>10} (the subprocess took {time.perf_counter() - start:.0f} s in all)")


if __name__ == "__main__":
    main()
