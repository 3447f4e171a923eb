"""LinearARX's filter free run equals the generic NARX loop on every regressor layout (issue 18).

The reference is ``NarxModel.simulate`` (the per-sample loop of ``neckid.models.base``), which
``LinearARX.simulate`` replaces with ``scipy.signal.lfilter`` (one output) or a compiled loop
(several coupled outputs). Both must agree to rounding: rtol 1e-10, with an absolute floor of
1e-10 times the largest output so that values crossing zero do not decide.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from neckid import IOData, Lags, LinearARX
from neckid.models.base import DivergenceError, NarxModel, _free_run
from neckid.models.io import load_model
from neckid.models.linear.arx import linear_free_run

RTOL = 1e-10


def assert_same_run(fast: np.ndarray, generic: np.ndarray) -> None:
    assert fast.shape == generic.shape
    np.testing.assert_allclose(fast, generic, rtol=RTOL, atol=RTOL * np.max(np.abs(generic)))


def siso(n: int = 1500, seed: int = 0) -> IOData:
    """y(t) = 1.2 y(t-1) - 0.5 y(t-3) + 0.7 u(t) + 0.3 u(t-4) + 0.4 + noise."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=n)
    forcing = signal.lfilter([0.7, 0, 0, 0, 0.3], [1.0], u) + 0.4
    y = signal.lfilter([1.0], [1.0, -1.2, 0.0, 0.5], forcing) + 0.01 * rng.normal(size=n)
    return IOData(u, y, ts=0.02, input_names=["command"], output_names=["incl"])


def miso(n: int = 1500, seed: int = 1) -> IOData:
    """Three inputs (one with lag 0) into one output, and an experimental condition."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 3))
    y = np.zeros(n)
    for t in range(3, n):
        y[t] = (
            0.6 * y[t - 1]
            - 0.2 * y[t - 2]
            + 0.5 * u[t, 0]
            - 0.4 * u[t - 2, 1]
            + 0.1 * u[t - 3, 2]
            + 0.05 * rng.normal()
        )
    return IOData(u, y, ts=0.02, input_names=["a", "b", "c"], output_names=["y"]).with_conditions(
        payload=0.4
    )


def mimo(n: int = 2000, seed: int = 2) -> IOData:
    """Three inputs, two outputs coupled through each other's past outputs."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 3))
    y = np.zeros((n, 2))
    for t in range(3, n):
        y[t, 0] = 0.5 * y[t - 1, 0] + 0.3 * y[t - 2, 1] + u[t, 0] - 0.5 * u[t - 1, 2] + 1.0
        y[t, 1] = -0.4 * y[t - 1, 0] + 0.6 * y[t - 1, 1] + 0.8 * u[t - 3, 1] + 0.2 * u[t, 2]
    y += 0.01 * rng.normal(size=y.shape)
    return IOData(u, y, ts=0.02, input_names=["u1", "u2", "u3"], output_names=["pitch", "roll"])


CASES = {
    "siso-arx": (siso, Lags.arx(2, 2)),
    "siso-sparse-lag0": (siso, Lags(outputs=[1, 3], inputs=[0, 4])),
    "siso-input-lag-longest": (siso, Lags(outputs=[1], inputs=[2, 7])),
    "siso-fir": (siso, Lags(outputs=0, inputs=[0, 1, 2])),
    "siso-ar-only": (siso, Lags(outputs=[1, 2, 3], inputs=0)),
    "miso-mapped-condition": (
        miso,
        Lags(outputs=2, inputs={"a": [0], "b": [2], "c": [1, 3]}, conditions=["payload"]),
    ),
    "mimo-arx": (mimo, Lags.arx(2, 2, 0)),
    "mimo-sparse": (
        mimo,
        Lags(outputs={"pitch": [1], "roll": [2, 4]}, inputs={"u1": [0], "u2": [3], "u3": [0, 1]}),
    ),
    "mimo-one-output-lag": (mimo, Lags(outputs={"roll": [1]}, inputs=[0, 1, 3])),
    "mimo-fir": (mimo, Lags(outputs=0, inputs=[0, 1, 2, 3])),
    "mimo-ar-only": (mimo, Lags(outputs=[1, 2], inputs=0)),
}


