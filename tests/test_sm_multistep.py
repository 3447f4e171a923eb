"""MultiStepSetMembership: k-step regressors, the ε/γ rules, guaranteed bands, runs, files, errors."""

from __future__ import annotations

import json

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
    chosen = one.settings_[0]
    reference = SetMembership(
        LAGS,
        epsilon=one.epsilon_[0].tolist(),
        gamma=one.gamma_[0].tolist(),
        linear_part=True,
        input_weight=chosen.input_weight,
        lipschitz=chosen.lipschitz,
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
    assert isinstance(model.invalidation([test_log, test_log[100:]])[2], list)
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


# ---------------------------------------------------------------------------- settings chosen
def _noisy_linear(n: int, seed: int) -> IOData:
    """``y(t) = POLE·y(t−1) + 0.9·u(t−1) + e(t)``, Gaussian ``e`` (σ = 0.1): no bound holds.

    The linear part is exact, so ε_k = factor × the noise's scale: small factors leave
    samples out of the band, and the rule has something to reject.
    """
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(0.0, 5.0, n // 10 + 1), 10)[:n]
    e = rng.normal(0.0, 0.1, n)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = POLE * y[t - 1] + 0.9 * u[t - 1] + e[t]
    return IOData(
        u, y, ts=0.025, input_names=["motor"], output_names=["inclination"], name=f"run{seed}"
    )


@pytest.fixture(scope="module")
def runs() -> list[IOData]:
    return [_noisy_linear(400, seed) for seed in (11, 12, 13)]


@pytest.fixture(scope="module")
def chosen(runs: list[IOData]) -> MultiStepSetMembership:
    return MultiStepSetMembership(LAGS, horizon=2).fit(runs)


def test_the_rule_picks_the_narrowest_setting_that_holds_the_target_on_held_out_runs(
    chosen: MultiStepSetMembership,
) -> None:
    selection = chosen.selection_
    assert selection is not None and selection.folds == "experiments"
    assert selection.fold_names == ("run11", "run12", "run13")
    table = selection.table()
    assert len(table) == 2 * 28  # two horizons, the whole grid
    for i, k in enumerate(chosen.horizons_):
        rows = table[table.horizon == k]
        eligible = rows[rows.coverage >= 0.95]
        assert len(eligible) > 0
        best = eligible.loc[eligible.width.idxmin()]
        assert best.status == "chosen"
        assert chosen.settings_[i].to_json() == {
            "epsilon_factor": best.epsilon_factor,
            "input_weight": best.input_weight,
            "lipschitz": best.lipschitz,
        }
        # Gaussian noise: the smallest ε leave too many samples out; the rule rejects settings
        # narrower than the one it keeps.
        assert (rows.status == "below target").sum() > 0
        # ... and the band is narrower than that of the settings before the selection.
        before = rows[(rows.epsilon_factor == 3) & (rows.input_weight == 1)]
        assert best.width < before[before.lipschitz == "global"].width.item()
        fitted = chosen.estimators_[i]
        assert (fitted.input_weight, fitted.lipschitz) == (best.input_weight, best.lipschitz)


def test_the_chosen_band_holds_a_new_run(chosen: MultiStepSetMembership) -> None:
    new = _noisy_linear(600, 14)
    for k in chosen.horizons_.tolist():
        ahead = chosen.predict_ahead(new, steps=k)
        assert coverage(new.y, ahead.lower, ahead.upper, skip=ahead.n_initial)[0] >= 0.93


def test_choose_takes_the_narrowest_above_target_else_the_best_covered() -> None:
    from neckid.models.set_membership.multistep_selection import _choose

    cover = np.array([[0.99], [0.96], [0.90], [np.nan], [0.97]])
    width = np.array([[5.0], [3.0], [1.0], [0.5], [3.0]])
    scale = np.ones(1)
    assert _choose(cover, width, scale, 0.95) == (1, True)  # tie with row 4: the first
    assert _choose(cover, width, scale, 0.5) == (2, True)
    assert _choose(cover, width, scale, 0.999) == (0, False)  # none: the best covered
    assert _choose(np.full((2, 1), np.nan), width[:2], scale, 0.95) == (None, False)


def test_folds_are_runs_with_several_experiments_and_time_blocks_with_one(
    runs: list[IOData],
) -> None:
    one = MultiStepSetMembership(LAGS, horizon=1, input_weight=1.0).fit(runs[0])
    assert one.selection_.folds == "time blocks"
    assert one.selection_.fold_names == tuple(f"run11 [block {i}/3]" for i in (1, 2, 3))
    assert len(one.selection_.rows) == 14 and len(one.selection_.rows[0].fold_coverage) == 3
    two = MultiStepSetMembership(LAGS, horizon=1, input_weight=1.0).fit(runs[:2])
    assert two.selection_.folds == "experiments"
    assert two.selection_.fold_names == ("run11", "run12")


def test_fixed_settings_or_a_given_epsilon_choose_nothing(runs: list[IOData]) -> None:
    fixed = MultiStepSetMembership(
        LAGS, horizon=2, epsilon_factor=3, input_weight=1, lipschitz="global"
    ).fit(runs)
    assert fixed.selection_ is None
    assert [s.to_json() for s in fixed.settings_] == [
        {"epsilon_factor": 3.0, "input_weight": 1.0, "lipschitz": "global"}
    ] * 2
    given = MultiStepSetMembership(LAGS, horizon=1, epsilon=0.5).fit(runs)
    assert given.selection_ is None
    assert given.settings_[0].to_json() == {
        "epsilon_factor": None,
        "input_weight": 1.0,
        "lipschitz": "global",
    }


@pytest.mark.parametrize(
    ("params", "match"),
    [
        ({"epsilon_factor": []}, "^epsilon_factor must be a number > 0 or a non-empty list"),
        ({"input_weight": [1.0, -0.3]}, "^input_weight must be a number > 0 or a non-empty list"),
        ({"input_weight": [1.0, 0.3], "epsilon": 0.5}, "^input_weight lists candidates"),
        ({"target_coverage": 1.5}, "^target_coverage must be"),
    ],
)
def test_bad_candidates_are_refused(runs: list[IOData], params, match) -> None:
    with pytest.raises(ValueError, match=match):
        MultiStepSetMembership(LAGS, horizon=1, **params).fit(runs)


def test_the_selection_is_saved_and_old_files_still_load(
    chosen: MultiStepSetMembership, runs: list[IOData], tmp_path
) -> None:
    loaded = load_model(chosen.save(tmp_path / "chosen"))
    saved = json.dumps(chosen.selection_.to_json())  # NaN (failed settings) as NaN
    assert json.dumps(loaded.selection_.to_json()) == saved
    assert loaded.settings_ == chosen.settings_
    assert loaded.epsilon_factor is None and loaded.target_coverage == 0.95
    np.testing.assert_array_equal(
        loaded.predict_ahead(runs[0], 2).upper, chosen.predict_ahead(runs[0], 2).upper
    )
    # A file of the release before the selection: scalar settings, no "settings"/"selection".
    old = MultiStepSetMembership(
        LAGS, horizon=1, epsilon_factor=3.0, input_weight=0.3, lipschitz="local"
    ).fit(runs)
    _, arrays, meta = read_model_file(old.save(tmp_path / "old"))
    del meta["settings"], meta["selection"], meta["params"]["target_coverage"]
    write_model_file(tmp_path / "before", "MultiStepSetMembership", arrays, meta)
    before = load_model(tmp_path / "before.npz")
    assert before.selection_ is None
    assert before.settings_[0].to_json() == {
        "epsilon_factor": 3.0,
        "input_weight": 0.3,
        "lipschitz": "local",
    }


# ---------------------------------------------------------------------------- shared = independent
def test_point_constants_and_bounds_of_many_priors_are_the_single_prior_kernels() -> None:
    from neckid.models.set_membership._kernels import (
        SMTree,
        learn_constants,
        local_bounds,
        point_gamma,
    )
    from neckid.models.set_membership._kernels.priors import point_gamma_grid, prior_bounds

    rng = np.random.default_rng(3)
    x = rng.normal(size=(700, 5))
    x[50:60] = x[50]  # identical regressors
    y = np.column_stack([np.sin(x[:, 0]), np.cos(x[:, 1])]) + 0.1 * rng.normal(size=(700, 2))
    tree = SMTree(x, y)
    epsilon = np.array([[0.3, 0.2], [0.35, 0.25], [0.5, 0.5], [2.0, 2.0]])
    slopes = point_gamma_grid(tree, epsilon)
    gamma = 1.1 * slopes.max(axis=1)
    constants = []
    for e in range(len(epsilon)):
        np.testing.assert_array_equal(slopes[e], point_gamma(tree, epsilon[e]))
        constants.append(learn_constants(tree, epsilon[e], gamma[e], 1.1))
    queries = 1.3 * rng.normal(size=(300, 5))
    local = np.array([-1, 0, -1, 1, 2, -1, 3])
    which = np.array([0, 0, 1, 1, 2, 3, 3])
    lower, upper = prior_bounds(
        tree, queries, epsilon[which], gamma[which], np.stack(constants), local, 7
    )
    for s, (m, e) in enumerate(zip(local, which, strict=True)):
        if m < 0:
            low, high = tree.bounds(queries, epsilon[e], gamma[e])
        else:
            low, high, _ = local_bounds(tree, constants[m], queries, epsilon[e], gamma[e], 7)
        np.testing.assert_array_equal(lower[:, s], low)
        np.testing.assert_array_equal(upper[:, s], high)


def test_the_shared_fold_gives_the_bands_of_independent_fits(runs: list[IOData]) -> None:
    """Every setting's band in a fold is, bit for bit, predict_ahead of a fit with it alone."""
    from neckid.models.set_membership.core import SMSettings
    from neckid.models.set_membership.horizon_fit import linear_part, stack_rows
    from neckid.models.set_membership.multistep_selection import SettingGrid, _fold_bands

    steps = 2
    grid = SettingGrid((1.0, 2.5), (1.0, 0.3), ("global", "local"))
    lags = horizon_lags(LAGS.resolve(runs), steps).resolve(runs)
    rows = [lags.build_one(d) for d in runs]
    train = rows[1:]
    lower, upper, _, failed = _fold_bands(
        train, rows[0], lags, linear_part(*stack_rows(train)), grid, SMSettings(linear_part=True)
    )
    assert failed == {}
    for s, setting in enumerate(grid.settings()):
        alone = MultiStepSetMembership(
            LAGS,
            horizon=1,
            horizons=[steps],
            epsilon_factor=setting.epsilon_factor,
            input_weight=setting.input_weight,
            lipschitz=setting.lipschitz,
        ).fit(runs[1:])
        ahead = alone.predict_ahead(runs[0], steps=steps)
        np.testing.assert_array_equal(ahead.lower[ahead.n_initial :], lower[:, s])
        np.testing.assert_array_equal(ahead.upper[ahead.n_initial :], upper[:, s])
