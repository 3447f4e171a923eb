"""γ*(ε) by kd-tree branch and bound against the all-pairs kernel and the NumPy reference.

γ*(ε) = max_{i≠j} (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖ (Milanese & Novara 2004). The tree skips only
pairs that cannot raise the running maximum, and evaluates the others with the same arithmetic
as the all-pairs kernel, so the two agree to the last bit; the brute-force NumPy reference sums
the squared distance in another order, so it agrees to rounding (rtol 1e-12).
"""

from __future__ import annotations

import logging

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from _sm_reference import gamma_star_reference
from neckid.models.set_membership._kernels.gamma import (
    TREE_MIN_POINTS,
    TREE_STRIKES,
    _TreeBlocks,
    gamma_star,
    gamma_star_blocked,
)
from neckid.models.set_membership._kernels.tree import SMTree

METHODS = ("tree", "pairs", "auto")


def _time_series(rng: np.random.Generator, n: int, outputs: int = 1):
    """Lagged regressors of a noisy nonlinear system: close consecutive points, like NARX data."""
    u = np.convolve(rng.uniform(-1, 1, n + 20), np.ones(8) / 8, mode="same")
    y = np.zeros((n + 20, outputs))
    for t in range(3, n + 20):
        for c in range(outputs):
            y[t, c] = (
                1.5 * y[t - 1, c] - 0.6 * y[t - 2, c] + 0.1 * np.tanh(2 * u[t - 2] + 0.3 * c)
            ) + rng.uniform(-1e-3, 1e-3)
    x = np.column_stack([y[2:-1, 0], y[1:-2, 0], u[2:-1], u[1:-2]])[-n:]
    return x / x.std(axis=0), y[3:][-n:]


def _random(rng: np.random.Generator, n: int, dims: int, outputs: int = 1):
    x = rng.normal(size=(n, dims))
    y = np.column_stack([np.sin(x @ rng.normal(size=dims)) + 0.1 * c for c in range(outputs)])
    return x, y + 0.05 * rng.normal(size=y.shape)


def _grid(y: np.ndarray, fractions) -> np.ndarray:
    return np.asarray(fractions)[:, None] * np.ptp(y, axis=0)[None, :]


def _check_against_reference(x, y, grid, methods=METHODS) -> None:
    results = {m: gamma_star(x, y, grid, method=m) for m in methods}
    for m in methods[1:]:
        np.testing.assert_array_equal(results[m], results[methods[0]])  # bit for bit
    for c in range(y.shape[1]):
        ref = gamma_star_reference(x, y[:, c], grid[:, c])
        np.testing.assert_allclose(results[methods[0]][:, c], ref, rtol=1e-12)


# ------------------------------------------------------------------ exactness
@pytest.mark.parametrize("outputs", [1, 2])
def test_tree_equals_pairs_and_reference_on_time_series(outputs: int) -> None:
    x, y = _time_series(np.random.default_rng(1), 1500, outputs)
    grid = _grid(y, [0.0, 1e-4, 1e-3, 0.01, 0.05, 0.2, 0.6])
    _check_against_reference(x, y, grid)


@pytest.mark.parametrize(("dims", "outputs"), [(1, 1), (3, 2), (12, 1)])
def test_tree_equals_pairs_and_reference_on_random_points(dims: int, outputs: int) -> None:
    rng = np.random.default_rng(dims)
    x, y = _random(rng, 1000, dims, outputs)
    grid = np.column_stack([np.sort(rng.uniform(0, 0.5, 9)) for _ in range(outputs)])
    _check_against_reference(x, y, grid)


def test_large_time_series_tree_equals_pairs_with_an_unsorted_grid() -> None:
    x, y = _time_series(np.random.default_rng(2), 20_000)
    grid = _grid(y, [0.05, 0.0, 0.002, 0.3, 0.002])  # unsorted, with a repeated ε
    tree = gamma_star(x, y, grid, method="tree")
    np.testing.assert_array_equal(tree, gamma_star(x, y, grid, method="pairs"))
    np.testing.assert_array_equal(tree, gamma_star(x, y, grid))  # auto: the tree at this size
    assert np.all(np.diff(tree[[1, 2, 0, 3], 0]) <= 0)  # γ* decreases with ε


