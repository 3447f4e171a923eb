"""Set Membership at scale: the prior check by branch and bound against the all-points reference,
the one copy of the training points (in place, recoverable bit for bit), and the memory it takes.

The prior (ε, γ) is consistent with the data iff γ >= γ*(ε) (Milanese & Novara 2004):
:func:`prior_holds` checks it with the γ* branch and bound started at γ; the reference
:func:`prior_holds_by_query` evaluates the bounds at every training point. Both allow the same
tolerance τ on ``|ỹ_i − ỹ_j| − 2ε − γ‖w̃_i − w̃_j‖`` and must agree away from that boundary.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from _sm_reference import (
    bounds_reference,
    gamma_star_reference,
    prior_holds_by_query,
    smallest_epsilon_by_query,
)
from neckid import IOData, Lags
from neckid.models.set_membership._kernels.gamma import gamma_star, gamma_star_blocked
from neckid.models.set_membership._kernels.tree import SMTree, _permute_rows, build_tree
from neckid.models.set_membership.narx import SetMembership
from neckid.models.set_membership.training import (
    check_duplicates,
    prior_holds,
    prior_tolerance,
    smallest_epsilon,
    training_tree,
    unscale,
)


def _coarse(rng: np.random.Generator, n: int, dims: int, outputs: int):
    """Rounded points and targets: identical regressors (often with other targets) happen."""
    x = np.round(rng.normal(size=(n, dims)), 1)
    y = np.round(
        np.sin(x @ rng.normal(size=(dims, outputs))) + 0.1 * rng.normal(size=(n, outputs)), 2
    )
    return x, y


# ------------------------------------------------------------------ the prior check
@settings(max_examples=80, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(2, 120),
    dims=st.integers(1, 3),
    outputs=st.integers(1, 2),
    factor=st.sampled_from([0.3, 0.9, 0.999, 1.0, 1.001, 1.5, 4.0]),
    leaf_size=st.sampled_from([1, 4, 16]),
)
def test_prior_check_equals_the_all_points_reference(
    seed: int, n: int, dims: int, outputs: int, factor: float, leaf_size: int
) -> None:
    rng = np.random.default_rng(seed)
    x, y = _coarse(rng, n, dims, outputs)
    tree = SMTree(x, y, leaf_size)
    epsilon = rng.uniform(0.0, 0.3, outputs) * np.ptp(y, axis=0)
    star = gamma_star(x, y, epsilon[None, :], method="pairs")[0]
    # γ around γ*(ε) (γ* = 0: any γ; γ* = inf, duplicates beyond 2ε: a finite γ fails)
    gamma = np.where(np.isfinite(star) & (star > 0), factor * star, rng.uniform(0.1, 2.0))
    valid, star_found = prior_holds(tree, epsilon, gamma)
    np.testing.assert_array_equal(valid, prior_holds_by_query(tree, epsilon, gamma))
    # the theory: valid iff γ >= γ*(ε) (no pair here is within the tolerance τ of the limit)
    np.testing.assert_array_equal(valid, gamma >= star)
    # where it fails, the value for the message is γ*(ε) itself
    np.testing.assert_array_equal(star_found[~valid], star[~valid])
    assert np.all(np.isnan(star_found[valid]))


def test_prior_check_at_the_boundary_of_the_tolerance() -> None:
    # Two points: γ*(ε) = (Δ − 2ε) / d exactly. Within τ below it the prior is accepted (the
    # bounds are computed with rounding); beyond τ it is refused, by both checks.
    x = np.array([[0.0], [2.0]])
    y = np.array([[0.0], [3.0]])
    tree = SMTree(x, y)
    epsilon = np.array([0.5])
    star = 1.0  # (3 − 1) / 2
    tolerance = float(prior_tolerance(tree.targets, epsilon)[0])
    for gamma, expected in [
        (star, True),
        (star - 0.25 * tolerance / 2.0, True),  # Δ − 2ε − γd = τ/4 <= τ
        (star - 4.0 * tolerance / 2.0, False),  # 4τ > τ
        (0.9, False),
    ]:
        g = np.array([gamma])
        assert prior_holds(tree, epsilon, g)[0][0] == expected, gamma
        assert prior_holds_by_query(tree, epsilon, g)[0] == expected, gamma


def test_identical_regressors_beyond_two_epsilon_fail_both_checks() -> None:
    x = np.array([[0.0, 1.0], [1.0, 0.0], [0.0, 1.0], [2.0, 2.0]])
    y = np.array([[0.0], [0.1], [0.5], [0.2]])  # rows 0 and 2: same regressor, Δ = 0.5
    tree = SMTree(x, y)
    for epsilon, expected in [(0.2, False), (0.25, True)]:
        eps = np.array([epsilon])
        valid, star = prior_holds(tree, eps, np.array([5.0]))
        assert valid[0] == expected == prior_holds_by_query(tree, eps, np.array([5.0]))[0]
        assert expected or star[0] == np.inf
    with pytest.raises(ValueError, match=r"rows 0 and 2 are identical.*differs by 0.5"):
        check_duplicates(tree, np.array([0.2]), ["y"])
    check_duplicates(tree, np.array([0.25]), ["y"])


@pytest.mark.parametrize("method", ["tree", "pairs"])
def test_gamma_star_with_a_floor_is_the_larger_of_the_two(method: str) -> None:
    rng = np.random.default_rng(3)
    x, y = _coarse(rng, 400, 3, 2)
    grid = np.array([[0.0, 0.0], [0.05, 0.02], [0.3, 0.4]])
    plain = gamma_star(x, y, grid, method=method)
    for floor in (np.array([0.0, 0.0]), np.array([1.0, 50.0]), plain[1]):
        floored = gamma_star(x, y, grid, method=method, floor=floor)
        np.testing.assert_array_equal(floored, np.maximum(plain, floor))
    # one ε and one output (the floor's broadcast must still be a writable copy)
    one = gamma_star(x[:, :1], y[:, :1], grid[1:2, :1], method=method, floor=plain[1, :1] / 2)
    np.testing.assert_array_equal(
        one, np.maximum(gamma_star(x[:, :1], y[:, :1], grid[1:2, :1]), plain[1, :1] / 2)
    )


def test_gamma_star_on_a_given_tree_equals_a_fresh_one() -> None:
    rng = np.random.default_rng(4)
    x, y = _coarse(rng, 3000, 4, 1)
    grid = np.array([[0.0], [0.01], [0.2]])
    tree = SMTree(x, y)  # leaf 16, not gamma_star's own leaf size
    on_tree = gamma_star(tree.points, tree.targets, grid, method="tree", tree=tree)
    np.testing.assert_array_equal(on_tree, gamma_star(x, y, grid, method="pairs"))


def test_estimator_refuses_a_gamma_below_gamma_star_with_the_value() -> None:
    rng = np.random.default_rng(5)
    u = rng.uniform(-1, 1, 3000)
    y = np.zeros(3000)
    for t in range(1, 3000):
        y[t] = 0.5 * y[t - 1] + np.sin(2 * u[t - 1]) + rng.uniform(-0.01, 0.01)
    data = IOData(u, y, ts=0.1)
    lags = Lags(outputs=1, inputs=1)
    fitted = SetMembership(lags, epsilon=0.01, gamma_margin=1.0, progress=False).fit(data)
    star = float(fitted.gamma_star_[0])
    SetMembership(lags, epsilon=0.01, gamma=star).fit(data)  # γ = γ*(ε): the prior holds
    with pytest.raises(ValueError, match=f"below gamma\\*\\(epsilon\\) = {star:.6g}"):
        SetMembership(lags, epsilon=0.01, gamma=0.99 * star).fit(data)


# ------------------------------------------------------------------ ε*(γ)
def _smallest_epsilon_brute_force(x: np.ndarray, y: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    distance = np.sqrt(((x[:, None, :] - x[None, :, :]) ** 2).sum(axis=2))
    delta = np.abs(y[:, None, :] - y[None, :, :])
    return 0.5 * np.maximum((delta - gamma * distance[:, :, None]).max(axis=(0, 1)), 0.0)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(2, 150),
    dims=st.integers(1, 3),
    outputs=st.integers(1, 2),
    leaf_size=st.sampled_from([1, 4, 16]),
)
def test_smallest_epsilon_by_the_tree_equals_all_pairs_and_the_query(
    seed: int, n: int, dims: int, outputs: int, leaf_size: int
) -> None:
    rng = np.random.default_rng(seed)
    x, y = _coarse(rng, n, dims, outputs)
    gamma = rng.uniform(0.05, 3.0, outputs)
    tree = SMTree(x, y, leaf_size)
    row = gamma[None, :]
    searched, _ = gamma_star_blocked(tree.points, tree.targets, row, 3, None, tree, margin=True)
    walked, _ = gamma_star_blocked(x, y, row, 3, None, None, margin=True)
    np.testing.assert_array_equal(searched, walked)  # bit for bit
    expected = _smallest_epsilon_brute_force(x, y, gamma)
    np.testing.assert_allclose(0.5 * searched[0], expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(smallest_epsilon(tree, gamma), expected, rtol=1e-12, atol=1e-15)
    by_query = smallest_epsilon_by_query(tree, gamma)
    np.testing.assert_allclose(by_query, expected, rtol=1e-12, atol=1e-15)


def test_smallest_epsilon_on_a_time_series_uses_the_tree_and_is_the_limit_of_the_prior() -> None:
    data = _neck_like(6000, seed=2)
    x, y = Lags(outputs=2, inputs=[1, 2]).build(data)
    points = np.ascontiguousarray(x / x.std(axis=0))
    tree = SMTree(points, y)
    gamma = np.array([0.05])
    epsilon = smallest_epsilon(tree, gamma)
    np.testing.assert_allclose(epsilon, smallest_epsilon_by_query(tree, gamma), rtol=1e-12)
    # at ε*(γ), γ*(ε) = γ: the prior holds there and fails just below
    assert prior_holds(tree, epsilon, gamma)[0].all()
    assert not prior_holds(tree, epsilon * (1 - 1e-6), gamma)[0].any()
    star = gamma_star(points, y, epsilon[None, :])[0]
    np.testing.assert_allclose(star, gamma, rtol=1e-9)


# ------------------------------------------------------------------ one copy of the points
@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    log_weight=st.floats(-12, 12),
    log_scale=st.floats(-30, 30),
)
def test_unscale_gives_rows_that_scale_back_bit_for_bit(
    seed: int, log_weight: float, log_scale: float
) -> None:
    rng = np.random.default_rng(seed)
    x0 = rng.normal(size=(500, 3)) * 10.0**log_scale
    weights = 10.0 ** (log_weight + rng.uniform(-1, 1, 3))
    points = x0 * weights
    x = unscale(points, weights)
    np.testing.assert_array_equal(x * weights, points)
    np.testing.assert_allclose(x, x0, rtol=1e-15, atol=0)


def test_permute_rows_in_place_equals_indexing() -> None:
    rng = np.random.default_rng(6)
    for n in (1, 2, 17, 1000):
        points = rng.normal(size=(n, 3))
        perm = rng.permutation(n)
        expected = points[perm]
        _permute_rows(points, perm)
        np.testing.assert_array_equal(points, expected)


def test_tree_over_its_own_copy_equals_the_tree_over_a_copy() -> None:
    rng = np.random.default_rng(7)
    x, y = _coarse(rng, 2000, 3, 2)
    reference = SMTree(x, y)
    owned = x.copy()
    tree = SMTree(owned, y, overwrite_points=True)
    assert tree.points is owned  # reordered in place, not copied
    np.testing.assert_array_equal(tree.points, x[tree.perm])
    np.testing.assert_array_equal(tree.perm, reference.perm)
    np.testing.assert_array_equal(tree.points, reference.points)


def test_median_split_with_many_ties_is_a_partition() -> None:
    rng = np.random.default_rng(8)
    x = rng.integers(0, 3, size=(5000, 2)).astype(float)  # nine distinct points
    tree = build_tree(x, 4)
    ordered = x[tree["perm"]]
    assert np.array_equal(np.sort(tree["perm"]), np.arange(5000))
    for node in np.flatnonzero(tree["left"] >= 0):
        left, right = tree["left"][node], tree["right"][node]
        a = ordered[tree["start"][left] : tree["end"][left]]
        b = ordered[tree["start"][right] : tree["end"][right]]
        # the children are split on some component: all of one side <= all of the other
        assert np.any(a.max(axis=0) <= b.min(axis=0))


@pytest.mark.parametrize("linear", [False, True])
def test_training_tree_keeps_one_copy_and_exact_targets(linear: bool) -> None:
    rng = np.random.default_rng(9)
    x, y = _coarse(rng, 3000, 4, 2)
    weights = 1.0 / x.std(axis=0)
    coef = rng.normal(size=(4, 2)) if linear else np.zeros((4, 2))
    intercept = rng.normal(size=2) if linear else np.zeros(2)
    owned = x.copy()
    tree, outputs = training_tree(owned, y, weights, coef, intercept, linear)
    assert tree.points is owned
    np.testing.assert_array_equal(tree.points, (x * weights)[tree.perm])
    raw = unscale(tree.points, weights)
    expected = y[tree.perm] - (raw @ coef + intercept)
    np.testing.assert_allclose(tree.targets, expected, rtol=0, atol=1e-12)
    assert (outputs is None) != linear
    if linear:
        np.testing.assert_array_equal(outputs, y[tree.perm])
    else:
        np.testing.assert_array_equal(tree.targets, y[tree.perm])  # no linear part: ỹ = y
    # rebuilt from what a model file holds (raw rows and outputs in tree order): same targets
    again, _ = training_tree(raw.copy(), y[tree.perm], weights, coef, intercept, linear)
    order = np.argsort(again.perm)
    np.testing.assert_array_equal(again.targets[order], tree.targets)


def _neck_like(n: int, seed: int = 0) -> IOData:
    rng = np.random.default_rng(seed)
    u = np.cumsum(rng.uniform(-0.1, 0.1, (n, 2)), axis=0)
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = 1.2 * y[t - 1] - 0.4 * y[t - 2] + 0.1 * np.tanh(u[t - 1, 0] - u[t - 2, 1])
    return IOData(u, y + rng.uniform(-1e-3, 1e-3, n), ts=0.02)


def test_a_fitted_model_holds_its_training_regressors_once() -> None:
    lags = Lags(outputs=3, inputs=[1, 2, 3])
    data = _neck_like(20_000)
    SetMembership(lags, epsilon=1e-3, gamma=5.0).fit(data[:500])  # compile first
    raw = lags.build(data)[0].nbytes
    tracemalloc.start()
    try:
        start = tracemalloc.get_traced_memory()[0]
        model = SetMembership(lags, epsilon=1e-3, gamma=5.0, progress=False).fit(data)
        retained, peak = (v - start for v in tracemalloc.get_traced_memory())
    finally:
        tracemalloc.stop()
    assert model.prior_valid_.all()
    # the tree's points (1x), its nodes and the targets; the regressor matrix built by
    # _prepare_fit (parts and their stack, 2x) sets the peak
    assert retained < 2.0 * raw, retained / raw
    assert peak < 2.5 * raw, peak / raw


def test_model_file_round_trip_is_exact_with_std_weights_and_a_linear_part(tmp_path) -> None:
    data = _neck_like(3000, seed=1)
    lags = Lags(outputs=2, inputs=[1, 2])
    model = SetMembership(lags, epsilon=2e-3, linear_part=True, progress=False).fit(data[:2500])
    loaded = SetMembership.load(model.save(tmp_path / "sm.npz"))
    x, _ = lags.build(data[2500:])
    a, b = model.bounds(x), loaded.bounds(x)
    for name in ("lower", "central", "upper"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    np.testing.assert_array_equal(np.sort(loaded._tree.targets, 0), np.sort(model._tree.targets, 0))
    # and the bounds are those of the brute force on the stored rows
    low, high = bounds_reference(
        model._x_train * model.weights_,
        model._y_train[:, 0] - (model._x_train @ model.coef_ + model.intercept_)[:, 0],
        x[:20] * model.weights_,
        model.epsilon_[0],
        model.gamma_[0],
    )
    linear = (x[:20] @ model.coef_ + model.intercept_)[:, 0]
    np.testing.assert_allclose(a.lower[:20, 0], linear + low, atol=1e-10)
    np.testing.assert_allclose(a.upper[:20, 0], linear + high, atol=1e-10)
    # γ*(ε) of the stored rows is the model's
    assert model.gamma_star_[0] == pytest.approx(
        gamma_star_reference(
            model._x_train * model.weights_, model._tree.targets[:, 0], model.epsilon_[:1]
        )[0],
        rel=1e-12,
    )
