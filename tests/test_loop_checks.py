"""``--in-loop`` refuses what it should check: the controller, its period, its file, the options.

Synthetic logs are made here by the lab's PI, the identified drive and an exact linear model as
the neck (``tests/test_lab_loop.py``'s helpers); the real-log cases skip without
``../shared/data``.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from typer.testing import CliRunner

from neckid.cli import app
from neckid.loops.lab_loop import in_loop_on_log, lab_controller
from neckid.loops.loop_checks import CONTROLLER_CHECK_TOLERANCE, ControllerMismatchError
from test_lab_loop import TS, _logged_loop, _plant_model

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
runner = CliRunner()


def _softneck_file(log, path: Path) -> Path:
    """The log as the bench writes it: six columns, no header."""
    columns = [log.time, log.channel("inclination"), log.channel("motor_position")]
    columns += [log.channel(n) for n in ("inclination", "velocity_command", "motor_velocity")]
    np.savetxt(path, np.column_stack(columns), delimiter=", ", fmt="%.12g")
    return path


@pytest.fixture
def pi_run(rng, tmp_path):
    """``(model file, log file, model, log)``: a step log the lab's PI made."""
    model = _plant_model(rng)
    log = _logged_loop(model)
    path = _softneck_file(log, tmp_path / "int000stepresponse.csv")
    return model.save(tmp_path / "model.npz"), path, model, log


def _in_loop(model_path: Path, log: Path, *extra: str):
    result = runner.invoke(app, ["validate", str(model_path), str(log), "--in-loop", *extra])
    assert "Traceback" not in result.output
    return result.exit_code, re.sub(r"\s+", " ", result.output)


def _adaptive_file(folder: Path, payload: str) -> Path:
    rows = np.column_stack(
        [np.arange(900) * TS, np.full(900, 0.3), np.full(900, 0.9), np.full(900, -0.6)]
    )
    path = folder / f"adacon{payload}.csv"
    np.savetxt(path, rows, delimiter=",")
    return path


# ---------------------------------------------------------------------------- the controller check
def test_a_controller_that_does_not_reproduce_the_log_is_refused(pi_run) -> None:
    model_path, path, model, log = pi_run
    with pytest.raises(ControllerMismatchError, match="controller fra does not reproduce") as found:
        in_loop_on_log(model, log, "fra")
    assert found.value.check > 100 * CONTROLLER_CHECK_TOLERANCE
    forced = in_loop_on_log(model, log, "fra", check_tolerance=None)
    assert forced.controller_check == pytest.approx(found.value.check)
    code, output = _in_loop(model_path, path, "--controller", "fra")
    assert code == 2, output
    assert output.count("error:") == 1
    assert "int000stepresponse.csv" in output and "controller fra" in output
    assert "controller check" in output and "1e-04 rad/s" in output and "--force" in output
    code, output = _in_loop(model_path, path, "--controller", "fra", "--force")
    assert code == 0, output
    assert "warning (--force)" in output and "two different loops" in output


def test_the_right_controller_passes_its_check(pi_run) -> None:
    _, _, model, log = pi_run
    result = in_loop_on_log(model, log)
    assert result.controller_check < 1e-12
    assert math.isnan(result.controller_check_first_stair_row)


def test_adaptive_parameter_logs_are_refused_for_a_log_another_controller_made(tmp_path) -> None:
    _adaptive_file(tmp_path, "000")
    with pytest.raises(ValueError, match=r"made by the fixed fractional controller \(fra\)"):
        lab_controller("fra000response.csv", "ada", tmp_path)
    with pytest.raises(ValueError, match=r"made by the PI \(int\)"):
        lab_controller("int000stepresponse.csv", "ada", tmp_path / "adacon000.csv")
    other = _adaptive_file(tmp_path, "400")
    with pytest.raises(
        ValueError, match=r"200 g adaptive run but the parameter log adacon400\.csv"
    ):
        lab_controller("ada200response.csv", "ada", other)
    # the benchmark passes the folder for every log: the name chooses the int and fra logs'
    _, label = lab_controller("int000stepresponse.csv", None, tmp_path)
    assert label == "int"


