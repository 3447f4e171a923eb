"""python-control interop: transfer functions of the linear models, I/O systems of every model.

Two code paths must agree: python-control simulating what :func:`neckid.export.control.to_control` and
:func:`neckid.export.control.to_iosystem` export, and neckid's own ``simulate`` / ``closed_loop``.
"""

from __future__ import annotations

import warnings

import control
import numpy as np
import pytest

import neckid
from neckid import GainScheduledModel, IOData, Lags, LinearARX, NotFittedError, RecursiveARX
from neckid.export.control import (
    default_form,
    initial_state,
    output_offset,
    to_control,
    to_iosystem,
)
from neckid.loops.model_in_loop import VelocityDrive
from neckid.plant import InclinationController, SoftNeck, closed_loop
from neckid.signals import multisine, sine

TS = 0.02
TOLERANCE = 1e-10


def _open_loop(seed: int, duration: float) -> IOData:
    """The demo's identification record: a motor-position multisine, as velocity commands."""
    n = round(duration / TS)
    position = 2.5 + 2.5 * multisine(
        n, TS, band=(0.05, 4.0), amplitude=1.0, phases="random", seed=seed
    )
    n_ramp = round(3.0 / TS)
    ramp = np.full(n_ramp, position[0] / (n_ramp * TS))
    velocity = np.concatenate([ramp, np.diff(position, prepend=position[0]) / TS])
    return SoftNeck(seed=seed).run(velocity)[n_ramp:]


@pytest.fixture(scope="module", autouse=True)
def _one_numba_thread():
    """Step-by-step Set Membership queries one regressor at a time: on a busy machine the
    parallel kernel's thread wake-ups cost milliseconds per query, far more than the query."""
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(before)


@pytest.fixture(scope="module")
def neck() -> IOData:
    return _open_loop(seed=1, duration=24.0)


