"""The command line's preprocessing (stored in the model, applied again) and --map everywhere."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from neckid import IOData, load_model
from neckid.cli import app
from neckid.data.preprocess import Pipeline, Relative, Tilt

runner = CliRunner()

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
SOFTNECK = SHARED_DATA / "softneck"
needs_softneck = pytest.mark.skipif(
    not SOFTNECK.is_dir(), reason=f"the shared soft-neck logs are not at {SOFTNECK}"
)


def _plain(text: str) -> str:
    return re.sub(r"\s+", " ", text)


def _fits(output: str, channel: str) -> list[float]:
    """The fit column of every table row of ``channel`` in a command's output."""
    rows = [line.split("│") for line in output.splitlines() if f"│ {channel} " in line]
    return [float(row[2]) for row in rows]


def _motor_log(path: Path, offset: float, seed: int, **extra: object) -> None:
    """A motor position that starts at ``offset`` (another encoder zero) -> an inclination."""
    rng = np.random.default_rng(seed)
    steps = np.repeat(rng.uniform(-1, 1, size=40), 20) * 0.05
    position = np.concatenate([[0.0], np.cumsum(steps)[:-1]])  # at rest at 0 first
    incl = np.zeros(position.size)
    for t in range(1, position.size):
        incl[t] = 0.9 * incl[t - 1] + 2.0 * position[t - 1]
    frame = pd.DataFrame(
        {"time": 0.02 * np.arange(position.size), "pos": position + offset, "incl": incl}
    )
    for name, value in extra.items():
        frame[name] = value
    frame.to_csv(path, index=False)


