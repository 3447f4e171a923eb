"""Models in the lab's loop of a log: the drive model, the loop, its measures and ``validate --in-loop``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from neckid import IOData, Lags, LinearARX
from neckid.cli import app
from neckid.data.preprocess import LowPass, Pipeline, Relative
from neckid.loops.controllers import AdaptiveFractionalReplay, LabPI, step_reference
from neckid.loops.controllers.tuned import AdaptiveFractionalTuner
from neckid.loops.lab_drive import LAB_DRIVE_GAINS, LabDrive, identify_drive, regimes
from neckid.loops.lab_loop import in_loop_on_log, lab_controller, run_lab_loop
from neckid.loops.loop_measures import oscillation, reference_segments, stair_responses

TS = 0.025
DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
runner = CliRunner()


# ---------------------------------------------------------------------------- the drive
def _drive_log(drive: LabDrive, rng: np.random.Generator, n: int = 1500) -> IOData:
    command = np.cumsum(rng.normal(0.0, 0.05, n)) + 0.3 * np.sin(np.arange(n) * 0.03)
    position, velocity = drive.simulate(command, position0=1.7)
    return IOData(
        u=np.column_stack([position, command, velocity]),
        y=np.zeros(n),
        ts=TS,
        input_names=["motor_position", "velocity_command", "motor_velocity"],
    )


@pytest.mark.parametrize("delay", [0, 1])
def test_the_drive_identification_recovers_known_gains_and_delay(rng, delay) -> None:
    truth = LabDrive((0.9, 1.05, 0.1, 1.2), (0.95, 0.98, 0.6, -0.3), delay=delay)
    fit = identify_drive([_drive_log(truth, rng), _drive_log(truth, rng)])
    assert fit.drive.delay == delay
    np.testing.assert_allclose(fit.drive.gains, truth.gains, atol=1e-9)
    np.testing.assert_allclose(fit.drive.velocity_gains, truth.velocity_gains, atol=1e-9)
    drift = fit.drift([_drive_log(truth, rng)])
    assert abs(drift["end_drift_rad"].iloc[0]) < 1e-9
    assert abs(drift["integrator_end_drift_rad"].iloc[0]) > 1e-3


def test_the_drive_steps_as_it_simulates(rng) -> None:
    drive = LabDrive((0.9, 1.05, 0.0, 1.2), (0.95, 0.98, 0.6, -0.3), delay=1)
    command = rng.normal(0.0, 0.3, 200)
    position, velocity = drive.simulate(command, position0=0.5)
    drive.reset(0.5)
    stepped = []
    for c in command:
        stepped.append((drive.motor_position[0], drive.motor_velocity[0]))
        drive.step([c])
    np.testing.assert_allclose(np.array(stepped), np.column_stack([position, velocity]), atol=1e-12)
    assert regimes([0.05]).tolist() == [[0.0, 0.0, 0.12783, 0.0]]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"gains": (1.0, 1.0)}, "gains must be 4 finite gains"),
        ({"delay": -1}, "delay"),
        ({"ts": 0.0}, "ts"),
    ],
)
def test_the_drive_refuses_bad_settings(kwargs, match) -> None:
    with pytest.raises(ValueError, match=match):
        LabDrive(**kwargs)


def test_identify_drive_refuses_a_log_without_the_motor_channels() -> None:
    log = IOData(u=np.zeros((100, 1)), y=np.zeros(100), ts=TS, input_names=["velocity_command"])
    with pytest.raises(ValueError, match="has no input 'motor_position'"):
        identify_drive([log])


# ---------------------------------------------------------------------------- measures
def test_oscillation_measures_give_a_sinusoids_period_and_amplitude(rng) -> None:
    n = 2800
    t = np.arange(n) * TS
    nominal = np.repeat([15.0, 20.0, 25.0, 30.0, 25.0, 20.0, 15.0], 400)
    y = nominal + 0.7 + 3.0 * np.sin(2 * np.pi * t / 2.6 + 0.4) + rng.normal(0.0, 0.2, n)
    found = oscillation(y, nominal, TS)
    assert found.period == pytest.approx(2.6, rel=0.005)
    assert found.amplitude == pytest.approx(3.0, rel=0.02)
    assert found.share > 0.95
    assert len(reference_segments(nominal, TS)) == 7


def test_stair_responses_of_a_first_order_step_are_analytic() -> None:
    tau, n = 0.5, 400
    t = np.arange(n) * TS
    y = 5.0 * (1.0 - np.exp(-t / tau))
    table = stair_responses(
        np.r_[np.zeros(80), y], np.r_[np.zeros(80), np.full(n, 5.0)], TS, band=0.25
    )
    assert table["overshoot_percent"].iloc[1] == 0.0
    # |y - 5| <= 0.25 from t = tau ln 20 on
    assert table["settling_time_s"].iloc[1] == pytest.approx(tau * np.log(20.0), abs=TS)


# ---------------------------------------------------------------------------- the loop
def _plant_model(rng: np.random.Generator) -> LinearARX:
    """An exact linear neck: inclination from the motor displacement and velocity (no noise)."""
    n = 1500
    displacement = np.cumsum(rng.normal(0.0, 0.02, n))
    velocity = rng.normal(0.0, 0.5, n)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.95 * y[k - 1] + 0.2 * displacement[k - 1] + 0.02 * velocity[k]
    record = IOData(
        u=np.column_stack([displacement, velocity]),
        y=y,
        ts=TS,
        input_names=["motor_displacement", "motor_velocity"],
        output_names=["inclination"],
    )
    return LinearARX(
        Lags(outputs=[1], inputs={"motor_displacement": [1], "motor_velocity": [0]})
    ).fit(record)


def _logged_loop(model, name: str = "int000stepresponse.csv") -> IOData:
    """A step log made by the lab's PI, the identified drive and ``model`` as the neck."""
    n = 401
    seed = IOData(
        u=np.column_stack([np.full(n, 1.3), np.zeros(n), np.zeros(n)]),
        y=np.zeros(n),
        ts=TS,
        input_names=["motor_position", "velocity_command", "motor_velocity"],
        output_names=["inclination"],
        name=name,
    )
    frame, diverged = run_lab_loop(
        model, LabPI(), step_reference().values, seed, drive=LabDrive.identified()
    )
    assert diverged is None
    return IOData(
        u=frame[["motor_position", "velocity_command", "motor_velocity"]].to_numpy(),
        y=frame["inclination"].to_numpy(),
        ts=TS,
        input_names=["motor_position", "velocity_command", "motor_velocity"],
        output_names=["inclination"],
        name=name,
    )


