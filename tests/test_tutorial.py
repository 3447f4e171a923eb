"""The tutorial (docs/tutorial.md) runs as written on the shared soft-neck logs.

Every ``$ neckid ...`` line of the page's ``console`` blocks is run, in order, in one temporary
folder, with ``../shared/data`` replaced by where the shared data are; ``$ export NAME=VALUE``
lines set a variable that later commands read as ``$NAME``. Each command must exit 0 and print
what the page says it prints (``EXPECTED``). Without the shared logs the test is skipped, saying
why. Run alone: ``python tests/test_tutorial.py`` prints every command's output (to refresh the
page's trimmed copies).
"""

from __future__ import annotations

import os
import re
import shlex
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "tutorial.md"
DATA = ROOT.parent / "shared" / "data"

#: What each command of the page must print, by its position among the page's commands (the
#: numbers the page's readers see in its output; a change of the output that the page explains
#: fails here). The count is checked too: a command added to the page needs its row.
EXPECTED: list[tuple[str, list[str]]] = [
    ("info", ["2804 samples over 70.08 s, ts = 0.025 s", "conditions: payload = 0.0 kg"]),
    ("identify", ["model saved to absolute.npz"]),
    (
        "identify",
        ["preprocessing stored in the model: relative motor_position", "model saved to arx.npz"],
    ),
    ("select", ["chosen: --lags", "saved to arx.npz"]),
    ("compare", ["recommended:", "comparison written to compare.json"]),
    ("validate", ["in the loop with int", "controller check", "results written to loop.json"]),
    ("design", ["phase margin 50.00 deg at 3.0000 rad/s", "controller written to controller.json"]),
    ("validate", ["in the loop with DesignedController", "tracking-error RMS"]),
    ("export", ["written to arx.json"]),
    ("export", ["written to arx_tf.m"]),
]


def commands(text: str) -> list[str]:
    """The ``$ ...`` lines of the page's console blocks, continuation lines joined."""
    found: list[str] = []
    for block in re.findall(r"```console\n(.*?)```", text, flags=re.DOTALL):
        lines = block.splitlines()
        i = 0
        while i < len(lines):
            line = lines[i]
            if line.startswith("$ "):
                command = line[2:]
                while command.endswith("\\") and i + 1 < len(lines):
                    i += 1
                    command = command[:-1].rstrip() + " " + lines[i].strip()
                found.append(command.strip())
            i += 1
    return found


def resolved(command_lines: list[str], data: Path) -> list[list[str]]:
    """The ``neckid`` commands as argument lists, data path and variables substituted."""
    variables: dict[str, str] = {}
    out: list[list[str]] = []
    for line in command_lines:
        line = line.replace("../shared/data", str(data))
        for name, value in variables.items():
            line = line.replace(f"${name}", value)
        words = shlex.split(line)
        if words[0] == "export":
            name, value = words[1].split("=", 1)
            variables[name] = value
            continue
        assert words[0] == "neckid", f"the tutorial runs neckid commands only: {line}"
        out.append(words[1:])
    return out


def test_the_tutorial_lists_its_commands() -> None:
    """Without the data too: the page holds the commands the test knows (nothing to skip)."""
    lines = commands(PAGE.read_text(encoding="utf-8"))
    args = resolved(lines, DATA)
    assert [a[0] for a in args] == [name for name, _ in EXPECTED]
    assert all("../shared/data" not in " ".join(a) for a in args)


@pytest.mark.skipif(
    not (DATA / "softneck" / "stair" / "int000response.csv").exists(),
    reason="the shared soft-neck logs (../shared/data/softneck) are not on this machine",
)
def test_the_tutorial_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from neckid.cli import app

    runner = CliRunner()
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "120")
    args = resolved(commands(PAGE.read_text(encoding="utf-8")), DATA)
    for words, (name, expected) in zip(args, EXPECTED, strict=True):
        assert words[0] == name
        result = runner.invoke(app, words)
        shown = " ".join(words)
        assert result.exit_code == 0, f"neckid {shown}\n{result.output}"
        for text in expected:
            assert text in result.output, f"neckid {shown}: {text!r} not in\n{result.output}"
    for name in (
        "absolute.npz",
        "arx.npz",
        "compare.json",
        "loop.json",
        "controller.json",
        "arx.json",
    ):
        assert (tmp_path / name).stat().st_size > 0, name


if __name__ == "__main__":
    from neckid.cli import app

    os.environ.setdefault("COLUMNS", "120")
    os.chdir(sys.argv[1] if len(sys.argv) > 1 else os.getcwd())
    for words in resolved(commands(PAGE.read_text(encoding="utf-8")), DATA):
        print("$ neckid " + " ".join(words), flush=True)
        result = CliRunner().invoke(app, words)
        print(result.output, f"[exit {result.exit_code}]", flush=True)
