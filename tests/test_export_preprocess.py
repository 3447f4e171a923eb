"""``export --to tf`` carries the model's preprocessing into the MATLAB script, or refuses (issue 39).

A model identified with ``--relative`` / ``--offset`` takes the preprocessed channels; a MATLAB
user feeding the raw log to a script that omits them would get another model's answer.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from typer.testing import CliRunner

from neckid import IOData, Lags, LinearARX
from neckid.cli import app
from neckid.data.preprocess import LowPass, Pipeline, Relative, RemoveOffset

runner = CliRunner()


def _model(tmp_path: Path, steps: list) -> Path:
    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(-1, 1, 30), 10)
    y = np.zeros(300)
    for t in range(1, 300):
        y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    data = IOData(u, y, ts=0.02, input_names=["motor_position"], output_names=["inclination"])
    model = LinearARX(Lags.arx(1, 1)).fit(data)
    model.preprocessing_ = Pipeline(steps)
    return model.save(tmp_path / "model.npz")


def test_relative_and_offset_are_written_as_code(tmp_path: Path) -> None:
    model = _model(tmp_path, [Relative("motor_position"), RemoveOffset("inclination", 0.0, 2.0)])
    result = runner.invoke(app, ["export", str(model), "--to", "tf"])
    assert result.exit_code == 0, result.output
    script = (tmp_path / "model.m").read_text()
    body = script.splitlines()
    start = body.index("if exist('U', 'var') && exist('Y', 'var')")
    assert (
        body.index("Ts = 0.02;  % sampling period [s]")
        < start
        < body.index("G = tf(num, den, Ts, 'InputName', input_names, 'OutputName', output_names);")
    )
    assert body[start + 1] == "  U(:, 1) = U(:, 1) - U(1, 1);  % relative motor_position"
    assert body[start + 2] == (
        "  Y(:, 1) = Y(:, 1) - mean(Y((0:size(Y, 1) - 1)' * Ts >= 0.0 - 1e-9 * Ts &"
        " (0:size(Y, 1) - 1)' * Ts < 2.0 - 1e-9 * Ts, 1));  % offset of inclination over 0..2 s"
    )
    assert body[start + 3] == "end" and "warning" not in result.output


def test_a_step_matlab_cannot_carry_is_refused_unless_forced(tmp_path: Path) -> None:
    model = _model(tmp_path, [Relative("motor_position"), LowPass("inclination", 1.0)])
    refused = runner.invoke(app, ["export", str(model), "--to", "tf"])
    lines = [line for line in refused.output.splitlines() if line.strip()]
    assert refused.exit_code == 2 and len(lines) == 1, refused.output
    assert "low-pass inclination at 1 rad/s" in lines[0] and "--force" in lines[0], refused.output
    assert not (tmp_path / "model.m").exists()
    forced = runner.invoke(app, ["export", str(model), "--to", "tf", "--force"])
    assert forced.exit_code == 0, forced.output
    assert (
        "warning:" in forced.output and "does not apply the model's preprocessing" in forced.output
    )
    script = (tmp_path / "model.m").read_text()
    assert "% NOT APPLIED (not writable as MATLAB code): low-pass inclination at 1 rad/s" in script
    assert "  U(:, 1) = U(:, 1) - U(1, 1);  % relative motor_position" in script