def test_a_perfect_model_reproduces_the_logged_loop(rng) -> None:
    model = _plant_model(rng)
    log = _logged_loop(model)
    result = in_loop_on_log(model, log, drive=LabDrive.identified())
    assert result.controller == "int"
    assert result.inclination_fit == pytest.approx(100.0, abs=1e-6)
    assert result.command_fit == pytest.approx(100.0, abs=1e-6)
    assert result.free_run_fit == pytest.approx(100.0, abs=1e-6)
    assert result.controller_check < 1e-12
    assert result.tracking_ratio == pytest.approx(1.0, abs=1e-9)
    # A drive of other gains makes another loop.
    other = in_loop_on_log(model, log, drive=LabDrive())
    assert other.command_fit < 99.0


def test_a_relative_motor_position_is_fed_as_the_displacement(rng) -> None:
    model = _plant_model(rng)
    log = _logged_loop(model)
    renamed = LinearARX(Lags(outputs=[1], inputs={"motor_position": [1], "motor_velocity": [0]}))
    view = log.select(inputs=["motor_position", "motor_velocity"], outputs=["inclination"])
    renamed.fit(Relative("motor_position").apply(view))
    renamed.preprocessing_ = Pipeline([Relative("motor_position")])
    result = in_loop_on_log(renamed, log, drive=LabDrive.identified())
    assert result.inclination_fit > 99.9


