"""``select`` says what identify says about ``--lags 3/1`` and refuses a method without lags (issue 39)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from neckid import IOData
from neckid.cli import app
from neckid.registry import methods

runner = CliRunner()


def _logs(folder: Path) -> list[str]:
    paths = []
    for seed in (0, 1):
        rng = np.random.default_rng(seed)
        u = np.repeat(rng.uniform(-1, 1, 30), 10)
        y = np.zeros(300)
        for t in range(1, 300):
            y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
        path = folder / f"run{seed}.csv"
        IOData(u, y, ts=0.02, input_names=["command"], output_names=["inclination"]).to_csv(path)
        paths.append(str(path))
    return paths


CHANNELS = ("--inputs", "command", "--outputs", "inclination")


def test_a_lone_output_lag_gets_identifys_note(tmp_path: Path) -> None:
    result = runner.invoke(
        app,
        [
            "select",
            *_logs(tmp_path),
            *CHANNELS,
            "--method",
            "arx",
            "--lags",
            "3/1",
            "--lags",
            "1/1",
        ],
    )
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    assert "note: --lags 3/...: the output lag 3 alone, y(t-3); for the lags 1 to 3 write" in text
    assert text.count("note: --lags") == 1  # 1/1 is no lone lag


@pytest.mark.parametrize("method", [m.name for m in methods().values() if m.lag_free])
def test_a_method_without_lags_is_refused_naming_it(tmp_path: Path, method: str) -> None:
    save = tmp_path / "model.npz"
    result = runner.invoke(
        app, ["select", *_logs(tmp_path), *CHANNELS, "--method", method, "--save", str(save)]
    )
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert lines[0].startswith(f"error: --method {method}: select chooses among lag sets")
    assert f"neckid identify --method {method}" in lines[0] and not save.exists()
