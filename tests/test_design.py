"""neckid.design: loop-shaping designs, the controller objects and file, the CLI.

Reference values from outside: python-control's ``stability_margins`` on the controller's own
state space (a second path to the margins); the lab's tuner re-implementation
(``neckid.loops.controllers.tuner``) on the same plant; the lab's controllers
(``LabPI``, ``LabFractionalController``) step by step.
"""

from __future__ import annotations

import json
import math

import control
import numpy as np
import pytest
from typer.testing import CliRunner

from neckid import GainScheduledModel, IOData, Lags, LinearARX, SetMembership
from neckid.cli import app
from neckid.design import (
    DesignedController,
    LinearForm,
    NoLinearFormError,
    design_fractional,
    design_pi,
    design_scheduled,
    gl_taps,
    grunwald_letnikov_operator,
    ideal_iso_damping,
    linear_form,
    load_controller,
    oustaloup_operator,
    save_controller,
    set_membership_check,
    simulated_neck_tests,
    tustin_integrator,
)
from neckid.design.loop_shaping import loop_margins, phase_slope
from neckid.export.control import to_iosystem
from neckid.loops.controllers import LabFractionalController, LabPI, grunwald_letnikov_weights
from neckid.loops.controllers.tuner import iso_damping_tuning
from neckid.plant import SoftNeck, closed_loop

TS = 0.02


def integrator_plant(gain: float = 7.0, tau: float = 0.15, delay: int = 1) -> LinearForm:
    """K / (s (tau s + 1)) by zero-order hold at TS, and the loop's delay: a known plant."""
    g = control.c2d(control.tf([gain], [tau, 1.0, 0.0]), TS, "zoh")
    return LinearForm(np.asarray(g.num[0][0]), np.asarray(g.den[0][0]), TS, delay, "test plant")


def python_control_margins(controller: DesignedController, form: LinearForm) -> tuple[float, float]:
    """Phase margin [deg] and crossover [rad/s] by python-control on the state spaces.

    The loop's frequency response on a grid from 0.01 rad/s to Nyquist (python-control's own
    default grid reaches down to where it evaluates the integrator's pole inaccurately).
    """
    delay = control.tf([1.0], [1.0] + [0.0] * form.computation_delay, dt=form.ts)
    loop = controller.to_control() * control.ss(form.plant()) * delay
    grid = np.geomspace(0.01, 0.999 * math.pi / form.ts, 2500)
    _, pm, _, _, wc, _ = control.stability_margins(control.frd(loop, grid))
    return float(pm), float(wc)


# ------------------------------------------------------------------------ designs on a known plant
@pytest.mark.parametrize(
    ("kind", "discretisation"), [("pi", None), ("fractional", "gl"), ("fractional", "oustaloup")]
)
def test_designs_meet_the_phase_margin_at_the_crossover(kind, discretisation) -> None:
    form = integrator_plant(tau=0.05, delay=0)
    design = (
        design_pi(form, 50.0, 3.0)
        if kind == "pi"
        else design_fractional(form, 50.0, 3.0, discretisation=discretisation)
    )
    pm, wc = python_control_margins(design.controller(), form)
    assert abs(pm - 50.0) < 1.0
    assert abs(wc - 3.0) / 3.0 < 0.02
    assert design.margins.stable
    assert design.kp > 0 and design.kf > 0


def test_oustaloup_design_flattens_the_realised_phase() -> None:
    form = integrator_plant(tau=0.05, delay=0)
    design = design_fractional(form, 50.0, 3.0, discretisation="oustaloup")
    assert design.flat and -1.0 < design.order < 0.0
    assert abs(design.margins.phase_slope) < 0.01
    # Iso-damping: a 20 % gain change moves the phase margin by little (less than the PI's).
    pi = design_pi(form, 50.0, 3.0)

    def spread(d):
        margins = []
        for scale in (0.8, 1.25):
            scaled = LinearForm(form.num * scale, form.den, TS, 0)
            margins.append(loop_margins(scaled, d.response).phase_margin)
        return max(margins) - min(margins)

    assert spread(design) < spread(pi)


def test_phase_slope_matches_the_closed_form_of_the_fractional_controller() -> None:
    # d arg(1 + x (jw/w0)^a)/dw at w0 = a x sin(a pi/2) / (w0 (1 + 2 x cos(a pi/2) + x^2))
    alpha, x, w0 = -0.6, 0.8, 3.0
    numeric = phase_slope(lambda w: 1.0 + x * (1j * np.asarray(w) / w0) ** alpha, w0)
    beta = alpha * math.pi / 2
    exact = alpha * x * math.sin(beta) / (w0 * (1 + 2 * x * math.cos(beta) + x * x))
    assert numeric == pytest.approx(math.degrees(exact), rel=1e-6)


