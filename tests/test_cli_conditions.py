"""The command line with experimental conditions: several logs, sidecars, --condition, --use-conditions."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import neckid
from neckid import IOData, load_model
from neckid.cli import app

runner = CliRunner()


def _plain(text: str) -> str:
    return re.sub(r"\s+", " ", text)


@pytest.fixture(scope="module")
def payload_logs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three runs whose offset grows with the payload; 0 g and 600 g have a sidecar, 300 g not."""
    folder = tmp_path_factory.mktemp("payload")
    rng = np.random.default_rng(0)
    for grams in (0, 300, 600):
        u = rng.normal(size=500)
        y = np.zeros(500)
        for t in range(1, 500):
            y[t] = 0.6 * y[t - 1] + u[t - 1] + 4.0 * grams / 1000
        IOData(u, y, ts=0.02, input_names=["cmd"], output_names=["incl"],
               output_units=["deg"]).to_csv(folder / f"run{grams}.csv")  # fmt: skip
        if grams != 300:
            sidecar = {"payload": {"value": grams / 1000, "unit": "kg"}, "controller": "pi"}
            (folder / f"run{grams}.conditions.json").write_text(json.dumps(sidecar))
    return folder


def _identify(folder: Path, *extra: str) -> object:
    return runner.invoke(
        app,
        ["identify", str(folder / "run0.csv"), str(folder / "run600.csv"), "--inputs", "cmd",
         "--outputs", "incl", "--method", "arx", "--lags", "1/1", "--save",
         str(folder / "model.npz"), "--force", *extra],
    )  # fmt: skip


def test_a_model_identified_on_two_payloads_runs_on_a_third(payload_logs: Path) -> None:
    result = _identify(payload_logs, "--use-conditions", "payload")
    assert result.exit_code == 0, result.output
    assert "run0.csv" in result.output and "run600.csv" in result.output
    model = load_model(payload_logs / "model.npz")
    assert model.input_names_ == ("cmd", "payload")
    assert model.training_ranges_["payload"] == (0.0, 0.6)

    missing = runner.invoke(app, ["validate", str(payload_logs / "model.npz"),
                                  str(payload_logs / "run300.csv")])  # fmt: skip
    assert missing.exit_code == 2
    assert "condition 'payload'" in _plain(missing.output)
    assert "Traceback" not in missing.output

    out = payload_logs / "sim.csv"
    given = runner.invoke(app, ["simulate", str(payload_logs / "model.npz"),
                                str(payload_logs / "run300.csv"), "--condition", "payload=0.3kg",
                                "--out", str(out), "--force"])  # fmt: skip
    assert given.exit_code == 0, given.output
    frame = pd.read_csv(out)
    assert frame["payload"].eq(0.3).all()
    measured = pd.read_csv(payload_logs / "run300.csv")["incl"].to_numpy()
    assert np.abs(frame["incl"].to_numpy()[1:] - measured[1:]).max() < 1e-6


def test_conditions_a_log_lacks_and_bad_values_are_named(payload_logs: Path) -> None:
    result = _identify(payload_logs, "--use-conditions", "speed")
    assert result.exit_code == 2
    assert "condition 'speed'" in _plain(result.output)
    bad = _identify(payload_logs, "--condition", "payload")
    assert bad.exit_code == 2
    assert "--condition takes name=value" in _plain(bad.output)
    label = _identify(payload_logs, "--use-conditions", "controller")  # a label: one-hot
    assert label.exit_code == 0, label.output
    assert neckid.load_model(payload_logs / "model.npz").input_names_ == ("cmd", "controller=pi")
    other = runner.invoke(app, ["validate", str(payload_logs / "model.npz"),
                                str(payload_logs / "run300.csv"), "--condition", "controller=ada"])  # fmt: skip
    assert other.exit_code == 2
    assert "controller='ada', a label the model was not identified with" in _plain(other.output)


def test_a_broken_sidecar_is_named(tmp_path: Path, payload_logs: Path) -> None:
    log = tmp_path / "run.csv"
    log.write_text((payload_logs / "run0.csv").read_text())
    (tmp_path / "run.conditions.json").write_text('{"payload": {"val": 1}}')
    result = runner.invoke(app, ["identify", str(log), "--inputs", "cmd", "--outputs", "incl",
                                 "--method", "arx", "--lags", "1/1", "--save",
                                 str(tmp_path / "m.npz")])  # fmt: skip
    assert result.exit_code == 2
    assert "run.conditions.json" in _plain(result.output)
