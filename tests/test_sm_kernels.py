"""Set Membership kernels: compiled tree / pair pass against the plain NumPy references, and the
guarantees of the bounds (Milanese & Novara 2004) as Hypothesis properties."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from _sm_reference import bounds_reference, gamma_star_reference
from neckid.models.set_membership._kernels.gamma import gamma_star
from neckid.models.set_membership._kernels.tree import (
    SMTree,
    build_tree,
)


def _data(rng: np.random.Generator, n: int, dims: int, outputs: int = 1, duplicates: int = 0):
    x = rng.normal(size=(n, dims))
    if duplicates:
        x[-duplicates:] = x[:duplicates]
    y = np.column_stack([np.sin(x @ rng.normal(size=dims)) + 0.1 * c for c in range(outputs)])
    return x, y


# ------------------------------------------------------------------ tree structure
@pytest.mark.parametrize("leaf_size", [1, 4, 16])
def test_tree_partitions_points_and_boxes_contain_them(leaf_size: int) -> None:
    rng = np.random.default_rng(1)
    x, _ = _data(rng, 300, 3, duplicates=20)
    tree = build_tree(x, leaf_size)
    assert np.array_equal(np.sort(tree["perm"]), np.arange(300))
    leaves = tree["left"] < 0
    # The leaves tile [0, n) and every node's box holds its points.
    spans = sorted(zip(tree["start"][leaves], tree["end"][leaves], strict=True))
    assert spans[0][0] == 0 and spans[-1][1] == 300
    assert all(a[1] == b[0] for a, b in itertools.pairwise(spans))
    ordered = x[tree["perm"]]
    for node in range(tree["start"].size):
        pts = ordered[tree["start"][node] : tree["end"][node]]
        assert np.all(pts >= tree["lo"][node]) and np.all(pts <= tree["hi"][node])
        if not leaves[node]:
            assert tree["end"][node] - tree["start"][node] > leaf_size


def test_identical_points_make_one_leaf() -> None:
    x = np.ones((100, 2))
    tree = build_tree(x, 4)
    assert tree["start"].size == 1


# ------------------------------------------------------------------ kernel == reference
@pytest.mark.parametrize("leaf_size", [1, 16])
def test_bounds_equal_brute_force(leaf_size: int) -> None:
    rng = np.random.default_rng(2)
    x, y = _data(rng, 700, 4, outputs=2, duplicates=30)
    queries = np.vstack([rng.normal(size=(150, 4)) * 1.5, x[:50]])
    eps = np.array([0.05, 0.2])
    gamma = np.array([1.3, 0.4])
    tree = SMTree(x, y, leaf_size=leaf_size)
    lower, upper = tree.bounds(queries, eps, gamma)
    for c in range(2):
        ref_lower, ref_upper = bounds_reference(x, y[:, c], queries, eps[c], gamma[c])
        np.testing.assert_allclose(lower[:, c], ref_lower, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(upper[:, c], ref_upper, rtol=1e-13, atol=1e-13)


def test_gamma_star_equals_brute_force_with_duplicates_and_unsorted_grid() -> None:
    rng = np.random.default_rng(3)
    x, y = _data(rng, 400, 3, outputs=2, duplicates=5)
    y[-5:, 0] += np.linspace(0.0, 0.4, 5)  # identical regressors, outputs up to 0.4 apart
    grid = np.array([0.3, 0.0, 0.05, 0.1, 0.01, 0.25, 2.0])
    fast = gamma_star(x, y, np.column_stack([grid, grid]), n_blocks=7)
    for c in range(2):
        ref = gamma_star_reference(x, y[:, c], grid)
        np.testing.assert_allclose(fast[:, c], ref, rtol=1e-12)
    # Duplicates 0.4 apart: infinite below eps = 0.2, finite above.
    assert np.isinf(fast[grid < 0.2, 0]).all() and np.isfinite(fast[grid > 0.2, 0]).all()
    assert fast[-1, 0] == 0.0  # 2 eps above every output difference


def test_gamma_star_reports_progress() -> None:
    rng = np.random.default_rng(4)
    x, y = _data(rng, 101, 2)
    calls: list[tuple[int, int]] = []
    gamma_star(x, y, np.zeros((1, 1)), n_blocks=5, callback=lambda d, t: calls.append((d, t)))
    assert len(calls) == 5 and calls[-1] == (101 * 100 // 2, 101 * 100 // 2)
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)


# ------------------------------------------------------------------ the guarantees
def _lipschitz_function(seed: int, dims: int):
    """f_o(w) = a sin(v.w) + c.w: Lipschitz with constant <= |a| ||v|| + ||c||."""
    rng = np.random.default_rng(seed)
    a, v, c = rng.uniform(0.5, 2.0), rng.normal(size=dims), rng.normal(size=dims) * 0.3
    constant = abs(a) * np.linalg.norm(v) + np.linalg.norm(c)
    return (lambda w: a * np.sin(w @ v) + w @ c), constant


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    dims=st.integers(1, 4),
    n=st.integers(2, 120),
    epsilon=st.floats(0.0, 0.5),
    gamma_factor=st.floats(1.0, 3.0),
)
def test_bounds_contain_the_true_function(
    seed: int, dims: int, n: int, epsilon: float, gamma_factor: float
) -> None:
    f, constant = _lipschitz_function(seed, dims)
    rng = np.random.default_rng(seed)
    x = rng.uniform(-2, 2, size=(n, dims))
    y = (f(x) + rng.uniform(-epsilon, epsilon, size=n))[:, None]
    gamma = np.array([constant * gamma_factor])
    eps = np.array([epsilon])
    tree = SMTree(x, y, leaf_size=4)
    queries = rng.uniform(-3, 3, size=(50, dims))
    lower, upper = tree.bounds(queries, eps, gamma)
    truth = f(queries)
    tol = 1e-9
    assert np.all(lower[:, 0] <= truth + tol) and np.all(truth <= upper[:, 0] + tol)
    central = 0.5 * (lower + upper)
    assert np.all(lower <= central) and np.all(central <= upper)
    # At a training point the width is at most 2 eps.
    lower_t, upper_t = tree.bounds(x, eps, gamma)
    assert np.all(upper_t - lower_t <= 2 * epsilon + tol)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), dims=st.integers(1, 3), n=st.integers(3, 100))
def test_bounds_tighten_as_data_are_added(seed: int, dims: int, n: int) -> None:
    f, constant = _lipschitz_function(seed, dims)
    rng = np.random.default_rng(seed)
    x = rng.uniform(-2, 2, size=(n, dims))
    y = (f(x) + rng.uniform(-0.1, 0.1, size=n))[:, None]
    eps, gamma = np.array([0.1]), np.array([constant])
    queries = rng.uniform(-2.5, 2.5, size=(40, dims))
    k = int(rng.integers(1, n))
    lower_few, upper_few = SMTree(x[:k], y[:k]).bounds(queries, eps, gamma)
    lower_all, upper_all = SMTree(x, y).bounds(queries, eps, gamma)
    assert np.all(upper_all <= upper_few) and np.all(lower_all >= lower_few)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 60), dims=st.integers(1, 3))
def test_gamma_star_kernel_matches_reference_property(seed: int, n: int, dims: int) -> None:
    rng = np.random.default_rng(seed)
    x = np.round(rng.normal(size=(n, dims)), 1)  # coarse values: duplicates happen
    y = np.round(rng.normal(size=(n, 1)), 2)
    grid = np.sort(rng.uniform(0, 1, size=6))
    fast = gamma_star(x, y, grid[:, None], n_blocks=3)[:, 0]
    np.testing.assert_allclose(fast, gamma_star_reference(x, y[:, 0], grid), rtol=1e-12)


def test_a_few_queries_without_threads_give_the_same_bits() -> None:
    from neckid.models.set_membership._kernels.tree import SERIAL_QUERIES

    rng = np.random.default_rng(5)
    x, y = rng.normal(size=(3000, 4)), rng.normal(size=(3000, 2))
    tree = SMTree(x, y)
    queries = rng.normal(size=(SERIAL_QUERIES * 2, 4))
    eps, gamma = np.array([0.1, 0.2]), np.array([1.5, 3.0])
    many_lower, many_upper = tree.bounds(queries, eps, gamma)  # threaded kernel
    few_lower, few_upper = tree.bounds(queries[:5], eps, gamma)  # serial kernel
    np.testing.assert_array_equal(few_lower, many_lower[:5])
    np.testing.assert_array_equal(few_upper, many_upper[:5])


@pytest.mark.parametrize("seed", range(12))
def test_gamma_star_with_a_repeated_epsilon_matches_the_reference(seed: int) -> None:
    # A grid holding one ε twice (SetMembership adds a given ε to its grid) once stopped the
    # pair loop early and gave a γ* that was too small.
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(120, 2))
    y = np.tanh(x.sum(axis=1, keepdims=True)) + 0.1 * rng.standard_t(2, size=(120, 1))
    grid = np.sort(rng.uniform(0.0, 0.5, size=6))
    grid = np.sort(np.concatenate([grid, grid[[1, 3, 3]]]))[:, None]
    np.testing.assert_allclose(
        gamma_star(x, y, grid)[:, 0], gamma_star_reference(x, y[:, 0], grid[:, 0]), rtol=1e-12
    )


def test_gamma_star_values_are_cached_per_data_and_epsilon(monkeypatch) -> None:
    from neckid.models.cache import GAMMA_CURVES
    from neckid.models.set_membership import prior as sm_prior

    rng = np.random.default_rng(11)
    points = rng.normal(size=(300, 3))
    targets = np.column_stack([np.sin(points[:, 0]), points[:, 1] ** 2])
    first = np.array([[0.0, 0.0], [0.01, 0.02], [0.1, 0.05]])
    second = np.array([[0.01, 0.02], [0.2, 0.3], [0.1, 0.05]])
    fresh = gamma_star(points, targets, second)
    GAMMA_CURVES.clear()
    calls = []
    real = sm_prior.gamma_star

    def spy(p, t, grid, **kwargs):
        calls.append(grid.copy())
        return real(p, t, grid, **kwargs)

    monkeypatch.setattr(sm_prior, "gamma_star", spy)
    sm_prior._gamma_star(points, targets, first, False)
    got = sm_prior._gamma_star(points, targets, second, False)
    np.testing.assert_array_equal(got, fresh)
    np.testing.assert_array_equal(calls[1], second[[1]])  # only the new ε was computed
    sm_prior._gamma_star(points.copy(), targets.copy(), second, False)
    assert len(calls) == 2  # the same bytes: nothing computed
    sm_prior._gamma_star(points + 1e-9, targets, second, False)
    assert len(calls) == 3  # other data: computed again
