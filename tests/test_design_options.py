"""``design`` says the computation delay it used and refuses options that do not apply (issue 39)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from neckid import IOData, Lags, LinearARX
from neckid.cli import app

runner = CliRunner()


@pytest.fixture
def model(tmp_path: Path) -> Path:
    u = np.cumsum(np.random.default_rng(4).normal(0, 0.05, 400)) + 2.0
    y = np.zeros(400)
    for t in range(1, 400):
        y[t] = 0.6 * y[t - 1] + 2.8 * u[t - 1]
    data = IOData(u, y, ts=0.02, input_names=["motor_position"], output_names=["inclination"])
    return LinearARX(Lags.arx(1, 1)).fit(data).save(tmp_path / "arx.npz")


def _design(model: Path, *options: str) -> tuple[int, list[str]]:
    out = model.parent / "controller.json"
    result = runner.invoke(
        app,
        ["design", str(model), "--pm", "50", "--wc", "3", *options, "--out", str(out), "--force"],
    )
    return result.exit_code, [line for line in result.output.splitlines() if line.strip()]


def test_the_default_delay_is_said_and_a_given_one_named(model: Path) -> None:
    code, lines = _design(model)
    assert code == 0, lines
    assert "computation delay: 1 sample (the default, neckid's simulated loop;" in " ".join(lines)
    assert "--delay 0" in " ".join(lines)
    code, lines = _design(model, "--delay", "0")
    assert code == 0 and "computation delay: 0 sample(s) (--delay)" in lines, lines


def test_a_discretisation_for_a_pi_is_refused(model: Path) -> None:
    code, lines = _design(model, "--discretisation", "oustaloup")
    assert code == 2 and len(lines) == 1, lines
    assert "--discretisation oustaloup applies to a fractional controller" in lines[0]
    assert not (model.parent / "controller.json").exists()
    code, lines = _design(model, "--fractional", "--discretisation", "oustaloup")
    assert code == 0 and "discretisation oustaloup" in " ".join(lines), lines


def test_a_huge_delay_is_refused_before_any_allocation(model: Path) -> None:
    code, lines = _design(model, "--delay", "100000000")
    assert code == 2 and len(lines) == 1, lines
    assert "--delay" in lines[0] and "100000000" in lines[0] and "0 to 1000 samples" in lines[0], (
        lines
    )
