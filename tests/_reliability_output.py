"""Reliability cases for what the command line shows (issue 39): it tells the truth and stays readable.

Tables and ``--help`` piped, progress when standard error is not a terminal, and options that
were accepted then silently not applied (the preprocessing of a MATLAB script, design's delay
and discretisation, select's lag text and lag-free methods). :mod:`test_reliability` lists them
in its table (``docs/reliability.md``); the tests beside them (``test_cli_output.py``,
``test_progress_plan.py``, ``test_export_preprocess.py``, ``test_design_options.py``,
``test_select_options.py``) check each in more detail.
"""

from __future__ import annotations

import io
import os
import re
from pathlib import Path

import numpy as np
import typer.main

import neckid
from _reliability_inputs import Case, cli, refused
from neckid import IOData, Lags
from neckid.data.preprocess import LowPass, Pipeline, Relative
from neckid.utils.progress import LineReporter, planned_task, reporting

INPUT = "motor_position_command_of_the_left_tendon"
OUTPUT = "inclination_filtered_by_the_imu_of_the_neck"


def _log(path: Path, seed: int, names: tuple[str, str] = (INPUT, OUTPUT), n: int = 300) -> Path:
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, n // 10), 10)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1] + 0.01 * rng.standard_normal()
    IOData(u, y, ts=0.02, input_names=[names[0]], output_names=[names[1]]).to_csv(path)
    return path


def _without_columns() -> dict[str, str]:
    """The environment without ``COLUMNS`` (a pipe has no width); restored by the caller."""
    saved = {k: os.environ.pop(k) for k in ("COLUMNS",) if k in os.environ}
    return saved


def _piped_tables(tmp: Path) -> None:
    saved = _without_columns()
    try:
        tests = [_log(tmp / f"spring_{k}_payload_400g_campaign_b_run1.csv", k) for k in (20, 10)]
        train = [_log(tmp / f"spring_{k}_payload_200g_train.csv", k + 1) for k in (20, 10)]
        code, shown = cli(
            "compare", *train, *(p for t in tests for p in ("--test", t)),
            "--inputs", INPUT, "--outputs", OUTPUT, "--methods", "arx",
        )  # fmt: skip
        assert code == 0 and "…" not in shown, shown
        for test in tests:
            assert re.search(rf"│ {test.name} +│ {OUTPUT} +│", shown), shown
        data = IOData.from_csv(train[0], [INPUT], [OUTPUT])
        model = neckid.LinearARX(Lags.arx(1, 1)).fit(data).save(tmp / "model.npz")
        code, shown = cli("validate", model, *tests)
        assert code == 0 and "…" not in shown and re.search(rf"│ {OUTPUT} +│", shown), shown
        code, shown = cli("info", tests[0])
        assert code == 0 and "…" not in shown and re.search(rf"│ {INPUT} +│", shown), shown
    finally:
        os.environ.update(saved)


def _piped_help(tmp: Path) -> None:
    from neckid.cli import app

    saved = _without_columns()
    try:
        for name in sorted(typer.main.get_command(app).commands):  # type: ignore[attr-defined]
            code, shown = cli(name, "--help")
            assert code == 0 and "…" not in shown, f"{name} --help cuts a word:\n{shown}"
        _, shown = cli("identify", "--help")
        assert "inclination=/imu/tilt:vector.x:output:deg" in shown, shown
    finally:
        os.environ.update(saved)