def _synthetic(n: int = 800, seed: int = 0) -> IOData:
    """A slow saturating first-order system, named as the loop's signals."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1.0, 1.0, n // 20), 20) + 0.05 * rng.normal(size=n)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.8 * y[t - 1] + 0.3 * np.tanh(2.0 * u[t - 1])
    return IOData(
        u,
        y + 0.01 * rng.normal(size=n),
        ts=TS,
        input_names=["velocity_command"],
        output_names=["inclination"],
        input_units=["rad/s"],
        output_units=["deg"],
    )


def _time(n: int) -> np.ndarray:
    return np.arange(n) * TS


# ------------------------------------------------------------------------------ to_control
def test_arx_transfer_function_reproduces_the_free_run_around_its_offset(neck: IOData) -> None:
    view = neck.select(inputs=["motor_position"], outputs=["inclination"])
    model = LinearARX(Lags.arx(2, 3, 1)).fit(view)
    tf = to_control(model)
    assert isinstance(tf, control.TransferFunction)
    assert tf.dt == TS
    assert (tf.input_labels, tf.output_labels) == (["motor_position"], ["inclination"])
    offset = output_offset(model)
    assert abs(offset[0]) > 0.1  # the intercept matters: without the offset the test would fail
    # Zero inputs before the record starts: the model rests at its offset, the TF at zero.
    m = model.max_lag_
    u = np.concatenate([np.zeros(m), view.u[:300, 0]])
    data = IOData(u, ts=TS, input_names=["motor_position"])
    free = model.simulate(data, initial=offset).y[:, 0]
    response = control.forced_response(tf, _time(u.size), u)
    np.testing.assert_allclose(response.outputs + offset[0], free, rtol=0, atol=TOLERANCE)


def test_state_space_form_starts_from_measured_initial_conditions(neck: IOData) -> None:
    view = neck.select(inputs=["motor_position"], outputs=["inclination"])[:400]
    model = LinearARX(Lags(outputs=3, inputs=[8, 9, 10])).fit(view)
    m = model.max_lag_
    offset = output_offset(model)
    ss = to_control(model, form="ss")
    assert ss.state_labels[0] == "inclination[t-10]"
    x0 = initial_state(model, view.y[:m] - offset, view.u[:m])
    response = control.forced_response(ss, _time(view.n_samples - m), view.u[m:, 0], X0=x0)
    free = model.simulate(view).y[m:, 0]
    np.testing.assert_allclose(response.outputs + offset[0], free, rtol=0, atol=TOLERANCE)
    # The realisation is the transfer function: the same frequency response.
    tf = to_control(model)
    for omega in (0.1, 2.0, 40.0):
        z = np.exp(1j * omega * TS)
        assert ss(z) == pytest.approx(tf(z), rel=1e-9)


def test_recursive_arx_exports_its_final_estimate(neck: IOData) -> None:
    view = neck.select(inputs=["motor_position"], outputs=["inclination"])[:600]
    model = RecursiveARX(Lags.arx(2, 2, 1)).fit(view)
    tf = to_control(model, strict=True)  # no intercept: strict passes
    coef = model.coef_[:, 0]  # [a1, a2, b1, b2] on [y(t-1), y(t-2), u(t-1), u(t-2)]
    np.testing.assert_allclose(tf.den[0][0], [1.0, -coef[0], -coef[1]], rtol=1e-12)
    np.testing.assert_allclose(tf.num[0][0], coef[2:], rtol=1e-12)
    u = np.concatenate([np.zeros(2), view.u[:200, 0]])
    free = model.simulate(IOData(u, ts=TS, input_names=["motor_position"]), initial=0.0).y[:, 0]
    response = control.forced_response(tf, _time(u.size), u)
    np.testing.assert_allclose(response.outputs, free, rtol=0, atol=TOLERANCE)


def test_mimo_arx_gives_a_transfer_matrix_whose_elements_superpose_to_the_free_run() -> None:
    rng = np.random.default_rng(3)
    n = 600
    u = rng.normal(size=(n, 2))
    y = np.zeros((n, 2))
    for t in range(2, n):
        y[t, 0] = 0.5 * y[t - 1, 0] + 0.2 * y[t - 1, 1] + u[t - 1, 0] - 0.3 * u[t - 2, 1]
        y[t, 1] = -0.1 * y[t - 1, 0] + 0.6 * y[t - 1, 1] + 0.1 * y[t - 2, 1] + 0.5 * u[t - 1, 1]
    data = IOData(u, y, ts=TS, input_names=["a", "b"], output_names=["p", "q"])
    model = LinearARX(Lags.arx(2, 2, 1), fit_intercept=False).fit(data)
    tf = to_control(model)
    assert (tf.ninputs, tf.noutputs) == (2, 2)
    assert (tf.input_labels, tf.output_labels) == (["a", "b"], ["p", "q"])
    # The coupled poles are the roots of det A(z), shared by every element.
    np.testing.assert_allclose(
        np.sort_complex(tf[0, 0].poles()), np.sort_complex(tf[1, 1].poles()), atol=1e-9
    )
    u_test = np.vstack([np.zeros((2, 2)), rng.normal(size=(200, 2))])
    free = model.simulate(IOData(u_test, ts=TS, input_names=["a", "b"]), initial=[0.0, 0.0]).y
    time = _time(u_test.shape[0])
    for o in range(2):
        with warnings.catch_warnings():
            # b(t-1) of input "b" on "p" is zero in truth, ~1e-17 fitted: scipy warns, rightly.
            warnings.simplefilter("ignore")
            total = sum(
                control.forced_response(tf[o, j], time, u_test[:, j]).outputs for j in range(2)
            )
        np.testing.assert_allclose(total, free[:, o], rtol=0, atol=TOLERANCE)
    # A MIMO transfer function needs slycot to simulate; the state-space form does not.
    ss = to_control(model, form="ss")
    x0 = initial_state(model, y[:2], u[:2])
    response = control.forced_response(ss, _time(n - 2), u[2:].T, X0=x0)
    np.testing.assert_allclose(response.outputs.T, model.simulate(data).y[2:], atol=TOLERANCE)


def test_scheduled_model_is_frozen_at_an_inclination() -> None:
    i = np.array([5.0, 15.0, 25.0, 35.0])
    model = GainScheduledModel.from_points(
        i, -0.059 * i + 1.857, 0.01175 * i - 0.4797, ts=TS, delay=3
    )
    tf = to_control(model, inclination=20.0, form="tf")
    reference = model.transfer_function(20.0, to="inclination")
    np.testing.assert_array_equal(tf.num[0][0], reference.num[0][0])
    np.testing.assert_array_equal(tf.den[0][0], reference.den[0][0])
    assert (tf.input_labels, tf.output_labels) == (["velocity_command"], ["inclination"])
    ss = to_control(model, inclination=20.0, form="ss")
    for omega in (0.5, 5.0):
        z = np.exp(1j * omega * TS)
        assert ss(z) == pytest.approx(tf(z), rel=1e-9)
    with pytest.raises(ValueError, match="inclination is required"):
        to_control(model)


def test_the_default_form_is_the_methods_entry() -> None:
    """ARX models: a transfer function; the scheduled model frozen: a state space (its entry's
    control_form), the same system as form="tf"."""
    for method in neckid.methods().values():
        assert default_form(method.make(Lags.arx(1, 1))) == method.control_form
    i = np.array([5.0, 15.0, 25.0, 35.0])
    model = GainScheduledModel.from_points(
        i, -0.059 * i + 1.857, 0.01175 * i - 0.4797, ts=TS, delay=3
    )
    frozen = to_control(model, inclination=20.0)
    assert isinstance(frozen, control.StateSpace)
    tf = to_control(model, inclination=20.0, form="tf")
    for omega in (0.5, 5.0):
        z = np.exp(1j * omega * TS)
        assert frozen(z) == pytest.approx(tf(z), rel=1e-9)
    arx = LinearARX(Lags.arx(1, 1), fit_intercept=False).fit(_synthetic(200))
    assert isinstance(to_control(arx), control.TransferFunction)


def test_position_form_scheduled_model_in_python_control() -> None:
    """The position form (inclination from motor displacement): ss = tf, and the I/O system's free
    run equals the model's."""
    i = np.array([10.0, 20.0, 30.0])
    model = GainScheduledModel.from_points(
        i, 0.05 * i + 1.0, 0.002 * i + 0.8, ts=TS, delay=2, form="position"
    )
    tf = to_control(model, inclination=20.0, form="tf")
    ss = to_control(model, inclination=20.0, form="ss")
    for omega in (0.0, 0.5, 5.0):
        z = np.exp(1j * omega * TS)
        assert ss(z) == pytest.approx(tf(z), rel=1e-9)
    assert float(np.real(ss(1.0))) == pytest.approx(2.0 / (1.0 - 0.84), rel=1e-9)
    u = np.concatenate([np.zeros(5), np.linspace(0.0, 3.0, 195)])
    data = IOData(u, np.full(200, 20.0), ts=TS, input_names=model.input_names_,
                  output_names=model.output_names_)  # fmt: skip
    system = to_iosystem(model)
    x0 = initial_state(model, data.y[: model.max_lag_], data.u[: model.max_lag_])
    response = control.input_output_response(system, _time(200 - model.max_lag_),
                                             u[model.max_lag_ :], X0=x0)  # fmt: skip
    np.testing.assert_allclose(
        response.outputs.ravel(), model.simulate(data).y[model.max_lag_ :, 0], atol=TOLERANCE
    )


