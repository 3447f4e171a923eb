"""Tests of RecursiveARX (CFF-RLS): analytic equivalences, recovery, tracking, guards, bad input."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import signal

from neckid import IOData, Lags, LinearARX
from neckid.models.base import NotFittedError
from neckid.models.io import load_model
from neckid.models.linear.rls import RecursiveARX, rls_reference


def arx_data(n: int, a: list[float], b: list[float], noise: float, seed: int) -> IOData:
    """y(t) = -a1 y(t-1) - ... + b1 u(t-1) + ... + e(t), white input and noise (equation error)."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=n)
    e = noise * rng.normal(size=n)
    y = signal.lfilter([0.0, *b], [1.0, *a], u) + signal.lfilter([1.0], [1.0, *a], e)
    return IOData(u, y, ts=0.02, input_names=["u"], output_names=["y"])


def test_forgetting_factor_one_equals_batch_least_squares() -> None:
    data = arx_data(2000, [-1.2, 0.5], [0.5, 0.3], noise=0.1, seed=1)
    model = RecursiveARX(Lags.arx(2, 2), forgetting_factor=1.0, initial_covariance=1e8).fit(data)
    batch = LinearARX(Lags.arx(na=2, nb=2), fit_intercept=False).fit(data).coef_.ravel()
    np.testing.assert_allclose(model.coef_.ravel(), batch, rtol=1e-8)
    # Exactly: the least-squares solution regularised by F(0)^-1.
    phi, y = model._regressor(data)
    exact = np.linalg.solve(phi.T @ phi + np.eye(4) / 1e8, phi.T @ y)
    np.testing.assert_allclose(model.theta_, exact, rtol=1e-9)


def test_regularised_equivalence_with_prior() -> None:
    """λ = 1 with a small F(0) and a prior θ(0): θ = (ΦᵀΦ + F0⁻¹)⁻¹(ΦᵀY + F0⁻¹θ0)."""
    data = arx_data(300, [-0.7], [1.5], noise=0.2, seed=2)
    f0 = np.array([[0.5, 0.1], [0.1, 0.2]])
    theta0 = np.array([0.3, -1.0])
    model = RecursiveARX(
        Lags.arx(1, 1), forgetting_factor=1.0, initial_covariance=f0, initial_parameters=theta0
    ).fit(data)
    phi, y = model._regressor(data)
    inv = np.linalg.inv(f0)
    exact = np.linalg.solve(phi.T @ phi + inv, phi.T @ y + inv @ theta0)
    np.testing.assert_allclose(model.theta_, exact, rtol=1e-10)


def test_recovers_known_arx_from_noisy_data() -> None:
    a, b = [-1.5, 0.7], [1.0, 0.5]
    data = arx_data(20_000, a, b, noise=0.3, seed=3)
    model = RecursiveARX(Lags.arx(2, 2), forgetting_factor=1.0).fit(data)
    np.testing.assert_allclose(model.theta_, [*a, *b], atol=0.02)
    assert model.parameter_names_ == ("a1", "a2", "b1", "b2")
    assert model.theta_history_.shape == (20_000, 4)
    ok, settled = model.converged(window=1000, tolerance=0.02)
    assert ok and settled is not None and settled < 19_000


def test_tracks_a_step_change_within_order_one_over_one_minus_lambda() -> None:
    lam = 0.98  # memory 1 / (1 - λ) = 50 samples
    rng = np.random.default_rng(4)
    n, change = 3000, 1500
    u = rng.normal(size=n)
    y = np.zeros(n)
    for t in range(1, n):
        pole, gain = (0.5, 1.0) if t < change else (-0.3, 2.0)
        y[t] = pole * y[t - 1] + gain * u[t - 1] + 0.01 * rng.normal()
    model = RecursiveARX(Lags.arx(1, 1), forgetting_factor=lam).fit(IOData(u, y, ts=0.02))
    history = model.theta_history_
    np.testing.assert_allclose(history[change - 1], [-0.5, 1.0], atol=0.05)
    memory = round(1 / (1 - lam))
    # Within 5 memories the new parameters are reached and held.
    after = history[change + 5 * memory :]
    np.testing.assert_allclose(after, np.broadcast_to([0.3, 2.0], after.shape), atol=0.05)
    # And not before a fraction of a memory: the test would pass for an estimator with no memory.
    assert abs(history[change + 2, 1] - 2.0) > 0.05
    ok, settled = model.converged(window=500, tolerance=0.05)
    assert ok and change <= settled <= change + 5 * memory


