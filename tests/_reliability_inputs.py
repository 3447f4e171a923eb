"""Reliability cases for the held-out campaign's classes of bad data, files and model files.

One case per class (issue 39): numbers that are not what they look like, inputs that contradict
or are incomplete, messages that must name what the user typed, the environment, the same run
under another name, refusals in the user's words, model files checked in full, names in
exports. :mod:`test_reliability` lists them in its table (``docs/reliability.md``).
"""

from __future__ import annotations

import datetime
import errno
import json
import os
import re
import shutil
import sys
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import neckid
from neckid import IOData, Lags
from neckid.cli import app

runner = CliRunner()


@dataclass(frozen=True)
class Case:
    """What the user does, what they see, and the check (as :class:`test_reliability.Case`)."""

    id: str
    surface: str
    given: str
    sees: str
    outcome: str
    check: Callable[[Path], None]


def cli(*args: object) -> tuple[int, str]:
    result = runner.invoke(app, [str(a) for a in args])
    output = result.output
    assert "Traceback" not in output, output
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise AssertionError(f"an exception escaped the CLI: {result.exception!r}\n{output}")
    return result.exit_code, output


def refused(*args: object, match: str) -> str:
    """The command exits 2 with one ``error:`` line that matches ``match``."""
    code, output = cli(*args)
    assert code == 2, output
    lines = [line for line in output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), output
    assert re.search(match, lines[0]), output
    return lines[0]


def _log(folder: Path, name: str = "run.csv", seed: int = 0, n: int = 300) -> Path:
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, n // 10), 10)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    path = folder / name
    IOData(u, y, ts=0.02, input_names=["command"], output_names=["inclination"]).to_csv(path)
    return path


def _model(folder: Path, log: Path, name: str = "model.npz") -> Path:
    data = IOData.from_csv(log, ["command"], ["inclination"])
    return neckid.LinearARX(Lags.arx(1, 1)).fit(data).save(folder / name)


READ = ("--inputs", "command", "--outputs", "inclination")


# ---------------------------------------------------------------------------- I1 numbers
def _numbers_not_what_they_look(tmp: Path) -> None:
    counts = np.arange(2**56, 2**56 + 500, dtype=np.uint64)  # 500 counts, 32 floats
    with pytest.raises(ValueError, match=r"u channel 'encoder' holds the whole number 72057594"):
        IOData(counts, np.zeros(500), ts=0.01, input_names=["encoder"])
    with pytest.raises(ValueError, match=r"u channel 'big' holds the whole number 1000.*digits"):
        IOData([10**400, 1, 2], [0.0, 1, 2], ts=0.1, input_names=["big"])
    with pytest.raises(ValueError, match="ts must be a positive number of seconds"):
        IOData([1.0, 2.0], ts=10**400)
    data = IOData.from_csv(_log(tmp), ["command"], ["inclination"])
    with pytest.raises(ValueError, match=r"ridge must be a number >= 0; got a whole number of 401"):
        neckid.LinearARX(Lags.arx(1, 1), ridge=10**400).fit(data)
    with pytest.raises(TypeError, match=r"u channel 'when' holds dates \(datetime64\)"):
        IOData(np.arange(5).astype("datetime64[D]"), ts=1.0, input_names=["when"])
    with pytest.raises(TypeError, match=r"y channel 'day' holds date values \(row 0"):
        IOData([1.0, 2.0], [datetime.date(2024, 1, 1)] * 2, ts=1.0, output_names=["day"])
    frame = pd.read_csv(_log(tmp))
    frame["command"] = pd.date_range("2024-01-01", periods=len(frame), freq="20ms")
    frame.to_parquet(tmp / "dates.parquet")
    refused("identify", tmp / "dates.parquet", *READ, "--save", tmp / "model.npz",
            match=r"column 'command' holds datetimes")  # fmt: skip
    assert not (tmp / "model.npz").exists()


