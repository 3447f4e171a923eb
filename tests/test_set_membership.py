"""SetMembership estimator: contract, bounds, free run, multi-output, files, errors."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone

from _sm_reference import gamma_star_reference
from neckid import IOData, Lags
from neckid.models.base import NotFittedError
from neckid.models.set_membership.narx import (
    GammaCurve,
    SetMembership,
    choose_epsilon,
    gamma_curve,
)

NOISE = 0.02


def _system(n: int, seed: int = 0, noise: float = NOISE, outputs: int = 1) -> IOData:
    """y(t) = 0.6 y(t-1) + tanh(2 u(t-1)) + e(t), |e| <= noise (a second output: a cubic).

    The noise is an equation error, so the NARX prior holds with epsilon = noise.
    """
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n)
    e = rng.uniform(-noise, noise, size=(n, outputs))
    y = np.zeros((n, outputs))
    for t in range(1, n):
        y[t, 0] = 0.6 * y[t - 1, 0] + np.tanh(2 * u[t - 1]) + e[t, 0]
        if outputs > 1:
            y[t, 1] = 0.3 * y[t - 1, 1] + 3.0 * u[t - 1] ** 3 + e[t, 1]
    return IOData(u, y, ts=0.02)


LAGS = Lags(outputs=1, inputs=1)


@pytest.fixture(scope="module")
def data() -> IOData:
    return _system(1200)


#: Lipschitz constant of (y, u) -> 0.6 y + tanh(2 u) in the unscaled Euclidean norm.
TRUE_GAMMA = float(np.hypot(0.6, 2.0))


@pytest.fixture(scope="module")
def model(data: IOData) -> SetMembership:
    """gamma = 1.1 gamma*(eps): learned from the data, may undershoot the true constant."""
    return SetMembership(LAGS, epsilon=NOISE).fit(data[:800])


@pytest.fixture(scope="module")
def valid_model(data: IOData) -> SetMembership:
    """The prior holds: the true noise bound and the true Lipschitz constant."""
    return SetMembership(LAGS, epsilon=NOISE, gamma=TRUE_GAMMA, scaling="none").fit(data[:800])


# ------------------------------------------------------------------ contract
def test_init_stores_arguments_only_and_clone_works() -> None:
    sm = SetMembership(LAGS, epsilon=0.1, gamma=2.0, gamma_margin=1.5, scaling="none")
    assert sm.get_params()["gamma_margin"] == 1.5
    assert not any(k.endswith("_") for k in vars(sm))
    assert clone(sm).get_params()["epsilon"] == 0.1
    with pytest.raises(NotFittedError, match="not fitted"):
        sm.bounds(np.zeros(2))
    with pytest.raises(NotFittedError):
        sm.simulate(_system(20))


def test_fit_sets_learned_attributes(model: SetMembership) -> None:
    assert model.epsilon_.shape == model.gamma_.shape == (1,)
    assert model.n_samples_ == 799
    assert model.prior_valid_.all()
    curve = model.gamma_curve_
    assert isinstance(curve, GammaCurve)
    assert NOISE in curve.epsilons[:, 0]
    # gamma = margin * gamma*(eps) and gamma*(eps) is what the NumPy reference gives.
    x, y = LAGS.build(_system(1200)[:800])
    ref = gamma_star_reference(x * model.weights_, y[:, 0], [NOISE])
    np.testing.assert_allclose(model.gamma_star_, ref, rtol=1e-12)
    np.testing.assert_allclose(model.gamma_, 1.1 * ref, rtol=1e-12)


def test_predict_and_simulate_carry_bounds(model: SetMembership, data: IOData) -> None:
    test = data[800:]
    for result, kind in ((model.predict(test), "prediction"), (model.simulate(test), "simulation")):
        assert result.kind == kind and result.n_initial == 1
        assert np.isnan(result.lower[:1]).all() and np.isnan(result.upper[:1]).all()
        assert np.all(result.lower[1:] <= result.y[1:]) and np.all(result.y[1:] <= result.upper[1:])
        assert result.fit_percent(test)[0] > 85


def test_bounds_contain_new_measurements_when_prior_holds(
    valid_model: SetMembership, data: IOData
) -> None:
    x, y = LAGS.build(data[800:])
    b = valid_model.bounds(x)
    eps = valid_model.epsilon_
    assert np.all(b.lower - eps <= y) and np.all(y <= b.upper + eps)


def test_compiled_free_run_equals_step_by_step(model: SetMembership, data: IOData) -> None:
    test = data[800:900]
    compiled = model.simulate(test)
    # Plain Python loop over bounds() on the regressor of the simulated history.
    y = np.array(test.y)
    for t in range(1, test.n_samples):
        w = model.lags_.regressor_from_history(y, test.u, t)
        y[t] = model.bounds(w).central[0]
    np.testing.assert_allclose(compiled.y, y, rtol=1e-12, atol=1e-12)
    sim = model.simulator()
    sim.reset(y0=test.y[:1], u0=test.u[:1])
    steps = [sim.step_bounds(test.u[t]) for t in range(1, test.n_samples)]
    np.testing.assert_allclose(np.array([s[0] for s in steps]), compiled.y[1:], rtol=1e-12)
    np.testing.assert_allclose(np.array([s[1] for s in steps]), compiled.lower[1:], rtol=1e-12)
    np.testing.assert_allclose(np.array([s[2] for s in steps]), compiled.upper[1:], rtol=1e-12)


def test_bounds_width_at_training_points_is_at_most_two_epsilon(model: SetMembership) -> None:
    x, _ = LAGS.build(_system(1200)[:800])
    b = model.bounds(x)
    assert np.all(b.upper - b.lower <= 2 * model.epsilon_ + 1e-12)


def test_static_map_contains_true_function() -> None:
    """Lags of inputs at 0 only: a static map, y = f(u1, u2) + e with known Lipschitz constant."""
    rng = np.random.default_rng(5)
    u = rng.uniform(-1, 1, size=(400, 2))

    def f(v: np.ndarray) -> np.ndarray:
        return np.sin(2 * v[:, 0]) + 0.5 * v[:, 1]  # Lipschitz constant sqrt(4 + 0.25)

    y = f(u) + rng.uniform(-0.05, 0.05, 400)
    sm = SetMembership(Lags(inputs=[0]), epsilon=0.05, gamma=np.sqrt(4.25), scaling="none")
    sm.fit(IOData(u, y, ts=1.0))
    queries = rng.uniform(-1.2, 1.2, size=(300, 2))
    b = sm.bounds(queries)
    truth = f(queries)[:, None]
    assert np.all(b.lower <= truth + 1e-12) and np.all(truth <= b.upper + 1e-12)


# ------------------------------------------------------------------ choices of eps and gamma
def test_epsilon_from_the_curve_is_near_the_noise_bound(data: IOData) -> None:
    sm = SetMembership(LAGS).fit(data[:800])
    assert NOISE / 2 < sm.epsilon_[0] < 2 * NOISE
    curve = sm.gamma_curve_
    assert curve is not None
    assert np.all(np.diff(curve.gamma[:, 0]) <= 1e-12)  # nonincreasing
    np.testing.assert_allclose(sm.gamma_, 1.1 * sm.gamma_star_)


def test_given_gamma_gives_smallest_consistent_epsilon(data: IOData) -> None:
    sm = SetMembership(LAGS, gamma=1.5).fit(data[:800])
    assert sm.gamma_curve_ is None
    # At that epsilon gamma*(eps) equals gamma (the binding pair), just above it, less.
    x, y = LAGS.build(data[:800])
    eps = sm.epsilon_[0]
    g = gamma_star_reference(x * sm.weights_, y[:, 0], [eps, eps * 1.01 + 1e-9])
    assert g[0] == pytest.approx(1.5, rel=1e-9) and g[1] < 1.5


def test_choose_epsilon_takes_where_the_slope_flattens() -> None:
    eps = np.array([0.0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.1, 0.2])
    gamma = np.array([np.inf, 60.0, 40.0, 20.0, 5.0, 4.9, 4.4, 3.4])
    assert choose_epsilon(eps, gamma) == 4
    assert choose_epsilon(eps[:3], gamma[:3]) == 1  # too few points: smallest finite
    with pytest.raises(ValueError, match="infinite over the whole"):
        choose_epsilon(eps, np.full(8, np.inf))


def test_gamma_curve_function_matches_reference_and_estimator(data: IOData) -> None:
    grid = [0.0, 0.01, 0.05, 0.3]
    calls: list[tuple[int, int]] = []
    curve = gamma_curve(data[:300], LAGS, grid, progress=lambda d, t: calls.append((d, t)))
    x, y = LAGS.build(data[:300])
    ref = gamma_star_reference(x / x.std(axis=0), y[:, 0], grid)
    np.testing.assert_allclose(curve.gamma[:, 0], ref, rtol=1e-12)
    assert calls and calls[-1][0] == calls[-1][1]
    unscaled = gamma_curve(data[:300], LAGS, grid, scaling="none")
    np.testing.assert_allclose(unscaled.gamma[:, 0], gamma_star_reference(x, y[:, 0], grid))


# ------------------------------------------------------------------ several outputs, experiments
def test_two_outputs_have_their_own_epsilon_and_gamma() -> None:
    data = _system(900, seed=2, outputs=2)
    sm = SetMembership(LAGS, epsilon=[0.02, 0.05]).fit(data[:600])
    assert sm.epsilon_.tolist() == [0.02, 0.05]
    assert sm.gamma_[0] != sm.gamma_[1]
    alone = SetMembership(Lags(outputs={"y2": [1]}, inputs=1), epsilon=0.05)
    alone.fit(data[:600].select(outputs=["y2"], inputs=["u", "y1"]))
    sim = sm.simulate(data[600:])
    assert sim.y.shape == (300, 2) and sim.fit_percent(data[600:]).min() > 70
    # Per output the bounds equal a single-output model on the same regressor and targets.
    x, _ = LAGS.build(data[:600])
    both = sm.bounds(x[:50])
    one = SetMembership(LAGS, epsilon=0.05, gamma=sm.gamma_[1]).fit(data[:600])
    np.testing.assert_allclose(one.bounds(x[:50]).upper[:, 1], both.upper[:, 1], rtol=1e-12)


def test_experiments_are_not_mixed() -> None:
    a, b = _system(300, seed=3), _system(200, seed=4)
    sm = SetMembership(Lags(outputs=2, inputs=2), epsilon=NOISE).fit([a, b])
    assert sm.n_samples_ == (300 - 2) + (200 - 2)


def test_linear_part_extrapolates() -> None:
    rng = np.random.default_rng(6)
    u = rng.uniform(-1, 1, 800)
    y = np.zeros(800)
    for t in range(1, 800):
        y[t] = 0.8 * y[t - 1] + 0.5 * u[t - 1] + 0.05 * np.sin(3 * u[t - 1])
    data = IOData(u, y + rng.uniform(-0.01, 0.01, 800), ts=0.1)
    plain = SetMembership(LAGS, epsilon=0.01).fit(data)
    linear = SetMembership(LAGS, epsilon=0.01, linear_part=True).fit(data)
    far = np.array([[6.0, 3.0]])  # y(t-1), u(t-1) far outside the training range
    truth = 0.8 * 6.0 + 0.5 * 3.0 + 0.05 * np.sin(9.0)
    assert abs(linear.bounds(far).central[0, 0] - truth) < 0.2
    assert abs(plain.bounds(far).central[0, 0] - truth) > 1.0
    b = linear.bounds(far)
    assert b.lower[0, 0] <= b.central[0, 0] <= b.upper[0, 0]


# ------------------------------------------------------------------ invalidation, files
def test_invalidation(valid_model: SetMembership, data: IOData) -> None:
    ok = valid_model.invalidation(data[800:])
    assert not ok.falsified and ok.fraction[0] == 0.0
    shifted = data[800:].replace(y=data[800:].y + 1.0)
    bad = valid_model.invalidation([shifted])[0]
    assert bad.falsified and bad.fraction[0] > 0.5 and np.all(bad.excess[bad.outside] > 0)


def test_save_load_round_trip(model: SetMembership, data: IOData, tmp_path) -> None:
    path = model.save(tmp_path / "sm")
    loaded = SetMembership.load(path)
    for name in ("epsilon_", "gamma_", "weights_", "coef_", "gamma_star_"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(model, name))
    a, b = model.simulate(data[800:]), loaded.simulate(data[800:])
    np.testing.assert_array_equal(a.y, b.y)
    np.testing.assert_array_equal(a.upper, b.upper)
    assert loaded.gamma_curve_ is not None
    np.testing.assert_array_equal(loaded.gamma_curve_.gamma, model.gamma_curve_.gamma)
    with open(path, "rb") as handle:  # a zip of .npy: no pickle inside
        assert handle.read(2) == b"PK"


def test_save_load_with_user_weights_and_linear_part(data: IOData, tmp_path) -> None:
    sm = SetMembership(LAGS, epsilon=0.02, gamma=3.0, scaling=[2.0, 1.0], linear_part=True)
    sm.fit(data[:400])
    loaded = SetMembership.load(sm.save(tmp_path / "w.npz"))
    x, _ = LAGS.build(data[400:500])
    np.testing.assert_array_equal(loaded.bounds(x).central, sm.bounds(x).central)
    assert loaded.get_params()["scaling"] == [2.0, 1.0]


def test_input_weight_scales_only_the_input_terms(data: IOData, tmp_path) -> None:
    lags = Lags(outputs=[1, 2], inputs=[0, 1])
    plain = SetMembership(lags, epsilon=NOISE, linear_part=True).fit(data[:400])
    light = SetMembership(lags, epsilon=NOISE, linear_part=True, input_weight=0.1)
    light.fit(data[:400])
    is_input = np.array([name.startswith("u") for name in light.lags_.names])
    assert is_input.tolist() == [False, False, True, True]
    np.testing.assert_allclose(light.weights_, plain.weights_ * np.where(is_input, 0.1, 1.0))
    np.testing.assert_array_equal(light.coef_, plain.coef_)  # the linear part does not change
    # the distance is the estimator's: gamma*(epsilon) equals the reference on the weighted rows
    x, y = lags.build(data[:400])
    residual = y - (x @ light.coef_ + light.intercept_)
    star = gamma_star_reference(x * light.weights_, residual[:, 0], [NOISE])[0]
    assert light.gamma_star_[0] == pytest.approx(star, rel=1e-12)
    curve = gamma_curve(data[:400], lags, [NOISE], linear_part=True, input_weight=0.1)
    assert curve.gamma[0, 0] == pytest.approx(star, rel=1e-12)
    loaded = SetMembership.load(light.save(tmp_path / "iw.npz"))
    assert loaded.get_params()["input_weight"] == 0.1
    np.testing.assert_array_equal(loaded.simulate(data[400:]).y, light.simulate(data[400:]).y)


# ------------------------------------------------------------------ bad input
def _duplicated() -> IOData:
    u = np.array([0.0, 1.0, 0.0, 1.0, 0.5, 0.2])
    y = np.array([0.0, 0.0, 0.0, 0.5, 0.1, 0.3])  # rows t=1 and t=3: same (y, u) lags, y differs
    return IOData(u, y, ts=1.0)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"epsilon": -0.1}, ValueError, r"epsilon must be >= 0.*-0.1"),
        (
            {"epsilon": float("nan")},
            ValueError,
            "epsilon must be None or a number >= 0 or an array of finite numbers; got nan",
        ),
        ({"epsilon": [0.1, 0.2]}, ValueError, "one per output"),
        ({"gamma": 0.0}, ValueError, r"gamma must be > 0.*0.0"),
        ({"gamma": -1.0}, ValueError, "gamma must be > 0"),
        ({"gamma_margin": 0.5}, ValueError, "gamma_margin must be a number >= 1; got 0.5"),
        (
            {"scaling": "minmax"},
            ValueError,
            "scaling must be one of 'std', 'gradient', 'none' or an array of finite numbers; got 'minmax'",
        ),
        ({"scaling": [1.0]}, ValueError, "one value per regressor term"),
        ({"scaling": [1.0, -1.0]}, ValueError, "finite and > 0"),
        ({"epsilon": 0.0, "gamma": 0.01}, ValueError, r"below gamma\*\(epsilon\) = \d"),
        ({"linear_part": "yes"}, TypeError, "linear_part must be True or False"),
        ({"epsilons": [-1.0, 0.0]}, ValueError, "epsilons must be finite and >= 0"),
        ({"input_weight": 0.0}, ValueError, "input_weight must be a number > 0; got 0.0"),
        ({"input_weight": float("inf")}, ValueError, "input_weight must be a number > 0; got inf"),
        ({"input_weight": "small"}, TypeError, "input_weight must be a number"),
    ],
)
def test_bad_arguments(data: IOData, kwargs: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        SetMembership(LAGS, **kwargs).fit(data[:200])


def test_gamma_below_gamma_star_names_the_value(data: IOData) -> None:
    x, y = LAGS.build(data[:200])
    star = gamma_star_reference(x / x.std(axis=0), y[:, 0], [0.0])[0]
    with pytest.raises(ValueError, match=f"gamma\\*\\(epsilon\\) = {star:.6g}"):
        SetMembership(LAGS, epsilon=0.0, gamma=star * 0.9).fit(data[:200])
    SetMembership(LAGS, epsilon=0.0, gamma=star * 1.0001).fit(data[:200])  # just above: fine


def test_duplicate_regressors_beyond_two_epsilon() -> None:
    with pytest.raises(ValueError, match=r"rows 0 and 2 are identical.*differs by 0.5"):
        SetMembership(LAGS, epsilon=0.1).fit(_duplicated())
    with pytest.raises(ValueError, match="identical"):
        SetMembership(LAGS, epsilon=0.1, gamma=5.0).fit(_duplicated())
    SetMembership(LAGS, epsilon=0.25, gamma=1.0).fit(_duplicated())  # 0.5 <= 2 eps: valid
    # With gamma alone, epsilon becomes at least half the duplicates' spread.
    assert SetMembership(LAGS, gamma=5.0).fit(_duplicated()).epsilon_[0] >= 0.25


def test_too_few_samples_constant_output_and_nan() -> None:
    with pytest.raises(ValueError, match="too few"):
        SetMembership(Lags(outputs=3, inputs=3), epsilon=0.1).fit(IOData([1.0, 2.0], [0.0, 1.0]))
    with pytest.raises(ValueError, match="at least 2 training regressors"):
        SetMembership(LAGS, epsilon=0.1).fit(IOData([1.0, 2.0], [0.0, 1.0]))
    with pytest.raises(ValueError, match="constant"):
        SetMembership(LAGS).fit(IOData(np.arange(10.0), np.ones(10)))
    with pytest.raises(ValueError, match="non-finite"):
        IOData([1.0, np.nan, 2.0], [0.0, 1.0, 2.0])


def test_bounds_refuses_bad_regressors(model: SetMembership) -> None:
    with pytest.raises(ValueError, match="non-finite value nan at row 1"):
        model.bounds([[0.0, 0.0], [np.nan, 0.0]])
    with pytest.raises(ValueError, match="must have 2 columns"):
        model.bounds(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="but the model was fitted on"):
        model.predict(IOData(np.zeros((5, 2)), np.zeros(5), ts=0.02))


def test_progress_bar_runs(data: IOData) -> None:
    shown = gamma_curve(data[:200], LAGS, [0.0, 0.02], progress=True)
    hidden = gamma_curve(data[:200], LAGS, [0.0, 0.02], progress=False)
    np.testing.assert_array_equal(shown.gamma, hidden.gamma)


def test_mimo_sm_bounds_contain_a_known_two_output_lipschitz_system() -> None:
    """Two outputs, each with its own ε and γ: the one-step bounds hold the noise-free map."""
    n, eps = 3000, np.array([0.02, 0.01])

    def f(y1: np.ndarray, y2: np.ndarray, u: np.ndarray) -> np.ndarray:
        # gradients (cos 2y1, 0, 1) and (0.5, -0.2 sin y2, 0.3 sech² u): Lipschitz 1.42 and 0.62
        return np.column_stack(
            [0.5 * np.sin(2.0 * y1) + u, 0.5 * y1 + 0.2 * np.cos(y2) + 0.3 * np.tanh(u)]
        )

    def record(seed: int) -> tuple[IOData, np.ndarray]:
        local = np.random.default_rng(seed)
        u = local.uniform(-1.0, 1.0, n)
        clean = np.zeros((n, 2))
        noisy = np.zeros((n, 2))
        for t in range(1, n):
            clean[t] = f(noisy[t - 1, :1], noisy[t - 1, 1:], u[t - 1 : t])[0]
            noisy[t] = clean[t] + local.uniform(-1.0, 1.0, 2) * eps
        return IOData(u, noisy, ts=0.01, output_names=["a", "b"]), clean

    train, _ = record(1)
    test, clean = record(2)
    model = SetMembership(
        Lags(outputs=1, inputs=[1]), epsilon=eps, gamma=[1.45, 0.65], scaling="none"
    )
    model.fit(train)
    assert model.prior_valid_.all()
    result = model.predict(test)
    inside = (result.lower[1:] <= clean[1:] + 1e-12) & (clean[1:] - 1e-12 <= result.upper[1:])
    assert inside.all(), inside.mean(axis=0)
    width = (result.upper - result.lower)[1:]
    assert np.all(np.median(width, axis=0) < [0.5, 0.25])  # bounds that say something
    assert np.all(result.fit_percent(test) > 90.0)