class _Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def _progress_lines(tmp: Path) -> None:
    stream, clock = io.StringIO(), _Clock()
    reporter = LineReporter(stream, clock=clock, heartbeat=None)
    units = [("arx, fold 1/1", "arx", 0.01), ("ss, fold 1/1", "ss", 0.3)]
    with (
        reporting(reporter),
        planned_task("fitting and scoring 2 candidates on 1 folds", units) as done,
    ):
        clock.now = 0.1
        done()  # arx in 0.1 s: ss, 30 times as costly, about 3 s
        for now in (5.0, 15.0, 25.0):  # one ss fit of 57 s, no step: a line every 10 s
            clock.now = now
            reporter.tick()
        clock.now = 57.1
        done()
    lines = stream.getvalue().splitlines()
    assert len(lines) == 4 and all(": ss, fold 1/1: 1/2 done" in line for line in lines[:3]), lines
    assert lines[0].endswith("longer than expected, time left not known") and lines[-1].endswith(
        "done in 57 s"
    ), lines


def _export_preprocessing(tmp: Path) -> None:
    data = IOData.from_csv(_log(tmp / "run.csv", 0, ("motor_position", "inclination")),
                           ["motor_position"], ["inclination"])  # fmt: skip
    model = neckid.LinearARX(Lags.arx(1, 1)).fit(data)
    model.preprocessing_ = Pipeline([Relative("motor_position")])
    simple = model.save(tmp / "relative.npz")
    code, _ = cli("export", simple, "--to", "tf")
    assert code == 0 and "U(:, 1) = U(:, 1) - U(1, 1);" in (tmp / "relative.m").read_text()
    model.preprocessing_ = Pipeline([Relative("motor_position"), LowPass("inclination", 1.0)])
    filtered = model.save(tmp / "filtered.npz")
    refused(
        "export", filtered, "--to", "tf",
        match=r"low-pass inclination at 1 rad/s cannot be written into a MATLAB script.*--force",
    )  # fmt: skip
    assert not (tmp / "filtered.m").exists()


def _design_options(tmp: Path) -> None:
    u = np.cumsum(np.random.default_rng(4).normal(0, 0.05, 400)) + 2.0
    y = np.zeros(400)
    for t in range(1, 400):
        y[t] = 0.6 * y[t - 1] + 2.8 * u[t - 1]
    data = IOData(u, y, ts=0.02, input_names=["motor_position"], output_names=["inclination"])
    model = neckid.LinearARX(Lags.arx(1, 1)).fit(data).save(tmp / "arx.npz")
    design = ("design", model, "--pm", "50", "--wc", "3", "--out", tmp / "c.json", "--force")
    code, shown = cli(*design)
    assert code == 0 and "computation delay: 1 sample (the default" in shown, shown
    refused(*design, "--delay", "100000000", match=r"'--delay'.*0 to 1000 samples.*got 100000000")
    refused(*design, "--discretisation", "oustaloup", match="applies to a fractional controller")


def _select_options(tmp: Path) -> None:
    logs = [_log(tmp / f"run{k}.csv", k, ("command", "inclination")) for k in (0, 1)]
    channels = ("--inputs", "command", "--outputs", "inclination")
    code, shown = cli("select", *logs, *channels, "--method", "arx", "--lags", "3/1")
    assert code == 0 and "note: --lags 3/...: the output lag 3 alone, y(t-3)" in shown, shown
    refused(
        "select",
        *logs,
        *channels,
        "--method",
        "ss",
        match=r"--method ss: select chooses among lag sets",
    )


def _unidentifiable(tmp: Path) -> None:
    rng = np.random.default_rng(0)
    y = np.cumsum(rng.normal(size=400)) * 0.01 + np.linspace(0.0, 1.0, 400)
    log = tmp / "rest.csv"
    IOData(np.ones(400), y, ts=0.02, input_names=["command"], output_names=["inclination"]).to_csv(
        log
    )
    channels = ("--inputs", "command", "--outputs", "inclination")
    code, shown = cli("identify", log, *channels, "--method", "ss", "--save", tmp / "ss.npz")
    said = " ".join(shown.split())
    assert code == 0 and "input 'command' is constant (1) over the training logs" in said, shown
    assert "Excite the system persistently" in said, shown
    short = tmp / "short.csv"
    IOData(
        np.ones(8), y[:8], ts=0.02, input_names=["command"], output_names=["inclination"]
    ).to_csv(short)
    refused("identify", short, *channels, "--method", "greybox-tanks", "--save", tmp / "t.npz",
            match=r"has 10 parameters to fit, and the training logs give only 8 output values")  # fmt: skip
    assert not (tmp / "t.npz").exists()


