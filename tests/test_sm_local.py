"""Local Lipschitz constants: kernels against brute force, the prior's consistency, models, files."""

from __future__ import annotations

import numpy as np
import pytest

from neckid import IOData, Lags, load_model
from neckid.models._sm_kernels import SMTree
from neckid.models._sm_local import local_bounds, point_gamma
from neckid.models.io import read_model_file, write_model_file
from neckid.models.set_membership import SetMembership
from neckid.models.sm_multistep import MultiStepSetMembership


def _slopes(points: np.ndarray, targets: np.ndarray, epsilon: np.ndarray) -> np.ndarray:
    """(|t_i − t_j| − 2ε)⁺ / d_ij for every pair, shape (n, n, n_outputs); 0 on the diagonal."""
    d = np.sqrt(((points[:, None, :] - points[None, :, :]) ** 2).sum(-1))
    rise = np.maximum(np.abs(targets[:, None, :] - targets[None, :, :]) - 2 * epsilon, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(d[..., None] > 0, rise / d[..., None], 0.0)
    return s


def _brute_bounds(points, targets, gammas, queries, epsilon, fallback, k):
    lower = np.empty((len(queries), targets.shape[1]))
    upper = np.empty_like(lower)
    used = np.empty_like(lower)
    for i, w in enumerate(queries):
        d = np.sqrt(((points - w) ** 2).sum(1))
        near = np.argsort(d, kind="stable")[:k]
        for c in range(targets.shape[1]):
            g = gammas[near, c].max()
            for attempt in (g, fallback[c]):
                slope = np.maximum(attempt, gammas[:, c])
                low = np.max(targets[:, c] - slope * d)
                high = np.min(targets[:, c] + slope * d)
                g = attempt
                if low - high <= 2 * epsilon[c] or fallback[c] <= attempt:
                    break
            lower[i, c], upper[i, c], used[i, c] = low - epsilon[c], high + epsilon[c], g
    return lower, upper, used


@pytest.fixture(scope="module")
def cloud() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(3)
    points = rng.normal(size=(700, 3))
    targets = np.column_stack(
        [np.tanh(3 * points[:, 0]) + 0.05 * rng.normal(size=700), points[:, 1] ** 2]
    )
    return points, targets


def test_point_gamma_is_each_points_steepest_slope(cloud) -> None:
    points, targets = cloud
    epsilon = np.array([0.05, 0.02])
    tree = SMTree(points, targets)
    got = point_gamma(tree, epsilon)
    expected = _slopes(tree.points, tree.targets, epsilon).max(axis=1)
    np.testing.assert_allclose(got, expected, rtol=1e-12)
    np.testing.assert_allclose(point_gamma(tree, epsilon, np.array([5, 17])), expected[[5, 17]])
    # Their maximum is the global γ*(ε), and every pair is consistent with max(γ_i, γ_j).
    s = _slopes(tree.points, tree.targets, epsilon)
    assert np.all(np.maximum(got[:, None, :], got[None, :, :]) >= s - 1e-12)


def test_point_gamma_is_infinite_for_identical_regressors_with_distant_targets() -> None:
    points = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 1.0]])
    targets = np.array([[0.0], [1.0], [0.5]])
    got = point_gamma(SMTree(points, targets), np.array([0.1]))
    assert np.isinf(got[0, 0]) and np.isinf(got[1, 0]) and np.isfinite(got[2, 0])


@pytest.mark.parametrize("neighbours", [1, 7])
@pytest.mark.parametrize("n_queries", [5, 300])  # the serial and the threaded kernels
def test_local_bounds_equal_a_brute_force_scan(cloud, neighbours: int, n_queries: int) -> None:
    points, targets = cloud
    epsilon = np.array([0.05, 0.02])
    tree = SMTree(points, targets)
    gammas = 1.1 * point_gamma(tree, epsilon)
    fallback = gammas.max(axis=0)
    queries = np.random.default_rng(4).normal(size=(n_queries, 3)) * 1.3
    got = local_bounds(tree, gammas, queries, epsilon, fallback, neighbours)
    expected = _brute_bounds(
        tree.points, tree.targets, gammas, queries, epsilon, fallback, neighbours
    )
    for g, e in zip(got, expected, strict=True):
        np.testing.assert_allclose(g, e, rtol=1e-12, atol=1e-12)
    lower, upper, _ = got
    assert np.all(lower <= upper)


def test_crossed_local_bounds_fall_back_to_the_global_constant() -> None:
    # Two steep points far from a flat cluster: a query near the cluster but between the steep
    # points gets a small local constant that cannot reconcile them.
    flat = np.column_stack([np.linspace(-1, 1, 40), np.zeros(40)])
    points = np.vstack([flat, [[0.0, 3.0], [0.0, 3.2]]])
    targets = np.concatenate([np.zeros(40), [10.0, -10.0]])[:, None]
    epsilon = np.array([0.01])
    tree = SMTree(points, targets)
    gammas = point_gamma(tree, epsilon)
    fallback = gammas.max(axis=0)
    lower, upper, used = local_bounds(
        tree, gammas, np.array([[0.0, 3.1], [0.0, 0.0]]), epsilon, fallback, 1
    )
    assert used[0, 0] == fallback[0] and used[1, 0] < fallback[0]
    assert np.all(lower <= upper)


