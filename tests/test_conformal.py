"""Split-conformal bands, k-step prediction of any model, and the coverage / width metrics."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import neckid
from neckid import IOData, Lags
from neckid.metrics import coverage, mean_width
from neckid.models.conformal import calibrate, conformal_quantile, predict_ahead
from neckid.models.kstep import _iterate_simulator

LAGS = Lags.arx(1, 1, 1)


def _log(seed: int, n: int = 2000) -> IOData:
    """``y(t) = 0.8 y(t−1) + 0.3 tanh(2 u(t−1)) + e(t)``, Gaussian ``e`` (sd 0.02), held input."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1.0, 1.0, n // 20), 20) + 0.05 * rng.normal(size=n)
    e = 0.02 * rng.normal(size=n)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.8 * y[t - 1] + 0.3 * np.tanh(2.0 * u[t - 1]) + e[t]
    return IOData(u, y, ts=0.02, input_names=["command"], output_names=["inclination"])


def _fit(name: str, data: IOData):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the quick network stops before converging
        return neckid.methods()[name].make(LAGS, quick=True).fit(data)


# ---------------------------------------------------------------------------- metrics
def test_coverage_and_mean_width_formulas() -> None:
    y = np.array([[0.0, 5.0], [1.0, 5.0], [2.0, 5.0], [3.0, 5.0]])
    lower = np.array([[np.nan, 4.0], [0.5, 4.0], [2.0, 6.0], [3.5, -np.inf]])
    upper = np.array([[np.nan, 6.0], [1.5, 6.0], [2.5, 7.0], [4.0, np.inf]])
    # Rows 1..3: inside, on the edge (inside), outside; second output: in, out, in.
    np.testing.assert_allclose(coverage(y, lower, upper, skip=1), [2 / 3, 2 / 3])
    np.testing.assert_allclose(mean_width(lower[1:, :1], upper[1:, :1]), [(1.0 + 0.5 + 0.5) / 3])
    assert mean_width(lower, upper, skip=1)[1] == np.inf
    np.testing.assert_allclose(coverage(y[:, 0], y[:, 0], y[:, 0]), [1.0])


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: coverage([1.0, 2.0], [np.nan, 0.0], [2.0, 3.0]), "lower is NaN at row 0"),
        (lambda: coverage([1.0, 2.0], [0.0, 3.0], [2.0, 2.5]), "lower > upper at row 1"),
        (lambda: coverage([1.0, 2.0], [0.0], [2.0]), "same shape"),
        (lambda: coverage([1.0, np.inf], [0.0, 0.0], [2.0, 3.0]), "y has a non-finite"),
        (lambda: mean_width([0.0, 1.0], [1.0, 2.0], skip=2), "skip=2 leaves no sample"),
        (lambda: mean_width([0.0], [1.0], skip=-1), "skip must be"),
    ],
)
def test_metrics_refuse_bad_bands(call, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        call()


# ---------------------------------------------------------------------------- the quantile
def test_conformal_quantile_is_the_rank_with_the_finite_sample_correction() -> None:
    scores = np.random.default_rng(0).permutation(np.arange(1.0, 100.0))  # n = 99
    for level, rank in ((0.95, 95), (0.9, 90), (0.5, 50), (0.99, 99)):
        # ⌈(n + 1)(1 − α)⌉ = ⌈100 · level⌉
        assert conformal_quantile(scores, level)[0] == rank
    two = np.column_stack([np.arange(1.0, 20.0), 10 * np.arange(1.0, 20.0)])
    np.testing.assert_array_equal(conformal_quantile(two, 0.9), [18.0, 180.0])  # ⌈20 · 0.9⌉


def test_too_few_calibration_samples_give_an_infinite_band_and_say_so() -> None:
    with pytest.warns(UserWarning, match="at least 19 samples"):
        assert conformal_quantile(np.arange(1.0, 19.0), 0.95)[0] == np.inf
    with pytest.raises(ValueError, match="coverage must be"):
        conformal_quantile([1.0, 2.0], coverage=1.0)
    with pytest.raises(ValueError, match="row 1"):
        conformal_quantile([1.0, np.nan])


# ---------------------------------------------------------------------------- k steps ahead
@pytest.mark.parametrize("name", ["arx", "nn", "sm-linear"])
def test_k_step_prediction_of_the_map_equals_the_simulator_from_every_anchor(name: str) -> None:
    model = _fit(name, _log(0, 600))
    data = _log(1, 200)
    for steps in (1, 4):
        vectorised = predict_ahead(model, data, steps)
        looped = _iterate_simulator(model, data, steps)
        s = vectorised.n_initial
        assert s == model.max_lag_ + steps - 1
        np.testing.assert_allclose(vectorised.y[s:], looped[s:], rtol=0, atol=1e-10)
    np.testing.assert_array_equal(predict_ahead(model, data, 1).y, model.predict(data).y)


def test_k_step_prediction_uses_a_direct_predictor_when_the_model_has_one() -> None:
    model = neckid.methods()["sm-multistep"].make(LAGS, horizon=3).fit(_log(0, 600))
    data = _log(1, 200)
    np.testing.assert_array_equal(
        predict_ahead(model, data, 3).y, model.predict_ahead(data, steps=3).y
    )


# ---------------------------------------------------------------------------- coverage
@pytest.mark.parametrize("name", ["arx", "nn"])
@pytest.mark.parametrize("kind", ["simulation", "prediction", 5])
def test_calibrated_bands_cover_held_out_experiments_at_the_stated_level(name: str, kind) -> None:
    """Fit on one experiment, calibrate on a second, measure on two more; 6 seeds."""
    shares = []
    for seed in range(6):
        model = _fit(name, _log(100 * seed))
        bands = calibrate(model, _log(100 * seed + 1), coverage=0.95, kind=kind)
        for j in (2, 3):
            data = _log(100 * seed + j)
            if kind == "simulation":
                result = bands.simulate(data)
            elif kind == "prediction":
                result = bands.predict(data)
            else:
                result = bands.predict_ahead(data)
            assert result.extras["band"] == "calibrated"
            assert result.extras["coverage"] == 0.95
            shares.append(coverage(data.y, result.lower, result.upper, skip=result.n_initial)[0])
    assert 0.93 <= np.mean(shares) <= 0.97


def test_the_band_is_the_estimate_plus_minus_the_calibration_quantile() -> None:
    model = _fit("sm", _log(0, 600))
    calibration = [_log(1, 300), _log(2, 300)]
    bands = calibrate(model, calibration, coverage=0.8, kind="prediction")
    scores = np.concatenate([np.abs(d.y[1:] - model.predict(d).y[1:]) for d in calibration])
    assert bands.n_calibration == scores.shape[0] == 598
    assert bands.quantile[0] == np.sort(scores[:, 0])[int(np.ceil(599 * 0.8)) - 1]
    result = bands.predict(_log(3, 300))
    np.testing.assert_allclose(result.upper[1:] - result.y[1:], bands.quantile[0], atol=1e-12)
    np.testing.assert_allclose(result.y[1:] - result.lower[1:], bands.quantile[0], atol=1e-12)
    assert np.isnan(result.lower[0]).all()
    # The model's own (Set Membership) bounds are kept beside the calibrated band.
    assert result.extras["model_upper"] is not None


def test_a_band_is_only_used_with_the_result_it_was_calibrated_for() -> None:
    model = _fit("arx", _log(0, 400))
    data = _log(1, 300)
    free_run = calibrate(model, data, kind="simulation")
    with pytest.raises(ValueError, match="calibrated for 'simulation', not 'prediction'"):
        free_run.predict(data)
    with pytest.raises(ValueError, match="calibrated for 'simulation'"):
        free_run.predict_ahead(data, 3)
    ahead = calibrate(model, data, kind=3)
    with pytest.raises(ValueError, match="calibrated for 3-step prediction"):
        ahead.predict_ahead(data, steps=4)
    with pytest.raises(ValueError, match="kind must be"):
        calibrate(model, data, kind="free run")
    with pytest.raises(ValueError, match="kind must be"):
        calibrate(model, data, kind=0)
    with pytest.raises(neckid.NotFittedError):
        calibrate(neckid.methods()["arx"].make(LAGS), data)
