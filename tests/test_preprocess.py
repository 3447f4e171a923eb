"""Preprocessing steps that travel with a model: formulas, JSON both ways, model files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from neckid import IOData, Lags, LinearARX, load_model
from neckid.cli.workflow import (
    describe_model,
    fit_model,
    map_channels,
    prepare_log,
    read_log,
)
from neckid.data.preprocess import (
    STEPS,
    LowPass,
    Pipeline,
    Relative,
    RemoveOffset,
    Resample,
    Restamp,
    Step,
    Tilt,
)
from neckid.data.tilt import tilt_log
from neckid.models.io import read_model_file, write_model_file

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
SOFTNECK = SHARED_DATA / "softneck"


def _log(n: int = 6, ts: float = 0.5, t0: float = 0.0) -> IOData:
    k = np.arange(n, dtype=float)
    return IOData(
        u=np.column_stack([2.0 + k, 10.0 - k]),
        y=np.column_stack([k**2]),
        ts=ts,
        t0=t0,
        input_names=["motor_position", "motor_velocity"],
        output_names=["inclination"],
        input_units=["rad", "rad/s"],
        output_units=["deg"],
        name="run.csv",
        conditions={"payload": 0.2},
        condition_units={"payload": "kg"},
    )


ALL_STEPS = [
    Relative("motor_position"),
    RemoveOffset("inclination", 0.0, 1.0),
    LowPass("inclination", 1.0),
    LowPass("motor_velocity", 2.5, initial="steady"),
    Resample(0.25),
    Restamp(),
    Restamp(keep="all"),
    Tilt(),
    Tilt("inclination_sensor", "orientation_sensor", representation="pitch_roll"),
]


# ---------------------------------------------------------------------------- formulas
def test_relative_subtracts_the_first_sample_and_keeps_the_rest() -> None:
    log = _log()
    out = Relative("motor_position").apply(log)
    np.testing.assert_array_equal(out.channel("motor_position"), np.arange(6.0))
    np.testing.assert_array_equal(out.channel("motor_velocity"), log.channel("motor_velocity"))
    assert out.input_units == log.input_units and dict(out.conditions) == {"payload": 0.2}
    assert (out.name, out.t0, out.ts) == (log.name, log.t0, log.ts)
    np.testing.assert_array_equal(log.channel("motor_position"), 2.0 + np.arange(6.0))  # unchanged
    on_output = Relative("inclination").apply(_log(t0=3.0)).channel("inclination")
    np.testing.assert_array_equal(on_output, np.arange(6.0) ** 2)


def test_relative_names_the_missing_channel() -> None:
    with pytest.raises(KeyError, match=r"relative speed.*run.csv has no channel 'speed'"):
        Relative("speed").apply(_log())


def test_remove_offset_uses_a_window_from_the_first_sample() -> None:
    # samples at t - t0 = 0, 0.5, 1.0, ...: the window [0, 1) holds k = 0, 1 -> mean (0 + 1) / 2
    for t0 in (0.0, 20.0):
        out = RemoveOffset("inclination", 0.0, 1.0).apply(_log(t0=t0))
        np.testing.assert_allclose(out.channel("inclination"), np.arange(6.0) ** 2 - 0.5)
    out = RemoveOffset("motor_position", 1.0, 2.0).apply(_log())  # k = 2, 3 -> 4.5
    np.testing.assert_allclose(out.channel("motor_position"), 2.0 + np.arange(6.0) - 4.5)
    with pytest.raises(ValueError, match=r"window holds no sample of run.csv, which lasts 3 s"):
        RemoveOffset("inclination", 5.0, 6.0).apply(_log())


def test_low_pass_follows_the_tustin_recursion() -> None:
    ts, wc = 0.025, 1.0
    x = np.array([0.41, 0.42, 0.09, 1.0, 2.0, 2.0, 2.0])
    a, b = wc * ts / (2 + wc * ts), (2 - wc * ts) / (2 + wc * ts)
    expected, previous_x, previous_y = [], 0.0, 0.0  # started at rest
    for value in x:
        previous_y = a * (value + previous_x) + b * previous_y
        previous_x = value
        expected.append(previous_y)
    log = IOData(u=np.zeros(x.size), y=x, ts=ts, output_names=["inclination"])
    out = LowPass("inclination", wc).apply(log)
    np.testing.assert_allclose(out.channel("inclination"), expected, rtol=1e-12)
    steady = LowPass("inclination", wc, initial="steady").apply(log.replace(y=np.full(7, 3.0)))
    np.testing.assert_allclose(steady.channel("inclination"), 3.0, rtol=1e-12)
    # DC gain 1, and the step response reaches 1 - e^{-wc t} closely at a small wc * ts
    step = LowPass("inclination", 2.0).apply(log.replace(y=np.ones(400), u=np.zeros(400)))
    t = 0.025 * np.arange(400)
    np.testing.assert_allclose(
        step.channel("inclination")[200:], 1 - np.exp(-2.0 * t[200:]), atol=1e-3
    )


@pytest.mark.skipif(not SOFTNECK.is_dir(), reason=f"shared soft-neck logs not found at {SOFTNECK}")
def test_low_pass_at_1_rad_s_is_the_bench_filter() -> None:
    from neckid.datasets import load_softneck_log

    log = load_softneck_log(SOFTNECK / "stair" / "ada000response.csv")
    out = LowPass("inclination", 1.0).apply(log)
    # The file stores the filtered inclination rounded to 1e-4 deg.
    np.testing.assert_allclose(
        out.channel("inclination"), log.channel("inclination_filtered"), atol=1e-4
    )


def test_resample_interpolates_linearly_onto_the_new_period() -> None:
    log = _log()  # ts 0.5, 6 samples: 2.5 s
    up = Resample(0.25).apply(log)
    assert up.ts == 0.25 and up.n_samples == 11
    np.testing.assert_allclose(up.channel("motor_position"), 2.0 + np.arange(11) / 2)
    np.testing.assert_allclose(up.channel("inclination")[1], 0.5)  # between 0 and 1
    down = Resample(1.0).apply(log)
    assert down.n_samples == 3
    np.testing.assert_allclose(down.channel("inclination"), [0.0, 4.0, 16.0])
    odd = Resample(0.3).apply(log)  # 0, 0.3, ..., 2.4: 9 samples
    assert odd.n_samples == 9 and odd.t0 == log.t0
    assert Resample(0.5).apply(log) is log


def test_restamp_keeps_the_first_row_or_all_rows() -> None:
    import pandas as pd

    keep, t = Restamp().stamps([0.0, 0.1, 0.1, 0.1, 0.2])
    assert keep.tolist() == [True, True, False, False, True] and t.tolist() == [0.0, 0.1, 0.2]
    keep, t = Restamp(keep="all").stamps([1.0, 1.1, 1.1, 1.2])
    assert keep.all()
    np.testing.assert_allclose(t, [1.0, 1.1, 1.2, 1.3])
    frame = pd.DataFrame({"time": [0.0, 0.1, 0.1, 0.2], "x": [1.0, 2.0, 9.0, 3.0]})
    out = Restamp().frame(frame, "time")
    assert out["x"].tolist() == [1.0, 2.0, 3.0] and frame["x"].tolist() == [1.0, 2.0, 9.0, 3.0]
    log = _log()
    assert Restamp().apply(log) is log  # a uniform log has no repeated stamp


def test_restamp_acts_where_a_csv_is_read(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    path.write_text("time,cmd,incl\n0,1,0\n0.02,2,0.1\n0.02,7,0.7\n0.04,3,0.3\n")
    with pytest.raises(ValueError, match="time"):
        read_log(path, ["cmd"], ["incl"])
    data = read_log(path, ["cmd"], ["incl"], preprocessing=Pipeline([Restamp()]))
    assert data.n_samples == 3 and data.ts == pytest.approx(0.02)
    np.testing.assert_array_equal(data.channel("cmd"), [1.0, 2.0, 3.0])


def test_tilt_is_tilt_log_and_reads_the_polar_outputs() -> None:
    y = np.array([[5.0, 359.0], [5.0, 1.0], [3.0, 90.0]])
    log = IOData(np.zeros(3), y, ts=0.02, output_names=["inc_s", "ori_s"])
    out = Tilt("inc_s", "ori_s").apply(log)
    expected = tilt_log(log, inclination="inc_s", orientation="ori_s")
    assert out == expected and out.output_names == ("tilt_x", "tilt_y")
    assert Tilt().sources(["tilt_x", "tilt_y", "other"]) == ["inclination", "orientation", "other"]
    assert Tilt(representation="pitch_roll").sources(["roll"]) == ["orientation"]


# ---------------------------------------------------------------------------- pipelines and JSON
def test_a_pipeline_applies_its_steps_in_order_and_changes_no_input() -> None:
    log = _log()
    before = log.channel("motor_position").copy()
    steps = [Relative("motor_position"), RemoveOffset("inclination", 0.0, 1.0), Resample(0.25)]
    pipeline = Pipeline(steps)
    out = pipeline.apply(log)
    expected = Resample(0.25).apply(RemoveOffset("inclination", 0, 1).apply(steps[0].apply(log)))
    assert out == expected
    np.testing.assert_array_equal(log.channel("motor_position"), before)
    both = pipeline.apply([log, log])
    assert isinstance(both, list) and both[1] == out
    steps.clear()  # the pipeline keeps its own tuple
    assert len(pipeline) == 3
    assert pipeline.describe() == (
        "relative motor_position; offset of inclination over 0..1 s; resample to 0.25 s"
    )
    assert Pipeline().describe() == "none" and not Pipeline()
    with pytest.raises(TypeError, match=r"steps\[0\] must be a preprocessing step"):
        Pipeline(["relative"])  # type: ignore[list-item]


@pytest.mark.parametrize("step", ALL_STEPS, ids=lambda s: s.kind)
def test_every_step_goes_through_plain_json_and_back(step: Step) -> None:
    text = json.dumps(step.to_dict())
    assert Step.from_dict(json.loads(text)) == step
    assert type(step).from_dict(json.loads(text)) == step


def test_every_kind_of_step_is_in_the_round_trip() -> None:
    assert {s.kind for s in ALL_STEPS} == set(STEPS)


def test_a_pipeline_goes_through_plain_json_and_back() -> None:
    pipeline = Pipeline(ALL_STEPS)
    items = json.loads(json.dumps(pipeline.to_list()))
    assert Pipeline.from_list(items) == pipeline
    assert items[2] == {
        "step": "lowpass",
        "channel": "inclination",
        "cutoff": 1.0,
        "initial": "rest",
    }


@pytest.mark.parametrize(
    ("item", "message"),
    [
        ("relative", r"must be a JSON object"),
        ({"channel": "x"}, r"unknown preprocessing step None \(key 'step'\)"),
        ({"step": "smooth", "channel": "x"}, r"unknown preprocessing step 'smooth'"),
        ({"step": "relative"}, r"'relative' needs the key 'channel'"),
        ({"step": "relative", "channel": "x", "gain": 2}, r"no key 'gain' \(value 2\)"),
        ({"step": "relative", "channel": 3}, r"'channel' must be a channel name.*got 3"),
        ({"step": "relative", "channel": ""}, r"'channel' must be a channel name.*got ''"),
        ({"step": "lowpass", "channel": "x", "cutoff": "fast"}, r"'cutoff'.*got 'fast'"),
        ({"step": "lowpass", "channel": "x", "cutoff": -1}, r"'cutoff' must be a positive.*-1"),
        ({"step": "lowpass", "channel": "x", "cutoff": True}, r"'cutoff'.*got True"),
        (
            {"step": "lowpass", "channel": "x", "cutoff": 1, "initial": "zero"},
            r"'initial' must be one of \['rest', 'steady'\]; got 'zero'",
        ),
        ({"step": "offset", "channel": "x", "start": 2, "stop": 1}, r"start=2, stop=1"),
        ({"step": "offset", "channel": "x", "start": -1, "stop": 1}, r"start=-1"),
        ({"step": "offset", "channel": "x", "start": 0, "stop": float("nan")}, r"'stop'.*nan"),
        ({"step": "resample", "ts": 0}, r"'ts' must be a positive number of seconds; got 0"),
        ({"step": "resample", "ts": None}, r"'ts' must be a number of seconds; got None"),
        ({"step": "restamp", "keep": "last"}, r"'keep' must be one of \['first', 'all'\]"),
        ({"step": "tilt", "representation": "polar"}, r"'representation'.*got 'polar'"),
    ],
)
def test_bad_json_is_refused_naming_the_key_and_the_value(item: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Step.from_dict(item)
    with pytest.raises(ValueError, match=r"preprocessing\[1\]: .*" + message):
        Pipeline.from_list([{"step": "restamp"}, item])


def test_a_pipeline_must_be_a_list_and_a_class_reads_its_own_kind() -> None:
    for bad in ({"step": "restamp"}, "restamp", 3):
        with pytest.raises(ValueError, match="must be a JSON list of steps"):
            Pipeline.from_list(bad)
    with pytest.raises(ValueError, match="'step' must be 'lowpass' for LowPass; got 'relative'"):
        LowPass.from_dict({"step": "relative", "channel": "x"})


# ---------------------------------------------------------------------------- models keep it
def _training_log(offset: float = 0.0, seed: int = 0) -> IOData:
    rng = np.random.default_rng(seed)
    u = np.cumsum(rng.normal(size=400)) * 0.05
    y = np.zeros(400)
    for t in range(1, 400):
        y[t] = 0.8 * y[t - 1] + 0.5 * (u[t - 1] - u[0])
    return IOData(u + offset, y, ts=0.02, input_names=["motor_position"], output_names=["incl"])


def test_a_model_saves_and_loads_its_preprocessing(tmp_path: Path) -> None:
    pipeline = Pipeline([Relative("motor_position"), LowPass("incl", 20.0, initial="steady")])
    model = fit_model(LinearARX(Lags.arx(1, 1)), _training_log(), pipeline)
    assert model.preprocessing_ is pipeline
    path = model.save(tmp_path / "m.npz")
    _, _, meta = read_model_file(path)
    assert meta["preprocessing"] == pipeline.to_list()
    loaded = load_model(path)
    assert loaded.preprocessing_ == pipeline
    assert describe_model(loaded)["preprocessing"] == pipeline.to_list()
    # A log with another encoder zero gives the same run once it is prepared like the training
    shifted = _training_log(offset=3.0)
    same = loaded.simulate(prepare_log(loaded, shifted)).y
    np.testing.assert_allclose(same, model.simulate(pipeline.apply(_training_log())).y)


def test_an_old_model_file_without_preprocessing_still_loads(tmp_path: Path) -> None:
    model = LinearARX(Lags.arx(1, 1)).fit(_training_log())
    path = model.save(tmp_path / "old.npz")
    class_name, arrays, meta = read_model_file(path)
    assert "preprocessing" not in meta
    loaded = load_model(path)
    assert loaded.preprocessing_ is None  # the model contract's "none" (models/facts.py)
    assert prepare_log(loaded, _training_log()) == _training_log()
    assert "preprocessing" not in describe_model(loaded)
    # A damaged entry is refused with the file, the step and the value named.
    meta["preprocessing"] = [{"step": "lowpass", "channel": "incl", "cutoff": "fast"}]
    write_model_file(tmp_path / "bad.npz", class_name, arrays, meta)
    with pytest.raises(
        ValueError, match=r"bad.npz: invalid LinearARX file: preprocessing\[0\].*'fast'"
    ):
        load_model(tmp_path / "bad.npz")


def test_map_channels_keeps_the_conditions() -> None:
    out = map_channels(_log(), {"inclination": "incl"})
    assert out.output_names == ("incl",) and dict(out.conditions) == {"payload": 0.2}
    assert dict(out.condition_units) == {"payload": "kg"} and out.name == "run.csv"