@pytest.mark.parametrize("lam", [1.0, 0.95])
def test_compiled_kernel_agrees_with_numpy_reference(lam: float) -> None:
    data = arx_data(1500, [-0.9, 0.2], [0.4, -0.1], noise=0.05, seed=5)
    model = RecursiveARX(
        Lags.arx(2, 2),
        forgetting_factor=lam,
        initial_covariance=100.0,
        initial_parameters=[0, 0, 1, 0],
    ).fit(data)
    phi, y = model._regressor(data)
    history, covariance, errors, resets = rls_reference(
        phi, y, lam, 100.0 * np.eye(4), initial_parameters=[0, 0, 1, 0]
    )
    np.testing.assert_allclose(model.theta_history_[2:], history, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(model.covariance_, covariance, rtol=1e-9, atol=1e-14)
    np.testing.assert_allclose(model.prediction_errors_[2:], errors, rtol=1e-9, atol=1e-12)
    assert np.all(np.isnan(model.prediction_errors_[:2]))
    assert resets == [] and model.n_covariance_resets_ == 0
    np.testing.assert_array_equal(model.covariance_, model.covariance_.T)


def test_online_update_equals_fit() -> None:
    data = arx_data(400, [-0.6], [0.8, 0.2], noise=0.1, seed=6)
    batch = RecursiveARX(Lags.arx(1, 2, 2)).fit(data)
    online = RecursiveARX(Lags.arx(1, 2, 2))
    errors = [online.update(y, u) for y, u in zip(data.y[:, 0], data.u[:, 0], strict=True)]
    np.testing.assert_allclose(online.theta_history_, batch.theta_history_, rtol=1e-12)
    np.testing.assert_allclose(errors, batch.prediction_errors_, rtol=1e-12, equal_nan=True)
    np.testing.assert_allclose(online.covariance_, batch.covariance_, rtol=1e-12)


def test_delay_zero_and_two_inputs() -> None:
    rng = np.random.default_rng(7)
    u = rng.normal(size=(3000, 2))
    y = np.zeros(3000)
    for t in range(1, 3000):
        y[t] = 0.5 * y[t - 1] + 1.0 * u[t, 0] - 2.0 * u[t, 1]
    data = IOData(u, y, ts=0.1, input_names=["left", "right"], output_names=["incl"])
    model = RecursiveARX(Lags.arx(1, 1, 0), forgetting_factor=1.0).fit(data)
    np.testing.assert_allclose(model.theta_, [-0.5, 1.0, -2.0], atol=1e-6)
    assert model.parameter_names_ == ("a1", "b1[left]", "b1[right]")
    online = RecursiveARX(Lags.arx(1, 1, 0), forgetting_factor=1.0)
    for t in range(3000):
        online.update(y[t], u[t])
    np.testing.assert_allclose(online.theta_, model.theta_, rtol=1e-10)


def test_several_experiments_carry_the_estimate_but_not_the_regressor() -> None:
    data = arx_data(1000, [-0.8], [0.5], noise=0.0, seed=8)
    parts = [data[:500], data[500:]]
    model = RecursiveARX(Lags.arx(1, 1), forgetting_factor=1.0).fit(parts)
    assert model.theta_history_.shape == (1000, 2)
    # The first row of the second experiment only fills the regressor.
    assert np.isnan(model.prediction_errors_[500])
    np.testing.assert_allclose(model.theta_, [-0.8, 0.5], atol=1e-5)
    again = RecursiveARX(Lags.arx(1, 1), forgetting_factor=1.0).fit(parts[0]).partial_fit(parts[1])
    np.testing.assert_allclose(again.theta_history_, model.theta_history_)


def test_predict_and_simulate_use_final_theta() -> None:
    data = arx_data(2000, [-0.8], [0.5], noise=0.0, seed=9)
    model = RecursiveARX(Lags.arx(1, 1), forgetting_factor=1.0).fit(data)
    simulated = model.simulate(data)
    predicted = model.predict(data)
    assert simulated.kind == "simulation" and predicted.kind == "prediction"
    assert simulated.n_initial == 1
    assert simulated.fit_percent(data)[0] > 99.99
    assert predicted.fit_percent(data)[0] > 99.99
    sim = model.simulator()
    sim.reset(y0=data.y[0], u0=data.u[0])
    out = [sim.step(u)[0] for u in data.u[1:50]]
    np.testing.assert_allclose(out, simulated.y[1:50, 0], rtol=1e-10)


def test_save_load_round_trip(tmp_path) -> None:  # type: ignore[no-untyped-def]
    data = arx_data(500, [-0.8], [0.5], noise=0.1, seed=10)
    model = RecursiveARX(Lags.arx(1, 1), forgetting_factor=0.99, initial_parameters=[0.1, 0.2]).fit(
        data
    )
    path = model.save(tmp_path / "rls")
    loaded = load_model(path)
    assert isinstance(loaded, RecursiveARX)
    assert loaded.get_params()["forgetting_factor"] == 0.99
    np.testing.assert_array_equal(loaded.theta_, model.theta_)
    np.testing.assert_array_equal(loaded.theta_history_, model.theta_history_)
    np.testing.assert_array_equal(loaded.covariance_, model.covariance_)
    np.testing.assert_array_equal(loaded.simulate(data).y, model.simulate(data).y)
    # A loaded model goes on learning online from where it stopped.
    loaded.update(1.0, 0.0)
    assert loaded.theta_history_.shape[0] == 501


def test_blow_up_guard_warns_and_resets_covariance() -> None:
    # No excitation: with λ < 1, F grows as λ^-t until the guard resets it. (One non-zero first
    # sample: a constant output is refused as carrying nothing to identify.)
    u = np.zeros(2000)
    y = np.zeros(2000)
    y[0] = 1.0
    model = RecursiveARX(Lags.arx(1, 1), forgetting_factor=0.9, max_covariance_trace=1e6)
    with pytest.warns(RuntimeWarning, match="blew up.*first at sample"):
        model.fit(IOData(u, y, ts=0.02))
    assert model.n_covariance_resets_ >= 10
    assert np.trace(model.covariance_) <= 1e6
    assert np.all(np.isfinite(model.theta_history_))
    # The guard does not fire on a healthy, excited run.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        RecursiveARX(Lags.arx(1, 1), forgetting_factor=0.9).fit(
            arx_data(2000, [-0.5], [1.0], 0.1, seed=11)
        )