def test_relative_is_stored_and_applied_to_every_new_log(tmp_path: Path) -> None:
    _motor_log(tmp_path / "train.csv", offset=0.0, seed=1)
    _motor_log(tmp_path / "other_zero.csv", offset=3.0, seed=2)
    model = tmp_path / "m.npz"
    common = ["--inputs", "pos", "--outputs", "incl", "--method", "arx", "--lags", "1/1"]
    result = runner.invoke(
        app, ["identify", str(tmp_path / "train.csv"), *common, "--save", str(model)]
    )
    assert result.exit_code == 0, result.output
    plain = runner.invoke(app, ["validate", str(model), str(tmp_path / "other_zero.csv")])
    assert plain.exit_code in (0, 3), plain.output
    result = runner.invoke(
        app,
        ["identify", str(tmp_path / "train.csv"), *common, "--relative", "pos", "--save",
         str(model), "--force"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "preprocessing stored in the model: relative pos" in result.output
    assert load_model(model).preprocessing_ == Pipeline([Relative("pos")])
    result = runner.invoke(app, ["validate", str(model), str(tmp_path / "other_zero.csv")])
    assert result.exit_code == 0, result.output
    assert "preprocessing from the model: relative pos" in result.output
    assert _fits(result.output, "incl")[0] > 99.0, result.output
    out = tmp_path / "sim.csv"
    result = runner.invoke(
        app, ["simulate", str(model), str(tmp_path / "other_zero.csv"), "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert "preprocessing from the model: relative pos" in result.output
    assert pd.read_csv(out)["pos"].iloc[0] == 0.0
    result = runner.invoke(app, ["info", str(model)])
    assert result.exit_code == 0 and "relative pos" in _plain(result.output), result.output
    result = runner.invoke(
        app, ["info", str(tmp_path / "other_zero.csv"), "--model", str(model), "--json"]
    )
    assert result.exit_code == 0, result.output
    read = json.loads(result.output)["as_model_reads_it"]
    assert read["preprocessing"] == [{"step": "relative", "channel": "pos"}]
    assert read["channels"]["pos"]["min"] <= 0.0 <= read["channels"]["pos"]["max"]


def test_every_preprocessing_option_is_stored_in_order(tmp_path: Path) -> None:
    _motor_log(tmp_path / "train.csv", offset=1.0, seed=1)
    model = tmp_path / "m.npz"
    result = runner.invoke(
        app,
        ["identify", str(tmp_path / "train.csv"), "--inputs", "pos", "--outputs", "incl",
         "--method", "arx", "--lags", "1-2/1", "--save", str(model), "--resample", "0.04",
         "--lowpass", "incl:20", "--offset", "incl:0:0.2", "--relative", "pos", "--restamp"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    steps = [s["step"] for s in load_model(model).preprocessing_.to_list()]
    assert steps == ["restamp", "relative", "offset", "lowpass", "resample"]
    assert load_model(model).ts_ == pytest.approx(0.04)
    result = runner.invoke(app, ["validate", str(model), str(tmp_path / "train.csv")])
    assert result.exit_code == 0, result.output
    assert "resample to 0.04 s" in _plain(result.output)


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (["--offset", "incl:0"], "--offset must look like CHANNEL:START:STOP"),
        (["--offset", "incl:2:1"], "--offset 'incl:2:1': the window needs 0 <= 'start' < 'stop'"),
        (["--lowpass", "incl:fast"], "--lowpass 'incl:fast': 'fast' is not a number"),
        (["--lowpass", "incl:-1"], "'cutoff' must be a positive number of rad/s"),
        (["--resample", "0"], "--resample '0.0': 'ts' must be a positive number of seconds"),
        (["--relative", "speed"], "has no channel 'speed'"),
    ],
)
def test_bad_preprocessing_options_say_what_is_wrong(
    tmp_path: Path, option: list[str], message: str
) -> None:
    _motor_log(tmp_path / "train.csv", offset=0.0, seed=1)
    result = runner.invoke(
        app,
        ["identify", str(tmp_path / "train.csv"), "--inputs", "pos", "--outputs", "incl",
         "--method", "arx", "--lags", "1/1", "--save", str(tmp_path / "m.npz"), *option],
    )  # fmt: skip
    assert result.exit_code == 2, result.output
    assert message in _plain(result.output)


def test_restamp_accepts_a_log_with_a_repeated_time_stamp(tmp_path: Path) -> None:
    _motor_log(tmp_path / "train.csv", offset=0.0, seed=1)
    frame = pd.read_csv(tmp_path / "train.csv")
    repeated = pd.concat([frame.iloc[:100], frame.iloc[99:100], frame.iloc[100:]])
    repeated.to_csv(tmp_path / "repeated.csv", index=False)
    args = ["identify", str(tmp_path / "repeated.csv"), "--inputs", "pos", "--outputs", "incl",
            "--method", "arx", "--lags", "1/1", "--save", str(tmp_path / "m.npz")]  # fmt: skip
    refused = runner.invoke(app, args)
    assert refused.exit_code == 2 and "repeated.csv" in refused.output, refused.output
    result = runner.invoke(app, [*args, "--restamp"])
    assert result.exit_code == 0, result.output
    assert _fits(result.output, "incl")[0] > 99.0
    result = runner.invoke(
        app, ["validate", str(tmp_path / "m.npz"), str(tmp_path / "repeated.csv")]
    )
    assert result.exit_code == 0 and "restamp" in result.output, result.output


def test_map_keeps_the_conditions_of_a_sidecar_and_of_condition(tmp_path: Path) -> None:
    for grams, seed in ((0, 1), (600, 2)):
        _motor_log(tmp_path / f"run{grams}.csv", offset=0.0, seed=seed)
        sidecar = {"payload": {"value": grams / 1000, "unit": "kg"}}
        (tmp_path / f"run{grams}.conditions.json").write_text(json.dumps(sidecar))
    model = tmp_path / "m.npz"
    result = runner.invoke(
        app,
        ["identify", str(tmp_path / "run0.csv"), str(tmp_path / "run600.csv"), "--inputs",
         "motor_position", "--outputs", "inclination", "--map", "motor_position=pos", "--map",
         "inclination=incl", "--use-conditions", "payload", "--method", "arx", "--lags", "1/1",
         "--save", str(model)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert load_model(model).input_names_ == ("motor_position", "payload")
    maps = ["--map", "motor_position=pos", "--map", "inclination=incl"]
    for log, extra in (("run600.csv", []), ("run0.csv", ["--condition", "payload=0.4kg"])):
        result = runner.invoke(app, ["validate", str(model), str(tmp_path / log), *maps, *extra])
        assert result.exit_code == 0, result.output
        assert _fits(result.output, "inclination"), result.output
    _motor_log(tmp_path / "bare.csv", offset=0.0, seed=3)
    result = runner.invoke(app, ["validate", str(model), str(tmp_path / "bare.csv"), *maps])
    assert result.exit_code == 2 and "condition 'payload'" in result.output
    result = runner.invoke(
        app, ["info", str(tmp_path / "run0.csv"), "--map", "inclination=incl", "--condition",
              "controller=pi"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "conditions: payload = 0.0 kg, controller = pi" in _plain(result.output)
    result = runner.invoke(
        app, ["info", str(tmp_path / "run0.csv"), "--map", "inclination=incl", "--json"]
    )
    described = json.loads(result.output)
    assert described["channels"]["inclination"]["column"] == "incl"
    assert described["conditions"] == {"payload": 0.0}
    result = runner.invoke(app, ["info", str(model)])
    assert re.search(r"conditions \(inputs\) +│ payload", result.output), result.output


def _sensor_csv(path: Path, seed: int) -> None:
    """A three-motor log whose tilt sensor columns are inclination_sensor, orientation_sensor."""
    from neckid.experiments.neck3d import excitation_positions
    from neckid.plant import SoftNeck

    q = excitation_positions(1200, 0.02, band=(0.05, 3.0), pretension=1.5, amplitude=2.5, seed=seed)
    velocity = np.vstack([np.full((150, 3), 1.5 / 3.0), np.diff(q, axis=0, prepend=q[:1]) / 0.02])
    log = SoftNeck(configuration="three_tendon", seed=seed).run(velocity)[150:]
    frame = pd.DataFrame(
        {
            "time": log.time,
            **{f"motor_{k}": log.channel(f"motor_position_{k}") for k in (1, 2, 3)},
            "inclination_sensor": log.channel("inclination"),
            "orientation_sensor": log.channel("orientation"),
        }
    )
    frame.to_csv(path, index=False)


def test_tilt_combines_with_map(tmp_path: Path) -> None:
    _sensor_csv(tmp_path / "train.csv", seed=1)
    _sensor_csv(tmp_path / "test.csv", seed=2)
    model = tmp_path / "tilt.npz"
    maps = ["--map", "inclination=inclination_sensor", "--map", "orientation=orientation_sensor"]
    result = runner.invoke(
        app,
        ["identify", str(tmp_path / "train.csv"), "--inputs", "motor_1,motor_2,motor_3",
         "--outputs", "inclination,orientation", "--tilt", *maps, "--method", "arx",
         "--lags", "1-2/1-3", "--save", str(model)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    loaded = load_model(model)
    assert loaded.output_names_ == ("tilt_x", "tilt_y")
    assert loaded.preprocessing_ == Pipeline([Tilt()])
    # The model knows its tilt step: --map is enough, and --tilt again is not applied twice.
    for extra in ([], ["--tilt"]):
        result = runner.invoke(
            app, ["validate", str(model), str(tmp_path / "test.csv"), *maps, *extra]
        )
        assert result.exit_code == 0, result.output
        assert "preprocessing from the model: tilt vector from inclination, orientation" in (
            _plain(result.output)
        )
        fits = _fits(result.output, "tilt_x") + _fits(result.output, "tilt_y")
        assert len(fits) == 2 and min(fits) > 90.0, result.output
    # The mapping travels with the model as the preprocessing does (issue 39): no --map needed.
    result = runner.invoke(app, ["validate", str(model), str(tmp_path / "test.csv")])
    assert result.exit_code == 0, result.output
    shown = "channel mapping from the model: --map inclination_sensor=inclination"
    assert shown in _plain(result.output).replace("\n", " ")
    fits = _fits(result.output, "tilt_x") + _fits(result.output, "tilt_y")
    assert len(fits) == 2 and min(fits) > 90.0, result.output
    assert loaded.channel_map_ == {
        "inclination_sensor": "inclination",
        "orientation_sensor": "orientation",
    }


def test_the_stored_mapping_is_skipped_for_a_log_that_already_names_the_channels(
    tmp_path: Path,
) -> None:
    """A model identified with --map on one rig validates on a log whose columns need none."""
    _sensor_csv(tmp_path / "train.csv", seed=1)
    renamed = pd.read_csv(tmp_path / "train.csv").rename(
        columns={"inclination_sensor": "inclination", "orientation_sensor": "orientation"}
    )
    renamed.to_csv(tmp_path / "plain.csv", index=False)
    model = tmp_path / "m.npz"
    maps = ["--map", "inclination=inclination_sensor", "--map", "orientation=orientation_sensor"]
    result = runner.invoke(
        app,
        ["identify", str(tmp_path / "train.csv"), "--inputs", "motor_1,motor_2,motor_3",
         "--outputs", "inclination,orientation", "--tilt", *maps, "--method", "arx",
         "--lags", "1-2/1-3", "--save", str(model)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["validate", str(model), str(tmp_path / "plain.csv")])
    assert result.exit_code == 0, result.output
    assert "channel mapping from the model" not in result.output
    info = runner.invoke(app, ["info", str(model)])
    assert "inclination_sensor=inclination" in _plain(info.output).replace("\n", " ")


def test_an_old_tilt_model_still_validates_with_tilt_and_map(tmp_path: Path) -> None:
    """A model without stored steps (older files): --tilt --map reads the renamed columns."""
    from neckid import Lags, LinearARX
    from neckid.cli.workflow import read_log

    _sensor_csv(tmp_path / "train.csv", seed=1)
    maps = {"inclination_sensor": "inclination", "orientation_sensor": "orientation"}
    data = read_log(
        tmp_path / "train.csv",
        ["motor_1", "motor_2", "motor_3"],
        ["inclination", "orientation"],
        tilt=True,
        maps=maps,
    )
    assert data.output_names == ("tilt_x", "tilt_y")
    LinearARX(Lags.arx(2, 3)).fit(data).save(tmp_path / "old.npz")
    result = runner.invoke(
        app,
        ["validate", str(tmp_path / "old.npz"), str(tmp_path / "train.csv"), "--tilt", "--map",
         "inclination=inclination_sensor", "--map", "orientation=orientation_sensor"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "preprocessing from the model" not in result.output


@needs_softneck
def test_a_step_log_validates_with_map_and_the_payload_of_its_file_name(tmp_path: Path) -> None:
    """The issue's example: the payload read from 400stepresponse.csv survives --map."""
    model = tmp_path / "pay.npz"
    stairs = [str(SOFTNECK / "stair" / f"ada{g}response.csv") for g in ("000", "600")]
    result = runner.invoke(
        app,
        ["identify", *stairs, "--layout", "softneck", "--inputs", "motor_position",
         "--outputs", "inclination_filtered", "--map", "inclination=inclination_filtered",
         "--relative", "motor_position", "--use-conditions", "payload", "--method", "arx",
         "--lags", "1-2/1", "--save", str(model)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    step = SOFTNECK / "step" / "400stepresponse.csv"
    result = runner.invoke(
        app,
        ["validate", str(model), str(step), "--layout", "softneck", "--map",
         "inclination=inclination_filtered"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert _fits(result.output, "inclination"), result.output


@needs_softneck
def test_the_cli_alone_reproduces_the_benchmark_single_log_arx_figures(tmp_path: Path) -> None:
    """Issue 30's done-when: --relative motor_position gives the benchmark's 72.7 / 85.1 / 83.8 %."""
    model = tmp_path / "m.npz"
    result = runner.invoke(
        app,
        ["identify", str(SOFTNECK / "stair" / "ada000response.csv"), "--layout", "softneck",
         "--inputs", "motor_position,motor_velocity", "--outputs", "inclination", "--relative",
         "motor_position", "--method", "arx", "--lags", "1-2/0-1", "--save", str(model)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    for name, expected in (("ada200", 72.7), ("fra000", 85.1), ("int400", 83.8)):
        log = SOFTNECK / "stair" / f"{name}response.csv"
        result = runner.invoke(app, ["validate", str(model), str(log), "--layout", "softneck"])
        assert result.exit_code == 0, result.output
        assert "preprocessing from the model: relative motor_position" in result.output
        assert _fits(result.output, "inclination")[0] == pytest.approx(expected, abs=0.1), name


def test_read_log_maps_before_the_pipeline_and_keeps_conditions(tmp_path: Path) -> None:
    from neckid.cli.workflow import read_log

    IOData(
        np.arange(5.0) + 2, np.arange(5.0), ts=0.1, input_names=["pos"], output_names=["incl"]
    ).to_csv(tmp_path / "run.csv")
    data = read_log(
        tmp_path / "run.csv",
        ["motor_position"],
        ["incl"],
        maps={"pos": "motor_position"},
        conditions=["payload=0.2kg"],
        preprocessing=Pipeline([Relative("motor_position")]),
    )
    np.testing.assert_array_equal(data.channel("motor_position"), np.arange(5.0))
    assert dict(data.conditions) == {"payload": 0.2}
