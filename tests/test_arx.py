"""Tests of LinearARX: parameter recovery, prediction vs simulation, experiments, save/load."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone

from neckid import IOData, Lags, LinearARX
from neckid.models.linear.arx import least_squares


def simulate_arx(u: np.ndarray, noise: np.ndarray | None = None) -> np.ndarray:
    y = np.zeros(u.shape[0])
    for t in range(3, u.shape[0]):
        y[t] = 1.5 * y[t - 1] - 0.7 * y[t - 2] + 0.4 * u[t, 1] + 0.25 * u[t - 3, 0] + 2.0
        if noise is not None:
            y[t] += noise[t]
    return y


@pytest.fixture
def data(rng: np.random.Generator) -> IOData:
    u = rng.normal(size=(600, 2))
    return IOData(u, simulate_arx(u), ts=0.02, input_names=["a", "b"], output_names=["y"])


LAGS = Lags(outputs=[1, 2], inputs={"a": [3], "b": [0]})


def test_recovers_known_arx(data: IOData) -> None:
    model = LinearARX(LAGS).fit(data)
    np.testing.assert_allclose(model.coef_.ravel(), [1.5, -0.7, 0.25, 0.4], atol=1e-9)
    np.testing.assert_allclose(model.intercept_, [2.0], atol=1e-8)
    assert model.lags_.names == ("y(t-1)", "y(t-2)", "a(t-3)", "b(t)")
    assert (model.n_inputs_, model.n_outputs_, model.n_samples_, model.ts_) == (2, 1, 597, 0.02)


def test_recovers_with_noise_within_tolerance(rng: np.random.Generator) -> None:
    u = rng.normal(size=(5000, 2))
    # Equation-error noise: least squares is consistent for ARX (Ljung 1999, sec. 7.3).
    y = simulate_arx(u, noise=rng.normal(scale=0.05, size=5000))
    model = LinearARX(LAGS).fit(IOData(u, y, ts=0.02, input_names=["a", "b"]))
    np.testing.assert_allclose(model.coef_.ravel(), [1.5, -0.7, 0.25, 0.4], atol=0.02)


def test_predict_simulate_and_simulator_agree(data: IOData) -> None:
    model = LinearARX(LAGS).fit(data)
    prediction = model.predict(data)
    simulation = model.simulate(data)
    assert prediction.kind == "prediction" and simulation.kind == "simulation"
    np.testing.assert_allclose(prediction.y, data.y, atol=1e-8)
    np.testing.assert_allclose(simulation.y, data.y, atol=1e-6)
    sim = model.simulator()
    sim.reset(y0=data.y[:3], u0=data.u[:3])
    stepped = np.array([sim.step(data.u[t]) for t in range(3, 50)])
    np.testing.assert_allclose(stepped, simulation.y[3:50], atol=1e-8)


def test_prediction_uses_measured_outputs_and_simulation_its_own(data: IOData) -> None:
    # A wrong model: prediction and simulation must then differ.
    model = LinearARX(Lags(outputs=[1], inputs={"b": [0]})).fit(data)
    pred = model.predict(data).y
    sim = model.simulate(data).y
    assert not np.allclose(pred, sim)
    # Prediction at t uses the measured y(t-1): recompute it by hand.
    t = 100
    expected = (
        model.intercept_[0]
        + model.coef_[0, 0] * data.y[t - 1, 0]
        + model.coef_[1, 0] * data.u[t, 1]
    )
    assert pred[t, 0] == pytest.approx(expected)


def test_fit_on_list_of_experiments(data: IOData) -> None:
    a, b = data.split(0.5)
    joined = LinearARX(LAGS).fit([a, b])
    assert joined.n_samples_ == (300 - 3) + (300 - 3)
    np.testing.assert_allclose(joined.coef_.ravel(), [1.5, -0.7, 0.25, 0.4], atol=1e-9)


def test_save_load_and_clone(data: IOData, tmp_path) -> None:
    model = LinearARX(LAGS, ridge=0.0).fit(data)
    loaded = LinearARX.load(model.save(tmp_path / "arx.npz"))
    np.testing.assert_array_equal(loaded.predict(data).y, model.predict(data).y)
    assert loaded.lags == model.lags_.to_lags()
    fresh = clone(model)
    assert not hasattr(fresh, "coef_") and fresh.get_params()["lags"] == LAGS


def test_least_squares_scaling_and_ridge(rng: np.random.Generator) -> None:
    x = rng.normal(size=(200, 2)) * [1e-3, 1e3]
    y = x @ np.array([[5.0], [-2.0]]) + 1.0
    coef, intercept = least_squares(x, y)
    np.testing.assert_allclose(coef.ravel(), [5.0, -2.0], rtol=1e-8)
    np.testing.assert_allclose(intercept, [1.0])
    # Ridge acts on standardised regressors: it solves (Z'Z + ridge N I) b = Z'y there.
    ridge = 0.5
    shrunk, _ = least_squares(x, y, ridge=ridge)
    scale = x.std(axis=0)
    z = (x - x.mean(axis=0)) / scale
    b = np.linalg.solve(z.T @ z + ridge * 200 * np.eye(2), z.T @ (y - y.mean()))
    np.testing.assert_allclose(shrunk, b / scale[:, None], rtol=1e-8)
    assert np.linalg.norm(shrunk * scale[:, None]) < np.linalg.norm(coef * scale[:, None])


BAD = [
    (
        lambda d: LinearARX(Lags.arx(2, 2)).fit(d[:4]),
        ValueError,
        r"least squares needs at least as many rows as unknowns",
    ),
    (
        lambda d: LinearARX(Lags.arx(5, 1)).fit(d[:5]),
        ValueError,
        r"has 5 samples, too few for lags up to 5",
    ),
    (
        lambda d: LinearARX(LAGS, ridge=-1.0).fit(d),
        ValueError,
        r"ridge must be a number >= 0; got -1.0",
    ),
    (lambda d: LinearARX(None).fit(d), ValueError, r"LinearARX needs lags=Lags\(...\); got None"),
    (
        lambda d: LinearARX([1, 2]).fit(d),
        TypeError,
        r"lags must be None or a neckid.Lags; got \[1, 2\]",
    ),
    (
        lambda d: LinearARX(LAGS).fit(d).simulate(d.select(inputs=["b", "a"])),
        ValueError,
        r"data has inputs \['b', 'a'\], but the model was fitted on \['a', 'b'\]",
    ),
    (
        lambda d: LinearARX(LAGS).fit(IOData(d.u, ts=0.02, input_names=["a", "b"])),
        ValueError,
        r"gives no regressor term|no output channel",
    ),
]


@pytest.mark.parametrize(("call", "error", "message"), BAD)
def test_bad_use_is_refused(data: IOData, call, error, message) -> None:
    with pytest.raises(error, match=message):
        call(data)