def _two_slopes(n: int, seed: int) -> IOData:
    """A static map, flat for u < 0 and steep for u > 0.8, with uniform noise of bound 0.01."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-3, 1, n)
    y = 0.1 * u + 4.0 * np.maximum(u - 0.8, 0) ** 1.0 + rng.uniform(-0.01, 0.01, n)
    return IOData(u, y, ts=1.0)


def test_local_constants_narrow_the_band_where_the_data_are_smooth() -> None:
    train, test = _two_slopes(800, 0), _two_slopes(400, 1)
    lags = Lags(outputs=[], inputs=[0])
    local = SetMembership(lags, epsilon=0.01, lipschitz="local").fit(train)
    glob = SetMembership(lags, epsilon=0.01).fit(train)
    np.testing.assert_array_equal(local.gamma_, glob.gamma_)
    assert local.point_gamma_.max() == pytest.approx(local.gamma_[0])
    flat = test.u[:, 0] < 0
    truth = 0.1 * test.u[:, 0] + 4.0 * np.maximum(test.u[:, 0] - 0.8, 0)
    lo_l, up_l = local.predict(test).lower[:, 0], local.predict(test).upper[:, 0]
    lo_g, up_g = glob.predict(test).lower[:, 0], glob.predict(test).upper[:, 0]
    assert np.mean((up_l - lo_l)[flat]) < 0.6 * np.mean((up_g - lo_g)[flat])
    # The true map holds the local prior here, so the band of f holds it everywhere.
    assert np.all((lo_l <= truth + 1e-12) & (truth <= up_l + 1e-12))


@pytest.fixture(scope="module")
def neck() -> tuple[IOData, IOData]:
    rng = np.random.default_rng(5)
    u = np.repeat(rng.uniform(-1, 1, 180), 10)
    y = np.zeros(u.size)
    for t in range(1, u.size):
        y[t] = 0.8 * y[t - 1] + np.tanh(2 * u[t - 1]) + rng.uniform(-0.01, 0.01)
    data = IOData(u, y, ts=0.02)
    return data[:1300], data[1300:]


def test_local_model_runs_files_and_updates(neck, tmp_path) -> None:
    train, test = neck
    model = SetMembership(Lags.arx(1, 1), epsilon=0.01, lipschitz="local").fit(train)
    free = model.simulate(test)
    sim = model.simulator()
    sim.reset(y0=test.y[0], u0=test.u[0])
    stepped = np.array([sim.step(u) for u in test.u[1:]])
    np.testing.assert_array_equal(stepped, free.y[1:])
    assert free.fit_percent(test)[0] > 90

    loaded = load_model(model.save(tmp_path / "local"))
    np.testing.assert_array_equal(loaded.predict(test).upper, model.predict(test).upper)
    _, arrays, meta = read_model_file(tmp_path / "local.npz")
    arrays["point_gamma"] = arrays["point_gamma"] * 0 + 2 * model.gamma_
    write_model_file(tmp_path / "edited", "SetMembership", arrays, meta)
    with pytest.raises(ValueError, match="point_gamma"):
        load_model(tmp_path / "edited.npz")
    del arrays["point_gamma"]
    write_model_file(tmp_path / "missing", "SetMembership", arrays, meta)
    with pytest.raises(ValueError, match="point_gamma"):
        load_model(tmp_path / "missing.npz")

    model.partial_fit(test)
    assert model.point_gamma_.shape == (model.n_samples_, 1)
    tree = model._tree
    s = _slopes(tree.points, tree.targets, model.epsilon_)
    pg = model.point_gamma_
    assert np.all(np.maximum(pg[:, None, :], pg[None, :, :]) >= s - 1e-12)


def test_multistep_local_passes_the_setting_to_every_horizon(neck, tmp_path) -> None:
    train, test = neck
    model = MultiStepSetMembership(
        Lags.arx(1, 1), horizon=3, epsilon=0.05, lipschitz="local", local_neighbours=3
    ).fit(train)
    assert all(m.lipschitz == "local" and m.local_neighbours == 3 for m in model.estimators_)
    ahead = model.predict_ahead(test, steps=3)
    glob = MultiStepSetMembership(Lags.arx(1, 1), horizon=3, epsilon=0.05).fit(train)
    width = np.nanmean(ahead.upper - ahead.lower)
    assert width < np.nanmean(
        glob.predict_ahead(test, steps=3).upper - glob.predict_ahead(test, steps=3).lower
    )
    loaded = load_model(model.save(tmp_path / "ms"))
    np.testing.assert_array_equal(loaded.predict_ahead(test, 3).upper, ahead.upper)


def test_bad_local_settings_are_refused(neck) -> None:
    train, _ = neck
    with pytest.raises(ValueError, match="lipschitz"):
        SetMembership(Lags.arx(1, 1), epsilon=0.01, lipschitz="cell").fit(train)
    with pytest.raises(ValueError, match="local_neighbours"):
        SetMembership(Lags.arx(1, 1), epsilon=0.01, lipschitz="local", local_neighbours=0).fit(
            train
        )


def test_parallel_sm_passes_local_constants_to_its_map(neck, tmp_path) -> None:
    from neckid.models.sm_parallel import ParallelSetMembership

    train, test = neck
    model = ParallelSetMembership(Lags.arx(1, 1), lipschitz="local", local_neighbours=4).fit(train)
    assert model.sm_.lipschitz == "local" and model.sm_.point_gamma_ is not None
    free = model.simulate(test)
    loaded = load_model(model.save(tmp_path / "parallel"))
    assert loaded.lipschitz == "local" and loaded.local_neighbours == 4
    np.testing.assert_array_equal(loaded.simulate(test).y, free.y)
