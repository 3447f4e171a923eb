"""Local Lipschitz constants: kernels against brute force, the prior's consistency, models, files."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from neckid import IOData, Lags, load_model
from neckid.models.io import read_model_file, write_model_file
from neckid.models.set_membership._kernels.local import local_bounds, point_gamma
from neckid.models.set_membership._kernels.tree import SMTree
from neckid.models.set_membership.multistep import MultiStepSetMembership
from neckid.models.set_membership.narx import SetMembership


def _slopes(points: np.ndarray, targets: np.ndarray, epsilon: np.ndarray) -> np.ndarray:
    """(|t_i − t_j| − 2ε)⁺ / d_ij for every pair, shape (n, n, n_outputs); 0 on the diagonal."""
    d = np.sqrt(((points[:, None, :] - points[None, :, :]) ** 2).sum(-1))
    rise = np.maximum(np.abs(targets[:, None, :] - targets[None, :, :]) - 2 * epsilon, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(d[..., None] > 0, rise / d[..., None], 0.0)
    return s


def _brute_bounds(points, targets, gammas, queries, epsilon, fallback, k):
    """The local bounds by a scan: γ(w) over every point within the k-th distance (ties in)."""
    lower = np.empty((len(queries), targets.shape[1]))
    upper = np.empty_like(lower)
    used = np.empty_like(lower)
    for i, w in enumerate(queries):
        d2 = ((points - w) ** 2).sum(1)
        d = np.sqrt(d2)
        near = d2 <= np.sort(d2)[k - 1]
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


def test_the_kernels_in_chunks_give_the_same_bits(cloud, monkeypatch) -> None:
    """Called in chunks (to return to Python, where a stop signal is taken): the same result."""
    from neckid.models.set_membership._kernels import local

    points, targets = cloud
    tree, epsilon = SMTree(points, targets), np.array([0.05, 0.02])
    queries = np.random.default_rng(5).normal(size=(300, 3))
    gammas = 1.1 * point_gamma(tree, epsilon)
    whole = (gammas, *local_bounds(tree, gammas, queries, epsilon, gammas.max(axis=0), 4))
    monkeypatch.setattr(local, "KERNEL_CHUNK", 64)  # 11 chunks of the points, 5 of the queries
    chunked = 1.1 * point_gamma(tree, epsilon)
    chunked = (chunked, *local_bounds(tree, chunked, queries, epsilon, chunked.max(axis=0), 4))
    for a, b in zip(whole, chunked, strict=True):
        np.testing.assert_array_equal(a, b)


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


def test_local_bounds_never_cross() -> None:
    # Steep jumps next to flat stretches: both ends of every pair carry its slope, so the
    # bounds cannot cross whatever the neighbourhood; the global constant is never needed.
    rng = np.random.default_rng(8)
    points = rng.uniform(-1, 1, size=(2000, 2))
    targets = np.where(points[:, :1] > 0.3, 5.0, 0.0) + 0.01 * rng.normal(size=(2000, 1))
    epsilon = np.array([0.02])
    tree = SMTree(points, targets)
    gammas = 1.1 * point_gamma(tree, epsilon)
    fallback = gammas.max(axis=0)
    queries = rng.uniform(-1.5, 1.5, size=(3000, 2))
    for neighbours in (1, 5):
        lower, upper, used = local_bounds(tree, gammas, queries, epsilon, fallback, neighbours)
        assert np.all(lower <= upper)
        without = local_bounds(tree, gammas, queries, epsilon, np.zeros(1), neighbours)
        for a, b in zip((lower, upper, used), without, strict=True):
            np.testing.assert_array_equal(a, b)  # the fallback never changed a query


def test_ties_do_not_depend_on_the_order_of_the_points() -> None:
    # A quantised signal at rest: many identical regressors with different constants. The tree
    # built on the same points in another order gives the same bounds (every tie counts).
    rng = np.random.default_rng(9)
    points = np.round(rng.uniform(-1, 1, size=(600, 2)), 1)
    targets = np.round(np.sin(3 * points[:, :1]) + 0.05 * rng.normal(size=(600, 1)), 2)
    epsilon = np.array([0.06])
    queries = np.round(rng.uniform(-1, 1, size=(400, 2)), 1)
    results = []
    for order in (np.arange(600), rng.permutation(600)):
        tree = SMTree(points[order], targets[order])
        gammas = 1.1 * point_gamma(tree, epsilon)
        results.append(local_bounds(tree, gammas, queries, epsilon, gammas.max(axis=0), 3))
    for a, b in zip(*results, strict=True):
        np.testing.assert_array_equal(a, b)


def test_a_query_with_no_neighbour_gets_an_infinite_constant() -> None:
    points = np.random.default_rng(1).normal(size=(50, 2))
    tree = SMTree(points, points[:, :1])
    gammas = point_gamma(tree, np.array([0.01]))
    _, _, used = local_bounds(
        tree, gammas, np.array([[np.nan, 0.0]]), np.array([0.01]), gammas.max(0), 3
    )
    assert np.isinf(used[0, 0])


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
    from neckid.models.set_membership.parallel import ParallelSetMembership

    train, test = neck
    model = ParallelSetMembership(Lags.arx(1, 1), lipschitz="local", local_neighbours=4).fit(train)
    assert model.sm_.lipschitz == "local" and model.sm_.point_gamma_ is not None
    free = model.simulate(test)
    loaded = load_model(model.save(tmp_path / "parallel"))
    assert loaded.lipschitz == "local" and loaded.local_neighbours == 4
    np.testing.assert_array_equal(loaded.simulate(test).y, free.y)


def test_a_failed_local_update_leaves_the_model_as_it_was(neck) -> None:
    train, test = neck
    model = SetMembership(Lags.arx(1, 1), epsilon=0.01, lipschitz="local").fit(train)
    before = model.predict(test).upper.copy()
    n = model.n_samples_
    # The first training rows again, with outputs 1 higher: identical regressors, outputs more
    # than 2ε apart; prior="keep" lets revise_prior pass, the constants cannot be learned.
    clash = IOData(
        train.u[:50], train.y[:50] + np.r_[0.0, np.ones(49)][:, None], ts=train.ts,
        input_names=train.input_names, output_names=train.output_names,
    )  # fmt: skip
    with pytest.raises(ValueError, match="identical"), pytest.warns(UserWarning):
        model.partial_fit(clash, prior="keep")
    assert model.n_samples_ == n and model.point_gamma_.shape == (n, 1)
    np.testing.assert_array_equal(model.predict(test).upper, before)


def test_set_params_after_fit_changes_neither_the_model_nor_its_file(neck, tmp_path) -> None:
    train, test = neck
    model = SetMembership(Lags.arx(1, 1), epsilon=0.01, lipschitz="local").fit(train)
    before = model.predict(test).upper.copy()
    model.set_params(lipschitz="global", local_neighbours=1)
    np.testing.assert_array_equal(model.predict(test).upper, before)
    loaded = load_model(model.save(tmp_path / "m"))
    np.testing.assert_array_equal(loaded.predict(test).upper, before)
    assert loaded.lipschitz == "local" and loaded.local_neighbours == 10


def test_local_band_still_widens_where_a_constant_fits_every_target() -> None:
    # ε_k above every residual: γ*(ε_k) = 0, the multi-step model falls back to γ*(f·ε_k) > 0,
    # and the local constants follow it instead of being all 0.
    rng = np.random.default_rng(2)
    u = np.repeat(rng.uniform(0, 1, 60), 10)
    y = np.zeros(u.size)
    for t in range(1, u.size):
        y[t] = 0.5 * y[t - 1] + 0.2 * u[t - 1] + rng.uniform(-0.01, 0.01)
    data = IOData(u, y, ts=0.02)
    near = IOData(u[:200], y[:200], ts=0.02)
    far = IOData(u[:200] + 30.0, y[:200] + 30.0, ts=0.02)
    widths = {}
    for form in ("global", "local"):
        model = MultiStepSetMembership(Lags.arx(1, 1), horizon=1, epsilon=0.011, lipschitz=form)
        with warnings.catch_warnings():  # the far log extrapolates, on purpose
            warnings.simplefilter("ignore")
            model.fit(data)
            assert model.gamma_star_[0, 0] == 0 and model.gamma_[0, 0] > 0
            widths[form] = [
                np.nanmean(model.predict_ahead(d, 1).upper - model.predict_ahead(d, 1).lower)
                for d in (near, far)
            ]
    for form, (w_near, w_far) in widths.items():
        assert w_far > 3 * w_near, (form, widths)
