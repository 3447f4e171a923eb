"""What the command line prints stays readable when it is not a terminal (issue 39).

``typer.testing.CliRunner`` is not a terminal, as a pipe, a file or a CI log is not: the tables
of ``compare``, ``validate`` and ``info`` keep the names that tell their rows apart whole (long
log names that differ only past their 10th character, long channel names), and every command's
``--help`` keeps its examples whole.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import typer.main
from typer.testing import CliRunner

from neckid import IOData, Lags, LinearARX
from neckid.cli import app

runner = CliRunner()

#: Channel names longer than a column of an 80-column table.
INPUT = "motor_position_command_of_the_left_tendon"
OUTPUT = "inclination_filtered_by_the_imu_of_the_neck"
#: Test logs that differ only after their 10th character ("spring_20…" and "spring_10…").
TESTS = ("spring_20_payload_400g_campaign_b_run1.csv", "spring_10_payload_400g_campaign_b_run1.csv")
TRAIN = (
    "spring_20_payload_200g_campaign_b_train.csv",
    "spring_10_payload_200g_campaign_b_train.csv",
)


def _log(path: Path, seed: int, n: int = 300) -> Path:
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, n // 10), 10)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1] + 0.01 * rng.standard_normal()
    IOData(u, y, ts=0.02, input_names=[INPUT], output_names=[OUTPUT]).to_csv(path)
    return path


@pytest.fixture
def logs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, Path]:
    monkeypatch.delenv("COLUMNS", raising=False)
    return {name: _log(tmp_path / name, seed) for seed, name in enumerate((*TRAIN, *TESTS))}


def _run(*args: object, env: dict[str, str] | None = None) -> str:
    result = runner.invoke(app, [str(a) for a in args], env=env)
    assert result.exit_code == 0, result.output
    assert "…" not in result.output, result.output  # nothing cut with an ellipsis
    return result.output


def test_compare_keeps_the_test_logs_names_whole(logs: dict[str, Path]) -> None:
    train = [logs[name] for name in TRAIN]
    tests = [part for name in TESTS for part in ("--test", logs[name])]
    shown = _run(
        "compare", *train, *tests, "--inputs", INPUT, "--outputs", OUTPUT, "--methods", "arx"
    )
    rows = [line for line in shown.splitlines() if line.startswith("│ arx")]
    # one row per test log, naming its log and output in full on one line, and the mean
    assert [
        re.search(rf"│ ({'|'.join(TESTS)}) +│ {OUTPUT} +│", row) is not None for row in rows
    ] == [
        True,
        True,
        False,
    ], shown


def test_validate_and_info_keep_channel_names_whole(logs: dict[str, Path], tmp_path: Path) -> None:
    data = IOData.from_csv(logs[TRAIN[0]], [INPUT], [OUTPUT])
    model = LinearARX(Lags.arx(1, 1)).fit(data).save(tmp_path / "model.npz")
    shown = _run("validate", model, *(logs[name] for name in TESTS))
    for name in TESTS:
        assert f"on {name} (free run)" in shown, shown
    assert re.search(rf"│ {OUTPUT} +│", shown), shown
    described = _run("info", logs[TESTS[0]])
    for channel in (INPUT, OUTPUT):
        assert re.search(rf"│ {channel} +│", described), described
    with_model = _run("info", logs[TESTS[0]], "--model", model)
    assert re.search(rf"│ {OUTPUT} +│ output", with_model), with_model


def test_info_shows_brackets_in_channel_names_as_written(tmp_path: Path) -> None:
    """A channel ``inclination [deg]`` is text, not rich markup: its brackets stay."""
    u = np.linspace(-1.0, 1.0, 60)
    y = np.convolve(u, [0.0, 0.5, 0.3])[:60]
    data = IOData(u, y, ts=0.02, input_names=["cmd [V]"], output_names=["inclination [deg]"])
    log = tmp_path / "run.csv"
    data.to_csv(log)
    model = LinearARX(Lags.arx(1, 1)).fit(data).save(tmp_path / "model.npz")
    described = _run("info", log)
    assert "cmd [V]" in described and "inclination [deg]" in described, described
    about = _run("info", model)
    assert "training range of inclination [deg]" in about, about


def test_a_narrow_console_wraps_names_and_never_cuts_them(logs: dict[str, Path]) -> None:
    """``COLUMNS`` set by the user still wins: the names then wrap in their cells."""
    shown = _run("info", logs[TESTS[0]], env={"COLUMNS": "40"})
    cells = "".join(
        line.split("│")[1].strip() for line in shown.splitlines() if line.count("│") > 2
    )
    assert INPUT in cells and OUTPUT in cells, shown


#: Examples of ``--help`` longer than a column of 80, as the help text spells them.
EXAMPLES = (
    "inclination=/imu/tilt:vector.x:output:deg",
    "NAME=TOPIC:FIELD:KIND[:UNIT]",
    "MODEL_CHANNEL=LOG_CHANNEL:",
    "inclination=inclination_filtered",
    "OUTPUT_LAGS/INPUT_LAGS,",
)


def test_every_commands_help_is_whole_when_piped(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("COLUMNS", raising=False)
    commands = sorted(typer.main.get_command(app).commands)  # type: ignore[attr-defined]
    seen = set()
    for name in commands:
        shown = runner.invoke(app, [name, "--help"]).output
        assert "…" not in shown, f"neckid {name} --help cuts a word:\n{shown}"
        seen.update(example for example in EXAMPLES if example in shown)
    assert seen == set(EXAMPLES)
