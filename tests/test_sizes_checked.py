"""Sizes checked before they reach the allocator (issue 39): a tiny ``--resample`` step, an ``ss``
order in the hundreds. Each is refused in one line naming the option and the value, exit 2."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import neckid.utils.memory as memory
from neckid import IOData
from neckid.cli import app
from neckid.models.linear.subspace import SubspaceStateSpace

runner = CliRunner()


def _data(n: int = 2000) -> IOData:
    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(-1, 1, n // 10), 10)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    return IOData(u, y, ts=0.02, input_names=["command"], output_names=["inclination"])


def _one_line(result) -> str:
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1 and lines[0].startswith("error: "), (
        result.output
    )
    return lines[0]


@pytest.mark.parametrize("step", ["1e-12", "1e-320"])
def test_a_tiny_resample_step_is_refused_naming_it(tmp_path: Path, step: str) -> None:
    log = tmp_path / "run.csv"
    _data(400).to_csv(log)
    save = tmp_path / "model.npz"
    args = ["identify", str(log), "--inputs", "command", "--outputs", "inclination"]
    line = _one_line(runner.invoke(app, [*args, "--resample", step, "--save", str(save)]))
    assert "(--resample) is far too short for this log" in line and "0.02 s" in line, line
    assert f"every {float(step):g} s" in line and not save.exists()


def test_an_ss_order_in_the_hundreds_is_refused_before_the_refinement(monkeypatch) -> None:
    monkeypatch.setattr(memory, "available_bytes", lambda: 50 * 1024**2)
    with pytest.raises(
        ValueError, match=r"the free-run refinement of order 50 .*give a smaller order"
    ):
        SubspaceStateSpace(order=50).fit(_data())
    SubspaceStateSpace(order=2).fit(_data())  # a small order fits in the same memory


def test_the_command_line_names_the_order(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(memory, "available_bytes", lambda: 50 * 1024**2)
    log = tmp_path / "run.csv"
    _data().to_csv(log)
    args = [
        "identify",
        str(log),
        "--inputs",
        "command",
        "--outputs",
        "inclination",
        "--method",
        "ss",
    ]
    line = _one_line(
        runner.invoke(app, [*args, "--set", "order=50", "--save", str(tmp_path / "m.npz")])
    )
    assert "order 50" in line and "--set order=N" in line, line