def test_the_loop_refuses_what_it_cannot_replay(rng) -> None:
    model = _plant_model(rng)
    log = _logged_loop(model)
    filtered = LinearARX(Lags(outputs=[1], inputs={"motor_position": [1]}))
    filtered.fit(log.select(inputs=["motor_position"], outputs=["inclination"]))
    filtered.preprocessing_ = Pipeline([LowPass("motor_position", 2.0)])
    with pytest.raises(ValueError, match="more than a constant offset"):
        in_loop_on_log(filtered, log)
    direct = LinearARX(Lags(outputs=[1], inputs={"velocity_command": [0]}))
    direct.fit(log.select(inputs=["velocity_command"], outputs=["inclination"]))
    with pytest.raises(ValueError, match="lag 0"):
        in_loop_on_log(direct, log)
    with pytest.raises(ValueError, match="names none"):
        in_loop_on_log(model, log.renamed("run.csv"))


def test_the_controller_follows_the_logs_name(tmp_path) -> None:
    assert isinstance(lab_controller("int200response.csv")[0], LabPI)
    tuned, label = lab_controller("ada200response.csv")
    assert isinstance(tuned, AdaptiveFractionalTuner) and "tuner" in label
    rows = np.column_stack(
        [np.arange(900) * TS, np.full(900, 0.3), np.full(900, 0.9), np.full(900, -0.6)]
    )
    np.savetxt(tmp_path / "adacon200.csv", rows, delimiter=",")
    replay, label = lab_controller("ada200response.csv", adaptive_parameters=tmp_path)
    assert isinstance(replay, AdaptiveFractionalReplay) and "adacon200.csv" in label
    with pytest.raises(ValueError, match="must be one of"):
        lab_controller("int200response.csv", "pid")


