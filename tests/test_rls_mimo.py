"""RecursiveARX with several outputs (issue 15) and its history in growing arrays (issue 18).

Multi-output CFF-RLS with a common regressor: one covariance ``F`` and one gain ``K = Fφ`` serve
every output, ``θ̂`` is ``(n_params, n_outputs)`` and ``θ̂ ← θ̂ + K εᵀ``. Checked here: recovery
of a known coupled system, equality with one single-output RLS per output on the same regressor,
online ``update`` equal to ``fit``, files, the free run, and that the histories are not
re-allocated per sample. The single-output behaviour is pinned by ``tests/test_rls.py``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from neckid import IOData, Lags
from neckid.models.base import NarxModel
from neckid.models.io import load_model, read_model_file, write_model_file
from neckid.models.linear.rls import RecursiveARX, rls_reference
from neckid.models.linear.rls_kernels import ParameterHistory

#: y1(t) = 0.6 y1(t-1) + 0.2 y2(t-1) + 0.5 u1(t-1) - 0.3 u2(t-2)
#: y2(t) = -0.3 y1(t-1) + 0.7 y2(t-1) - 0.1 y2(t-2) + 0.8 u2(t-1) + 0.4 u1(t-2)
A1 = np.array([[0.6, 0.2], [-0.3, 0.7]])
A2 = np.array([[0.0, 0.0], [0.0, -0.1]])
B1 = np.array([[0.5, 0.0], [0.0, 0.8]])
B2 = np.array([[0.0, -0.3], [0.4, 0.0]])


def coupled(n: int, noise: float = 0.0, seed: int = 0) -> IOData:
    """The two-output, two-input system above, white inputs, optional output noise."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 2))
    y = np.zeros((n, 2))
    for t in range(2, n):
        y[t] = A1 @ y[t - 1] + A2 @ y[t - 2] + B1 @ u[t - 1] + B2 @ u[t - 2]
    y += noise * rng.normal(size=y.shape)
    return IOData(u, y, ts=0.02, input_names=["left", "right"], output_names=["pitch", "roll"])


def true_theta() -> np.ndarray:
    """θ for Lags.arx(2, 2): rows a1[pitch], a1[roll], a2[pitch], a2[roll]... in lags_ order."""
    # Lags.arx(2, 2) resolves to pitch(t-1), pitch(t-2), roll(t-1), roll(t-2),
    # left(t-1), left(t-2), right(t-1), right(t-2); output terms carry a minus sign in θ.
    rows = [-A1[:, 0], -A2[:, 0], -A1[:, 1], -A2[:, 1], B1[:, 0], B2[:, 0], B1[:, 1], B2[:, 1]]
    return np.array(rows)


def test_two_output_system_recovered_on_noiseless_data() -> None:
    data = coupled(3000)
    model = RecursiveARX(Lags.arx(2, 2), forgetting_factor=1.0, initial_covariance=1e8).fit(data)
    expected = true_theta()
    assert model.theta_.shape == (8, 2)
    np.testing.assert_allclose(model.theta_, expected, atol=1e-6)
    assert model.parameter_names_ == (
        "a1[pitch]",
        "a2[pitch]",
        "a1[roll]",
        "a2[roll]",
        "b1[left]",
        "b2[left]",
        "b1[right]",
        "b2[right]",
    )
    assert model.theta_history_.shape == (3000, 8, 2)
    assert model.prediction_errors_.shape == (3000, 2)
    assert np.all(np.isnan(model.prediction_errors_[:2]))
    np.testing.assert_allclose(model.prediction_errors_[-100:], 0.0, atol=1e-8)
    # coef_ is on the Lags regressor, as LinearARX's: the a's with their sign flipped.
    sign = np.where(model.lags_.source == 0, -1.0, 1.0)[:, None]
    np.testing.assert_array_equal(model.coef_, sign * model.theta_)
    ok, settled = model.converged(window=500, tolerance=1e-4, atol=1e-9)
    assert ok and settled is not None and settled < 2500