# ---------------------------------------------------------------------------- I2 contradictions
def _contradicting_or_incomplete(tmp: Path) -> None:
    log = _log(tmp)
    text = log.read_text().rstrip("\n")
    cut = tmp / "writing.csv"
    cut.write_text(text[:-4])  # the last number cut short, no line break
    with pytest.warns(UserWarning, match=r"writing.csv: the last line \(row 299, .*no line break"):
        data = IOData.from_csv(cut, ["command"], ["inclination"])
    assert data.n_samples == 299
    code, output = cli("info", cut)
    assert code == 0 and "warning: writing.csv: the last line (row 299" in output, output
    refused(
        "identify", log, *READ, "--ts", "0.01", "--save", tmp / "m.npz",
        match=r"ts=0.01 s \(--ts\) contradicts the time column 'time', whose stamps are 0.02 s",
    )  # fmt: skip
    assert IOData.from_csv(log, ["command"], ["inclination"], ts=0.02).ts == 0.02  # agrees
    frame = pd.read_csv(log)
    frame.insert(0, "time [ms]", frame.pop("time") * 1000)
    frame.to_csv(tmp / "ms.csv", index=False)
    assert IOData.from_csv(tmp / "ms.csv", ["command"], time="time [ms]").ts == pytest.approx(0.02)
    code, output = cli("info", tmp / "ms.csv", "--time", "time [ms]")
    assert code == 0 and "ts = 0.02 s" in output, output
    frame.rename(columns={"time [ms]": "time [ticks]"}).to_csv(tmp / "ticks.csv", index=False)
    refused(
        "identify", tmp / "ticks.csv", *READ, "--time", "time [ticks]",
        match=r"time column 'time \[ticks\]' is in 'ticks' .*not a unit of time",
    )  # fmt: skip


# ---------------------------------------------------------------------------- I3 messages
def _messages_name_what_was_typed(tmp: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    upper = tmp / "MODEL.NPZ"
    shutil.copy(model, upper)
    code, output = cli("info", upper)
    assert code == 0 and "LinearARX" in output, output
    refused("identify", upper, *READ, match=r"MODEL.NPZ is a NumPy .npz archive .*not a CSV log")
    commented = tmp / "commented.csv"
    commented.write_text("# bench 3, 2024-05-02\n" + log.read_text())
    assert IOData.from_csv(commented, ["command"], ["inclination"]).n_samples == 300
    commented.write_text("# bench 3\n#" + log.read_text())  # the header itself commented
    assert IOData.from_csv(commented, ["command"], ["inclination"]).n_samples == 300
    refused(
        "validate", model, log, "--map", "nosuch=command",
        match=r"--map nosuch=command: the model has no channel 'nosuch' \(it reads command,",
    )  # fmt: skip
    (tmp / "out").mkdir()
    refused("simulate", model, log, "--out", tmp / "out", match=r"--out .*out' is a folder; give")
    line = refused("identify", match=r"neckid identify: Missing argument 'LOG...'")
    assert "╭" not in line
    refused("validate", model, log, "--ts", "abc", match=r"Invalid value for '--ts'")
    with pytest.raises(TypeError, match=r"initial must be numbers: .*got str 'abc'"):
        neckid.load_model(model).simulate(IOData.from_csv(log, ["command"]), initial="abc")
    with pytest.raises(ValueError, match=r"initial must have shape \(1,\) or \(1, 1\); got \(3,\)"):
        neckid.load_model(model).simulate(IOData.from_csv(log, ["command"]), initial=[1, 2, 3])

    def full(target: Path) -> tuple[Path, int]:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(target))

    monkeypatch.setattr("neckid.utils.files._temporary", full)
    refused(
        "simulate", model, log, "--out", tmp / "sim.csv",
        match=r"no space left on the device holding .*sim.csv.: free some space",
    )  # fmt: skip
    assert not (tmp / "sim.csv").exists()


