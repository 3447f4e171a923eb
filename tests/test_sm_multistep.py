"""MultiStepSetMembership: k-step regressors, the ε/γ rules, guaranteed bands, runs, files, errors."""

from __future__ import annotations

import numpy as np
import pytest

from _sm_reference import gamma_star_reference
from neckid import IOData, Lags, LinearARX, SetMembership, load_model
from neckid.metrics import coverage
from neckid.models.base import NotFittedError
from neckid.models.io import read_model_file, write_model_file
from neckid.models.set_membership.multistep import (
    MAD_TO_STD,
    MultiStepSetMembership,
    horizon_lags,
    robust_scale,
)

POLE = 0.7
NOISE = 0.05
LAGS = Lags.arx(1, 1)


class NeckLike:
    """``y(t) = POLE·y(t−1) + (1 − POLE)·g(u(t−1)) + e(t)``, ``|e(t)| <= NOISE`` (uniform).

    A neck-like first-order response of the inclination [deg] to the motor displacement ``u``
    [rad] through a saturating static map ``g(u) = 30 tanh(0.3 u)``. Being affine in ``y``, its
    noise-free k-step output from a measured ``y(t)`` is known in closed form, and so is the
    bound of the k-step error: ``|d_k| <= NOISE · (1 − POLE^k) / (1 − POLE)``.
    """

    @staticmethod
    def g(u: np.ndarray) -> np.ndarray:
        return 30.0 * np.tanh(0.3 * u)

    @classmethod
    def record(cls, n: int, seed: int) -> IOData:
        rng = np.random.default_rng(seed)
        u = np.repeat(rng.uniform(0.0, 5.0, n // 10 + 1), 10)[:n]
        e = rng.uniform(-NOISE, NOISE, n)
        y = np.zeros(n)
        for t in range(1, n):
            y[t] = POLE * y[t - 1] + (1 - POLE) * cls.g(u[t - 1]) + e[t]
        return IOData(u, y, ts=0.025, input_names=["motor"], output_names=["inclination"])

    @classmethod
    def noise_free_ahead(cls, data: IOData, steps: int) -> np.ndarray:
        """Row ``s``: the noise-free ``y(s)`` from the measured ``y(s − k)`` and the inputs."""
        y, u = data.y[:, 0], data.u[:, 0]
        out = np.full(data.n_samples, np.nan)
        for s in range(steps, data.n_samples):
            value = y[s - steps]
            for t in range(s - steps, s):
                value = POLE * value + (1 - POLE) * cls.g(u[t])
            out[s] = value
        return out

    @staticmethod
    def error_bound(steps: int) -> float:
        return NOISE * (1 - POLE**steps) / (1 - POLE)


@pytest.fixture(scope="module")
def train() -> IOData:
    return NeckLike.record(1500, seed=1)


@pytest.fixture(scope="module")
def test_log() -> IOData:
    return NeckLike.record(600, seed=2)


@pytest.fixture(scope="module")
def model(train: IOData) -> MultiStepSetMembership:
    return MultiStepSetMembership(LAGS, horizon=3, horizons=[6]).fit(train)


# ---------------------------------------------------------------------------- regressors
@pytest.mark.parametrize("steps", [1, 2, 5])
def test_horizon_lags_hold_the_anchor_outputs_and_every_input_up_to_the_target(steps: int) -> None:
    data = IOData(np.zeros((30, 2)), np.zeros((30, 1)), ts=0.1)
    one = Lags(outputs=[1, 2], inputs=[0, 1]).resolve(data)
    lags = horizon_lags(one, steps)
    # y(t), y(t-1) with t = s - k; u(s), u(s-1), ..., u(s-k): lags 0 .. k.
    expected = Lags(
        outputs={"y": [steps, steps + 1]},
        inputs={"u1": list(range(steps + 1)), "u2": list(range(steps + 1))},
    )
    assert lags == expected
    assert lags.max_lag == one.max_lag + steps - 1
    if steps == 1:
        assert lags == one.to_lags()


def test_robust_scale_is_the_normalised_mad() -> None:
    values = np.array([[1.0, 10.0], [2.0, 10.0], [4.0, 13.0], [100.0, 16.0]])
    # Medians 3 and 11.5; absolute deviations [2, 1, 1, 97] and [1.5, 1.5, 1.5, 4.5].
    np.testing.assert_allclose(robust_scale(values), MAD_TO_STD * np.array([1.5, 1.5]))


# ---------------------------------------------------------------------------- the rules
def test_linear_part_is_the_direct_least_squares_arx(
    model: MultiStepSetMembership, train: IOData
) -> None:
    for k, estimator in zip(model.horizons_, model.estimators_, strict=True):
        direct = LinearARX(horizon_lags(model.lags_, int(k))).fit(train)
        np.testing.assert_allclose(estimator.coef_, direct.coef_, rtol=0, atol=1e-10)
        np.testing.assert_allclose(estimator.intercept_, direct.intercept_, rtol=0, atol=1e-10)


def test_epsilon_is_the_factor_times_the_robust_scale_of_the_direct_arx_residual(
    train: IOData,
) -> None:
    model = MultiStepSetMembership(LAGS, horizon=2, epsilon_factor=2.5).fit(train)
    for i, k in enumerate(model.horizons_):
        direct = LinearARX(horizon_lags(model.lags_, int(k))).fit(train)
        residual = train.y - direct.predict(train).y
        scale = robust_scale(residual[direct.max_lag_ :])
        np.testing.assert_allclose(model.residual_scale_[i], scale, rtol=1e-9)
        np.testing.assert_allclose(model.epsilon_[i], 2.5 * scale, rtol=1e-9)


def test_gamma_is_the_margin_times_the_brute_force_gamma_star(train: IOData) -> None:
    short = train[:300]
    # epsilon_factor 1.5: γ*(ε) > 0 for both horizons (no fallback).
    model = MultiStepSetMembership(LAGS, horizon=2, gamma_margin=1.3, epsilon_factor=1.5)
    model.fit(short)
    for i, estimator in enumerate(model.estimators_):
        x, y = estimator.lags_.build_one(short)
        residual = y - (x @ estimator.coef_ + estimator.intercept_)
        star = gamma_star_reference(x * estimator.weights_, residual[:, 0], model.epsilon_[i])
        assert star[0] > 0
        np.testing.assert_allclose(model.gamma_star_[i], star, rtol=1e-9)
        np.testing.assert_allclose(model.gamma_[i], 1.3 * star, rtol=1e-9)


def test_gamma_falls_back_to_half_epsilon_when_a_constant_fits(train: IOData) -> None:
    x, y = LAGS.build(train)
    probe = MultiStepSetMembership(LAGS, horizon=1).fit(train)
    residual = y - (x @ probe.estimators_[0].coef_ + probe.estimators_[0].intercept_)
    spread = float(np.ptp(residual))
    # 2ε > spread: γ*(ε) = 0; 2(ε/2) < spread: γ*(ε/2) > 0.
    model = MultiStepSetMembership(LAGS, horizon=1, epsilon=0.6 * spread).fit(train)
    assert model.gamma_star_[0, 0] == 0.0
    weights = model.estimators_[0].weights_
    half = gamma_star_reference(x * weights, residual[:, 0], np.array([0.3 * spread]))
    np.testing.assert_allclose(model.gamma_[0], 1.1 * half, rtol=1e-9)
    with pytest.raises(ValueError, match=r"γ\*\(ε\) = 0"):
        MultiStepSetMembership(LAGS, horizon=1, epsilon=2.0 * spread).fit(train)


# ---------------------------------------------------------------------------- guarantees
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_bands_contain_the_noise_free_k_step_output_when_the_prior_holds(seed: int) -> None:
    """Milanese & Novara (2004), Theorem 1, for each direct predictor f_k.

    ε_k is the true bound of the k-step error; γ_k = 2 γ*(ε_k) from dense data.
    """
    train = NeckLike.record(2000, seed=10 * seed)
    test = NeckLike.record(500, seed=10 * seed + 1)
    horizons = [1, 2, 3, 5]
    epsilon = [NeckLike.error_bound(k) for k in horizons]
    model = MultiStepSetMembership(
        LAGS, horizon=3, horizons=[5], epsilon=epsilon, gamma_margin=2.0
    ).fit(train)
    for k in horizons:
        result = model.predict_ahead(test, steps=k)
        s = result.n_initial
        truth = NeckLike.noise_free_ahead(test, k)
        low, high = result.extras["function_lower"], result.extras["function_upper"]
        assert coverage(truth[s:], low[s:], high[s:])[0] == 1.0
        assert coverage(test.y, result.lower, result.upper, skip=s)[0] == 1.0
        # Tight enough that the truth one sample off would not fit: the test can fail.
        assert coverage(truth[s + 1 :], low[s:-1], high[s:-1])[0] < 0.9


def test_bands_on_the_simulated_neck_contain_the_noise_free_inclination() -> None:
    """The simulated soft neck with a sensor of known accuracy ``BOUND`` (uniform noise).

    The neck is not a finite NARX (motor, link and hysteresis states), so the prior is an
    assumption here, checked on held-out data: with ε = the sensor's bound and γ = 1.1 γ*(ε),
    the guaranteed band holds the noise-free inclination at every test sample.
    """
    from neckid.plant import SoftNeck, SoftNeckParameters

    bound = 0.05

    def run(seed: int) -> tuple[IOData, np.ndarray]:
        rng = np.random.default_rng(seed)
        parameters = SoftNeckParameters(sensor_noise=0.0, sensor_resolution=1e-6)
        commands = np.repeat(rng.uniform(-2.0, 2.0, 150), 20)
        position = 0.0
        for t in range(commands.size):  # wind and unwind between 0 and about 4 rad
            if (position > 4.0 and commands[t] > 0) or (position < 0.2 and commands[t] < 0):
                commands[t] = -commands[t]
            position += commands[t] * 0.02
        log = SoftNeck(parameters, ts=0.02, seed=seed).run(commands)
        log = log.select(inputs=["motor_position", "motor_velocity"])
        noisy = log.y + rng.uniform(-bound, bound, log.y.shape)
        measured = IOData(
            log.u,
            noisy,
            ts=log.ts,
            input_names=log.input_names,
            output_names=log.output_names,
        )
        return measured, log.y

    train, _ = run(1)
    test, truth = run(2)
    model = MultiStepSetMembership(Lags.arx(2, 2), horizon=1, horizons=[5], epsilon=bound)
    model.fit(train)
    for k in (1, 5):
        result = model.predict_ahead(test, steps=k)
        s = result.n_initial
        assert coverage(truth, result.lower, result.upper, skip=s)[0] == 1.0
        assert coverage(test.y, result.lower, result.upper, skip=s)[0] == 1.0


# ---------------------------------------------------------------------------- results
def test_predict_ahead_is_aligned_at_the_target_time(
    model: MultiStepSetMembership, test_log: IOData
) -> None:
    result = model.predict_ahead(test_log, steps=6)
    assert result.kind == "prediction"
    assert result.n_initial == model.max_lag_ + 6 - 1
    assert result.extras["band"] == "guaranteed" and result.extras["steps"] == 6
    np.testing.assert_array_equal(result.y[:6], test_log.y[:6])
    assert np.isnan(result.lower[:6]).all() and np.isnan(result.upper[:6]).all()
    assert np.all(result.lower[6:] <= result.y[6:]) and np.all(result.y[6:] <= result.upper[6:])
    # The row of time s depends on the outputs up to s - 6 only.
    changed = test_log.y.copy()
    changed[100:106] += 10.0
    moved = model.predict_ahead(
        IOData(test_log.u, changed, ts=test_log.ts, input_names=["motor"],
               output_names=["inclination"]),
        steps=6,
    )  # fmt: skip
    np.testing.assert_array_equal(moved.y[6:106], result.y[6:106])
    assert not np.allclose(moved.y[106:112], result.y[106:112])
    np.testing.assert_array_equal(moved.y[112:], result.y[112:])
    np.testing.assert_array_equal(model.predict(test_log).y, model.predict_ahead(test_log, 1).y)


def test_receding_horizon_is_the_direct_predictions_re_anchored_on_measurements(
    model: MultiStepSetMembership, test_log: IOData
) -> None:
    result = model.predict_receding(test_log)
    steps = result.extras["steps"]
    assert result.extras["band"] == "guaranteed"
    np.testing.assert_array_equal(steps[:4], [0, 1, 2, 3])
    np.testing.assert_array_equal(steps[4:7], [1, 2, 3])
    for k in (1, 2, 3):
        direct = model.predict_ahead(test_log, steps=k)
        rows = np.flatnonzero(steps == k)
        np.testing.assert_array_equal(result.y[rows], direct.y[rows])
        np.testing.assert_array_equal(result.upper[rows], direct.upper[rows])


def test_free_run_chains_the_predictors_from_its_own_outputs(
    model: MultiStepSetMembership, test_log: IOData, train: IOData
) -> None:
    result = model.simulate(test_log)
    assert result.kind == "simulation" and result.extras["band"] == "chained"
    assert result.extras["steps"][:7].tolist() == [0, 1, 2, 3, 1, 2, 3]  # horizon of each row
    # The first block starts from the measured initial outputs: the direct predictions.
    for k in (1, 2, 3):
        direct = model.predict_ahead(test_log, steps=k)
        np.testing.assert_allclose(result.y[k], direct.y[k], rtol=0, atol=1e-12)
    # With blocks of one sample it is the one-step Set Membership free run.
    one = MultiStepSetMembership(LAGS, horizon=1).fit(train)
    reference = SetMembership(
        LAGS, epsilon=one.epsilon_[0].tolist(), gamma=one.gamma_[0].tolist(), linear_part=True
    ).fit(train)
    np.testing.assert_allclose(
        one.simulate(test_log).y, reference.simulate(test_log).y, rtol=0, atol=1e-10
    )
    # With the known bounds of the k-step errors, the chained free run follows the system.
    known = MultiStepSetMembership(
        LAGS, horizon=3, epsilon=[NeckLike.error_bound(k) for k in (1, 2, 3)]
    ).fit(train)
    assert known.simulate(test_log).fit_percent(test_log)[0] > 97


def test_save_load_keeps_every_horizon(model: MultiStepSetMembership, test_log, tmp_path) -> None:
    path = model.save(tmp_path / "multistep")
    loaded = load_model(path)
    np.testing.assert_array_equal(loaded.horizons_, model.horizons_)
    for k in (2, 6):
        np.testing.assert_array_equal(
            loaded.predict_ahead(test_log, k).upper, model.predict_ahead(test_log, k).upper
        )
    _, arrays, meta = read_model_file(path)
    arrays["horizons"] = np.array([1, 2, 3, 5])
    write_model_file(tmp_path / "edited", "MultiStepSetMembership", arrays, meta)
    with pytest.raises(ValueError, match=r"edited.*h5_"):
        load_model(tmp_path / "edited.npz")
    arrays["horizons"] = np.array([1, 2, 6])
    write_model_file(tmp_path / "edited2", "MultiStepSetMembership", arrays, meta)
    with pytest.raises(ValueError, match="horizons"):
        load_model(tmp_path / "edited2.npz")


def test_rule_epsilon_is_raised_to_fit_identical_regressors() -> None:
    # A quantised sensor at rest: identical regressors whose outputs differ by one step.
    rng = np.random.default_rng(0)
    u = np.repeat(rng.choice([0.0, 1.0, 2.0], 60), 20)
    y = np.zeros(u.size)
    for t in range(1, u.size):
        y[t] = 0.7 * y[t - 1] + 0.3 * u[t - 1]
    y = np.round(y + rng.uniform(-0.06, 0.06, u.size), 1)
    data = IOData(u, y, ts=0.02)
    with pytest.warns(UserWarning, match="identical regressors"):
        model = MultiStepSetMembership(Lags.arx(1, 1), horizon=2, epsilon_factor=0.1).fit(data)
    assert np.all(model.epsilon_ >= 0.05 - 1e-12)
    assert np.all(np.isfinite(model.gamma_))


def test_invalidation_per_horizon_and_the_smallest_epsilon_that_holds_everything(
    train: IOData, test_log: IOData
) -> None:
    bounds = [NeckLike.error_bound(k) for k in (1, 2, 3)]
    model = MultiStepSetMembership(LAGS, horizon=3, epsilon=bounds).fit(train)
    # The neck with a different payload: its outputs sit 1 degree higher.
    test_log = IOData(
        test_log.u, test_log.y + 1.0, ts=test_log.ts, input_names=test_log.input_names,
        output_names=test_log.output_names,
    )  # fmt: skip
    report = model.invalidation(test_log)
    assert sorted(report) == [1, 2, 3]
    for k, found in report.items():
        ahead = model.predict_ahead(test_log, steps=k)
        held = coverage(test_log.y, ahead.lower, ahead.upper, skip=ahead.n_initial)
        np.testing.assert_allclose(1 - found.fraction, held)
        # With the smallest epsilon (gamma kept) every sample is held, and not with less.
        predictor = model.estimators_[k - 1]
        lags_k, gamma = predictor.lags_.to_lags(), predictor.gamma_
        needed = found.smallest_epsilon
        assert found.falsified and np.all(needed > bounds[k - 1])
        refit = SetMembership(lags_k, epsilon=needed, gamma=gamma, linear_part=True).fit(train)
        assert refit.invalidation(test_log).excess.max() < 1e-12  # on the edge, to rounding
        below = SetMembership(lags_k, epsilon=needed - 1e-6, gamma=gamma, linear_part=True)
        assert below.fit(train).invalidation(test_log).falsified
    assert isinstance(model.invalidation([test_log, test_log])[2], list)
    short = test_log[:2]  # long enough for horizon 1 (regressor of 1 sample), not for 2 and 3
    both = model.invalidation([short, test_log])
    assert sorted(both) == [1] and len(both[1]) == 2  # positions match the list given


# ---------------------------------------------------------------------------- errors
@pytest.mark.parametrize(
    ("params", "error", "match"),
    [
        ({"horizon": 0}, ValueError, "^horizon must be"),
        ({"horizons": [0, 4]}, ValueError, r"^horizons must hold horizons in \[1, 1000\]"),
        ({"epsilon": [0.1, 0.2]}, ValueError, r"^epsilon must be a number, 3 numbers"),
        ({"epsilon": -1.0}, ValueError, "^epsilon must be"),
        ({"epsilon_factor": 0.0}, ValueError, "^epsilon_factor must be"),
        ({"scaling": [1.0, 2.0]}, TypeError, "^scaling must be one of 'std', 'none'"),
        ({"horizons": [600]}, ValueError, "500 samples, too few for horizon 600"),
    ],
)
def test_bad_settings_are_refused_at_fit(train: IOData, params, error, match) -> None:
    with pytest.raises(error, match=match):
        MultiStepSetMembership(LAGS, **{"horizon": 3, **params}).fit(train[:500])


def test_bad_calls_are_refused(model: MultiStepSetMembership, test_log: IOData) -> None:
    with pytest.raises(
        ValueError, match=r"steps must be one of the fitted horizons \[1, 2, 3, 6\]"
    ):
        model.predict_ahead(test_log, steps=4)
    with pytest.raises(TypeError, match="steps must be a whole number"):
        model.predict_ahead(test_log, steps=2.0)
    inputs_only = IOData(test_log.u, ts=test_log.ts, input_names=["motor"])
    with pytest.raises(ValueError, match="inputs only"):
        model.predict_ahead(inputs_only, steps=2)
    with pytest.raises(ValueError, match="inputs only"):
        model.predict_receding(inputs_only)
    unfitted = MultiStepSetMembership(LAGS)
    with pytest.raises(NotFittedError):
        unfitted.predict_ahead(test_log, steps=1)
    with pytest.raises(NotFittedError):
        unfitted.predict_receding(test_log)
