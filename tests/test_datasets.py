from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from neckid.datasets import (
    SILVERBOX_TS,
    load_bouc_wen,
    load_cascaded_tanks,
    load_robot_arm,
    load_silverbox,
    load_softneck_directory,
    load_softneck_log,
)

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
needs_softneck = pytest.mark.skipif(
    not (SHARED_DATA / "softneck").is_dir(),
    reason=f"the real soft-neck logs are not at {SHARED_DATA / 'softneck'}",
)
needs_benchmarks = pytest.mark.skipif(
    not (SHARED_DATA / "benchmarks").is_dir(),
    reason=f"the public benchmark files are not at {SHARED_DATA / 'benchmarks'}",
)


def write_log(path: Path, rows: list[list[float]] | list[str]) -> Path:
    lines = [r if isinstance(r, str) else ", ".join(f"{v:g}" for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def grid(n: int, n_columns: int, t0: float = 0.0) -> list[list[float]]:
    rng = np.random.default_rng(0)
    values = rng.normal(size=(n, n_columns))
    values[:, 0] = t0 + 0.025 * np.arange(n)
    return values.tolist()


# ---------------------------------------------------------------------------- soft-neck layouts
@pytest.mark.parametrize(
    ("n_columns", "inputs", "outputs"),
    [
        (3, ["motor_position"], ["inclination_filtered"]),
        (
            6,
            ["motor_position", "velocity_command", "motor_velocity"],
            ["inclination", "inclination_filtered"],
        ),
        (
            7,
            ["motor_position", "velocity_command", "motor_velocity", "control_filtered"],
            ["inclination", "inclination_filtered"],
        ),
    ],
)
def test_layouts_give_named_channels_with_units(tmp_path, n_columns, inputs, outputs):
    rows = grid(20, n_columns, t0=20.0)
    data = load_softneck_log(write_log(tmp_path / "log.csv", rows))
    assert list(data.input_names) == inputs
    assert list(data.output_names) == outputs
    assert data.ts == pytest.approx(0.025)
    assert data.t0 == pytest.approx(20.0)
    assert data.n_samples == 20
    assert data.unit("motor_position") == "rad"
    assert data.unit("inclination_filtered") == "deg"
    values = np.asarray(rows)
    # Column order in the files: filtered inclination is always column 1.
    np.testing.assert_allclose(data.channel("inclination_filtered"), values[:, 1], rtol=1e-5)
    position_column = {3: 2, 6: 2, 7: 3}[n_columns]
    np.testing.assert_allclose(
        data.channel("motor_position"), values[:, position_column], rtol=1e-5
    )
    if n_columns > 3:
        raw_column = {6: 3, 7: 4}[n_columns]
        np.testing.assert_allclose(data.channel("inclination"), values[:, raw_column], rtol=1e-5)
        np.testing.assert_allclose(data.channel("motor_velocity"), values[:, -1], rtol=1e-5)
        assert data.unit("velocity_command") == "rad/s"


def test_select_channels_on_load(tmp_path):
    path = write_log(tmp_path / "log.csv", grid(10, 6))
    data = load_softneck_log(
        path, inputs=["motor_position", "motor_velocity"], outputs=["inclination"]
    )
    assert data.input_names == ("motor_position", "motor_velocity")
    assert data.output_names == ("inclination",)
    with pytest.raises(KeyError, match="velocity_command"):
        load_softneck_log(
            write_log(tmp_path / "three.csv", grid(10, 3)), inputs=["velocity_command"]
        )


def test_trailing_comma_and_blank_lines_are_accepted(tmp_path):
    rows = [f"{0.025 * k}, {k}, {2 * k}," for k in range(5)] + ["", "  "]
    data = load_softneck_log(write_log(tmp_path / "log.csv", rows))
    assert data.n_samples == 5


@pytest.mark.parametrize(
    ("rows", "match"),
    [
        (
            ["0, 1, 2, 3, 4", "0.025, 1, 2, 3, 4"],
            r"unknown .* 5 columns .*first row .*'0, 1, 2, 3, 4'",
        ),
        (["0, 1"], r"unknown .* 2 columns"),
        (["0, 1, 2", "0.025, 1, 2, 3"], r"line 2: 4 fields"),
        (["0, 1, 2", "0.025, abc, 2"], r"line 2, column 2 \(inclination_filtered\): 'abc'"),
        (["0, 1, 2", "0.025, 1, nan"], r"line 2, column 3 \(motor_position\): non-finite"),
        (
            ["0, 1, 2", "0.025, 1, 2", "0.01, 1, 2"],
            r"bad.csv: time column 'time' is not sorted: row 2 has t=0.01 after t=0.025",
        ),
        (
            ["0, 1, 2", "0.025, 1, 2", "0.1, 1, 2"],
            r"bad.csv: .*not uniformly sampled: the step before row 2 is 0.075 s",
        ),
        (["0, 1, 2", "0, 1, 2"], r"same time stamp 0.0 on every row"),
        (["0, 1, 2"], r"bad.csv: time column 'time' needs at least 2 time stamps.*; got 1"),
        ([], r"no data row"),
    ],
)
def test_bad_logs_are_refused_with_the_row(tmp_path, rows, match):
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(ValueError, match=match):
        load_softneck_log(path)


def test_repeated_time_stamps(tmp_path):
    rows = grid(10, 3)
    rows.insert(5, [rows[4][0], 7.0, 8.0])  # a second row at the same time stamp
    path = write_log(tmp_path / "stair.csv", rows)
    restamped = load_softneck_log(path)
    assert restamped.n_samples == 11
    assert restamped.channel("inclination_filtered")[5] == 7.0
    np.testing.assert_allclose(np.diff(restamped.time), 0.025)
    dropped = load_softneck_log(path, repeated_stamps="drop")
    assert dropped.n_samples == 10
    assert 7.0 not in dropped.channel("inclination_filtered")
    with pytest.raises(ValueError, match=r"1 repeated time stamp.*data row 5"):
        load_softneck_log(path, repeated_stamps="raise")
    with pytest.raises(ValueError, match="repeated_stamps must be"):
        load_softneck_log(path, repeated_stamps="keep")  # type: ignore[arg-type]


def test_ts_can_be_inferred(tmp_path):
    rows = [[0.01 * k, k, k] for k in range(6)]
    path = write_log(tmp_path / "log.csv", rows)
    data = load_softneck_log(path, ts=None)
    assert data.ts == pytest.approx(0.01)
    with pytest.raises(ValueError, match=r"log.csv: .*step before row 1 is 0.01 s .* where ts is"):
        load_softneck_log(path)  # the bench's 0.025 s
    with pytest.raises(ValueError, match=r"ts must be a positive number of seconds; got 0\.0"):
        load_softneck_log(path, ts=0.0)


def test_directory_loader(tmp_path):
    (tmp_path / "step").mkdir()
    (tmp_path / "id" / "ol1").mkdir(parents=True)
    write_log(tmp_path / "step" / "fra000stepresponse.csv", grid(8, 6))
    write_log(tmp_path / "id" / "ol1" / "id000response.csv", grid(8, 3))
    logs = load_softneck_directory(tmp_path)
    assert list(logs) == ["id/ol1/id000response.csv", "step/fra000stepresponse.csv"]
    assert logs["id/ol1/id000response.csv"].n_inputs == 1
    write_log(tmp_path / "step" / "bad.csv", ["0, 1, 2, 3"])
    with pytest.raises(ValueError, match=r"step/bad.csv: .*unknown"):
        load_softneck_directory(tmp_path)
    with pytest.raises(FileNotFoundError):
        load_softneck_directory(tmp_path / "missing")
    with pytest.raises(FileNotFoundError, match="no file matches"):
        load_softneck_directory(tmp_path, pattern="*.txt")


# ---------------------------------------------------------------------------- benchmarks, small files
def test_cascaded_tanks_from_written_file(tmp_path):
    n = 30
    rng = np.random.default_rng(1)
    frame = pd.DataFrame(rng.uniform(1, 9, size=(n, 4)), columns=["uEst", "uVal", "yEst", "yVal"])
    frame["Ts"] = [4.0] + [np.nan] * (n - 1)
    frame.to_csv(tmp_path / "dataBenchmark.csv", index=False)
    bench = load_cascaded_tanks(tmp_path)
    assert bench.train.ts == 4.0
    np.testing.assert_allclose(bench.train.u.ravel(), frame["uEst"])
    np.testing.assert_allclose(bench.tests["validation"].y.ravel(), frame["yVal"])
    assert bench.train.output_units == ("V",)
    assert bench.n_initial is None
    frame.loc[3, "yVal"] = np.nan
    frame.to_csv(tmp_path / "dataBenchmark.csv", index=False)
    with pytest.raises(ValueError, match=r"'yVal' .* data row 3"):
        load_cascaded_tanks(tmp_path)
    frame.drop(columns=["uVal"]).to_csv(tmp_path / "dataBenchmark.csv", index=False)
    with pytest.raises(ValueError, match=r"\['uVal'\] are missing"):
        load_cascaded_tanks(tmp_path)
    with pytest.raises(FileNotFoundError, match=r"dataBenchmark.csv"):
        load_cascaded_tanks(tmp_path / "nowhere")


def test_silverbox_splits_from_written_file(tmp_path):
    n = 131072
    index = np.arange(n, dtype=float)
    frame = pd.DataFrame({"V1": index, "V2": -index})
    path = tmp_path / "SNLS80mV.csv"
    frame.to_csv(path, index=False)
    bench = load_silverbox(path)
    assert bench.n_initial == 50
    assert bench.rmse_scale == 1000.0 and bench.rmse_unit == "mV"
    assert bench.train.u[0, 0] == 40650 and bench.train.u[-1, 0] == 105711
    test = bench.tests["multisine"]
    assert test.u[0, 0] == 105712 and test.u[-1, 0] == 127399
    assert bench.tests["arrow_full"].u[0, 0] == 100
    assert bench.tests["arrow_full"].n_samples == 40475
    assert bench.tests["arrow_no_extrapolation"].n_samples == 32000
    assert bench.train.ts == pytest.approx(SILVERBOX_TS)
    assert bench.train.t0 == pytest.approx(40650 * SILVERBOX_TS)
    frame.iloc[:1000].to_csv(path, index=False)
    with pytest.raises(ValueError, match="1000 samples"):
        load_silverbox(path)


def test_bouc_wen_from_written_files(tmp_path):
    h5py = pytest.importorskip("h5py")
    from scipy.io import savemat

    rng = np.random.default_rng(2)
    with h5py.File(tmp_path / "train.h5", "w") as handle:
        group = handle.create_group("multisine")
        group["u"] = rng.normal(size=(100, 1))
        group["y"] = rng.normal(size=(100, 1))
        group["fs"] = np.array([[750.0]])
    for label, n in (("multisine", 40), ("sinesweep", 60)):
        savemat(tmp_path / f"uval_{label}.mat", {f"uval_{label}": rng.normal(size=(1, n))})
        savemat(tmp_path / f"yval_{label}.mat", {f"yval_{label}": rng.normal(size=(1, n))})
    bench = load_bouc_wen(tmp_path)
    assert bench.train.n_samples == 100
    assert bench.train.ts == pytest.approx(1 / 750)
    assert {k: v.n_samples for k, v in bench.tests.items()} == {"multisine": 40, "sinesweep": 60}
    assert bench.train.input_units == ("N",) and bench.train.output_units == ("m",)
    savemat(tmp_path / "yval_sinesweep.mat", {"other": np.zeros(3)})
    with pytest.raises(ValueError, match="no variable 'yval_sinesweep'"):
        load_bouc_wen(tmp_path)


def test_bouc_wen_without_h5py_says_how_to_install(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "h5py", None)
    with pytest.raises(ImportError, match=r"neckid\[data\]"):
        load_bouc_wen(tmp_path)


def test_robot_arm_from_written_file(tmp_path):
    values = np.column_stack([np.arange(1024.0), -np.arange(1024.0)])
    np.savetxt(tmp_path / "robot_arm.dat", values)
    bench = load_robot_arm(tmp_path)
    assert bench.train.n_samples == 512
    assert bench.tests["second_half"].u[0, 0] == 512
    np.savetxt(tmp_path / "robot_arm.dat", np.zeros((10, 3)))
    with pytest.raises(ValueError, match="two columns"):
        load_robot_arm(tmp_path)


# ---------------------------------------------------------------------------- the real files
@needs_softneck
def test_real_softneck_logs_load():
    logs = load_softneck_directory(SHARED_DATA / "softneck")
    assert len(logs) == 26
    stair = logs["stair/ada000response.csv"]
    assert stair.n_samples == 3605  # 5 repeated stamps kept as samples
    assert stair.n_inputs == 4 and stair.n_outputs == 2
    assert logs["id/id000response.csv"].n_samples == 6000
    assert logs["step/fra200stepresponse.csv"].t0 == pytest.approx(20.0)
    assert logs["step/200stepresponse.csv"].output_names == ("inclination_filtered",)
    assert stair.channel("inclination").min() >= 0.0 and stair.channel("inclination").max() < 40


@needs_softneck
def test_repeated_stamps_are_consecutive_control_periods():
    # The filtered inclination is the raw one through a bilinear 1 rad/s low-pass at 0.025 s; it
    # follows that recursion across the rows with a repeated time stamp, which is why the loader
    # keeps them as samples by default.
    data = load_softneck_log(SHARED_DATA / "softneck" / "stair" / "ada000response.csv")
    raw = data.channel("inclination")
    filtered = data.channel("inclination_filtered")
    c = 1.0 * 0.025 / 2
    predicted = ((1 - c) * filtered[:-1] + c * (raw[1:] + raw[:-1])) / (1 + c)
    assert np.max(np.abs(filtered[1:] - predicted)) < 1e-3
    dropped = load_softneck_log(
        SHARED_DATA / "softneck" / "stair" / "ada000response.csv", repeated_stamps="drop"
    )
    assert dropped.n_samples == 3600


@needs_benchmarks
def test_real_benchmarks_load():
    root = SHARED_DATA / "benchmarks"
    tanks = load_cascaded_tanks(root / "cascaded_tanks")
    assert tanks.train.n_samples == 1024 and tanks.tests["validation"].n_samples == 1024
    silverbox = load_silverbox(root / "silverbox")
    assert silverbox.train.n_samples == 65062
    assert silverbox.tests["multisine"].n_samples == 21688
    arm = load_robot_arm(root / "robot_arm")
    assert arm.train.n_samples + arm.tests["second_half"].n_samples == 1024
    pytest.importorskip("h5py")
    bouc_wen = load_bouc_wen(root / "bouc_wen")
    assert bouc_wen.train.n_samples == 40960
    assert bouc_wen.tests["sinesweep"].n_samples == 153000
    assert bouc_wen.train.ts == pytest.approx(1 / 750)


# ---------------------------------------------------------------------------- damaged soft-neck logs
def test_softneck_log_with_a_byte_order_mark_is_read(tmp_path):
    path = write_log(tmp_path / "log.csv", grid(5, 3))
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert load_softneck_log(path).n_samples == 5


@pytest.mark.parametrize(
    ("content", "match"),
    [
        (
            b"0, 1, 2\n0.025, 1, \xe9\n",
            r"^bad.csv is not a text CSV \(byte 0xe9 at offset 18, line 2, is not valid utf-8\);"
            r" soft-neck logs are UTF-8",
        ),
        (
            b"time, incl, motor\n0, 1, 2\n",
            r"line 1, column 1 \(time\): 'time' is not a number \(a soft-neck log has no header"
            r" row\)",
        ),
        (
            b"0, 1, 2\n0.025, 1, " + b"9" * 500 + b"x\n",
            r"line 2, column 3 \(motor_position\): '9+\.\.\.' is not a number",
        ),
    ],
)
def test_damaged_softneck_logs_are_refused_naming_the_file(tmp_path, content, match):
    path = tmp_path / "bad.csv"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=match) as caught:
        load_softneck_log(path)
    assert type(caught.value) is ValueError
    assert len(str(caught.value)) < 400  # a long row is cut, not copied whole


def test_softneck_path_that_is_missing_or_a_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"soft-neck log '.*nope.csv' does not exist"):
        load_softneck_log(tmp_path / "nope.csv")
    with pytest.raises(ValueError, match=r"is a folder, not a soft-neck log"):
        load_softneck_log(tmp_path)
