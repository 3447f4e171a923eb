"""The slope bound of the γ*(ε) search: regional linear models of the targets (issue 33).

:mod:`neckid.models.set_membership._kernels.slope` skips a pair of kd-tree nodes when a linear
model of the targets shows that no pair between them can reach the running maximum. The bound
must hold for every pair (checked here on the tree's leaves directly), and the search with it
must give γ*(ε) bit for bit as the all-pairs kernel does, on nearly linear data where it prunes
much, on random data and with duplicates.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from neckid.models.set_membership._kernels.gamma import gamma_star, gamma_star_blocked
from neckid.models.set_membership._kernels.slope import slope_bounds, slope_skips
from neckid.models.set_membership._kernels.tree import SMTree
from neckid.models.set_membership.training import duplicate_spread


def _held(n: int, outputs: int = 1, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Scaled regressors (y(t-1), u(t-1)) of a nearly linear plant with a held input."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n // 20 + 2).repeat(20)[: n + 1]
    y = np.zeros((n + 1, outputs))
    for t in range(1, n + 1):
        for c in range(outputs):
            y[t, c] = (0.9 - 0.1 * c) * y[t - 1, c] + 0.1 * np.tanh(2 * u[t - 1])
            y[t, c] += 0.02 * u[t - 1] * abs(y[t - 1, c])
    y += rng.uniform(-1e-3, 1e-3, y.shape)
    x = np.column_stack([y[:-1, 0], u[:-1]])
    return np.ascontiguousarray(x / x.std(axis=0)), np.ascontiguousarray(y[1:])


def _grid(targets: np.ndarray, fractions: list[float]) -> np.ndarray:
    return 2.0 * np.asarray(fractions)[:, None] * np.ptp(targets, axis=0)[None, :]


def _leaf_pairs_max(tree: SMTree, a: int, b: int, twice_eps: np.ndarray) -> np.ndarray:
    """max over i in leaf a, j in leaf b (i != j) of (|Δ| − 2ε) / d, per ε and output."""
    pa = tree.points[tree.start[a] : tree.end[a]]
    pb = tree.points[tree.start[b] : tree.end[b]]
    ta = tree.targets[tree.start[a] : tree.end[a]]
    tb = tree.targets[tree.start[b] : tree.end[b]]
    d = np.sqrt(((pa[:, None, :] - pb[None, :, :]) ** 2).sum(axis=2))
    delta = np.abs(ta[:, None, :] - tb[None, :, :])
    keep = d > 0
    out = np.full(twice_eps.shape, -np.inf)
    for e in range(twice_eps.shape[0]):
        ratio = (delta - twice_eps[e]) / np.where(keep, d, 1.0)[:, :, None]
        out[e] = np.max(ratio[keep], axis=0)
    return out


def test_the_bound_never_skips_a_pair_that_reaches_the_maximum() -> None:
    x, y = _held(6_000, outputs=2)
    tree = SMTree(x, y, 8)
    twice_eps = _grid(y, [0.0, 0.002, 0.01, 0.05])
    bounds = slope_bounds(tree, twice_eps, region_points=400)
    slopes = tuple(bounds)
    leaves = np.flatnonzero(tree.left < 0)
    rng = np.random.default_rng(1)
    skipped_far_above = 0
    for a, b in rng.choice(leaves, size=(300, 2)):
        if a == b:
            continue
        truth = _leaf_pairs_max(tree, a, b, twice_eps)
        gap = np.maximum(tree.lo[b] - tree.hi[a], tree.lo[a] - tree.hi[b])
        dist2 = float(np.sum(np.maximum(gap, 0.0) ** 2))
        args = (bounds.region[a], bounds.low[a], bounds.high[a], tree.lo[a], tree.hi[a], b)
        rest = (tree.lo, tree.hi, dist2, twice_eps)
        # a running maximum just below the true one: some pair exceeds it, never skipped (with
        # the shortcut for a maximum that decreases along the grid, and without)
        below = np.where(truth > 0, truth * (1 - 1e-7), -1.0)
        for monotone in (True, False):
            assert not slope_skips(slopes, *args, *rest, below, monotone)
        # far above every pair: the bound may skip (and must, for most leaves far apart)
        above = np.maximum.accumulate((np.abs(truth) * 10 + 10)[::-1], axis=0)[::-1]
        skipped_far_above += slope_skips(slopes, *args, *rest, above, True)
    assert skipped_far_above > 100


def test_residual_ranges_hold_every_point_of_every_node() -> None:
    x, y = _held(5_000, outputs=2, seed=2)
    tree = SMTree(x, y, 8)
    bounds = slope_bounds(tree, _grid(y, [0.01]), region_points=300)
    assert bounds.gradients.shape[0] == 17  # 2**4 regions and the nodes above them
    assert np.all(np.isfinite(bounds.gradients))
    for node in range(tree.n_nodes):
        rows = slice(tree.start[node], tree.end[node])
        k = bounds.region[node]
        residual = tree.targets[rows] - tree.points[rows] @ bounds.gradients[k].T
        np.testing.assert_array_less(bounds.low[node] - 1e-12, residual.min(axis=0) + 1e-15)
        np.testing.assert_array_less(residual.max(axis=0) - 1e-15, bounds.high[node] + 1e-12)
        if tree.left[node] >= 0 and k > 0:  # a region holds whole subtrees
            assert bounds.region[tree.left[node]] == bounds.region[tree.right[node]] == k


@pytest.mark.parametrize("outputs", [1, 2])
def test_the_search_with_slope_bounds_equals_all_pairs_on_nearly_linear_data(
    outputs: int,
) -> None:
    x, y = _held(5_000, outputs=outputs, seed=3)
    twice_eps = _grid(y, [0.0, 3e-4, 1e-3, 3e-3, 0.01, 0.1])
    walked, _ = gamma_star_blocked(x, y, twice_eps, 8, None, None)
    tree = SMTree(x, y, 8)
    bounds = slope_bounds(tree, twice_eps, region_points=250)
    for slopes in ("never", "always", bounds):
        found, stats = gamma_star_blocked(x, y, twice_eps, 8, None, tree, slopes=slopes)
        np.testing.assert_array_equal(found, walked)
        assert (stats["sloped"] > 0) == (slopes != "never")
    # and as a check with a floor (above γ*, equal to it, below it)
    for factor in (1.1, 1.0, 0.9):
        floor = factor * walked
        checked, _ = gamma_star_blocked(x, y, twice_eps, 8, None, tree, floor=floor, slopes=bounds)
        np.testing.assert_array_equal(checked, np.maximum(walked, floor))


def test_auto_keeps_the_bounds_where_they_prune_and_drops_them_where_they_do_not() -> None:
    x, y = _held(20_000, seed=4)
    tree = SMTree(x, y, 8)
    flat = _grid(y, [5e-3])  # past the knee: distant pairs within a few per cent of γ*
    plain, plain_stats = gamma_star_blocked(x, y, flat, 64, None, tree, slopes="never")
    auto, auto_stats = gamma_star_blocked(x, y, flat, 64, None, tree, slopes="auto")
    np.testing.assert_array_equal(auto, plain)
    assert plain_stats["slope_blocks"] == 0 and auto_stats["slope_blocks"] == 64
    assert auto_stats["computed"] < plain_stats["computed"] / 5
    # points and targets on a line: every pair has slope γ*(0), no bound can skip a node
    line = np.linspace(0.0, 1.0, 4_000)[:, None]
    tree = SMTree(line, 2.0 * line, 8)
    _, line_stats = gamma_star_blocked(
        line, 2.0 * line, np.zeros((1, 1)), 16, None, tree, slopes="auto"
    )
    assert line_stats["skipped"] == 0 and line_stats["slope_blocks"] == 1


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(2, 120),
    dims=st.integers(1, 4),
    outputs=st.integers(1, 2),
    n_eps=st.integers(1, 4),
    leaf_size=st.sampled_from([1, 2, 4, 8]),
    region_points=st.sampled_from([1, 4, 16, 1000]),
)
def test_search_with_forced_slope_bounds_equals_all_pairs_property(
    seed: int, n: int, dims: int, outputs: int, n_eps: int, leaf_size: int, region_points: int
) -> None:
    rng = np.random.default_rng(seed)
    x = np.round(rng.normal(size=(n, dims)), 1)  # coarse values: duplicates happen
    slope = rng.normal(size=(dims, outputs))
    y = np.round(x @ slope + 0.05 * rng.normal(size=(n, outputs)), 3)
    twice_eps = np.sort(rng.uniform(0, 0.3, size=(n_eps, outputs)), axis=0)
    walked, _ = gamma_star_blocked(x, y, twice_eps, 3, None, None)
    tree = SMTree(x, y, leaf_size)
    bounds = slope_bounds(tree, twice_eps, region_points=region_points)
    searched, _ = gamma_star_blocked(x, y, twice_eps, 3, None, tree, slopes=bounds)
    np.testing.assert_array_equal(searched, walked)


def test_gamma_star_takes_a_lower_bound_per_epsilon_in_the_order_of_the_grid() -> None:
    x, y = _held(3_000, seed=5)
    grid = np.array([[0.02], [0.0], [0.005]])  # unsorted
    exact = gamma_star(x, y, grid, method="tree")
    sub = gamma_star(x[::7], y[::7], grid, method="tree")  # pairs of a subset: lower bounds
    assert np.all(sub <= exact) and np.any(sub > 0)
    np.testing.assert_array_equal(gamma_star(x, y, grid, method="tree", floor=sub), exact)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_duplicate_spread_equals_grouping_the_rows(seed: int) -> None:
    rng = np.random.default_rng(seed)
    x = rng.integers(-3, 4, size=(4_000, 3)).astype(np.float64)  # many identical rows
    x[rng.random(x.shape) < 0.05] *= -1.0  # −0.0 and 0.0 are the same value
    y = rng.normal(size=(4_000, 2))
    groups = np.unique(x + 0.0, axis=0, return_inverse=True)[1].ravel()
    expected = np.zeros(2)
    for c in range(2):
        low = np.full(groups.max() + 1, np.inf)
        high = np.full(groups.max() + 1, -np.inf)
        np.minimum.at(low, groups, y[:, c])
        np.maximum.at(high, groups, y[:, c])
        expected[c] = np.max(high - low)
    np.testing.assert_array_equal(duplicate_spread(x, y), expected)
    unique = np.unique(x + 0.0, axis=0)
    np.testing.assert_array_equal(duplicate_spread(unique, y[: unique.shape[0]]), np.zeros(2))