# ---------------------------------------------------------------------------- the command line
def test_validate_in_loop_on_a_synthetic_log(rng, tmp_path) -> None:
    model = _plant_model(rng)
    log = _logged_loop(model)
    columns = [
        log.time,
        log.channel("inclination"),
        log.channel("motor_position"),
        log.channel("inclination"),
        log.channel("velocity_command"),
        log.channel("motor_velocity"),
    ]
    path = tmp_path / "int000stepresponse.csv"
    np.savetxt(path, np.column_stack(columns), delimiter=", ", fmt="%.12g")
    model_path = model.save(tmp_path / "model.npz")
    out = tmp_path / "loop.json"
    result = runner.invoke(
        app, ["validate", str(model_path), str(path), "--in-loop", "--json", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert "in the loop with int" in result.output
    record = json.loads(out.read_text())["logs"][0]
    assert record["inclination_fit_percent"] > 99.9
    assert record["controller_check_rad_s"] < 1e-6
    bad = runner.invoke(
        app, ["validate", str(model_path), str(path), "--in-loop", "--controller", "pid"]
    )
    assert bad.exit_code != 0
    assert "--controller must be int, fra, ada" in bad.output


def test_validate_in_loop_takes_a_designed_controller_file(rng, tmp_path) -> None:
    design = pytest.importorskip("neckid.design", reason="neckid.design is not installed")
    if not hasattr(design, "save_controller"):
        pytest.skip("neckid.design has no controller files yet")
    from neckid.design.operators import tustin_integrator

    model = _plant_model(rng)
    log = _logged_loop(model)
    path = tmp_path / "int000stepresponse.csv"
    columns = [log.time, log.channel("inclination"), log.channel("motor_position")]
    columns += [log.channel(n) for n in ("inclination", "velocity_command", "motor_velocity")]
    np.savetxt(path, np.column_stack(columns), delimiter=", ", fmt="%.12g")
    # The lab's PI as a designed controller: the same loop.
    pi = design.DesignedController(0.2084, 0.8237, tustin_integrator(TS))
    file = design.save_controller(pi, tmp_path / "pi.json")
    model_path = model.save(tmp_path / "model.npz")
    out = tmp_path / "loop.json"
    arguments = ["validate", str(model_path), str(path), "--in-loop", "--controller", str(file)]
    result = runner.invoke(app, [*arguments, "--json", str(out)])
    assert result.exit_code == 0, result.output
    assert json.loads(out.read_text())["logs"][0]["inclination_fit_percent"] > 99.9


# ---------------------------------------------------------------------------- the real logs
@pytest.mark.skipif(
    not (DATA / "softneck").is_dir(),
    reason="the shared soft-neck logs (../shared/data) are not here",
)
def test_on_the_real_logs_the_drive_and_the_loop_hold() -> None:
    from neckid.datasets.softneck import load_softneck_log

    root = DATA / "softneck" / "stair"
    train = [
        load_softneck_log(root / f"{c}{p}response.csv")
        for c in ("ada", "fra", "int")
        for p in ("000", "600")
    ]
    fit = identify_drive(train)
    assert fit.drive.delay == 0
    np.testing.assert_allclose(fit.drive.gains, LAB_DRIVE_GAINS, atol=1e-4)
    test = load_softneck_log(root / "int200response.csv")
    drift = fit.drift([test])
    assert abs(drift["end_drift_rad"].iloc[0]) < abs(drift["integrator_end_drift_rad"].iloc[0])
    view = [
        log.select(inputs=["motor_position", "motor_velocity"], outputs=["inclination"])
        for log in train[4:]
    ]
    model = LinearARX(
        Lags(outputs=[1, 2], inputs={"motor_position": [1, 2], "motor_velocity": [1]})
    )
    model.fit([Relative("motor_position").apply(v) for v in view])
    model.preprocessing_ = Pipeline([Relative("motor_position")])
    result = in_loop_on_log(model, test, drive=fit.drive)
    assert result.controller_check <= 1e-5
    assert result.logged_oscillation.period == pytest.approx(2.58, abs=0.05)
    assert np.isfinite(result.inclination_fit)


@pytest.mark.skipif(
    not (DATA / "softneck").is_dir(),
    reason="the shared soft-neck logs (../shared/data) are not here",
)
def test_the_in_loop_protocol_ranks_free_run_and_in_loop_side_by_side() -> None:
    from neckid.experiments.benchmark.in_loop import run_in_loop_benchmark

    report = run_in_loop_benchmark(DATA, ["arx"], quick=True)
    assert len(report.table) == 6
    assert report.table["controller_check_rad_s"].max() < 2e-4  # ada: the first stair row
    ranks = report.rankings()
    assert list(ranks["method"]) == ["arx"]
    assert {"free_run_rank", "in_loop_rank", "period_within_10"} <= set(ranks.columns)


@pytest.mark.skipif(
    not (DATA / "softneck" / "stair").is_dir(),
    reason="the shared soft-neck logs (../shared/data/softneck) are not on this machine",
)
def test_the_benchmark_runs_the_in_loop_protocol(tmp_path: Path) -> None:
    import pandas as pd
    from typer.testing import CliRunner

    from neckid.cli import app

    out = tmp_path / "in-loop"
    args = ["benchmark", "--data-dir", str(DATA), "--only", "softneck-in-loop", "--methods", "arx"]
    result = CliRunner().invoke(app, [*args, "--out", str(out)])
    assert result.exit_code == 0, result.output
    rankings = pd.read_csv(out / "in_loop_rankings.csv")
    assert list(rankings["method"]) == ["arx"] and rankings["inclination_fit"].iloc[0] > 50
    assert len(pd.read_csv(out / "in_loop.csv")) == 6  # the six test stairs