def test_validate_in_loop_refuses_a_parameter_folder_for_a_pi_log(pi_run, tmp_path) -> None:
    model_path, path, _, _ = pi_run
    folder = tmp_path / "adaptive"
    folder.mkdir()
    _adaptive_file(folder, "000")
    code, output = _in_loop(model_path, path, "--controller", str(folder))
    assert code == 2, output
    assert "int000stepresponse.csv was made by the PI (int)" in output
    assert "--controller int" in output


# ---------------------------------------------------------------------------- designed controllers
def _designed(tmp_path: Path, name: str, ts: float = TS, method: str = "tustin") -> Path:
    design = pytest.importorskip("neckid.design", reason="neckid.design is not installed")
    from neckid.design.operators import grunwald_letnikov_operator, tustin_integrator

    operator = (
        tustin_integrator(ts) if method == "tustin" else grunwald_letnikov_operator(-0.55, ts)
    )
    return design.save_controller(
        design.DesignedController(0.2084, 0.8237, operator), tmp_path / name
    )


def test_a_designed_controller_at_another_period_is_refused(pi_run, tmp_path) -> None:
    model_path, path, _, _ = pi_run
    file = _designed(tmp_path, "slow.json", ts=0.05)
    code, output = _in_loop(model_path, path, "--controller", str(file))
    assert code == 2, output
    assert "runs every 0.05 s but the log is sampled every 0.025 s" in output
    same = _designed(tmp_path, "pi.json")
    code, output = _in_loop(model_path, path, "--controller", str(same))
    assert code == 0, output  # the lab's PI written as a designed controller reproduces the log


def _edit(file: Path, change) -> Path:
    document = json.loads(file.read_text())
    change(document)
    file.write_text(json.dumps(document))
    return file


@pytest.mark.parametrize(
    ("method", "key", "value", "match"),
    [
        ("tustin", "kp", math.nan, r"gains\.kp must be a finite number; got nan"),
        ("tustin", "kf", math.inf, r"gains\.kf must be a finite number; got inf"),
        ("tustin", "ki", 0.9, r"gains\.ki = 0\.9 disagrees with gains\.kf = 0\.8237"),
        ("gl", "kd_lab", 0.5, r"gains\.kd_lab = 0\.5 disagrees with gains\.kf = 0\.8237"),
    ],
)
def test_a_controller_file_names_a_bad_or_lonely_gain(tmp_path, method, key, value, match) -> None:
    from neckid.design import load_controller

    file = _designed(tmp_path, "c.json", method=method)
    _edit(file, lambda d: d["gains"].__setitem__(key, value))
    with pytest.raises(ValueError, match=match) as found:
        load_controller(file)
    assert str(found.value).startswith(str(file))


def test_validate_in_loop_names_the_file_of_a_non_finite_gain(pi_run, tmp_path) -> None:
    model_path, path, _, _ = pi_run
    file = _edit(
        _designed(tmp_path, "nan.json"), lambda d: d.__setitem__("command_limit", math.inf)
    )
    code, output = _in_loop(model_path, path, "--controller", str(file))
    assert code == 2, output
    assert "nan.json: command_limit must be a finite number; got inf" in output


# ---------------------------------------------------------------------------- the loop and options
def test_a_diverged_loop_exits_3_as_a_diverged_free_run_does(pi_run, tmp_path) -> None:
    _, path, _, _ = pi_run
    unstable = _plant_model(np.random.default_rng(5))
    unstable.coef_ = unstable.coef_.copy()
    unstable.coef_[0] = 1.6  # the inclination's own pole: 1.6
    model_path = unstable.save(tmp_path / "unstable.npz")
    out = tmp_path / "loop.json"
    code, output = _in_loop(model_path, path, "--json", str(out))
    assert code == 3, output
    assert "diverged:" in output and "int000stepresponse.csv" in output
    record = json.loads(out.read_text())["logs"][0]
    assert (
        record["diverged_at"] is not None and record["controller_check_rad_s"] < 1e-9
    )  # the file's 12 digits