def test_duplicate_regressors_give_inf_below_half_their_target_gap() -> None:
    rng = np.random.default_rng(3)
    x, y = _random(rng, 3000, 3, outputs=2)
    x[-6:] = x[:6]  # identical regressors ...
    y[-6:, 0] = y[:6, 0] + np.linspace(0.0, 0.4, 6)  # ... with outputs up to 0.4 apart
    y[-6:, 1] = y[:6, 1]  # ... and equal ones
    grid = np.column_stack([np.array([0.0, 0.1, 0.19, 0.21, 0.5])] * 2)
    fast = gamma_star(x, y, grid, method="tree")
    np.testing.assert_array_equal(fast, gamma_star(x, y, grid, method="pairs"))
    assert np.isinf(fast[:3, 0]).all() and np.isfinite(fast[3:, 0]).all()
    assert np.isfinite(fast[:, 1]).all()
    np.testing.assert_allclose(fast[3:, 0], gamma_star_reference(x, y[:, 0], grid[3:, 0]))


def test_all_points_identical() -> None:
    x = np.ones((50, 2))
    y = np.linspace(0.0, 1.0, 50)[:, None]
    grid = np.array([[0.0], [0.49], [0.5], [0.6]])
    for method in METHODS:
        np.testing.assert_array_equal(
            gamma_star(x, y, grid, method=method)[:, 0], [np.inf, np.inf, 0.0, 0.0]
        )


def test_epsilon_above_half_the_output_span_gives_zero() -> None:
    x, y = _time_series(np.random.default_rng(4), 3000, outputs=2)
    grid = np.vstack([0.5 * np.ptp(y, axis=0), np.ptp(y, axis=0), [0.0, 0.0]])
    fast = gamma_star(x, y, grid, method="tree")
    np.testing.assert_array_equal(fast[:2], 0.0)
    assert np.all(fast[2] > 0)


def test_a_constant_output_gives_zero_and_leaves_the_other_exact() -> None:
    x, y = _time_series(np.random.default_rng(5), 3000, outputs=2)
    y[:, 1] = 0.7
    grid = _grid(y, [0.0, 0.01]) + np.array([[0.0, 0.0], [0.0, 0.1]])
    fast = gamma_star(x, y, grid, method="tree")
    np.testing.assert_array_equal(fast[:, 1], 0.0)
    np.testing.assert_array_equal(fast, gamma_star(x, y, grid, method="pairs"))


@pytest.mark.parametrize("n", [0, 1, 2, 3])
def test_tiny_inputs(n: int) -> None:
    x = np.arange(n * 2, dtype=float).reshape(n, 2)
    y = (np.arange(n, dtype=float) ** 2)[:, None]
    grid = np.array([[0.0], [0.25]])
    expected = gamma_star_reference(x, y[:, 0], grid[:, 0])
    for method in METHODS:
        np.testing.assert_allclose(gamma_star(x, y, grid, method=method)[:, 0], expected)


# ------------------------------------------------------------------ the driver
def test_progress_reaches_the_total_with_the_tree() -> None:
    x, y = _time_series(np.random.default_rng(6), 3000)
    calls: list[tuple[int, int]] = []
    gamma_star(
        x,
        y,
        np.zeros((1, 1)),
        n_blocks=7,
        method="tree",
        callback=lambda d, t: calls.append((d, t)),
    )
    total = 3000 * 2999 // 2
    assert len(calls) == 7 and calls[-1] == (total, total)
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)


def test_auto_walks_the_pairs_below_the_threshold_and_searches_above(
    caplog: pytest.LogCaptureFixture,
) -> None:
    x, y = _time_series(np.random.default_rng(7), TREE_MIN_POINTS)
    with caplog.at_level(logging.DEBUG, logger="neckid.models.set_membership._kernels.gamma"):
        gamma_star(x[:-1], y[:-1], np.zeros((1, 1)))
        gamma_star(x, y, np.zeros((1, 1)))
    below, above = (record.args[1] for record in caplog.records)  # type: ignore[index]
    assert below["tree_rows"] == 0 and below["pair_rows"] == TREE_MIN_POINTS - 1
    assert above["tree_rows"] == TREE_MIN_POINTS and above["pair_rows"] == 0