def test_blow_up_guard_online() -> None:
    model = RecursiveARX(Lags.arx(1, 1), forgetting_factor=0.5, max_covariance_trace=1e5)
    with pytest.warns(RuntimeWarning, match="blew up"):
        for _ in range(40):
            model.update(0.0, 0.0)
    assert np.trace(model.covariance_) <= 1e5


def test_convergence_test() -> None:
    data = arx_data(3000, [-0.8], [0.5], noise=0.0, seed=12)
    model = RecursiveARX(Lags.arx(1, 1), forgetting_factor=1.0).fit(data)
    ok, settled = model.converged(window=100, tolerance=1e-6)
    assert ok and settled < 500
    # A window longer than the record cannot be met.
    assert not model.converged(window=5000).converged
    # Still drifting at the end: not converged.
    ramp = IOData(np.random.default_rng(0).normal(size=300), np.linspace(0, 30, 300), ts=0.02)
    drifting = RecursiveARX(Lags.arx(1, 1), forgetting_factor=0.9).fit(ramp)
    assert not drifting.converged(window=100, tolerance=1e-3).converged


def test_not_fitted() -> None:
    model = RecursiveARX(Lags.arx(1, 1))
    assert not hasattr(model, "theta_history_")
    with pytest.raises(NotFittedError):
        model.converged()
    with pytest.raises(NotFittedError):
        model.simulate(arx_data(10, [-0.5], [1.0], 0.0, 0))