def test_intercept_and_argument_rules(neck: IOData) -> None:
    view = neck.select(inputs=["motor_position"], outputs=["inclination"])[:300]
    model = LinearARX(Lags.arx(1, 1)).fit(view)
    with pytest.raises(ValueError, match="has an intercept"):
        to_control(model, strict=True)
    with pytest.raises(ValueError, match="inclination applies to a GainScheduledModel only"):
        to_control(model, inclination=10.0)
    with pytest.raises(ValueError, match="form must be 'tf' or 'ss'; got 'zpk'"):
        to_control(model, form="zpk")  # type: ignore[arg-type]
    with pytest.raises(NotFittedError):
        to_control(LinearARX(Lags.arx(1, 1)))
    integrator = LinearARX(Lags.arx(1, 1)).fit(view)
    integrator.coef_ = np.array([[1.0], [0.5]])
    with pytest.raises(ValueError, match="pole at z = 1"):
        output_offset(integrator)


@pytest.mark.parametrize("name", ["sm", "nn"])
def test_a_nonlinear_model_points_at_to_iosystem(name: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = neckid.methods()[name].make(Lags.arx(1, 1), quick=True).fit(_synthetic(200))
    with pytest.raises(TypeError, match=rf"a {type(model).__name__} is nonlinear.*to_iosystem"):
        to_control(model)


# ------------------------------------------------------------------------------ to_iosystem
SYNTHETIC = _synthetic()


@pytest.fixture(scope="module", params=sorted(neckid.methods()))
def fitted(request: pytest.FixtureRequest):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the quick network stops before converging
        model = neckid.methods()[request.param].make(Lags.arx(1, 1, 1), quick=True)
        model.fit(SYNTHETIC)
    return request.param, model


def test_every_model_as_an_iosystem_reproduces_its_free_run(fitted) -> None:
    _name, model = fitted
    system = to_iosystem(model)
    assert system.isdtime(strict=True) and system.dt == TS
    assert (system.input_labels, system.output_labels) == (["velocity_command"], ["inclination"])
    data = SYNTHETIC[:120]
    m = max(model.max_lag_, 1)
    x0 = initial_state(model, data.y[:m], data.u[:m])
    response = control.input_output_response(
        system, _time(data.n_samples - m), data.u[m:, 0], X0=x0
    )
    np.testing.assert_allclose(response.outputs, model.simulate(data).y[m:, 0], atol=TOLERANCE)


def test_every_model_simulator_closes_the_loop_as_its_iosystem_does(fitted) -> None:
    """``closed_loop(model.simulator(), ...)`` and ``control.interconnect`` give the same loop."""
    _name, model = fitted
    reference = np.r_[np.zeros(5), np.full(35, 0.4)]
    loop = control.interconnect(
        [to_iosystem(model), to_iosystem(InclinationController(ts=TS))],
        inplist=["reference"],
        outlist=["inclination", "velocity_command"],
    )
    response = control.input_output_response(loop, _time(reference.size), reference)
    log = closed_loop(model.simulator(), InclinationController(ts=TS), reference, TS)
    np.testing.assert_allclose(response.outputs[0], log.y[:, 0], rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(
        response.outputs[1], log.channel("velocity_command"), rtol=0, atol=TOLERANCE
    )


@pytest.mark.parametrize("name", ["arx", "sm", "nn"])
def test_a_loop_through_interconnect_equals_closed_loop_on_neck_models(
    name: str, neck: IOData
) -> None:
    view = neck.select(inputs=["velocity_command"], outputs=["inclination"])[:600]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = neckid.methods()[name].make(Lags(outputs=2, inputs=[1, 2, 3]), quick=True)
        model.fit(view)
    reference = sine(_time(120), amplitude=5.0, omega=2.0, offset=10.0)
    loop = control.interconnect(
        [to_iosystem(model), to_iosystem(InclinationController(ts=TS))],
        inplist=["reference"],
        outlist=["inclination", "velocity_command"],
    )
    response = control.input_output_response(loop, _time(reference.size), reference)
    log = closed_loop(model.simulator(), InclinationController(ts=TS), reference, TS)
    assert np.ptp(log.y) > 1.0  # the loop moves
    np.testing.assert_allclose(response.outputs[0], log.y[:, 0], rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(
        response.outputs[1], log.channel("velocity_command"), rtol=0, atol=TOLERANCE
    )


def test_position_model_drive_and_controller_close_the_neck_loop(neck: IOData) -> None:
    """A motor-position model needs the drive between the command and its input."""
    from neckid.loops.model_in_loop import ModelPlant

    view = neck.select(inputs=["motor_position"], outputs=["inclination"])
    model = LinearARX(Lags.arx(2, 2, 3)).fit(view)
    drive = VelocityDrive.from_parameters(ts=TS)
    loop = control.interconnect(
        [to_iosystem(model), to_iosystem(drive), to_iosystem(InclinationController(ts=TS))],
        inplist=["reference"],
        outlist=["inclination", "velocity_command", "motor_position", "motor_velocity"],
    )
    reference = sine(_time(150), amplitude=5.0, omega=2.0, offset=15.0)
    response = control.input_output_response(loop, _time(reference.size), reference)
    log = closed_loop(ModelPlant(model, drive), InclinationController(ts=TS), reference, TS)
    np.testing.assert_allclose(response.outputs[0], log.y[:, 0], rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(response.outputs[2], log.channel("motor_position"), atol=1e-12)


def test_input_lag_zero_is_direct_feedthrough_and_keeps_the_alignment() -> None:
    data = SYNTHETIC
    direct = LinearARX(Lags(outputs=1, inputs=[0, 1])).fit(data)
    delayed = LinearARX(Lags(outputs=1, inputs=[1, 2])).fit(data)
    x = np.array([0.3, 0.1])
    assert to_iosystem(direct).output(0.0, x, [1.0]) != to_iosystem(direct).output(0.0, x, [2.0])
    x2 = initial_state(delayed, [[0.3], [0.2]], 0.1)
    assert to_iosystem(delayed).output(0.0, x2, [1.0]) == to_iosystem(delayed).output(
        0.0, x2, [2.0]
    )
    tf = to_control(direct)
    assert len(tf.num[0][0]) == len(tf.den[0][0])  # proper, not strictly: D != 0
    # y[k] of python-control goes with u[k], as simulate's y(t) with u(t).
    response = control.input_output_response(
        to_iosystem(direct),
        _time(99),
        data.u[1:100, 0],
        X0=initial_state(direct, data.y[:1], data.u[:1]),
    )
    np.testing.assert_allclose(
        response.outputs, direct.simulate(data[:100]).y[1:, 0], atol=TOLERANCE
    )


def test_set_membership_bounds_as_outputs() -> None:
    model = neckid.methods()["sm"].make(Lags.arx(1, 1)).fit(SYNTHETIC)
    system = to_iosystem(model, bounds=True)
    assert system.output_labels == ["inclination", "inclination_lower", "inclination_upper"]
    data = SYNTHETIC[:80]
    response = control.input_output_response(
        system, _time(79), data.u[1:, 0], X0=initial_state(model, data.y[:1], data.u[:1])
    )
    result = model.simulate(data)
    assert result.lower is not None and result.upper is not None
    np.testing.assert_allclose(response.outputs[1], result.lower[1:, 0], atol=TOLERANCE)
    np.testing.assert_allclose(response.outputs[2], result.upper[1:, 0], atol=TOLERANCE)


def test_controller_iosystem_is_the_controller_with_one_sample_of_measurement_delay() -> None:
    rng = np.random.default_rng(5)
    for configuration, width in (("planar", 1), ("three_tendon", 2)):
        controller = InclinationController(kp=0.8, ki=2.0, ts=TS, configuration=configuration)
        n = 200
        reference = np.column_stack([rng.uniform(0, 30, n), rng.uniform(0, 360, n)])[:, :width]
        measured = np.column_stack([rng.uniform(0, 30, n), rng.uniform(0, 360, n)])[:, :width]
        system = to_iosystem(controller)
        response = control.input_output_response(
            system, _time(n), np.hstack([reference, measured]).T
        )
        controller.reset()
        previous = np.zeros(width)
        expected = []
        for k in range(n):
            expected.append(controller.step(reference[k], previous))
            previous = measured[k]
        commands = np.array(expected)
        assert np.any(np.abs(commands) >= controller.command_limit)  # saturation exercised
        np.testing.assert_allclose(response.outputs.reshape(-1, n).T, commands, atol=TOLERANCE)


def test_drive_iosystem_is_the_drive() -> None:
    drive = VelocityDrive.from_parameters(ts=TS)
    commands = np.r_[np.full(20, 4.0), np.full(20, -4.0), np.linspace(-1, 1, 40)]
    response = control.input_output_response(to_iosystem(drive), _time(commands.size), commands)
    drive.reset()
    expected = [drive.step([c])[0] for c in commands]
    np.testing.assert_array_equal(response.outputs[0], expected)


@pytest.mark.parametrize(
    ("system", "error", "match"),
    [
        (SoftNeck(), TypeError, "got SoftNeck"),
        (LinearARX(Lags.arx(1, 1)), NotFittedError, "not fitted yet"),
    ],
)
def test_to_iosystem_refuses_what_it_cannot_export(system, error, match) -> None:
    with pytest.raises(error, match=match):
        to_iosystem(system)
