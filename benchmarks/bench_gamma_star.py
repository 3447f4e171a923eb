"""γ*(ε) speed: kd-tree branch and bound vs the all-pairs kernel, side by side, checked equal.

Run:  .venv/bin/python benchmarks/bench_gamma_star.py [--quick] [--large]

γ*(ε) = max_{i≠j} (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖ (Milanese & Novara 2004). Targets (issue 18):

- γ* at one ε >= 20x faster than the all-pairs kernel at N = 100,000 neck-like regressors;
- N = 1,000,000, n = 12, one ε, under 60 s on 2 cores (``--large``; the all-pairs time there is
  extrapolated from N = 100,000 by the pair count, as running it would take hours).

Regressors are those of ``bench_set_membership.py``: a simulated system shaped like the neck
(y(t-1..t-3), three inputs at lags 8..10, n = 12, scaled to unit variance), targets ỹ the raw
outputs; the one ε is the simulated noise bound (1e-3), the grid the estimator's default 48 values.
A second table uses i.i.d. uniform points in 12-D, where kd-trees degrade, and a third a
degenerate 1-D case where every pair has the same slope and no pair can be pruned, to show what
``method="auto"`` does when the tree does not pay. Each row checks that the methods agree bit for
bit. Timings on a shared 2-core machine are noisy: read the ratios, measured side by side.
"""

from __future__ import annotations

import argparse
import logging
import os
import time
from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from _systems import NECK_LIKE_LAGS, NECK_LIKE_NOISE, neck_like

from neckid.models.set_membership._kernels.gamma import gamma_star
from neckid.models.set_membership.prior import _default_epsilons

LAGS = NECK_LIKE_LAGS
NOISE = NECK_LIKE_NOISE


def neck_points(n: int, seed: int = 6) -> tuple[np.ndarray, np.ndarray]:
    x, y = LAGS.build(neck_like(n + LAGS.max_lag, seed))
    return np.ascontiguousarray(x / x.std(axis=0)), np.ascontiguousarray(y)


class _Stats(logging.Handler):
    """Keeps the work counts that ``gamma_star`` logs at DEBUG level."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.last: dict[str, int] = {}

    def emit(self, record: logging.LogRecord) -> None:
        self.last = dict(record.args[1])  # type: ignore[index]


STATS = _Stats()


def timed(function: Callable[[], Any]) -> tuple[float, Any]:
    start = time.perf_counter()
    result = function()
    return time.perf_counter() - start, result


def compare(label: str, points: np.ndarray, targets: np.ndarray, grid: np.ndarray) -> float:
    """Time pairs, tree and auto on one problem; check they agree; print one row."""
    t_pairs, g_pairs = timed(lambda: gamma_star(points, targets, grid, method="pairs"))
    t_tree, g_tree = timed(lambda: gamma_star(points, targets, grid, method="tree"))
    tree_stats = STATS.last
    t_auto, g_auto = timed(lambda: gamma_star(points, targets, grid, method="auto"))
    auto_stats = STATS.last
    np.testing.assert_array_equal(g_tree, g_pairs)
    np.testing.assert_array_equal(g_auto, g_pairs)
    pairs = tree_stats["pairs"]
    handed = auto_stats["pair_rows"] / max(points.shape[0], 1)
    print(
        f"  {label:<42} {t_pairs:8.2f} s {t_tree:8.2f} s {t_auto:8.2f} s"
        f" {t_pairs / t_tree:7.1f}x {t_pairs / t_auto:7.1f}x"
        f"   {tree_stats['computed'] / pairs:8.2e} {tree_stats['tested'] / pairs:8.2e}"
        f"  {handed:5.0%}"
    )
    return t_pairs


HEADER = (
    f"  {'':<42} {'pairs':>10} {'tree':>10} {'auto':>10} {'tree':>8} {'auto':>8}"
    f"   {'pair d²':>8} {'box d²':>8}  {'auto→'}\n"
    f"  {'':<42} {'':>10} {'':>10} {'':>10} {'speed-up':>8} {'speed-up':>8}"
    f"   {'/ pairs':>8} {'/ pairs':>8}  {'pairs'}"
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller sizes (a smoke run)")
    parser.add_argument("--large", action="store_true", help="also N = 1,000,000, tree only")
    args = parser.parse_args()
    sizes = [2_000, 10_000] if args.quick else [20_000, 100_000]
    logger = logging.getLogger("neckid.models.set_membership._kernels.gamma")
    logger.addHandler(STATS)
    logger.setLevel(logging.DEBUG)

    print(
        f"numba {numba.__version__}, {numba.get_num_threads()} threads,"
        f" {os.cpu_count()} CPUs visible (shared machine: timings are noisy)"
    )
    start = time.perf_counter()
    warm_x, warm_y = neck_points(3_000)
    for method in ("pairs", "tree"):
        gamma_star(warm_x, warm_y, _default_epsilons(warm_y), method=method)
    print(f"compile / cache load of the kernels: {time.perf_counter() - start:.1f} s")
    print(
        "columns: seconds per method; speed-up over pairs; squared pair and box distances the"
        " tree computed, per pair; share of rows auto handed to the pair kernel\n"
    )

    print("1. Neck-like regressors, n = 12 (targets: raw outputs)")
    print(HEADER)
    one_eps_pairs = {}
    for n in sizes:
        points, targets = neck_points(n)
        one_eps_pairs[n] = compare(
            f"N = {n:>7,}, one eps = {NOISE:g}", points, targets, np.array([[NOISE]])
        )
        compare(f"N = {n:>7,}, 48-eps default grid", points, targets, _default_epsilons(targets))

    print("\n2. Worst cases: i.i.d. uniform points in 12-D, and a line of equal slopes")
    print(HEADER)
    rng = np.random.default_rng(3)
    n = sizes[0]
    xu = rng.uniform(size=(n, 12))
    yu = np.sin(xu.sum(axis=1, keepdims=True))
    compare(f"uniform 12-D, N = {n:,}, eps = 0", xu, yu, np.zeros((1, 1)))
    compare(f"uniform 12-D, N = {n:,}, 48-eps grid", xu, yu, _default_epsilons(yu))
    noisy = yu + 0.1 * rng.normal(size=yu.shape)
    compare(f"uniform 12-D + noise, N = {n:,}, 48 eps", xu, noisy, _default_epsilons(noisy))
    line = np.linspace(0.0, 1.0, n // 2)[:, None]
    compare(f"1-D line, slope 2, N = {n // 2:,}, eps = 0", line, 2.0 * line, np.zeros((1, 1)))

    if args.large:
        n = 1_000_000
        print(
            f"\n3. N = {n:,}, n = 12, one eps = {NOISE:g}: tree only (all pairs would take hours)"
        )
        points, targets = neck_points(n)
        t_tree, g_tree = timed(
            lambda: gamma_star(points, targets, np.array([[NOISE]]), method="tree")
        )
        stats = STATS.last
        base = max(one_eps_pairs)
        extrapolated = one_eps_pairs[base] * (n * (n - 1)) / (base * (base - 1))
        print(
            f"  tree (build included) {t_tree:.1f} s on {numba.get_num_threads()} threads"
            f" (target < 60 s); gamma* = {g_tree[0, 0]:.6g}; pair d² / pairs"
            f" {stats['computed'] / stats['pairs']:.2e}"
        )
        print(
            f"  all pairs extrapolated from N = {base:,}: {extrapolated:,.0f} s"
            f" -> ratio {extrapolated / t_tree:,.0f}x"
        )


if __name__ == "__main__":
    main()