def test_map_is_honoured_and_tilt_refused(pi_run, tmp_path) -> None:
    model_path, _, model, log = pi_run
    header = tmp_path / "int000stepresponse.csv"
    columns = {
        "time": log.time,
        "motor_position": log.channel("motor_position"),
        "velocity_command": log.channel("velocity_command"),
        "motor_velocity": log.channel("motor_velocity"),
        "incl_sensor": log.channel("inclination"),
    }
    import pandas as pd

    pd.DataFrame(columns).to_csv(header, index=False)
    code, output = _in_loop(model_path, header)
    assert code == 2, output
    assert "inclination" in output
    out = tmp_path / "loop.json"
    code, output = _in_loop(
        model_path, header, "--map", "inclination=incl_sensor", "--json", str(out)
    )
    assert code == 0, output
    assert json.loads(out.read_text())["logs"][0]["inclination_fit_percent"] > 99.9
    model.channel_map_ = {"incl_sensor": "inclination"}  # as identify --map stores it
    mapped = model.save(tmp_path / "mapped.npz")
    code, output = _in_loop(mapped, header)
    assert code == 0, output  # the model's stored mapping, replayed
    code, output = _in_loop(model_path, header, "--map", "inclination=incl_sensor", "--tilt")
    assert code == 2, output
    assert "--tilt: the lab's loop measures the inclination alone" in output
    code, output = _in_loop(model_path, header, "--channel", "inclination=/imu:x:output:deg")
    assert code == 2, output
    assert "--channel names the channels of a ROS 2 bag (--layout rosbag)" in output


def test_in_loop_plot_draws_the_loop(pi_run, tmp_path, monkeypatch) -> None:
    import neckid.cli.explain as explain

    model_path, path, _, log = pi_run
    figures = []
    monkeypatch.setattr(explain, "_save_figure", lambda fig, target: figures.append(fig))
    code, output = _in_loop(model_path, path, "--plot", str(tmp_path / "loop.png"))
    assert code == 0, output
    (fig,) = figures
    inclination, command, position = fig.axes
    lines = {line.get_label(): line.get_ydata() for line in inclination.lines}
    assert {"reference", "logged", "model in the loop", "model, free run"} <= set(lines)
    np.testing.assert_allclose(lines["logged"], log.channel("inclination"))
    np.testing.assert_allclose(lines["model in the loop"], log.channel("inclination"), atol=1e-6)
    commands = {line.get_label(): line.get_ydata() for line in command.lines}
    np.testing.assert_allclose(commands["logged"], log.channel("velocity_command"))
    assert inclination.get_ylabel() == "inclination [deg]"
    assert command.get_ylabel() == "velocity command [rad/s]"
    assert position.get_ylabel() == "motor position [rad]"
    plt.close(fig)


# ---------------------------------------------------------------------------- the real logs
needs_logs = pytest.mark.skipif(
    not (DATA / "softneck" / "stair").is_dir() or not (DATA / "softneck_adaptive").is_dir(),
    reason="the shared soft-neck logs (../shared/data/softneck, softneck_adaptive) are not here",
)


@needs_logs
def test_on_the_real_logs_a_right_controller_passes_and_a_wrong_one_is_refused(rng) -> None:
    stair = DATA / "softneck" / "stair"
    folder = DATA / "softneck_adaptive"
    model = _plant_model(rng)  # any model with the loop's inputs: the check is the log's
    ada = stair / "ada200response.csv"
    replayed = in_loop_on_log(model, ada, adaptive_parameters=folder)
    assert replayed.controller_check < 1e-5  # measured 6.7e-6
    assert 5e-5 < replayed.controller_check_first_stair_row < 2e-4  # measured 1.18e-4
    with pytest.raises(ValueError, match="made by the fixed fractional controller"):
        in_loop_on_log(model, stair / "fra200response.csv", "ada", adaptive_parameters=folder)
    with pytest.raises(ControllerMismatchError) as tuner:
        in_loop_on_log(model, ada)  # the re-implemented tuner: approximate by nature
    assert tuner.value.check > 0.1  # measured 0.78–1.03 rad/s on the ada logs


def test_a_non_finite_adaptive_gain_names_the_file_row_and_column(tmp_path) -> None:
    path = _adaptive_file(tmp_path, "200")
    rows = path.read_text().splitlines()
    cells = rows[2].split(",")
    cells[2] = "nan"
    rows[2] = ",".join(cells)
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(ValueError, match=r"adacon200\.csv: kd of row 3 is nan"):
        lab_controller("ada200response.csv", "ada", path)
    path.write_text("0,0.3,0.9\n")
    with pytest.raises(ValueError, match=r"adacon200\.csv: .* 4 columns \(t, kp, kd, fex\); got 3"):
        lab_controller("ada200response.csv", "ada", path)