@pytest.mark.parametrize("fit_intercept", [True, False])
@pytest.mark.parametrize("case", sorted(CASES))
def test_filter_free_run_equals_generic_loop(case: str, fit_intercept: bool) -> None:
    make, lags = CASES[case]
    data = make()
    model = LinearARX(lags, fit_intercept=fit_intercept).fit(data)
    fast = model.simulate(data)
    generic = NarxModel.simulate(model, data)
    assert fast.kind == generic.kind == "simulation"
    assert fast.n_initial == generic.n_initial == model.max_lag_
    assert_same_run(fast.y, generic.y)
    # Not a vacuous comparison: every output moves over the run.
    assert np.all(np.ptp(fast.y[model.max_lag_ :], axis=0) > 1e-3)


@pytest.mark.parametrize("case", ["siso-sparse-lag0", "miso-mapped-condition", "mimo-sparse"])
def test_initial_outputs_given(case: str) -> None:
    make, lags = CASES[case]
    data = make()
    model = LinearARX(lags).fit(data)
    m = model.max_lag_
    inputs_only = IOData(data.u, ts=data.ts, input_names=data.input_names).with_conditions(
        **data.conditions
    )
    start = np.linspace(-1.0, 2.0, m * data.n_outputs).reshape(m, data.n_outputs)
    fast = model.simulate(inputs_only, initial=start)
    generic = NarxModel.simulate(model, inputs_only, initial=start)
    np.testing.assert_array_equal(fast.y[:m], start)
    assert_same_run(fast.y, generic.y)
    # One row is repeated over the initial samples, in both paths.
    one_row = model.simulate(inputs_only, initial=start[-1])
    assert_same_run(one_row.y, NarxModel.simulate(model, inputs_only, initial=start[-1]).y)
    np.testing.assert_array_equal(one_row.y[:m], np.broadcast_to(start[-1], (m, data.n_outputs)))


@pytest.mark.parametrize("case", ["siso-input-lag-longest", "mimo-sparse"])
def test_simulator_steps_to_the_filter_run(case: str) -> None:
    make, lags = CASES[case]
    data = make()[:300]
    model = LinearARX(lags).fit(data)
    m = model.max_lag_
    expected = model.simulate(data).y
    simulator = model.simulator()
    simulator.reset(y0=data.y[:m], u0=data.u[:m])
    stepped = np.array([simulator.step(data.u[t]) for t in range(m, data.n_samples)])
    assert_same_run(stepped, expected[m:])


@pytest.mark.parametrize("case", ["siso-sparse-lag0", "mimo-arx"])
def test_save_load_then_simulate(case: str, tmp_path) -> None:  # type: ignore[no-untyped-def]
    make, lags = CASES[case]
    data = make()
    model = LinearARX(lags).fit(data)
    loaded = load_model(model.save(tmp_path / case))
    assert isinstance(loaded, LinearARX)
    np.testing.assert_array_equal(loaded.simulate(data).y, model.simulate(data).y)
    assert_same_run(loaded.simulate(data).y, NarxModel.simulate(model, data).y)


def test_kernel_function_against_generic_loop_with_hand_made_coefficients() -> None:
    """Coefficients not from a fit (near the stability limit), directly on the function."""
    data = mimo(800)
    resolved = Lags(outputs={"pitch": [1, 2], "roll": [3]}, inputs=[0, 2]).resolve(data)
    rng = np.random.default_rng(5)
    coef = rng.normal(scale=0.3, size=(resolved.n_terms, 2))
    coef[:2] = [[0.9, 0.05], [-0.1, 0.02]]
    coef[2] = [0.05, 0.95]  # roll(t-3) -> roll: slow
    intercept = np.array([0.3, -0.2])

    def rows(x: np.ndarray) -> np.ndarray:
        return x @ coef + intercept

    fast = linear_free_run(resolved, coef, intercept, data.u, data.y)
    assert_same_run(fast, _free_run(resolved, rows, data.u, data.y))
    np.testing.assert_array_equal(fast[:3], data.y[:3])


def test_unstable_model_diverges_at_the_same_sample_in_both_paths() -> None:
    data = siso(3000)
    model = LinearARX(Lags.arx(1, 1)).fit(data)
    model.coef_ = np.array([[1.5], [1.0]])  # a pole at 1.5: overflows after some 1700 samples
    with pytest.raises(DivergenceError) as fast:
        model.simulate(data)
    with pytest.raises(DivergenceError) as generic:
        NarxModel.simulate(model, data)
    assert str(fast.value) == str(generic.value)
    assert_same_run(fast.value.result.y[:1000], generic.value.result.y[:1000])


def test_too_short_record_refused() -> None:
    resolved = Lags.arx(3, 1).resolve(siso(10))
    with pytest.raises(ValueError, match="needs at least 4"):
        linear_free_run(resolved, np.zeros((4, 1)), [0.0], np.zeros((3, 1)), np.zeros((3, 1)))
