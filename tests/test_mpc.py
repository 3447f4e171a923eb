"""Predictive control (neckid.design.mpc, issue 44): prediction, limits, offset-free, files, CLI."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("osqp", reason="the mpc extra (pip install 'neckid[mpc]') is not installed")

import control
from typer.testing import CliRunner

from neckid import IOData, Lags, LinearARX
from neckid.cli import app
from neckid.design import linear_form, load_controller, save_controller
from neckid.design.mpc import (
    MPCController,
    disturbance_gain,
    mpc_problem,
)
from neckid.plant import closed_loop

runner = CliRunner()
TS = 0.02
#: The tests' deadline [s]: no solve is dropped for being late on a loaded machine (results
#: would depend on the load); the late fallback has its own test.
PATIENT = 60.0


class DifferenceEquation:
    """A plant ``y_t = sum a_i y_{t-i} + sum b_l u_{t-l} + bias`` (no feedthrough, b_0 = 0)."""

    def __init__(self, a, b, bias=0.0, gain=1.0):
        self.a, self.b, self.bias, self.gain = np.asarray(a), np.asarray(b), bias, gain

    def reset(self):
        self.y = [0.0] * self.a.size
        self.u = [0.0] * self.b.size

    def step(self, u):
        self.u = [float(u[0]), *self.u[:-1]]
        value = float(np.dot(self.a, self.y) + self.gain * np.dot(self.b, self.u) + self.bias)
        self.y = [value, *self.y[:-1]]
        return [value]


def _form(a, b, delay=1):
    den = np.concatenate([[1.0], -np.asarray(a)])
    num = np.trim_zeros(np.asarray(b, dtype=float), "f")
    system = control.tf(num, den, dt=TS)
    return linear_form(system, computation_delay=delay)


def _direct(a, b, delay, y_past, u_past, moves, delta, n):
    """The difference equation stepped by hand: y_{k-d+1} ... y_{k+N}."""
    y = {-delay - i: y_past[i] for i in range(len(a))}
    u = {-1 - i: u_past[i] for i in range(len(u_past))}
    for i in range(n):
        u[i] = moves[min(i, len(moves) - 1)]
    out = []
    for t in range(-delay + 1, n + 1):
        value = sum(a[i] * y[t - 1 - i] for i in range(len(a)))
        value += sum(b[j] * u.get(t - j, 0.0) for j in range(len(b)))
        y[t] = value + delta
        out.append(value + delta)
    return np.array(out)


@pytest.mark.parametrize("delay", [0, 1, 2])
def test_the_prediction_matrices_are_the_difference_equation(delay: int) -> None:
    rng = np.random.default_rng(delay)
    a = np.array([1.2, -0.35])
    b = np.array([0.0, 0.3, 0.1])
    problem = mpc_problem(_form(a, b, delay), horizon=7, control_horizon=4)
    assert problem.free.shape == (7 + delay, 2 + problem.n_past_commands)
    y_past, u_past = rng.normal(size=2), rng.normal(size=problem.n_past_commands)
    moves, delta = rng.normal(size=4), float(rng.normal())
    expected = _direct(a, b, delay, y_past, u_past, moves, delta, 7)
    got = problem.predict(np.concatenate([y_past, u_past]), moves, delta)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)


def test_the_disturbance_gain_solves_the_riccati_equation() -> None:
    for ratio in (1e-4, 0.01, 1.0, 100.0):
        gain = disturbance_gain(ratio)
        p = gain / (1 - gain)  # L = P / (P + 1)
        assert math.isclose(p * p, ratio * (p + 1), rel_tol=1e-12)  # P^2 = q (P + r), r = 1


def test_offset_free_on_a_plant_the_model_gets_wrong() -> None:
    a, b = [1.6, -0.6], [0.0, 0.05, 0.02]  # an integrator (a pole at 1) and a lag
    controller = MPCController(mpc_problem(_form(a, b), horizon=20), deadline=PATIENT)
    plant = DifferenceEquation(a, b, bias=0.02, gain=1.3)  # 30 % more gain, a drift
    log = closed_loop(plant, controller, np.full(600, 10.0), TS)
    assert abs(log.y[-1, 0] - 10.0) < 1e-3
    assert controller.stats.failed == controller.stats.late == 0


def test_the_command_and_its_rate_stay_inside_their_limits() -> None:
    a, b = [1.0], [0.0, 0.1]
    problem = mpc_problem(_form(a, b), horizon=15, command_limit=2.0, rate_limit=25.0)
    controller = MPCController(problem, deadline=PATIENT)
    log = closed_loop(DifferenceEquation(a, b), controller, np.full(300, 20.0), TS)
    u = log.channel("velocity_command")
    assert np.max(np.abs(u)) <= 2.0 + 1e-12
    assert np.max(np.abs(np.diff(np.concatenate([[0.0], u])))) <= 25.0 * TS + 1e-12
    assert np.max(np.abs(u)) > 1.99  # the limit is reached: the test can fail


def test_preview_moves_before_the_step_and_tracks_better() -> None:
    a, b = [1.0], [0.0, 0.1]
    reference = np.where(np.arange(300) >= 100, 10.0, 0.0)
    errors = {}
    for preview in (True, False):
        controller = MPCController(
            mpc_problem(_form(a, b), horizon=20, preview=preview), deadline=PATIENT
        )
        controller.set_reference(reference)
        log = closed_loop(DifferenceEquation(a, b), controller, reference, TS)
        errors[preview] = float(np.sqrt(np.mean((reference - log.y[:, 0]) ** 2)))
        moved_early = abs(log.y[99, 0]) > 0.1
        assert moved_early == preview
    assert errors[True] < 0.8 * errors[False]


def test_an_output_limit_holds_on_the_model_itself() -> None:
    a, b = [1.0], [0.0, 0.1]
    problem = mpc_problem(_form(a, b), horizon=20, output_max=8.0)
    controller = MPCController(problem)
    log = closed_loop(DifferenceEquation(a, b), controller, np.full(300, 10.0), TS)
    assert np.max(log.y[:, 0]) <= 8.0 + 1e-3  # the reference is beyond it: held at the limit
    assert log.y[-1, 0] > 7.9
    nominal = closed_loop(
        DifferenceEquation(a, b),
        MPCController(mpc_problem(_form(a, b), horizon=20), deadline=PATIENT),
        np.full(300, 10.0),
        TS,
    )
    assert np.max(nominal.y[:, 0]) > 9.9  # without the limit it goes there


def test_a_late_solve_holds_the_previous_command_and_is_counted() -> None:
    a, b = [1.0], [0.0, 0.1]
    controller = MPCController(mpc_problem(_form(a, b), horizon=10), deadline=1e-12)
    log = closed_loop(DifferenceEquation(a, b), controller, np.full(50, 5.0), TS)
    stats = controller.stats
    assert stats.steps == 50 and stats.late + stats.failed == 50
    assert np.all(log.channel("velocity_command") == 0.0)
    assert stats.median_ms >= 0 and stats.max_ms >= stats.median_ms


def test_a_failed_read_holds_the_command_and_a_copy_steps_the_same() -> None:
    a, b = [1.0], [0.0, 0.1]
    controller = MPCController(mpc_problem(_form(a, b), horizon=10), deadline=PATIENT)
    first = controller.step(5.0, 0.0)
    assert controller.step(5.0, math.nan)[0] == first[0]
    twin = copy.deepcopy(controller)
    for y in (0.1, 0.3, 0.6):  # the copy's solver starts afresh: equal to OSQP's tolerance
        assert controller.step(5.0, y)[0] == pytest.approx(twin.step(5.0, y)[0], abs=1e-3)


def _model(tmp_path: Path) -> Path:
    u = np.cumsum(np.random.default_rng(4).normal(0, 0.05, 400)) + 2.0
    y = np.zeros(400)
    for t in range(1, 400):
        y[t] = 0.6 * y[t - 1] + 2.8 * u[t - 1]
    data = IOData(u, y, ts=TS, input_names=["motor_position"], output_names=["inclination"])
    return LinearARX(Lags.arx(1, 1)).fit(data).save(tmp_path / "arx.npz")


def test_the_controller_file_round_trips_and_refuses_edits(tmp_path: Path) -> None:
    a, b = [1.6, -0.6], [0.0, 0.05, 0.02]
    controller = MPCController(
        mpc_problem(_form(a, b), horizon=12, output_max=9.0), deadline=PATIENT
    )
    path = save_controller(controller, tmp_path / "mpc.json")
    loaded = load_controller(path)
    assert isinstance(loaded, MPCController) and loaded.problem.output_max == 9.0
    reference = np.full(100, 10.0)
    one = closed_loop(DifferenceEquation(a, b), controller, reference, TS)
    two = closed_loop(DifferenceEquation(a, b), loaded, reference, TS)
    np.testing.assert_allclose(one.u, two.u, atol=1e-12)  # same matrices, same solver path
    document = json.loads(path.read_text())
    for key, value, message in (
        ("a", [1.5, -0.6], "problem.free is not the prediction matrix"),
        ("move_weight", -1.0, "problem.move_weight must be >= 0"),
        ("disturbance_gain", 0.5, "is not the Kalman gain"),
        ("horizon", "12", "problem.horizon must be a whole number"),
    ):
        edited = copy.deepcopy(document)
        edited["problem"][key] = value
        bad = tmp_path / f"bad_{key}.json"
        bad.write_text(json.dumps(edited))
        with pytest.raises(ValueError, match=message):
            load_controller(bad)


def test_design_mpc_writes_a_file_that_info_describes(tmp_path: Path) -> None:
    model = _model(tmp_path)
    out = tmp_path / "mpc.json"
    args = ["design", str(model), "--mpc", "--horizon", "15", "--output-max", "30"]
    result = runner.invoke(app, [*args, "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "mpc controller, ts = 0.02 s, horizon 15 samples" in result.output
    again = runner.invoke(app, [*args, "--out", str(out)])
    assert again.exit_code != 0 and "--force" in again.output
    info = runner.invoke(app, ["info", str(out), "--json"])
    assert info.exit_code == 0, info.output
    described = json.loads(info.output)
    assert described["kind"] == "mpc" and described["prediction_matrices"]["forced"] == [16, 15]
    pi_file = tmp_path / "pi.json"
    assert runner.invoke(app, ["design", str(model), "--out", str(pi_file)]).exit_code == 0
    pi_info = runner.invoke(app, ["info", str(pi_file)])
    assert pi_info.exit_code == 0 and "pi controller, ts = 0.02 s" in pi_info.output
    refused = runner.invoke(app, [*args, "--fractional", "--out", str(tmp_path / "x.json")])
    assert refused.exit_code == 2
    assert "--fractional designs a PI or fractional controller" in refused.output


def test_tighten_needs_a_limit_and_logs(tmp_path: Path) -> None:
    model = _model(tmp_path)
    out = str(tmp_path / "mpc.json")
    result = runner.invoke(
        app, ["design", str(model), "--mpc", "--tighten", str(model), "--out", out]
    )
    assert result.exit_code == 2 and "give --output-max or --output-min" in result.output


class _Neckish:
    """A neck-like plant the linear model gets wrong: a motor that integrates, a sine in the gain."""

    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.reset()

    def reset(self) -> None:
        self.p, self.y = 0.0, 0.0
        self.motor_position, self.motor_velocity = np.zeros(1), np.zeros(1)

    def step(self, u):
        noise = self.rng.uniform(-0.02, 0.02)  # bounded: the SM prior can hold
        self.y = 0.8 * self.y + 0.2 * (8.0 * self.p + 1.5 * np.sin(2.0 * self.p)) + noise
        self.p += TS * float(u[0])
        self.motor_position, self.motor_velocity = np.array([self.p]), np.array([float(u[0])])
        return [self.y]


class _Proportional:
    ts = TS

    def reset(self) -> None:
        pass

    def step(self, reference, measurement):
        return np.array([np.clip(0.8 * (reference - measurement), -4.0, 4.0)])


def test_sm_tightening_bounds_the_prediction_error_and_keeps_a_limit() -> None:
    from neckid.design.mpc import band_tightening, controller_predictions
    from neckid.models.set_membership.multistep import MultiStepSetMembership

    rng = np.random.default_rng(0)
    logs = [
        closed_loop(_Neckish(s), _Proportional(), np.repeat(rng.uniform(0, 20, 30), 60), TS)
        for s in (1, 2)
    ]
    views = [log.select(inputs=["motor_position"], outputs=["inclination"]) for log in logs]
    form = linear_form(LinearARX(Lags(outputs=[1], inputs=[1])).fit(views))
    nominal = mpc_problem(form, horizon=8)
    sm = MultiStepSetMembership(
        Lags(outputs=[1], inputs=[1]),
        horizon=9,
        epsilon_factor=2.0,
        input_weight=1.0,
        lipschitz="global",
    ).fit(views)
    tight = band_tightening(nominal, sm, logs)
    assert np.all(tight.tightening >= tight.half_width) and tight.coverage.min() == 1.0
    # where the measurement is in the band, the controller's prediction is within w_j of it
    predictions = controller_predictions(nominal, logs[0])
    y = logs[0].channel("inclination")
    for j in (0, 7):
        steps = j + 1 + nominal.delay
        error = np.abs(y[steps:] - predictions[:-steps, nominal.delay + j])
        assert np.nanmax(error) <= tight.tightening[j] + 1e-9
        assert np.nanmax(error) > 0.2 * tight.tightening[j]  # not loose by orders
    reference = np.repeat([5.0, 10.0, 15.0, 10.0, 15.0], 100)
    peaks = {}
    for name, tightening in (("nominal", None), ("tightened", tight.tightening)):
        problem = mpc_problem(form, horizon=8, output_max=15.1, tightening=tightening)
        controller = MPCController(problem, deadline=PATIENT)
        controller.set_reference(reference)
        peaks[name] = np.sum(closed_loop(_Neckish(3), controller, reference, TS).y[:, 0] > 15.1)
    assert peaks["nominal"] > 0 and peaks["tightened"] == 0


SOFTNECK = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "softneck"


@pytest.mark.skipif(
    not (SOFTNECK / "stair").is_dir(),
    reason="the shared soft-neck logs (../shared/data) are absent",
)
def test_the_file_runs_in_the_labs_loop_and_tracks_better_than_the_labs_pi(tmp_path: Path) -> None:
    from neckid.data.preprocess import Pipeline, Relative
    from neckid.datasets import load_softneck_log
    from neckid.loops.lab_loop import in_loop_on_log

    stair = SOFTNECK / "stair"
    pipeline = Pipeline([Relative("motor_position")])
    train = [
        load_softneck_log(stair / f"int{p}response.csv").select(
            inputs=["motor_position", "motor_velocity"], outputs=["inclination"]
        )
        for p in ("000", "600")
    ]
    model = LinearARX(Lags(outputs=[1, 2], inputs=[0, 1])).fit(pipeline.apply(train))
    model.preprocessing_ = pipeline
    path = model.save(tmp_path / "arx.npz")
    out = tmp_path / "mpc.json"
    designed = runner.invoke(
        app, ["design", str(path), "--mpc", "--delay", "0", "--on-late", "use", "--out", str(out)]
    )
    assert designed.exit_code == 0, designed.output
    log = stair / "int200response.csv"
    result = runner.invoke(
        app,
        [
            "validate",
            str(path),
            str(log),
            "--layout",
            "softneck",
            "--in-loop",
            "--controller",
            str(out),
            "--force",
            "--json",
            str(tmp_path / "loop.json"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "in the loop with MPCController" in result.output
    mpc_rms = in_loop_on_log(model, log, controller=load_controller(out), check_tolerance=None)
    pi_rms = in_loop_on_log(model, log)  # the lab's PI (the log's own), the same model
    assert mpc_rms.tracking_rms < 0.7 * pi_rms.tracking_rms


def _neckish_logs() -> list[IOData]:
    rng = np.random.default_rng(0)
    return [
        closed_loop(_Neckish(s), _Proportional(), np.repeat(rng.uniform(0, 20, 30), 60), TS)
        for s in (1, 2)
    ]


def test_design_tighten_from_the_command_line(tmp_path: Path) -> None:
    from neckid.models.set_membership.multistep import MultiStepSetMembership

    logs = _neckish_logs()
    views = [log.select(inputs=["motor_position"], outputs=["inclination"]) for log in logs]
    arx = LinearARX(Lags(outputs=[1], inputs=[1])).fit(views).save(tmp_path / "arx.npz")
    sm = (
        MultiStepSetMembership(
            Lags(outputs=[1], inputs=[1]),
            horizon=9,
            epsilon_factor=2.0,
            input_weight=1.0,
            lipschitz="global",
        )
        .fit(views)
        .save(tmp_path / "sm.npz")
    )
    paths = []
    for i, log in enumerate(logs):
        log.to_csv(tmp_path / f"run{i}.csv")
        paths += ["--tighten-log", str(tmp_path / f"run{i}.csv")]
    out = tmp_path / "robust.json"
    args = ["design", str(arx), "--mpc", "--horizon", "8", "--output-max", "15.1"]
    result = runner.invoke(app, [*args, "--tighten", str(sm), *paths, "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "(Set Membership k-step bands)" in result.output
    robust = load_controller(out)
    assert robust.problem.tightening[0] > 0.5 and robust.problem.info["robust"]["anchors"] > 1000
    short = runner.invoke(
        app,
        [
            *args[:3],
            "--output-max",
            "15.1",
            "--tighten",
            str(sm),
            *paths,
            "--out",
            str(tmp_path / "x.json"),
        ],
    )  # horizon 25: bands to 9
    assert short.exit_code == 2 and "fit it with horizon=26" in short.output


def test_on_the_simulated_neck_preview_tracks_under_0_7_of_the_demo_pi() -> None:
    from neckid.design import paper_test_references, tracking_rms
    from neckid.plant import InclinationController, SoftNeck

    levels = np.repeat(np.random.default_rng(2).uniform(5, 30, 20), 100)
    run = closed_loop(SoftNeck(seed=3), InclinationController(ts=TS), levels, TS)
    view = run.select(inputs=["motor_position"], outputs=["inclination"])
    form = linear_form(
        LinearARX(Lags(outputs=[1], inputs=[1, 2])).fit(view), drive_time_constant=0.015
    )
    for test in ("test 2: 5° staircase", "test 3: 20° step"):
        reference = paper_test_references()[test]
        pi = closed_loop(SoftNeck(seed=7), InclinationController(ts=TS), reference, TS)
        mpc = MPCController(mpc_problem(form), deadline=PATIENT)
        mpc.set_reference(reference)
        log = closed_loop(SoftNeck(seed=7), mpc, reference, TS)
        assert tracking_rms(log, reference) <= 0.7 * tracking_rms(pi, reference)
        assert np.max(np.abs(log.channel("velocity_command"))) <= 4.0