def test_free_run_and_one_step_of_the_mimo_model() -> None:
    data = coupled(1500)
    model = RecursiveARX(Lags.arx(2, 2), forgetting_factor=1.0, initial_covariance=1e8).fit(data)
    simulated = model.simulate(data)
    np.testing.assert_allclose(simulated.y, NarxModel.simulate(model, data).y, rtol=1e-10)
    assert np.all(simulated.fit_percent(data) > 99.9)
    assert np.all(model.predict(data).fit_percent(data) > 99.9)
    m = model.max_lag_
    simulator = model.simulator()
    simulator.reset(y0=data.y[:m], u0=data.u[:m])
    stepped = np.array([simulator.step(data.u[t]) for t in range(m, 200)])
    np.testing.assert_allclose(stepped, simulated.y[m:200], rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("forgetting_factor", [1.0, 0.97])
def test_mimo_equals_one_siso_rls_per_output_on_the_same_regressor(
    forgetting_factor: float,
) -> None:
    """Decoupled outputs; each SISO model gets the other output as an input, same φ up to signs."""
    rng = np.random.default_rng(1)
    n = 2000
    u = rng.normal(size=n)
    y = np.zeros((n, 2))
    for t in range(1, n):
        y[t, 0] = 0.7 * y[t - 1, 0] + 0.5 * u[t - 1]
        y[t, 1] = -0.4 * y[t - 1, 1] + 1.5 * u[t - 1]
    y += 0.05 * rng.normal(size=y.shape)
    both = IOData(u, y, ts=0.02, input_names=["u"], output_names=["y1", "y2"])
    settings = {"forgetting_factor": forgetting_factor, "initial_covariance": 50.0}
    mimo = RecursiveARX(Lags.arx(1, 1), **settings).fit(both)
    # φ = [-y1(t-1), -y2(t-1), u(t-1)] for both outputs.
    for k, other in ((0, 1), (1, 0)):
        alone = IOData(
            np.column_stack([y[:, other], u]),
            y[:, k],
            ts=0.02,
            input_names=["other", "u"],
            output_names=["self"],
        )
        siso = RecursiveARX(Lags(outputs=[1], inputs=[1]), **settings).fit(alone)
        # SISO φ = [-y_k(t-1), +y_other(t-1), u(t-1)]: reorder and flip to the MIMO's terms.
        order = [0, 1, 2] if k == 0 else [1, 0, 2]
        sign = np.array([1.0, -1.0, 1.0])[order]
        np.testing.assert_allclose(
            mimo.theta_history_[:, :, k],
            siso.theta_history_[:, order] * sign,
            rtol=1e-10,
            atol=1e-13,
        )
        np.testing.assert_allclose(
            mimo.prediction_errors_[:, k], siso.prediction_errors_, rtol=1e-10, equal_nan=True
        )
    # And with the NumPy reference, column by column and all at once.
    phi, targets = mimo._regressor(both)
    f0 = 50.0 * np.eye(3)
    for k in range(2):
        history, covariance, errors, _ = rls_reference(phi, targets[:, k], forgetting_factor, f0)
        np.testing.assert_allclose(mimo.theta_history_[1:, :, k], history, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(mimo.covariance_, covariance, rtol=1e-9, atol=1e-14)
    history, _, errors, _ = rls_reference(phi, targets, forgetting_factor, f0)
    np.testing.assert_allclose(mimo.theta_history_[1:], history, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(mimo.prediction_errors_[1:], errors, rtol=1e-9, atol=1e-12)


def test_update_per_sample_equals_fit_on_the_whole_record() -> None:
    data = coupled(600, noise=0.05, seed=2)
    # update() on a fresh model knows no channel names: lags per channel by name cannot apply.
    lags = Lags(outputs=[2], inputs=[0, 3])
    batch = RecursiveARX(lags, forgetting_factor=0.99).fit(data)
    online = RecursiveARX(lags, forgetting_factor=0.99)
    errors = [online.update(y, u) for y, u in zip(data.y, data.u, strict=True)]
    assert all(isinstance(e, np.ndarray) and e.shape == (2,) for e in errors)
    assert online.output_names_ == ("y1", "y2")  # no names given online
    np.testing.assert_allclose(
        np.array(errors), batch.prediction_errors_, rtol=1e-12, equal_nan=True
    )
    np.testing.assert_allclose(online.theta_history_, batch.theta_history_, rtol=1e-12)
    np.testing.assert_allclose(online.covariance_, batch.covariance_, rtol=1e-12)
    np.testing.assert_allclose(online.theta_, batch.theta_, rtol=1e-12)
    # Online after a fit goes on from the estimate (the next max_lag samples fill the regressor).
    more = coupled(300, noise=0.05, seed=3)
    continued = RecursiveARX(lags, forgetting_factor=0.99).fit(data)
    for y, u in zip(more.y, more.u, strict=True):
        continued.update(y, u)
    whole = RecursiveARX(lags, forgetting_factor=0.99).fit([data, more])
    np.testing.assert_allclose(continued.theta_history_, whole.theta_history_, rtol=1e-12)


def test_save_load_round_trip(tmp_path) -> None:  # type: ignore[no-untyped-def]
    data = coupled(400, noise=0.05, seed=4)
    theta0 = np.arange(16.0).reshape(8, 2) / 100
    model = RecursiveARX(Lags.arx(2, 2), forgetting_factor=0.99, initial_parameters=theta0).fit(
        data
    )
    path = model.save(tmp_path / "mimo")
    _, arrays, _ = read_model_file(path)
    assert arrays["theta"].shape == (8, 2)
    assert arrays["theta_history"].shape == (400, 8, 2)
    assert arrays["prediction_errors"].shape == (400, 2)
    loaded = load_model(path)
    assert isinstance(loaded, RecursiveARX)
    np.testing.assert_array_equal(loaded.theta_, model.theta_)
    np.testing.assert_array_equal(loaded.theta_history_, model.theta_history_)
    np.testing.assert_array_equal(loaded.prediction_errors_, model.prediction_errors_)
    np.testing.assert_array_equal(loaded.covariance_, model.covariance_)
    np.testing.assert_array_equal(loaded.simulate(data).y, model.simulate(data).y)
    assert loaded.parameter_names_ == model.parameter_names_
    # Both go on learning online from where they stopped, to the same values.
    for y, u in zip(data.y[:5], data.u[:5], strict=True):
        np.testing.assert_array_equal(loaded.update(y, u), model.update(y, u))
    assert loaded.theta_history_.shape == (405, 8, 2)
    np.testing.assert_array_equal(loaded.theta_history_, model.theta_history_)


def test_single_output_files_keep_their_layout(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A SISO model writes (p,), (n, p), (n,) as before, and a file in that layout loads."""
    rng = np.random.default_rng(5)
    u = rng.normal(size=300)
    y = np.zeros(300)
    for t in range(1, 300):
        y[t] = 0.8 * y[t - 1] + 0.5 * u[t - 1]
    model = RecursiveARX(Lags.arx(1, 1)).fit(IOData(u, y, ts=0.02))
    path = model.save(tmp_path / "siso")
    _, arrays, meta = read_model_file(path)
    assert arrays["theta"].shape == (2,)
    assert arrays["theta_history"].shape == (300, 2)
    assert arrays["prediction_errors"].shape == (300,)
    assert model.coef_.shape == (2, 1)
    assert isinstance(model.update(0.1, 0.2), float)
    # A file as the single-output RecursiveARX wrote it (same arrays and meta) loads and runs.
    again = write_model_file(tmp_path / "old", "RecursiveARX", arrays, meta)
    old = load_model(again)
    np.testing.assert_array_equal(old.theta_history_, arrays["theta_history"])
    assert isinstance(old.update(0.1, 0.2), float)
    assert old.theta_history_.shape == (301, 2)


def test_damaged_mimo_file_refused(tmp_path) -> None:  # type: ignore[no-untyped-def]
    model = RecursiveARX(Lags.arx(1, 1)).fit(coupled(200, noise=0.01))
    _, arrays, meta = read_model_file(model.save(tmp_path / "good"))
    arrays["theta"] = arrays["theta"][:, 0]  # a single-output estimate for two outputs
    bad = write_model_file(tmp_path / "bad", "RecursiveARX", arrays, meta)
    with pytest.raises(ValueError, match=r"theta must have shape \(4, 2\) for 4 parameters and 2"):
        load_model(bad)


def test_initial_parameters_with_several_outputs() -> None:
    data = coupled(50, noise=0.01)
    start = np.full((8, 2), 0.25)
    model = RecursiveARX(Lags.arx(2, 2), initial_parameters=start, forgetting_factor=1.0)
    model.fit(data)
    np.testing.assert_array_equal(model.theta_history_[:2], np.broadcast_to(start, (2, 8, 2)))
    with pytest.raises(
        ValueError, match=r"initial_parameters must have shape \(8, 2\).*got shape \(8,\)"
    ):
        RecursiveARX(Lags.arx(2, 2), initial_parameters=np.zeros(8)).fit(data)


def test_blow_up_guard_with_several_outputs() -> None:
    u = np.zeros(1000)
    y = np.zeros((1000, 2))
    y[0] = [1.0, -1.0]
    model = RecursiveARX(Lags.arx(1, 1), forgetting_factor=0.9, max_covariance_trace=1e6)
    with pytest.warns(RuntimeWarning, match="blew up"):
        model.fit(IOData(u, y, ts=0.02))
    assert model.n_covariance_resets_ >= 5
    assert np.all(np.isfinite(model.theta_history_))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        RecursiveARX(Lags.arx(1, 1), forgetting_factor=0.9).fit(coupled(1000, noise=0.1))


def test_update_refuses_a_sample_of_the_wrong_size() -> None:
    model = RecursiveARX(Lags.arx(1, 1)).fit(coupled(100, noise=0.01))
    with pytest.raises(
        ValueError, match=r"y must have 2 value\(s\), one per output \['pitch', 'roll'\]; got 1"
    ):
        model.update(1.0, [0.0, 0.0])
    before = (model.theta_.copy(), model.covariance_.copy(), model.n_samples_)
    with pytest.raises(ValueError, match=r"non-finite value .*inf"):
        model.update([1.0, np.inf], [0.0, 0.0])
    with pytest.raises(ValueError, match=r"u channel .* non-finite value .*nan"):
        model.update([1.0, 2.0], [0.0, np.nan])
    # A refused sample changes nothing.
    np.testing.assert_array_equal(model.theta_, before[0])
    np.testing.assert_array_equal(model.covariance_, before[1])
    assert model.n_samples_ == before[2] == model.theta_history_.shape[0]
    with pytest.raises(ValueError, match="u must have 2 values"):
        model.update([1.0, 2.0], [0.0])


def test_history_grows_by_doubling_not_per_sample() -> None:
    history = ParameterHistory(3, 2)
    capacities = []
    for k in range(5000):
        theta, errors = history.append(1)
        theta[0] = k
        errors[0] = -k
        capacities.append(history.capacity)
    assert sorted(set(capacities)) == [64 * 2**k for k in range(8)]  # 64, 128, ..., 8192
    assert history.size == 5000
    np.testing.assert_array_equal(history.theta[:, 0, 0], np.arange(5000.0))
    np.testing.assert_array_equal(history.errors[:, 1], -np.arange(5000.0))
    # The same through update: the buffers change only when full.
    model = RecursiveARX(Lags.arx(1, 1))
    model.update(0.0, 0.0)
    buffer, allocations = model._history._theta, 1
    for y, u in zip(np.sin(np.arange(3000) / 7), np.cos(np.arange(3000) / 3), strict=True):
        model.update(y, u)
        if model._history._theta is not buffer:
            buffer, allocations = model._history._theta, allocations + 1
    assert allocations == 7  # 64, 128, ..., 4096 rows
    assert model.theta_history_.shape == (3001, 2)