GOOD = arx_data(50, [-0.5], [1.0], 0.0, 0)


@pytest.mark.parametrize(
    ("params", "error", "match"),
    [
        (
            {"forgetting_factor": 1.2},
            ValueError,
            r"forgetting_factor must be a number in \(0, 1\]; got 1.2",
        ),
        (
            {"forgetting_factor": 0.0},
            ValueError,
            r"forgetting_factor must be a number in \(0, 1\]; got 0.0",
        ),
        ({"forgetting_factor": np.nan}, ValueError, "forgetting_factor must be a number in"),
        ({"forgetting_factor": "0.98"}, TypeError, "forgetting_factor must be a number"),
        ({"lags": 3}, TypeError, "lags must be None or a neckid.Lags; got 3"),
        (
            {"initial_covariance": -1.0},
            ValueError,
            "initial_covariance must be a number > 0 or a positive",
        ),
        ({"initial_covariance": np.eye(3)}, ValueError, r"\(2, 2\) matrix for 2 parameters"),
        ({"initial_covariance": [[1.0, 2.0], [0.0, 1.0]]}, ValueError, "must be symmetric"),
        ({"initial_covariance": [[1.0, 2.0], [2.0, 1.0]]}, ValueError, "positive definite"),
        ({"initial_parameters": [1.0]}, ValueError, "initial_parameters must have 2 values"),
        (
            {"initial_parameters": [1.0, np.inf]},
            ValueError,
            "initial_parameters must be None or an array of finite",
        ),
        ({"max_covariance_trace": 1.0}, ValueError, "max_covariance_trace must exceed"),
    ],
)
def test_bad_parameters_refused(params: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        RecursiveARX(**{"lags": Lags.arx(1, 1), **params}).fit(GOOD)


def test_bad_data_refused() -> None:
    with pytest.raises(ValueError, match="needs at least 4"):
        RecursiveARX(Lags.arx(3, 1)).fit(GOOD[:3])
    # Several outputs are identified (tests/test_rls_mimo.py); a sample must match them.
    with pytest.raises(
        ValueError, match=r"y must have 1 value\(s\), one per output \['y'\]; got 2"
    ):
        RecursiveARX(Lags.arx(1, 1)).fit(GOOD).update([0.0, 1.0], 1.0)
    with pytest.raises(ValueError, match=r"non-finite value .*nan.* at row 3"):
        RecursiveARX(Lags.arx(1, 1)).fit(
            IOData(np.ones(10), [0, 1, 2, np.nan, 4, 5, 6, 7, 8, 9], ts=1.0)
        )
    with pytest.raises(ValueError, match="needs lags=Lags"):
        RecursiveARX().fit(GOOD)
    model = RecursiveARX(Lags.arx(1, 1))
    with pytest.raises(ValueError, match=r"non-finite value .*nan"):
        model.update(np.nan, 1.0)
    model.update(0.0, [1.0])
    with pytest.raises(ValueError, match="u must have 1 values"):
        model.update(0.0, [1.0, 2.0])
    with pytest.raises(ValueError, match="window must be a whole number >= 1; got 0"):
        model.converged(window=0)