def test_auto_hands_over_to_the_pairs_when_the_tree_prunes_nothing() -> None:
    # Points on a line with targets on a line: every pair has slope exactly 2 = γ*(0), so no
    # node can be pruned; "auto" gives up on the tree after its first TREE_STRIKES blocks.
    x = np.linspace(0.0, 1.0, 4000)[:, None]
    y = 2.0 * x
    grid = np.zeros((1, 1))
    tree = SMTree(x, y, 8)
    calls: list[int] = []
    gamma, stats = gamma_star_blocked(
        x, y, grid, 16, lambda done, total: calls.append(done), tree, adaptive=True
    )
    assert stats["pair_rows"] > 0 and stats["tree_rows"] <= 1.1 * TREE_STRIKES * 4000 / 16
    assert stats["tree_rows"] + stats["pair_rows"] == 4000
    assert len(calls) == 16 and calls == sorted(calls) and calls[-1] == stats["pairs"]
    forced, forced_stats = gamma_star_blocked(x, y, grid, 16, None, tree, adaptive=False)
    assert forced_stats["pair_rows"] == 0
    np.testing.assert_array_equal(gamma, forced)
    np.testing.assert_allclose(gamma, [[2.0]], rtol=1e-12)


@pytest.mark.parametrize("costly", [{0}, {0, 2}, {0, 1}, {3, 4, 5}])
def test_auto_hands_over_only_after_consecutive_costly_blocks(
    monkeypatch: pytest.MonkeyPatch, costly: set[int]
) -> None:
    # The first block also finds the large slopes later blocks prune with: a costly block alone
    # (or costly blocks apart) keeps the tree; TREE_STRIKES costly blocks in a row hand over.
    x, y = _time_series(np.random.default_rng(9), 4000)
    tree = SMTree(x, y, 8)
    run = _TreeBlocks.run
    blocks: list[int] = []

    def counted(self: _TreeBlocks, *args: object) -> np.ndarray:
        out = run(self, *args)  # type: ignore[arg-type]
        if len(blocks) in costly:
            self.cost = np.inf
        blocks.append(len(blocks))
        return out

    monkeypatch.setattr(_TreeBlocks, "run", counted)
    gamma, stats = gamma_star_blocked(x, y, np.zeros((1, 1)), 16, None, tree, adaptive=True)
    consecutive = any(set(range(k, k + TREE_STRIKES)) <= costly for k in range(16))
    if consecutive:
        last = min(k for k in range(16) if set(range(k, k + TREE_STRIKES)) <= costly)
        assert len(blocks) == last + TREE_STRIKES and stats["pair_rows"] > 0
    else:
        assert len(blocks) == 16 and stats["pair_rows"] == 0
    np.testing.assert_array_equal(gamma, gamma_star(x, y, np.zeros((1, 1)), method="pairs"))


def test_the_tree_skips_most_pairs_on_time_series() -> None:
    x, y = _time_series(np.random.default_rng(8), 10_000)
    tree = SMTree(x, y, 8)
    twice_eps = 2.0 * _grid(y, [0.001])
    _, stats = gamma_star_blocked(x, y, twice_eps, 16, None, tree, adaptive=True)
    assert stats["pair_rows"] == 0
    assert stats["computed"] < 0.01 * stats["pairs"]


def test_unknown_method_is_refused() -> None:
    with pytest.raises(ValueError, match="method must be 'auto', 'tree' or 'pairs'; got 'kd'"):
        gamma_star(np.zeros((3, 1)), np.zeros((3, 1)), np.zeros((1, 1)), method="kd")  # type: ignore[arg-type]


# ------------------------------------------------------------------ property
@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(0, 80),
    dims=st.integers(1, 4),
    outputs=st.integers(1, 2),
    n_eps=st.integers(1, 5),
    leaf_size=st.sampled_from([1, 2, 4, 8]),
)
def test_tree_equals_pairs_and_reference_property(
    seed: int, n: int, dims: int, outputs: int, n_eps: int, leaf_size: int
) -> None:
    rng = np.random.default_rng(seed)
    x = np.round(rng.normal(size=(n, dims)), 1)  # coarse values: duplicates happen
    y = np.round(rng.normal(size=(n, outputs)), 2)
    twice_eps = np.sort(rng.uniform(0, 1.5, size=(n_eps, outputs)), axis=0)
    pairs, _ = gamma_star_blocked(x, y, twice_eps, 3, None, None)
    tree = SMTree(x, y, leaf_size) if n > 1 else None
    searched, _ = gamma_star_blocked(x, y, twice_eps, 3, None, tree)
    np.testing.assert_array_equal(searched, pairs)
    for c in range(outputs):
        ref = gamma_star_reference(x, y[:, c], twice_eps[:, c] / 2) if n else np.zeros(n_eps)
        np.testing.assert_allclose(searched[:, c], ref, rtol=1e-12)
