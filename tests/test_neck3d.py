"""The 3-D protocol (neckid.experiments.neck3d) and ``neckid demo --3d``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from neckid.cli import app
from neckid.data.tilt import from_tilt
from neckid.experiments.neck3d import (
    METHODS_3D,
    TESTS_3D,
    Demo3DSettings,
    closed_loop_references,
    excitation_positions,
    orientation_error,
    run_demo3d,
)


def test_the_excitation_keeps_the_pretension_and_bends_every_way() -> None:
    q = excitation_positions(3000, 0.02, band=(0.05, 4.0), pretension=1.5, amplitude=2.5, seed=3)
    np.testing.assert_allclose(q.sum(axis=1), 4.5, atol=1e-9)
    # The desired bending direction (the projection back on the tendon directions) goes round.
    angles = np.radians([0.0, 120.0, 240.0])
    xy = (q - 1.5) @ np.column_stack([np.cos(angles), np.sin(angles)]) / 1.5
    direction = np.degrees(np.arctan2(xy[:, 1], xy[:, 0]))
    assert np.histogram(direction, bins=6, range=(-180, 180))[0].min() > 100


def test_closed_loop_references() -> None:
    refs = closed_loop_references(12.0, 0.02)
    assert list(refs) == list(TESTS_3D[1:])
    circle = refs[TESTS_3D[1]]
    assert np.all(circle[:, 0] == 15.0) and np.ptp(circle[:, 1]) > 350.0
    steps = refs[TESTS_3D[2]]
    assert set(np.unique(steps[:, 1])) == {0.0, 60.0, 120.0}
    diagonal = refs[TESTS_3D[3]]
    assert diagonal[0, 0] == 0.0 and diagonal[-1, 0] == 20.0 and np.all(diagonal[:, 1] == 45.0)


def test_orientation_error_is_circular_and_skips_small_inclinations() -> None:
    measured = np.array([[10.0, -0.1], [0.1, 0.0], [0.0, 10.0]])
    simulated = np.array([[10.0, 0.1], [-0.1, 0.0], [0.0, 10.0]])  # 359.4° vs 0.6°; upright
    assert orientation_error(measured, simulated, min_inclination=3.0) == pytest.approx(
        np.degrees(np.arctan(0.01)), rel=1e-9
    )
    assert np.isnan(orientation_error(measured, simulated, min_inclination=50.0))


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo3d") / "out"
    steps: list[str] = []
    result = run_demo3d(out, Demo3DSettings.make(quick=True), on_step=steps.append)
    return out, result, steps


def test_the_quick_3d_demo_writes_its_report(quick_run) -> None:
    out, result, steps = quick_run
    assert len(steps) == 6
    names = {p.name for p in out.iterdir()}
    assert {"report.html", "metrics.json", "fig1_bandwidth.png", "fig3_circle.png"} <= names
    assert sum(name.startswith("model_") for name in names) == len(METHODS_3D)
    page = (out / "report.html").read_text()
    assert "tilt_x" in page and "Free-run fit [%] per tilt component" in page
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["slack_share"]["identification"] == 0.0
    assert 3.0 < result.bandwidths[0.0] < 6.0
    # Every method fits, per tilt component; the linear-part SM and ARX fit the validation well.
    assert list(result.fit.index) == list(metrics["fit_percent"])
    assert result.fit.shape == (len(METHODS_3D), 2 * len(TESTS_3D))
    validation = result.fit[TESTS_3D[0]]
    assert (validation.loc["Set Membership + linear"] > 90.0).all()
    assert (validation.loc["Linear ARX"] > 90.0).all()
    assert (result.mae.xs("orientation", axis=1, level=1).loc["Linear ARX"] < 5.0).all()


def test_the_3d_models_load_and_convert_back(quick_run) -> None:
    import neckid

    out, _result, _ = quick_run
    model = neckid.load_model(out / "model_set_membership_linear.npz")
    assert model.output_names_ == ("tilt_x", "tilt_y")
    assert model.input_names_ == ("motor_position_1", "motor_position_2", "motor_position_3")
    incl, orient = from_tilt(np.array([3.0]), np.array([-3.0]))
    assert incl[0] == pytest.approx(np.hypot(3.0, 3.0)) and orient[0] == pytest.approx(315.0)


def test_cli_demo_3d_refuses_an_existing_folder_and_the_paper_regressor(tmp_path) -> None:
    runner = CliRunner()
    out = tmp_path / "taken"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    result = runner.invoke(app, ["demo", "--3d", "--quick", "--out", str(out)])
    assert result.exit_code != 0
    assert (out / "mine.txt").read_text() == "keep"
    assert "Traceback" not in result.output
    result = runner.invoke(app, ["demo", "--3d", "--paper-regressor", "--out", str(tmp_path / "x")])
    assert result.exit_code == 2 and "--3d" in result.output


def test_cli_demo_3d_quick_prints_both_tables(tmp_path) -> None:
    result = CliRunner().invoke(app, ["demo", "--3d", "--quick", "--out", str(tmp_path / "d")])
    assert result.exit_code == 0, result.output
    assert "tilt_x / tilt_y" in result.output and "inclination / orientation" in result.output
    assert "step 6/6" in result.output  # not a terminal: plain progress lines
    assert (tmp_path / "d" / "report.html").exists()


def _imu_csv(path, seed: int, payload: float = 0.2) -> None:
    """A three-motor log of the simulated neck written the way an IMU bench writes one."""
    import pandas as pd

    from neckid.experiments.neck3d import excitation_positions
    from neckid.plant import SoftNeck

    q = excitation_positions(1500, 0.02, band=(0.05, 3.0), pretension=1.5, amplitude=2.5, seed=seed)
    velocity = np.vstack([np.full((150, 3), 1.5 / 3.0), np.diff(q, axis=0, prepend=q[:1]) / 0.02])
    log = SoftNeck(configuration="three_tendon", seed=seed).run(velocity)[150:]
    frame = pd.DataFrame(
        {
            "time": log.time,
            **{f"motor_{k}": log.channel(f"motor_position_{k}") for k in (1, 2, 3)},
            "inclination": log.channel("inclination"),
            "orientation": log.channel("orientation"),
            "mass": payload,
        }
    )
    frame.to_csv(path, index=False)


def test_three_motor_logs_load_as_the_tilt_vector(tmp_path) -> None:
    from neckid.datasets import load_three_motor_log

    _imu_csv(tmp_path / "run.csv", seed=1)
    log = load_three_motor_log(tmp_path / "run.csv", payload="mass")
    assert log.input_names == ("motor_1", "motor_2", "motor_3")
    assert log.output_names == ("tilt_x", "tilt_y") and log.output_units == ("deg", "deg")
    assert log.conditions["payload"] == 0.2 and log.condition_units["payload"] == "kg"
    raw = np.loadtxt(tmp_path / "run.csv", delimiter=",", skiprows=1)
    assert np.max(np.abs(np.diff(raw[:, 5]))) > 300.0  # the orientation wraps in the file
    assert np.max(np.abs(np.diff(log.y, axis=0))) < 1.0  # the tilt vector does not jump
    back = log.with_polar()
    np.testing.assert_allclose(back.channel("inclination"), raw[:, 4], atol=1e-9)
    pitch_roll = load_three_motor_log(tmp_path / "run.csv", representation="pitch_roll")
    assert pitch_roll.output_names == ("pitch", "roll") and not pitch_roll.conditions
    (tmp_path / "bad.csv").write_text(
        "time,motor_1,motor_2,motor_3,inclination,orientation,mass\n"
        "0,0,0,0,1,0,0.2\n0.02,0,0,0,1,0,0.4\n"
    )
    with pytest.raises(ValueError, match=r"payload column 'mass' must be constant.*row 2"):
        load_three_motor_log(tmp_path / "bad.csv", payload="mass")
    with pytest.raises(KeyError, match="motor_4"):
        load_three_motor_log(tmp_path / "run.csv", motors=["motor_1", "motor_4"])


def test_cli_identifies_and_validates_the_tilt_vector(tmp_path) -> None:
    _imu_csv(tmp_path / "train.csv", seed=1)
    _imu_csv(tmp_path / "test.csv", seed=2)
    runner = CliRunner()
    motors = "motor_1,motor_2,motor_3"
    model = tmp_path / "tilt.npz"
    common = ["--inputs", motors, "--outputs", "inclination,orientation"]
    result = runner.invoke(
        app,
        ["identify", str(tmp_path / "train.csv"), *common, "--tilt", "--method", "arx",
         "--lags", "1-2/1-3", "--save", str(model)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "tilt_x" in result.output and "tilt_y" in result.output
    result = runner.invoke(app, ["validate", str(model), str(tmp_path / "test.csv"), "--tilt"])
    assert result.exit_code == 0, result.output
    rows = [line.split("│") for line in result.output.splitlines() if "│ tilt_" in line]
    fits = [float(row[2]) for row in rows]
    assert len(fits) == 2 and min(fits) > 90.0, result.output
    result = runner.invoke(app, ["identify", str(tmp_path / "train.csv"), "--inputs", motors,
                                 "--outputs", "inclination", "--tilt"])  # fmt: skip
    assert result.exit_code == 2
    assert "--tilt needs the outputs inclination and orientation" in result.output