# ---------------------------------------------------------------------------- I4 environment
def _environment_not_internal(tmp: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = _log(tmp)
    IOData.from_csv(log, ["command"], ["inclination"]).to_parquet(tmp / "run.parquet")
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    refused(
        "identify", tmp / "run.parquet", *READ, "--save", tmp / "m.npz",
        match=r"reading run.parquet needs pyarrow, which is not installed: pip install"
        r" 'neckid\[parquet\]'",
    )  # fmt: skip
    refused(
        "identify", log, *READ, "--lags", "1-1000000000/1", "--save", tmp / "m.npz",
        match=r"--lags \(outputs\): lag 1000000000 in '1-1000000000' is beyond 100000 samples",
    )  # fmt: skip
    refused(
        "select", log, *READ, "--orders", "1-1000,1-1000,0-10",
        match=r"--orders 1-1000,1-1000,0-10: 11000000 candidates",
    )  # fmt: skip
    assert not (tmp / "m.npz").exists()


# ---------------------------------------------------------------------------- I5 the same run
def _same_run_under_another_name(tmp: Path) -> None:
    log, other = _log(tmp), _log(tmp, "other.csv", seed=1)
    os.link(log, tmp / "linked.csv")
    shutil.copy(log, tmp / "copy.csv")
    save = ("--save", tmp / "m.npz")
    refused("identify", log, tmp / "linked.csv", *READ, *save, match=r"linked.csv is given twice"
            r" \(a hard link to .*run.csv\): the same log would count twice")  # fmt: skip
    refused("identify", log, tmp / "copy.csv", *READ, *save,
            match=r"copy.csv holds the same bytes as .*run.csv \(a copy of one run\)")  # fmt: skip
    refused("select", log, tmp / "linked.csv", *READ, match="a hard link to")
    refused("compare", log, other, "--test", tmp / "copy.csv", *READ,
            match=r"copy.csv holds the same bytes as .*run.csv .*a test log must not be a"
            " training log")  # fmt: skip
    assert not (tmp / "m.npz").exists()


# ---------------------------------------------------------------------------- I6 internals
def _refusals_in_the_users_words(tmp: Path) -> None:
    log = _log(tmp)
    faster = tmp / "fast.csv"
    frame = pd.read_csv(_log(tmp, "b.csv", seed=1))
    frame["time"] /= 2
    frame.to_csv(faster, index=False)
    refused("identify", log, faster, *READ, "--save", tmp / "m.npz",
            match=r"fast.csv \(data\[1\]\) is sampled every 0.01 s, but run.csv \(data\[0\]\)"
            " every 0.02 s")  # fmt: skip
    refused("select", log, faster.with_name("b.csv"), *READ, "--jobs", "0",
            match=r"n_jobs \(--jobs\) must be a positive number of parallel workers, or -1")  # fmt: skip
    rest = pd.read_csv(log).assign(inclination=0.5)
    rest.to_csv(tmp / "rest.csv", index=False)
    refused("compare", log, "--test", faster.with_name("b.csv"), "--test", tmp / "rest.csv",
            *READ, match=r"test log rest.csv: its output 'inclination' is constant \(0.5")  # fmt: skip
    refused("select", log, tmp / "rest.csv", *READ,
            match=r"training log rest.csv: its output 'inclination' is constant")  # fmt: skip
    from neckid.design import load_controller

    with pytest.raises(ValueError, match=r"model.npz is a NumPy .npz archive .*not a controller"):
        load_controller(_model(tmp, log))
    refused("identify", log, *READ, "--method", "ss", "--set", "order=500", "--save",
            tmp / "m.npz", match=r"order=500 is too high for these logs \(300 samples\).*give an"
            " order of at most")  # fmt: skip
    refused("identify", log, *READ, "--method", "sm-parallel", "--set", "base=nope", "--save",
            tmp / "m.npz", match=r"base must be the name of a method .*got base='nope'")  # fmt: skip
    assert not (tmp / "m.npz").exists()


# ---------------------------------------------------------------------------- I7 model files
def _edit(path: Path, target: Path, **arrays: np.ndarray) -> Path:
    with np.load(path, allow_pickle=False) as archive:
        content = {k: archive[k] for k in archive.files}
    content.update(arrays)
    with target.open("wb") as handle:
        np.savez(handle, **content)
    return target


def _model_files_checked_in_full(tmp: Path) -> None:
    data = IOData.from_csv(_log(tmp, n=200), ["command"], ["inclination"])
    model = neckid.methods()["pnlss"].make(Lags.arx(1, 1))
    model.set_params(order=1, degree=2, max_iter=5)
    path = model.fit(data).save(tmp / "pnlss.npz")
    with np.load(path) as archive:
        low, high, powers = archive["low"], archive["high"], archive["powers"]
    swapped = _edit(path, tmp / "window.npz", low=high, high=low)
    refused("info", swapped, match=r"window.npz: invalid PolynomialStateSpace file: the monomial"
            r" window \[low, high\] of variable 0 is \[\S+, \S+\]: .*low < high")  # fmt: skip
    other = powers.copy()
    other[0] = other[-1]
    edited = _edit(path, tmp / "powers.npz", powers=other)
    refused("validate", edited, tmp / "run.csv",
            match=r"powers.npz: invalid PolynomialStateSpace file: powers row 0 is")  # fmt: skip
    assert neckid.load_model(path).simulate(data).y.shape == (200, 1)


# ---------------------------------------------------------------------------- I8 names in exports
def _names_in_exports(tmp: Path) -> None:
    log = _log(tmp)
    frame = pd.read_csv(log).rename(columns={"inclination": "incl\nination"})
    frame.to_csv(tmp / "newline.csv", index=False)  # a quoted header cell with a line break
    refused("identify", tmp / "newline.csv", "--inputs", "command", "--outputs", "incl\nination",
            match=r"newline.csv: output_names: channel name 'incl\\nination' holds the control"
            r" character '\\n'")  # fmt: skip
    model = _model(tmp, log)
    with np.load(model, allow_pickle=False) as archive:
        header = json.loads(str(archive["__neckid__"]))
    text = json.dumps(header).replace('"inclination', '"incl\\nination')  # every mention
    edited = _edit(model, tmp / "edited.npz", __neckid__=np.array(text))
    refused("export", edited, "--to", "tf", "--out", tmp / "model.m",
            match=r"edited.npz: invalid LinearARX file: .*control character")  # fmt: skip
    accents = pd.read_csv(log).rename(columns={"inclination": "inclinação"})
    accents.to_csv(tmp / "pt.csv", index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = IOData.from_csv(tmp / "pt.csv", ["command"], ["inclinação"])
    accented = neckid.LinearARX(Lags.arx(1, 1)).fit(data).save(tmp / "pt.npz")
    refused("export", accented, "--to", "mat", "--out", tmp / "pt.mat",
            match=r"model.output_names\{1\} is 'inclinação', which holds non-ASCII characters:"
            " a .mat file .* export --to json keeps the text")  # fmt: skip
    assert not (tmp / "pt.mat").exists() and not (tmp / "model.m").exists()
    code, output = cli("export", accented, "--to", "json", "--out", tmp / "pt.json")
    assert code == 0, output
    assert json.loads((tmp / "pt.json").read_text(encoding="utf-8"))["output_names"] == [
        "inclinação"
    ]


def _with_monkeypatch(check: Callable[[Path, pytest.MonkeyPatch], None]) -> Callable[[Path], None]:
    def run(tmp: Path) -> None:
        with pytest.MonkeyPatch.context() as monkeypatch:
            check(tmp, monkeypatch)

    return run


CASES = [
    Case("I1", "API/CLI", "whole numbers beyond 2**53 (encoder counts near 2**56), a Python integer beyond the float range (in a channel, `ts`, a setting), datetime64 or `date` values as a channel", "refused, naming the channel: u channel 'encoder' holds the whole number 72057594037927936 at row 0, beyond 2**53 ... / holds dates (datetime64), not numbers: convert them explicitly; never an OverflowError", "clear", _numbers_not_what_they_look),
    Case("I2", "API/CLI", "a log still being written (no line break after a number cut short); `--ts` that contradicts the time column; `--time 'time [ms]'`", "warning: the last line (row N, ...) has no line break ... it is left out / refused: ts=0.01 s (--ts) contradicts the time column 'time', whose stamps are 0.02 s apart / ms, us, ns, min, h in the header honoured (ts = 0.02 s); an unknown unit refused", "clear", _contradicting_or_incomplete),
    Case("I3", "API/CLI", "`MODEL.NPZ`; comment lines above the header (or `#time,...`); `--map` of a channel the model lacks; `--out` a folder; a usage error; `initial=` of the wrong type; a full disk", "read as a model / comments skipped / refused: --map nosuch=command: the model has no channel 'nosuch' (it reads ...) / --out '...' is a folder; give a file name / one line: neckid identify: Missing argument 'LOG...' / TypeError: initial must be numbers / no space left on the device holding ...", "clear", _with_monkeypatch(_messages_name_what_was_typed)),
    Case("I4", "CLI", "a Parquet log without pyarrow; `--lags 1-1000000000/1`; `--orders` ranges of 11 million candidates", "exit 2: reading run.parquet needs pyarrow, which is not installed: pip install 'neckid[parquet]' / refused before allocating: lag 1000000000 ... is beyond 100000 samples / 11000000 candidates ... narrow the ranges", "clear", _with_monkeypatch(_environment_not_internal)),
    Case("I5", "CLI", "a hard link or a byte-identical copy of a training log, as a second training log (identify, select) or as a test log (compare)", "refused: linked.csv is given twice (a hard link to run.csv) / copy.csv holds the same bytes as run.csv (a copy of one run) ... a test log must not be a training log", "clear", _same_run_under_another_name),
    Case("I6", "API/CLI", "logs at two sampling periods; `--jobs 0`; a log of a neck at rest in `compare` or `select`; a model file as a controller file; `--set order=500` (ss); `--set base=nope`", "refused naming the file: fast.csv (data[1]) is sampled every 0.01 s, but run.csv (data[0]) every 0.02 s / n_jobs (--jobs) must be a positive number / test log rest.csv: its output 'inclination' is constant (compare and select stop before any fit: a fit % there is undefined) / is a NumPy .npz archive, not a controller file / order=500 is too high ... at most N / base must be the name of a method", "clear", _refusals_in_the_users_words),
    Case("I7", "CLI", "a pnlss model file whose monomial window has low above high, or whose stored monomial powers differ from the model's", "refused on load: the monomial window [low, high] of variable 0 is [2, -2] / powers row 0 is [...], but a degree-2 model ... has the monomial [...] there", "clear", _model_files_checked_in_full),
    Case("I8", "CLI", "a channel name with a line break (in the log, or edited into a model file); a non-ASCII channel name exported to `.mat`", "refused when read: channel name 'incl\\nination' holds the control character '\\n' / refused: model.output_names{1} is 'inclinação', which holds non-ASCII characters ... export --to json keeps the text; nothing written", "clear", _names_in_exports),
]  # fmt: skip