def _sizes_checked(tmp: Path) -> None:
    import neckid.utils.memory as memory

    log = _log(tmp / "run.csv", 0, ("command", "inclination"), n=3000)
    channels = ("--inputs", "command", "--outputs", "inclination")
    refused("identify", log, *channels, "--resample", "1e-12", "--save", tmp / "r.npz",
            match=r"every 1e-12 s .*\(--resample\) is far too short for this log")  # fmt: skip
    real = memory.available_bytes
    memory.available_bytes = lambda: 50 * 1024**2  # type: ignore[assignment]
    try:
        refused("identify", log, *channels, "--method", "ss", "--set", "order=40", "--save",
                tmp / "s.npz", match=r"refinement of order 40 .*give a smaller order \(--set order=N\)")  # fmt: skip
    finally:
        memory.available_bytes = real  # type: ignore[assignment]
    assert not (tmp / "r.npz").exists() and not (tmp / "s.npz").exists()


CASES = [
    Case("O1", "CLI", "`compare`, `validate`, `info` piped, with long log names (spring_20… and spring_10…) and channel names", "every name whole on its row: a table not on a terminal is as wide as it needs (with COLUMNS set, names wrap in their cells, never cut)", "correct", _piped_tables),
    Case("O2", "CLI", "`--help` of every command piped", "every example whole (120 columns when not a terminal), no word cut", "correct", _piped_help),
    Case("O3", "CLI", "`select` / `compare` with stderr not a terminal, one `ss` fit of 57 s after quick ARX folds", "a line every 10 s even inside the fit: the method, candidate and fold, and the time left from the candidates' registry costs (at least ... once a fold runs longer than expected)", "correct", _progress_lines),
    Case("O4", "CLI", "`export --to tf` of a model identified with `--relative` / `--offset`, or with `--lowpass`", "relative and offset written into the script as code on U and Y; refused: ... low-pass inclination at 1 rad/s cannot be written into a MATLAB script ...; --force writes it, its header and a warning say what is not applied", "clear", _export_preprocessing),
    Case("O5", "CLI", "`design` without `--delay`, with `--delay 100000000`, a PI with `--discretisation oustaloup`", "a line: computation delay: 1 sample (the default, neckid's simulated loop; ... give --delay 0) / refused: '--delay': ... 0 to 1000 samples ...; got 100000000 / refused: --discretisation oustaloup applies to a fractional controller", "clear", _design_options),
    Case("O6", "CLI", "`select --lags 3/1`; `select --method ss` (a lag-free method)", "note: --lags 3/...: the output lag 3 alone, y(t-3) ... / refused: --method ss: select chooses among lag sets, and ss reads no lags ...: fit it with neckid identify --method ss", "clear", _select_options),
    Case("O7", "CLI", "`identify --method ss` / `greybox-neck` on a constant input; `greybox-tanks` (10 parameters) on 8 samples", "a warning: SubspaceStateSpace: input 'command' is constant (1) over the training logs: ... not identifiable ... Excite the system persistently ... / refused: GreyBoxODE (cascaded-tanks) has 10 parameters to fit, and the training logs give only 8 output values", "clear", _unidentifiable),
    Case("O8", "CLI", "`--resample 1e-12` on a log at 0.02 s; `identify --method ss --set order=40` beyond the memory there is", "refused before allocating: resampling run.csv ... every 1e-12 s ... needs about ... TB ...: the resampling period 1e-12 s (--resample) is far too short ... / the free-run refinement of order 40 ... needs about ...: give a smaller order (--set order=N)", "clear", _sizes_checked),
]  # fmt: skip