def test_ideal_design_agrees_with_the_labs_tuner_on_its_model() -> None:
    # The lab's G(z) = b0 / (z^2 + a1 z + a0) (a typical identified estimate): the same problem.
    theta = np.array([-1.27, 0.27, 0.113])
    lab = iso_damping_tuning(theta)
    form = LinearForm(np.array([theta[2]]), np.array([1.0, theta[0], theta[1]]), 0.025, 0)
    kp, kf, alpha, flat = ideal_iso_damping(form)
    assert flat
    assert alpha == pytest.approx(lab.alpha, abs=0.003)
    # The lab divides by |G| at 3.1 rad/s instead of 3: its gains are a few % higher.
    assert kp == pytest.approx(lab.kp, rel=0.05)
    assert kf == pytest.approx(lab.kd, rel=0.05)


def test_a_pi_that_cannot_give_the_phase_is_refused() -> None:
    form = integrator_plant(tau=0.5, delay=3)  # far more lag than 130 deg at 3 rad/s
    with pytest.raises(ValueError, match="no PI gives a phase margin of 50 deg"):
        design_pi(form, 50.0, 3.0)


# ------------------------------------------------------------------------ operators
@pytest.mark.parametrize("order", [0.45, 0.2, 0.7, 1.4])
def test_gl_taps_are_the_labs(order) -> None:
    np.testing.assert_array_equal(gl_taps(order), grunwald_letnikov_weights(order))


def test_gl_controller_is_the_labs_fractional_controller() -> None:
    fex, kp, kd_lab, ts = -0.55, 0.2084, 0.8237, 0.025
    kf = kd_lab * ts ** (1.0 + fex)  # the lab's step-1 sum realises kd T^a s^fex
    mine = DesignedController(kp, kf, grunwald_letnikov_operator(fex, ts))
    lab = LabFractionalController(kp, kd_lab, fex, ts)
    rng = np.random.default_rng(0)
    for r, y in zip(rng.normal(10, 3, 200), rng.normal(10, 3, 200), strict=True):
        assert mine.step(r, y)[0] == pytest.approx(lab.step(r, y)[0], abs=1e-12)


def test_pi_controller_is_the_labs_pi() -> None:
    mine = DesignedController(0.2084, 0.8237, tustin_integrator(0.025))
    lab = LabPI(0.2084, 0.8237, 0.025)
    for r, y in np.random.default_rng(1).normal(10, 3, (100, 2)):
        assert mine.step(r, y)[0] == pytest.approx(lab.step(r, y)[0], abs=1e-12)


def test_oustaloup_filter_has_the_fractional_phase_inside_its_band() -> None:
    op = oustaloup_operator(-0.5, TS, band=(0.03, 78.0), sections=5, prewarp=3.0)
    w = np.array([0.3, 1.0, 3.0, 10.0])
    np.testing.assert_allclose(np.degrees(np.angle(op.response(w))), -45.0, atol=4.0)
    np.testing.assert_allclose(np.abs(op.response(w)), w**-0.5, rtol=0.05)


# ------------------------------------------------------------------------ controller objects
def designed_controllers() -> dict[str, DesignedController]:
    form = integrator_plant()
    scheduled_model = GainScheduledModel.from_points(
        [10.0, 20.0, 30.0], [3.0, 2.5, 2.0], [0.55, 0.58, 0.6], ts=TS, delay=3
    )
    return {
        "pi": design_pi(form).controller(command_limit=4.0),
        "gl": design_fractional(form, discretisation="gl").controller(),
        "oustaloup": design_fractional(form, discretisation="oustaloup").controller(),
        "scheduled": design_scheduled(scheduled_model).controller(command_limit=4.0),
    }


def test_controller_file_round_trips_step_by_step(tmp_path) -> None:
    rng = np.random.default_rng(2)
    references, measurements = rng.normal(15, 5, 300), rng.normal(15, 5, 300)
    measurements[50] = np.nan  # a failed read: the command is held
    for name, controller in designed_controllers().items():
        path = save_controller(controller, tmp_path / f"{name}.json")
        loaded = load_controller(path)
        assert loaded.kind == controller.kind
        controller.reset()
        for r, y in zip(references, measurements, strict=True):
            assert loaded.step(r, y)[0] == controller.step(r, y)[0]
    document = json.loads((tmp_path / "gl.json").read_text())
    assert document["discretisation"]["method"] == "gl"
    assert {"kp", "kf", "kd_lab"} <= set(document["gains"])
    assert document["achieved"]["phase_margin_deg"] == pytest.approx(50.0)


def test_controller_file_errors_name_the_problem(tmp_path) -> None:
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"format": "something else"}))
    with pytest.raises(ValueError, match="not a neckid controller file"):
        load_controller(path)
    good = save_controller(designed_controllers()["gl"], tmp_path / "gl.json")
    document = json.loads(good.read_text())
    document["order"] = -0.3
    path.write_text(json.dumps(document))
    with pytest.raises(ValueError, match="taps are not those of order"):
        load_controller(path)


def test_to_control_is_the_controller_without_saturation() -> None:
    controller = designed_controllers()["gl"]
    errors = np.random.default_rng(3).normal(0, 2, 150)
    system = controller.to_control()
    response = control.forced_response(system, np.arange(150) * TS, errors)
    stepped = [controller.step(e, 0.0)[0] for e in errors]
    np.testing.assert_allclose(np.ravel(response.outputs), stepped, atol=1e-10)


