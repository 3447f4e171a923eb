"""Tests of IOData: construction, files, slicing, channels, experiments, bad input."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.io import savemat

from neckid.data.iodata import IOData, as_experiments
from neckid.utils.checks import check_uniform_time


@pytest.fixture
def log(rng: np.random.Generator) -> IOData:
    return IOData(
        u=rng.normal(size=(50, 2)),
        y=rng.normal(size=50),
        ts=0.02,
        input_names=["m1", "m2"],
        output_names=["incl"],
        input_units=["rad/s", "rad/s"],
        output_units=["deg"],
        t0=1.0,
        name="run",
    )


def test_from_arrays_shapes_time_and_read_only(log: IOData) -> None:
    assert (log.n_samples, log.n_inputs, log.n_outputs) == (50, 2, 1)
    assert log.u.shape == (50, 2) and log.y.shape == (50, 1)
    np.testing.assert_allclose(log.time, 1.0 + 0.02 * np.arange(50))
    assert log.duration == pytest.approx(1.0)
    with pytest.raises(ValueError, match="read-only"):
        log.u[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        log.y[0, 0] = 1.0


def test_inputs_are_never_mutated_nor_shared(rng: np.random.Generator) -> None:
    u = rng.normal(size=(20, 1))
    y = rng.normal(size=20)
    u_copy, y_copy = u.copy(), y.copy()
    data = IOData(u, y, ts=0.1)
    u[0, 0] = 99.0
    assert data.u[0, 0] == u_copy[0, 0]
    data.with_derivative("y").split(0.5)
    np.testing.assert_array_equal(y, y_copy)


def test_frame_csv_parquet_round_trip(log: IOData, tmp_path) -> None:
    frame = log.to_frame()
    assert list(frame.columns) == ["time", "m1", "m2", "incl"]
    assert frame.attrs["units"]["incl"] == "deg"
    back = IOData.from_frame(frame, inputs=["m1", "m2"], outputs=["incl"], time="time")
    np.testing.assert_array_equal(back.u, log.u)
    np.testing.assert_array_equal(back.y, log.y)
    assert back.input_names == log.input_names and back.output_names == log.output_names
    assert back.ts == pytest.approx(log.ts) and back.t0 == pytest.approx(1.0)
    assert back.unit("incl") == "deg"
    log.to_csv(tmp_path / "log.csv")
    csv = IOData.from_csv(tmp_path / "log.csv", inputs=["m1", "m2"], outputs=["incl"])
    np.testing.assert_allclose(csv.u, log.u)
    np.testing.assert_allclose(csv.y, log.y)
    assert csv.ts == pytest.approx(0.02) and csv.name == "log.csv"
    log.to_parquet(tmp_path / "log.parquet")
    pq = IOData.from_parquet(tmp_path / "log.parquet", inputs=["m1"], outputs=["incl"])
    np.testing.assert_array_equal(pq.u[:, 0], log.u[:, 0])
    assert pq.ts == pytest.approx(0.02)


def test_csv_without_time_column(tmp_path) -> None:
    path = tmp_path / "plain.csv"
    pd.DataFrame({"a": [1.0, 2.0, 3.0], "b": [0.0, 1.0, 4.0]}).to_csv(path, index=False)
    data = IOData.from_csv(path, inputs=["a"], outputs=["b"], ts=0.5)
    assert data.ts == 0.5 and data.t0 == 0.0 and data.n_samples == 3


def test_from_mat(tmp_path) -> None:
    path = tmp_path / "log.mat"
    t = np.arange(10) * 0.05
    savemat(path, {"t": t[:, None], "cmd": np.sin(t), "incl": np.cos(t)[:, None], "Ts": 0.05})
    by_time = IOData.from_mat(path, inputs=["cmd"], outputs=["incl"], time="t")
    by_var = IOData.from_mat(path, inputs=["cmd"], outputs=["incl"], ts="Ts")
    for data in (by_time, by_var):
        np.testing.assert_allclose(data.u.ravel(), np.sin(t))
        np.testing.assert_allclose(data.y.ravel(), np.cos(t))
        assert data.ts == pytest.approx(0.05)
    with pytest.raises(KeyError, match=r"variables \['nope'\] are not in log.mat"):
        IOData.from_mat(path, inputs=["nope"], ts=0.05)


def test_slicing_by_sample_and_time(log: IOData) -> None:
    part = log[10:20]
    assert part.n_samples == 10 and part.t0 == pytest.approx(1.2)
    np.testing.assert_array_equal(part.u, log.u[10:20])
    every_other = log[::2]
    assert every_other.ts == pytest.approx(0.04) and every_other.n_samples == 25
    window = log.time_slice(1.1, 1.3)
    np.testing.assert_allclose(window.time, log.time[5:15])
    with pytest.raises(TypeError, match="sliced by sample with a slice"):
        log[3]  # type: ignore[index]
    with pytest.raises(ValueError, match="selects no sample"):
        log.time_slice(5.0, 6.0)


def test_split_select_and_derivative(log: IOData) -> None:
    a, b = log.split(0.6)
    assert (a.n_samples, b.n_samples) == (30, 20)
    assert b.t0 == pytest.approx(log.time[30])
    sel = log.select(inputs=["m2"], outputs=["incl"])
    assert sel.input_names == ("m2",) and sel.input_units == ("rad/s",)
    np.testing.assert_array_equal(sel.u[:, 0], log.u[:, 1])
    swapped = log.select(inputs=["incl"], outputs=["m1"])
    np.testing.assert_array_equal(swapped.u[:, 0], log.y[:, 0])
    ramp = IOData(u=np.zeros(6), y=3.0 * np.arange(6) * 0.1, ts=0.1, output_names=["x"])
    for method in ("central", "backward"):
        d = ramp.with_derivative("x", method=method)
        np.testing.assert_allclose(d.channel("d(x)/dt"), 3.0)
        assert "d(x)/dt" in d.output_names
    quadratic = IOData(u=np.zeros(11), y=np.arange(11.0) ** 2, ts=1.0, output_names=["q"])
    # Central differences are exact on a quadratic (inside the record).
    np.testing.assert_allclose(
        quadratic.with_derivative("q", name="dq", kind="input").channel("dq")[1:-1],
        2.0 * np.arange(1, 10),
    )


def test_list_of_experiments(log: IOData) -> None:
    assert as_experiments(log) == [log]
    a, b = log.split(0.5)
    assert as_experiments([a, b]) == [a, b]
    other = log.select(inputs=["m1"])
    with pytest.raises(ValueError, match=r"data\[1\]\) has channels \['m1'\]"):
        as_experiments([log, other])
    with pytest.raises(
        ValueError, match=r"data\[1\]\)? is sampled every 0.04 s, but .*every 0.02 s"
    ):
        as_experiments([log, log[::2]])
    with pytest.raises(TypeError, match=r"data\[1\] must be an IOData; got int"):
        as_experiments([log, 3])
    with pytest.raises(ValueError, match="empty list"):
        as_experiments([])


def test_uniform_time_gives_mean_step_and_start() -> None:
    ts, t0 = check_uniform_time(2.0 + 0.1 * np.arange(100))
    assert ts == pytest.approx(0.1) and t0 == 2.0
    # Jitter within 5 % is accepted; ts is the mean step (t[-1] - t[0]) / (n - 1).
    jittered = 0.02 * np.arange(11) + 1e-4 * np.array([0, 1, -1] * 3 + [0, 0])
    assert check_uniform_time(jittered)[0] == pytest.approx(0.02, rel=1e-12)


def test_uniform_time_with_repeats_and_a_given_period() -> None:
    stamps = [0.0, 0.1, 0.2, 0.2, 0.3]
    assert check_uniform_time(stamps, allow_repeats=True) == (pytest.approx(0.1), 0.0)
    assert check_uniform_time(stamps, ts=0.1, allow_repeats=True) == (0.1, 0.0)
    with pytest.raises(ValueError, match=r"where ts is 0.2 s"):
        check_uniform_time(stamps, ts=0.2, allow_repeats=True)
    with pytest.raises(ValueError, match=r"'time' has the same time stamp 1.0 on every row"):
        check_uniform_time([1.0, 1.0, 1.0], allow_repeats=True)


def test_from_frame_reads_the_time_column() -> None:
    frame = pd.DataFrame({"clock": 3.0 + 0.05 * np.arange(6), "a": np.arange(6.0)})
    data = IOData.from_frame(frame, ["a"], time="clock")
    assert data.ts == pytest.approx(0.05) and data.t0 == 3.0
    with pytest.raises(ValueError, match=r"time column 'clock' is not uniformly sampled"):
        IOData.from_frame(frame.drop(index=3), ["a"], time="clock")


BAD = [
    (
        lambda: IOData(u=[1.0, np.nan, 2.0], y=[0.0, 0.0, 0.0], ts=1.0, input_names=["cmd"]),
        ValueError,
        r"u channel 'cmd' has a non-finite value nan at row 1",
    ),
    (
        lambda: IOData(u=[1.0, 2.0], y=[[0.0, 1.0], [np.inf, 0.0]], ts=1.0),
        ValueError,
        r"y channel 'y1' has a non-finite value inf at row 1",
    ),
    (
        lambda: IOData(u=np.zeros(5), y=np.zeros(4), ts=1.0),
        ValueError,
        r"same number of samples.*u with 5 and y with 4",
    ),
    (
        lambda: IOData(u=np.zeros(5), ts=0.0),
        ValueError,
        r"ts must be a positive number of seconds; got 0.0",
    ),
    (
        lambda: IOData(u=np.zeros(5), ts=-0.02),
        ValueError,
        r"ts must be a positive number of seconds; got -0.02",
    ),
    (
        lambda: IOData(u=np.zeros(5), ts="fast"),
        TypeError,
        r"ts must be a number of seconds; got 'fast'",
    ),
    (
        lambda: IOData(u=np.zeros(5), ts=np.nan),
        ValueError,
        r"ts must be a positive number of seconds; got nan",
    ),
    (
        lambda: IOData(u=np.zeros((5, 2)), input_names=["a"]),
        ValueError,
        r"input_names has 1 names \['a'\] for 2 channels",
    ),
    (
        lambda: IOData(u=np.zeros((5, 2)), input_names=["a", "a"]),
        ValueError,
        r"input_names must be unique; repeated: \['a'\]",
    ),
    (
        lambda: IOData(u=np.zeros(5), y=np.zeros(5), input_names=["x"], output_names=["x"]),
        ValueError,
        r"both an input and an output: \['x'\]",
    ),
    (lambda: IOData(u=np.zeros((2, 2, 2))), ValueError, r"u must be 1-D or 2-D.*\(2, 2, 2\)"),
    (lambda: IOData(u=["a", "b"]), TypeError, r"u must be numeric"),
    (
        lambda: check_uniform_time([0.0, 0.1, 0.05, 0.2]),
        ValueError,
        r"time column 'time' is not sorted: row 2 has t=0.05 after t=0.1",
    ),
    (
        lambda: check_uniform_time([0.0, 0.1, 0.1, 0.2]),
        ValueError,
        r"repeats the time stamp 0.1 at rows 1 and 2",
    ),
    (
        lambda: check_uniform_time([0.0, 0.1, 0.2, 0.5, 0.6]),
        ValueError,
        r"not uniformly sampled: the step before row 3",
    ),
    (
        lambda: check_uniform_time([0.0, np.nan, 0.2]),
        ValueError,
        r"time column 'time' has a non-finite value nan at row 1",
    ),
    (
        lambda: IOData.from_frame(
            pd.DataFrame({"a": [1.0], "b": [2.0]}), inputs=["a", "zz"], ts=1.0
        ),
        KeyError,
        r"columns \['zz'\] are not in the table; it has \['a', 'b'\]",
    ),
    (
        lambda: IOData.from_frame(pd.DataFrame({"a": [1.0, 2.0]}), inputs=["a"]),
        ValueError,
        r"exactly one of time=",
    ),
    (
        lambda: IOData.from_frame(pd.DataFrame({"a": [1.0, np.nan, 3.0]}), inputs=["a"], ts=1.0),
        ValueError,
        r"u channel 'a' has a non-finite value nan at row 1",
    ),
    (
        lambda: IOData.from_frame(pd.DataFrame({"a": ["1", "x"]}), inputs=["a"], ts=1.0),
        ValueError,
        r"column 'a' is not numeric: row 1 holds 'x'",
    ),
    (
        lambda: IOData.from_frame(
            pd.DataFrame({"t": [0.0, 0.0], "a": [1.0, 2.0]}), inputs=["a"], time="t"
        ),
        ValueError,
        r"time column 't' repeats the time stamp 0.0 at rows 0 and 1",
    ),
    (
        lambda: IOData(u=np.zeros(3)).select(inputs=["nope"]),
        KeyError,
        r"inputs names 'nope', which is not a channel",
    ),
    (lambda: IOData(u=np.zeros(3)).channel("nope"), KeyError, r"no channel named 'nope'"),
    (
        lambda: IOData(u=np.zeros(3)).split(1.5),
        ValueError,
        r"fraction must be in \(0, 1\); got 1.5",
    ),
    (
        lambda: IOData(u=np.zeros(3)).with_derivative("u", method="spline"),
        ValueError,
        r"method must be 'central' or 'backward'; got 'spline'",
    ),
    (
        lambda: IOData(u=np.zeros(3)).with_channel("v", np.zeros(4)),
        ValueError,
        r"channel 'v' must have shape \(3,\)",
    ),
]


@pytest.mark.parametrize(("call", "error", "message"), BAD)
def test_bad_input_is_refused(call, error, message) -> None:
    with pytest.raises(error, match=message):
        call()


# ---------------------------------------------------------------------------- damaged CSV files
GOOD_CSV = "time,cmd,incl\n0,1,2\n0.02,1.5,2.5\n0.04,2,3\n"

BAD_CSV = [
    (
        "cmé".join(GOOD_CSV.split("cmd")).encode("latin-1"),
        ValueError,
        r"^log.csv is not a text CSV \(byte 0xe9 at offset 7, line 1, is not valid utf-8\);"
        r" save it as UTF-8 text or pass encoding=",
    ),
    (GOOD_CSV.encode("utf-16"), ValueError, r"byte 0xff at offset 0, line 1"),
    (
        GOOD_CSV.replace("0.02,1.5,2.5", "0.02,1.5,2.5,7").encode(),
        ValueError,
        r"^log.csv: cannot parse as CSV: Expected 3 fields in line 3, saw 4$",
    ),
    (b'time,cmd,incl\n0,1,2\n"0.02,1,2\n', ValueError, r"cannot parse as CSV: EOF inside string"),
    (b"\n\n  \n", ValueError, r"^log.csv holds no CSV header and no data"),
    (
        GOOD_CSV.replace("0.02,1.5,2.5", "0.02,,2.5").encode(),
        ValueError,
        r"^log.csv: column 'cmd' has no value at row 1 \(an empty cell or NaN; 1 in all\)",
    ),
    (
        GOOD_CSV.replace("0.04,2,3", "0.04,2,nan").encode(),
        ValueError,
        r"^log.csv: column 'incl' has no value at row 2",
    ),
    (
        GOOD_CSV.replace("0.04,2,3", "0.04,2,inf").encode(),
        ValueError,
        r"^log.csv: y channel 'incl' has a non-finite value inf at row 2",
    ),
    (
        GOOD_CSV.replace("0.04,2,3", "0.04,abc,3").encode(),
        ValueError,
        r"^log.csv: column 'cmd' is not numeric: row 2 holds 'abc'",
    ),
    (
        GOOD_CSV.replace("incl", "cmd").encode(),
        ValueError,
        r"^log.csv: column name 'cmd' appears 2 times in the header",
    ),
    (
        GOOD_CSV.split("\n", 1)[1].encode(),
        KeyError,
        r"log.csv: columns .* are not in the table; it has \['0', '1', '2'\]; the first row holds"
        r" numbers, not names: the file has no header row; pass header=None, names=",
    ),
    (
        GOOD_CSV.replace(",", ";").encode(),
        KeyError,
        r"log.csv: .*the header is one column holding ';': pass sep=';'",
    ),
    (
        b"time,cmd,incl\n0,1,2\n",
        ValueError,
        r"^log.csv: time column 'time' needs at least 2 time stamps",
    ),
    (
        b"time,cmd,incl\n0,1,2\n0.04,1,2\n0.02,1,2\n",
        ValueError,
        r"^log.csv: time column 'time' is not sorted: row 2 has t=0.02 after t=0.04",
    ),
    (
        b"time,cmd,incl\n0,1,2\n0.02,1,2\n0.02,1,2\n",
        ValueError,
        r"^log.csv: time column 'time' repeats the time stamp 0.02 at rows 1 and 2",
    ),
]


@pytest.mark.parametrize(("content", "error", "message"), BAD_CSV)
def test_damaged_csv_is_refused_naming_the_file(tmp_path, content, error, message) -> None:
    path = tmp_path / "log.csv"
    path.write_bytes(content)
    with pytest.raises(error, match=message) as caught:
        IOData.from_csv(path, ["cmd"], ["incl"])
    assert type(caught.value) is error  # not a UnicodeDecodeError, nor a pandas ParserError


def test_csv_with_a_byte_order_mark_or_another_encoding_is_read(tmp_path) -> None:
    path = tmp_path / "log.csv"
    path.write_bytes(b"\xef\xbb\xbf" + GOOD_CSV.encode())
    assert IOData.from_csv(path, ["cmd"], ["incl"]).input_names == ("cmd",)
    path.write_bytes(GOOD_CSV.replace("cmd", "cmé").encode("latin-1"))
    data = IOData.from_csv(path, ["cmé"], ["incl"], encoding="latin-1")
    np.testing.assert_array_equal(data.u.ravel(), [1.0, 1.5, 2.0])


def test_csv_path_that_is_missing_or_a_folder(tmp_path) -> None:
    with pytest.raises(FileNotFoundError, match=r"csv file '.*nope.csv' does not exist"):
        IOData.from_csv(tmp_path / "nope.csv", ["cmd"])
    with pytest.raises(ValueError, match=r"is a folder, not a csv file"):
        IOData.from_csv(tmp_path, ["cmd"])
