"""Units agree or are refused by name: runs fitted together, a model and a new log, a log given twice."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import neckid
from neckid import IOData, Lags, LinearARX
from neckid.cli import app

runner = CliRunner()


def _run(seed: int, output_unit: str = "deg", input_unit: str = "rad/s") -> IOData:
    rng = np.random.default_rng(seed)
    u = rng.normal(size=300)
    y = np.zeros(300)
    for t in range(1, 300):
        y[t] = 0.7 * y[t - 1] + u[t - 1]
    return IOData(u, y, ts=0.02, input_names=["cmd"], output_names=["incl"],
                  input_units=[input_unit], output_units=[output_unit], name=f"run{seed}")  # fmt: skip


def test_runs_fitted_together_must_agree_on_units() -> None:
    with pytest.raises(
        ValueError, match=r"data\[1\] \(run2\) has incl in rad, but data\[0\] \(run1\) in deg"
    ):
        LinearARX(Lags.arx(1, 1, 1)).fit([_run(1), _run(2, "rad")])
    LinearARX(Lags.arx(1, 1, 1)).fit([_run(1), _run(2, "")])  # an unknown unit is not checked


def test_a_model_refuses_a_log_in_other_units(tmp_path: Path) -> None:
    model = LinearARX(Lags.arx(1, 1, 1)).fit(_run(1))
    loaded = neckid.load_model(model.save(tmp_path / "m.npz"))
    assert loaded.input_units_ == ("rad/s",)
    for other, name in (
        (_run(2, "rad"), "incl in rad"),
        (_run(2, input_unit="deg/s"), "cmd in deg/s"),
    ):
        with pytest.raises(ValueError, match=rf"run2 has {name}, but the model was identified"):
            loaded.simulate(other)
    assert np.isfinite(loaded.simulate(_run(2)).y).all()


def test_the_same_log_given_twice_is_refused(tmp_path: Path) -> None:
    _run(1).to_csv(tmp_path / "run.csv")
    args = [
        "--inputs",
        "cmd",
        "--outputs",
        "incl",
        "--method",
        "arx",
        "--save",
        str(tmp_path / "m.npz"),
    ]
    twice = runner.invoke(
        app,
        [
            "identify",
            str(tmp_path / "run.csv"),
            str(tmp_path / ".." / tmp_path.name / "run.csv"),
            *args,
        ],
    )
    assert twice.exit_code == 2
    assert "is given twice" in re.sub(r"\s+", " ", twice.output)
    overlap = runner.invoke(app, ["compare", str(tmp_path / "run.csv"), "--test", str(tmp_path / "run.csv"),
                                  "--inputs", "cmd", "--outputs", "incl", "--methods", "arx"])  # fmt: skip
    assert overlap.exit_code == 2
    assert "a test log must not be a training log" in re.sub(r"\s+", " ", overlap.output)