def test_to_iosystem_runs_the_controller_as_closed_loop_does() -> None:
    controller = designed_controllers()["scheduled"]
    system = to_iosystem(controller)
    t = np.arange(100) * TS
    reference = np.full(100, 20.0)
    inclination = np.linspace(0.0, 18.0, 100)
    response = control.input_output_response(system, t, np.vstack([reference, inclination]))
    controller.reset()
    previous = np.r_[0.0, inclination[:-1]]  # command k reads the inclination of k - 1
    stepped = [controller.step(r, y)[0] for r, y in zip(reference, previous, strict=True)]
    np.testing.assert_allclose(np.ravel(response.outputs), stepped, atol=1e-12)


def test_saturation_holds_the_limit() -> None:
    controller = designed_controllers()["pi"]
    commands = [controller.step(30.0, 0.0)[0] for _ in range(50)]
    assert max(abs(c) for c in commands) == pytest.approx(4.0)


def test_closed_loop_on_the_simulated_neck_tracks() -> None:
    controller = designed_controllers()["oustaloup"]
    log = closed_loop(SoftNeck(seed=3), controller, np.full(300, 15.0), TS)
    assert abs(log.y[-50:, 0].mean() - 15.0) < 0.5
    tests = simulated_neck_tests({"designed": controller}, duration=3.0)
    assert tests.table.shape == (1, 3) and np.all(np.isfinite(tests.table.to_numpy()))


# ------------------------------------------------------------------------ models and linear forms
def arx_of_position(n: int = 400) -> LinearARX:
    u = np.cumsum(np.random.default_rng(4).normal(0, 0.05, n)) + 2.0
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.6 * y[t - 1] + 2.8 * u[t - 1]
    data = IOData(u, y, ts=TS, input_names=["motor_position"], output_names=["inclination"])
    return LinearARX(Lags.arx(1, 1)).fit(data)


def test_linear_form_of_a_position_model_adds_the_drive() -> None:
    form = linear_form(arx_of_position(), computation_delay=0)
    z = np.exp(1j * 3.0 * TS)
    expected = 2.8 / (z - 0.6) * TS / (z - 1.0)
    assert complex(form.response(3.0)) == pytest.approx(expected, rel=1e-6)


@pytest.fixture(scope="module")
def set_membership() -> SetMembership:
    """SM on a known first-order plant of the motor position (a nonlinear-model stand-in)."""
    n = 300
    u = 2.0 + 0.5 * np.sin(np.arange(n) * 0.05)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.6 * y[t - 1] + 2.8 * u[t - 1]
    data = IOData(u, y, ts=TS, input_names=["motor_position"], output_names=["inclination"])
    return SetMembership(Lags.arx(1, 1), progress=False).fit(data)


def test_models_without_a_linear_form_are_refused(set_membership) -> None:
    with pytest.raises(NoLinearFormError, match="nonlinear and has no linear form"):
        linear_form(set_membership)
    with pytest.raises(NoLinearFormError, match="takes a fitted neckid model"):
        linear_form(object())
    with pytest.raises(ValueError, match="leave it out"):
        linear_form(arx_of_position(), inclination=10.0)


def test_a_nonlinear_model_linearised_at_a_point_is_its_local_arx(set_membership) -> None:
    # The SM model of y(t) = 0.6 y(t-1) + 2.8 u(t-1): its secant slopes near the data.
    form = linear_form(set_membership, inclination=14.0, computation_delay=0)
    z = np.exp(1j * 3.0 * TS)
    expected = 2.8 / (z - 0.6) * TS / (z - 1.0)
    assert abs(complex(form.response(3.0)) / expected - 1.0) < 0.05


def test_set_membership_check_runs_the_bounding_functions(set_membership) -> None:
    controller = design_pi(linear_form(arx_of_position())).controller(command_limit=4.0)
    table = set_membership_check(controller, set_membership, np.full(150, 14.0))
    assert list(table.index) == ["central", "lower", "upper", "adversary"]
    assert table["finite"].all() and (table["inside_data"] > 0.9).all()


# ------------------------------------------------------------------------ the command line
def test_cli_writes_the_file_and_refuses_an_existing_one(tmp_path, set_membership) -> None:
    model_path = arx_of_position().save(tmp_path / "arx")
    out = tmp_path / "controller.json"
    runner = CliRunner()
    args = ["design", str(model_path), "--pm", "50", "--wc", "3", "--fractional", "--out", str(out)]
    done = runner.invoke(app, args)
    assert done.exit_code == 0, done.output
    assert load_controller(out).kind == "fractional"
    again = runner.invoke(app, args)
    assert again.exit_code == 2 and "exists" in again.output
    assert runner.invoke(app, [*args, "--force"]).exit_code == 0
    sm_path = set_membership.save(tmp_path / "sm")
    refused = runner.invoke(app, ["design", str(sm_path), "--out", str(tmp_path / "sm.json")])
    assert refused.exit_code == 2
    assert "no linear form" in refused.output and "--inclination" in refused.output
    assert not (tmp_path / "sm.json").exists()
