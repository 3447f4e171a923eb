"""Bad input, through the API and the command line: every case is refused clearly or handled right.

Each :class:`Case` states what a user does and what they see; ``docs/reliability.md`` is the
table of these cases, generated from this module (``python tests/test_reliability.py`` writes it;
a test checks that it is up to date). Outcomes:

- *clear*: refused with one line that names the argument, file, column, row or value;
- *correct*: accepted, and the result is right (nothing lost, nothing silent).

A CLI case also checks that no traceback reaches the user and that nothing was written or
overwritten where it should not be.
"""

from __future__ import annotations

import json
import os
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import neckid
from _reliability_inputs import CASES as INPUT_CASES
from _reliability_interrupt import CASES as INTERRUPT_CASES
from _reliability_output import CASES as OUTPUT_CASES
from neckid import IOData, Lags
from neckid.cli import app

DOC = Path(__file__).resolve().parents[1] / "docs" / "reliability.md"
runner = CliRunner()


# ---------------------------------------------------------------------------- fixtures as functions
def _log(folder: Path, name: str = "run.csv", ts: float = 0.02, n: int = 400) -> Path:
    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(-1, 1, n // 10), 10)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    data = IOData(u, y, ts=ts, input_names=["command"], output_names=["inclination"])
    path = folder / name
    data.to_csv(path)
    return path


def _model(folder: Path, log: Path, name: str = "model.npz") -> Path:
    data = IOData.from_csv(log, ["command"], ["inclination"])
    return neckid.LinearARX(Lags.arx(1, 1)).fit(data).save(folder / name)


def _unstable_model(folder: Path) -> Path:
    """A LinearARX whose pole is 8: a free run of 400 samples overflows."""
    log = _log(folder)
    model_path = _model(folder, log, "unstable.npz")
    _edit_model(model_path, arrays={"coef": np.array([[8.0], [0.5]])})
    return model_path


def _edit_model(
    path: Path,
    arrays: dict[str, np.ndarray] | None = None,
    meta: Callable[[dict], None] | None = None,
    header: object = None,
    drop: str | None = None,
) -> None:
    with np.load(path, allow_pickle=False) as archive:
        content = {k: archive[k] for k in archive.files}
    parsed = json.loads(str(content["__neckid__"]))
    if meta is not None:
        meta(parsed["meta"])
    content["__neckid__"] = np.array(json.dumps(parsed if header is None else header))
    content.update(arrays or {})
    if drop is not None:
        del content[drop]
    with path.open("wb") as handle:
        np.savez(handle, **content)


def cli(*args: str) -> tuple[int, str]:
    result = runner.invoke(app, [str(a) for a in args])
    output = result.output
    assert "Traceback" not in output, output
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise AssertionError(f"an exception escaped the CLI: {result.exception!r}\n{output}")
    return result.exit_code, re.sub(r"\s+", " ", output)


def refused(folder: Path, *args: str, match: str, code: int = 2) -> str:
    exit_code, output = cli(*args)
    assert exit_code == code, output
    assert re.search(match, output), output
    return output


# ---------------------------------------------------------------------------- the cases
@dataclass(frozen=True)
class Case:
    """One bad (or tricky) input: what the user does, what they see, and the check."""

    id: str
    surface: str
    given: str
    sees: str
    outcome: str
    check: Callable[[Path], None]


def _simulate_onto_the_log(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    before = log.read_bytes()
    refused(tmp, "simulate", model, log, "--out", log, match="is an input of this command")
    refused(tmp, "simulate", model, log, "--out", log, "--force", match="is an input")
    assert log.read_bytes() == before


def _simulate_onto_the_model(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    before = model.read_bytes()
    refused(tmp, "simulate", model, log, "--out", model, "--force", match="is an input")
    assert model.read_bytes() == before


def _existing_output(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    out = tmp / "sim.csv"
    out.write_text("keep me")
    refused(tmp, "simulate", model, log, "--out", out, match="exists already; use --force")
    assert out.read_text() == "keep me"
    code, _ = cli("simulate", model, log, "--out", out, "--force")
    assert code == 0 and out.read_text().startswith("time,")
    assert sorted(p.name for p in tmp.iterdir() if p.name.startswith(".")) == []


def _missing_folder(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    refused(tmp, "simulate", model, log, "--out", tmp / "nowhere" / "s.csv", match="does not exist")
    refused(
        tmp, "validate", model, log, "--plot", tmp / "nowhere" / "f.png", match="does not exist"
    )


def _read_only_folder(tmp: Path) -> None:
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        pytest.skip("root writes into read-only folders; the check cannot be seen as root")
    log = _log(tmp)
    model = _model(tmp, log)
    locked = tmp / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        refused(tmp, "validate", model, log, "--plot", locked / "f.png", match="not writable")
    finally:
        locked.chmod(0o700)


def _identify_existing_model(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    before = model.read_bytes()
    refused(
        tmp, "identify", log, "--inputs", "command", "--outputs", "inclination", "--method",
        "arx", "--lags", "1/1", "--save", model, match="exists already",
    )  # fmt: skip
    assert model.read_bytes() == before


def _unknown_setting(tmp: Path) -> None:
    log = _log(tmp)
    base = ["identify", log, "--inputs", "command", "--outputs", "inclination", "--method", "sm"]
    base += ["--lags", "1/1", "--save", tmp / "m.npz"]
    refused(tmp, *base, "--set", "lipschits=local", match="has no setting 'lipschits'.*lipschitz")
    refused(tmp, *base, "--set", "lipschitz", match="--set takes NAME=VALUE")
    refused(tmp, *base, "--set", "lipschitz=cell", match="lipschitz must be .*'cell'")
    refused(tmp, *base, "--set", "random_state=3", match="--set random_state: give it with --seed")
    assert not (tmp / "m.npz").exists()


def _constant_output(tmp: Path) -> None:
    path = tmp / "flat.csv"
    IOData(np.arange(100.0), np.ones(100), ts=0.1, input_names=["command"],
           output_names=["inclination"]).to_csv(path)  # fmt: skip
    for method in ("arx", "nn", "rls", "sm"):
        refused(
            tmp, "identify", path, "--inputs", "command", "--outputs", "inclination", "--method",
            method, "--lags", "1/1", "--save", tmp / f"{method}.npz", match="is constant",
        )  # fmt: skip
        assert not (tmp / f"{method}.npz").exists()


def _huge_values(tmp: Path) -> None:
    path = tmp / "huge.csv"
    rng = np.random.default_rng(1)
    IOData(rng.normal(size=200) * 1e300, rng.normal(size=200), ts=0.1, input_names=["command"],
           output_names=["inclination"]).to_csv(path)  # fmt: skip
    for method in ("arx", "nn"):
        refused(
            tmp, "identify", path, "--inputs", "command", "--outputs", "inclination", "--method",
            method, "--lags", "1/1", "--save", tmp / "m.npz", match="reaches .*e\\+300.*rescale",
        )  # fmt: skip
    assert not (tmp / "m.npz").exists()


def _diverging_free_run(tmp: Path) -> None:
    log = _log(tmp)
    model = _unstable_model(tmp)
    out = tmp / "sim.csv"
    refused(tmp, "simulate", model, log, "--out", out, match="diverged.*at sample", code=3)
    assert not out.exists()
    refused(tmp, "validate", model, log, match="diverged", code=3)
    code, output = cli("simulate", model, log, "--out", out, "--keep-diverged")
    assert code == 3 and out.exists(), output


def _diverging_api(tmp: Path) -> None:
    model = neckid.load_model(_unstable_model(tmp))
    data = IOData.from_csv(_log(tmp), ["command"], ["inclination"])
    with pytest.raises(neckid.DivergenceError, match=r"at sample \d+ \(t = .* s\)") as caught:
        model.simulate(data)
    assert caught.value.result.y.shape == data.y.shape


def _other_sampling_time(tmp: Path) -> None:
    model = _model(tmp, _log(tmp))
    fast = _log(tmp, "fast.csv", ts=0.01)
    refused(tmp, "validate", model, fast, match="sampled every 0.01 s but the model every 0.02 s")


def _model_file(kind: str) -> Callable[[Path], None]:
    def check(tmp: Path) -> None:
        log = _log(tmp)
        model = _model(tmp, log)
        expected = {
            "truncated": "is not a neckid model file",
            "empty": r"is not a neckid model file \(it is empty\)",
            "random": "is not a neckid model file",
            "list header": "must be a JSON object",
            "missing key": "has no 'coef' entry",
            "unknown parameter": "invalid LinearARX file: .*unexpected keyword argument 'speed'",
            "wrong shape": r"coef must have shape \(2, 1\); got \(3, 1\)",
            "negative ts": "ts must be a positive number of seconds",
        }[kind]
        if kind == "truncated":
            model.write_bytes(model.read_bytes()[:200])
        elif kind == "empty":
            model.write_bytes(b"")
        elif kind == "random":
            model.write_bytes(np.random.default_rng(0).bytes(500))
        elif kind == "list header":
            _edit_model(model, header=[1, 2])
        elif kind == "missing key":
            _edit_model(model, drop="coef")
        elif kind == "unknown parameter":
            _edit_model(model, meta=lambda m: m["params"].update(speed=3))
        elif kind == "wrong shape":
            _edit_model(model, arrays={"coef": np.ones((3, 1))})
        elif kind == "negative ts":
            _edit_model(model, meta=lambda m: m.update(ts=-0.02))
        refused(tmp, "validate", model, log, match=expected)
        with pytest.raises(ValueError, match=expected):
            neckid.load_model(model)

    return check


def _sm_negative_gamma(tmp: Path) -> None:
    data = IOData.from_csv(_log(tmp), ["command"], ["inclination"])
    path = neckid.SetMembership(Lags.arx(1, 1)).fit(data).save(tmp / "sm.npz")
    _edit_model(path, arrays={"gamma": np.array([-1.0])})
    with pytest.raises(ValueError, match="gamma must be > 0"):
        neckid.load_model(path)


def _csv(kind: str) -> Callable[[Path], None]:
    def check(tmp: Path) -> None:
        path = tmp / "bad.csv"
        text, expected = {
            "empty": ("", "is empty"),
            "duplicated column": (
                "time,command,command,inclination\n0,1,2,3\n0.1,1,2,3\n0.2,1,2,4\n",
                "column name 'command' appears 2 times",
            ),
            "text in time": (
                "time,command,inclination\n0,1,3\nabc,1,3\n0.2,1,4\n",
                "time column 'time' is not numeric: row 1 holds 'abc'",
            ),
            "missing column": (
                "time,cmd,inclination\n0,1,3\n0.1,1,3\n0.2,1,4\n",
                r"columns \['command'\] are not in",
            ),
        }[kind]
        path.write_text(text)
        refused(
            tmp, "identify", path, "--inputs", "command", "--outputs", "inclination",
            "--method", "arx", "--lags", "1/1", "--save", tmp / "m.npz", match=expected,
        )  # fmt: skip
        assert not (tmp / "m.npz").exists()

    return check


def _semicolon_log(tmp: Path) -> None:
    comma = _log(tmp)
    semicolon = tmp / "semicolon.csv"
    semicolon.write_text(comma.read_text().replace(",", ";"))
    refused(
        tmp, "identify", semicolon, "--inputs", "command", "--outputs", "inclination",
        "--method", "arx", "--lags", "1/1", "--save", tmp / "m.npz", match="are not in the table",
    )  # fmt: skip
    code, output = cli(
        "identify", semicolon, "--inputs", "command", "--outputs", "inclination", "--method",
        "arx", "--lags", "1/1", "--save", tmp / "m.npz", "--sep", ";",
    )  # fmt: skip
    assert code == 0 and "fit %" in output, output


def _chirp_in_two_units(tmp: Path) -> None:
    import pandas as pd

    from neckid.plant import InclinationController, SoftNeck, closed_loop
    from neckid.signals import paper_chirp

    neck = SoftNeck(seed=0)
    reference = paper_chirp(np.arange(1500) * neck.ts)
    frame = closed_loop(neck, InclinationController(ts=neck.ts), reference, neck.ts).to_frame()
    frame["inclination_rad"] = np.deg2rad(frame["inclination"])
    path = tmp / "chirp.csv"
    frame.to_csv(path, index=False)
    refused(
        tmp, "bandwidth", path, "--command", "reference", "--response", "inclination_rad",
        "--rate", "0.1", match="response's amplitude is 0.0[0-9]+ times the command's",
    )  # fmt: skip
    assert pd.read_csv(path).shape[0] == 1500


def _complex_array(tmp: Path) -> None:
    with pytest.raises(TypeError, match="u holds complex numbers"):
        IOData(np.ones(5) + 1j, np.ones(5))


def _reset_shape(tmp: Path) -> None:
    model = neckid.load_model(_model(tmp, _log(tmp)))
    with pytest.raises(ValueError, match=r"y0 must have shape \(1,\) or \(1, 1\); got \(3, 2\)"):
        model.simulator().reset(y0=np.ones((3, 2)))


def _bad_hyper_parameter(tmp: Path) -> None:
    data = IOData.from_csv(_log(tmp), ["command"], ["inclination"])
    with pytest.raises(
        ValueError, match=r"forgetting_factor must be a number in \(0, 1\]; got 1.2"
    ):
        neckid.RecursiveARX(Lags.arx(1, 1), forgetting_factor=1.2).fit(data)


def _demo_out_is_a_file(tmp: Path) -> None:
    target = tmp / "report.txt"
    target.write_text("mine")
    refused(tmp, "demo", "--quick", "--out", target, match="is a file; give a folder")
    assert target.read_text() == "mine"


def _demo_negative_seed(tmp: Path) -> None:
    refused(tmp, "demo", "--quick", "--seed", "-1", "--out", tmp / "d", match="seed")
    assert not (tmp / "d").exists()


def _demo_folder_in_use(tmp: Path) -> None:
    from neckid.utils.files import output_folder

    with output_folder(tmp / "demo"):
        refused(tmp, "demo", "--quick", "--out", tmp / "demo", match="another neckid run")


def _demo_folder_with_files(tmp: Path) -> None:
    folder = tmp / "demo"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    refused(tmp, "demo", "--quick", "--out", folder, match="holds files already; use --force")
    assert (folder / "notes.txt").read_text() == "mine"


def _interrupted(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    out = tmp / "sim.csv"

    def interrupt(*_args: object, **_kwargs: object) -> None:
        raise KeyboardInterrupt

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(neckid.LinearARX, "simulate", interrupt)
        refused(
            tmp, "simulate", model, log, "--out", out, code=130,
            match=r"interrupted \(Ctrl-C\): stopped before the end; no output was written",
        )  # fmt: skip
    assert not out.exists()


def _unexpected(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)

    def broken(*_args: object, **_kwargs: object) -> None:
        raise RuntimeError("a bug")

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(neckid.LinearARX, "simulate", broken)
        refused(tmp, "validate", model, log, match=r"unexpected error \(RuntimeError\).*--debug",
                code=1)  # fmt: skip


def _benchmark_failures(tmp: Path) -> None:
    import pandas as pd

    from neckid.experiments import benchmark

    row = {"benchmark": "bouc_wen", "test": "multisine", "method": "sm", "rmse": np.nan,
           "rmse_unit": "m", "fit_percent": np.nan, "n_initial": 0, "train_time_s": np.nan,
           "simulate_time_s": np.nan, "settings": "", "note": "failed: ValueError: x"}  # fmt: skip
    report = benchmark.BenchmarkReport(pd.DataFrame([row]), pd.DataFrame(), {})
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(benchmark, "run_benchmark", lambda *a, **k: report)
        refused(tmp, "benchmark", "--data-dir", tmp, "--quick", "--out", tmp / "b",
                match="1 row\\(s\\) failed \\(sm on bouc_wen\\)", code=1)  # fmt: skip


def _output_written_whole(tmp: Path) -> None:
    from neckid.utils.files import atomic_path

    target = tmp / "model.npz"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_path(target) as temporary:
        temporary.write_text("half")
        raise RuntimeError("the disk is full")
    assert target.read_text() == "old"
    assert [p.name for p in tmp.iterdir()] == ["model.npz"]


# ---------------------------------------------------------------------------- round two (issue 32)
def _identify_args(log: Path, save: Path, *extra: object) -> list[str]:
    return ["identify", str(log), "--inputs", "command", "--outputs", "inclination", "--method",
            "arx", "--lags", "1/1", "--save", str(save), *map(str, extra)]  # fmt: skip


def _special_files_refused(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    pipe = tmp / "pipe.csv"
    os.mkfifo(pipe)
    link = tmp / "link.csv"
    link.symlink_to(pipe)
    folder = tmp / "folder.csv"
    folder.mkdir()
    for target, kind in ((pipe, "a named pipe"), (link, "a named pipe"), (folder, "a folder")):
        refused(tmp, "simulate", model, log, "--out", target, "--force", match=f"is {kind}")
    assert pipe.is_fifo() and link.is_symlink() and folder.is_dir()
    os.mkfifo(tmp / "fifo.npz")
    refused(tmp, *_identify_args(log, tmp / "fifo.npz"), "--force", match="is a named pipe")
    assert (tmp / "fifo.npz").is_fifo()


def _concurrent_saves(tmp: Path) -> None:
    import subprocess
    import textwrap

    log = _log(tmp, n=4000)
    save = tmp / "same.npz"
    script = textwrap.dedent(
        """
        import sys, time
        import neckid
        fit = neckid.SetMembership.fit
        def slow(self, data):  # a fit long enough for the two runs to overlap
            time.sleep(1.0)
            return fit(self, data)
        neckid.SetMembership.fit = slow
        from neckid.cli import app
        app(sys.argv[1:], prog_name="neckid")
        """
    )
    args = [sys.executable, "-c", script, *_identify_args(log, save)]
    args[args.index("arx")] = "sm"
    runs = [subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                             cwd=tmp) for _ in range(2)]  # fmt: skip
    outputs = [(run.wait(timeout=300), run.stdout.read()) for run in runs if run.stdout]
    saved = [out for code, out in outputs if code == 0]
    refusals = [out for code, out in outputs if code == 2]
    assert len(saved) == 1 and "model saved" in saved[0], outputs
    assert len(refusals) == 1, outputs
    assert re.search(r"another neckid run is writing --save|exists already", refusals[0]), outputs
    assert "model saved" not in refusals[0]
    assert neckid.load_model(save) is not None
    assert [p.name for p in tmp.iterdir() if p.name.startswith(".")] == []


def _locked_output(tmp: Path) -> None:
    from filelock import FileLock

    from neckid.utils.files import lock_path

    log = _log(tmp)
    save = tmp / "m.npz"
    with FileLock(lock_path(save)):  # another run holds the output
        refused(tmp, *_identify_args(log, save), match="another neckid run is writing --save")
    assert not save.exists()
    code, output = cli(*_identify_args(log, save))
    assert code == 0 and "model saved" in output


def _umask_kept(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    previous = os.umask(0o022)
    try:
        out = tmp / "sim.csv"
        assert cli("simulate", model, log, "--out", out)[0] == 0
        assert out.stat().st_mode & 0o777 == 0o644
        out.chmod(0o640)
        assert cli("simulate", model, log, "--out", out, "--force")[0] == 0
        assert out.stat().st_mode & 0o777 == 0o640
        fresh = tmp / "fresh.npz"
        assert cli(*_identify_args(log, fresh))[0] == 0
        assert fresh.stat().st_mode & 0o777 == 0o644
    finally:
        os.umask(previous)


def _terminated(tmp: Path) -> None:
    import signal
    import time

    log = _log(tmp)
    model = _model(tmp, log)
    out = tmp / "sim.csv"
    for signum, code, name in ((signal.SIGTERM, 143, "SIGTERM"), (signal.SIGHUP, 129, "SIGHUP")):

        def stopped(*_args: object, signum: int = signum, **_kwargs: object) -> None:
            os.kill(os.getpid(), signum)
            time.sleep(5)

        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(neckid.LinearARX, "simulate", stopped)
            refused(
                tmp, "simulate", model, log, "--out", out, code=code,
                match=rf"interrupted \({name}\): .*no output was written",
            )  # fmt: skip
        assert not out.exists()
        assert sorted(p.name for p in tmp.iterdir() if p.name.startswith(".")) == []
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL


def _stale_temporaries(tmp: Path) -> None:
    from neckid.utils.files import output_folder

    log = _log(tmp)
    model = _model(tmp, log)
    (tmp / ".sim.csv.1a2b3c4d.part").write_text("half of a killed run")
    (tmp / ".other.csv.1a2b3c4d.part").write_text("not ours")
    assert cli("simulate", model, log, "--out", tmp / "sim.csv")[0] == 0
    hidden = sorted(p.name for p in tmp.iterdir() if p.name.startswith("."))
    assert hidden == [".other.csv.1a2b3c4d.part"]
    folder = tmp / "report"
    (folder / ".staging-killed").mkdir(parents=True)
    (folder / ".staging-killed" / "half.html").write_text("half")
    with output_folder(folder) as staged:
        staged.path("a.txt").write_text("done")
    assert sorted(p.name for p in folder.iterdir()) == ["a.txt"]


def _degenerate_names(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    for name in ("", ".", ".."):
        refused(tmp, "simulate", model, log, "--out", name, "--force", match="names no file")
        refused(tmp, "validate", model, log, "--plot", name, "--force", match="names no file")
    from neckid.utils.files import output_name

    with pytest.raises(FileExistsError, match=r"--save '\.\.' names no file"):
        output_name("..", ".npz")


def _wrong_extension(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    refused(tmp, "validate", model, log, "--plot", tmp / "fit.pdf", match="written as PNG.*\\.png")
    refused(tmp, "simulate", model, log, "--out", tmp / "s.parquet", match="written as CSV.*\\.csv")
    assert sorted(p.name for p in tmp.iterdir()) == ["model.npz", "run.csv"]
    assert cli("validate", model, log, "--plot", tmp / "fit.PNG")[0] == 0


def _closed_stdout(tmp: Path) -> None:
    import subprocess

    log = _log(tmp)
    save = tmp / "m.npz"
    run = subprocess.Popen([sys.executable, "-c", "from neckid.cli import app; app()",
                            *_identify_args(log, save)], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE)  # fmt: skip
    assert run.stdout is not None and run.stderr is not None
    run.stdout.close()  # `| head -0`: the reader is gone before the first line
    error = run.stderr.read().decode()
    assert run.wait(timeout=300) == 0, error
    assert "Error" not in error and "Traceback" not in error, error
    assert neckid.load_model(save).n_inputs_ == 1


def _condition_numbers(tmp: Path) -> None:
    log = _log(tmp)
    save = tmp / "m.npz"
    for value in ("0,4kg", "1,000kg", "1 000g", "1'000g"):
        refused(tmp, *_identify_args(log, save), "--condition", f"payload={value}",
                match="decimal comma or a thousands separator.*decimal point")  # fmt: skip
    for value, unit in (("0.4kg!", "kg!"), ("0.4.5kg", ".5kg"), ("2 kg m", "kg m")):
        refused(tmp, *_identify_args(log, save), "--condition", f"payload={value}",
                match=f"'{re.escape(unit)}' after the number .* is not a unit")  # fmt: skip
    assert not save.exists()


def _bad_ts_option(tmp: Path) -> None:
    log = _log(tmp)
    save = tmp / "m.npz"
    for value, reason in (("0", "positive"), ("-0.1", "positive"), ("nan", "positive"),
                          ("inf", "positive"), ("1e307", "1e\\+06"),
                          ("0,01", "valid number")):  # fmt: skip
        refused(tmp, *_identify_args(log, save), "--ts", value, match=f"--ts.*{reason}")
    assert not save.exists()


def _ts_not_a_number(tmp: Path) -> None:
    u, y = np.arange(5.0), np.arange(5.0) ** 2
    for ts, error, match in (
        (True, TypeError, "ts must be a number of seconds; got True"),
        ("0.1", TypeError, "ts must be a number of seconds; got '0.1'"),
        (0.1 + 0j, TypeError, "ts must be a number of seconds; got"),
        (1e307, ValueError, "at most 1e\\+06"),
        (np.float64("nan"), ValueError, "positive number of seconds; got nan"),
    ):
        with pytest.raises(error, match=match):
            IOData(u, y, ts=ts)
    assert IOData(u, y, ts=np.array(0.5)).ts == 0.5


def _values_beyond_floats(tmp: Path) -> None:
    import pandas as pd

    path = tmp / "big.csv"
    path.write_text("time,command,inclination\n0,1,2\n0.1,9007199254740993,3\n0.2,1,4\n")
    refused(tmp, *_identify_args(path, tmp / "m.npz"),
            match="column 'command' holds the whole number 9007199254740993 at row 1, beyond 2\\*\\*53")  # fmt: skip
    frame = pd.DataFrame({"time": np.arange(50) * 0.1, "inclination": np.sin(np.arange(50.0)),
                          "command": pd.date_range("2024-01-01", periods=50, freq="s")})  # fmt: skip
    frame.to_parquet(tmp / "dates.parquet")
    refused(tmp, *_identify_args(tmp / "dates.parquet", tmp / "m.npz"),
            match="column 'command' holds datetimes .*not numbers")  # fmt: skip
    assert not (tmp / "m.npz").exists()


def _datetime_time_column(tmp: Path) -> None:
    import pandas as pd

    rng = np.random.default_rng(0)
    u = rng.normal(size=200)
    y = np.convolve(u, [0.0, 0.5, 0.3])[:200]
    for name, stamps in (
        ("datetime", pd.date_range("2024-05-01 12:00", periods=200, freq="20ms")),
        ("aware", pd.date_range("2024-05-01 12:00", periods=200, freq="20ms", tz="Europe/Madrid")),
        ("timedelta", pd.to_timedelta(np.arange(200) * 20 + 3000, unit="ms")),
    ):
        frame = pd.DataFrame({"time": stamps, "command": u, "inclination": y})
        path = tmp / f"{name}.parquet"
        frame.to_parquet(path)
        data = IOData.from_parquet(path, ["command"], ["inclination"])
        assert data.ts == pytest.approx(0.02) and data.t0 == 0.0, name
        assert IOData.from_frame(frame, ["command"], ["inclination"], time="time").ts == (
            pytest.approx(0.02)
        )
        code, output = cli(*_identify_args(path, tmp / f"{name}.npz"))
        assert code == 0, output
        assert neckid.load_model(tmp / f"{name}.npz").ts_ == pytest.approx(0.02)


def _mat_variables(tmp: Path) -> None:
    from scipy.io import savemat

    n = 50
    good = {"command": np.arange(n, dtype=float), "inclination": np.sin(np.arange(n) / 5)}
    for edit, match in (
        ({"command": np.ones((n, 3))}, "variable 'command' is a 50x3 matrix"),
        ({"command": np.ones(n) + 1j}, "variable 'command' holds complex numbers"),
        ({"command": "fifty"}, "variable 'command' holds text"),
        (
            {"command": np.ones(n - 1)},
            "the variables read have unequal lengths \\('command' has 49, 'inclination' has 50",
        ),
        ({"command": np.array([], dtype=float)}, "variable 'command' is empty"),
        ({"command": np.array([{"a": 1}], dtype=object)}, "variable 'command' holds"),
    ):
        path = tmp / "bad.mat"
        savemat(path, {**good, **edit})
        with pytest.raises(ValueError, match=f"^bad.mat: {match}"):
            IOData.from_mat(path, ["command"], ["inclination"], ts=0.1)
    savemat(tmp / "matrix.mat", {**good, "command": np.ones((n, 3))})
    refused(tmp, *_identify_args(tmp / "matrix.mat", tmp / "m.npz"), "--ts", "0.1",
            match="matrix.mat: variable 'command' is a 50x3 matrix")  # fmt: skip
    savemat(tmp / "one_column.mat", {**good, "command": good["command"][:, None]})
    assert (
        IOData.from_mat(tmp / "one_column.mat", ["command"], ["inclination"], ts=0.1).n_samples == n
    )


def write_mat73(path: Path, variables: dict[str, np.ndarray], classes: dict[str, str]) -> None:
    """A MATLAB v7.3 file as MATLAB writes one: HDF5 after a 512-byte text header."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as handle:
        for name, value in variables.items():
            dataset = handle.create_dataset(name, data=np.atleast_2d(value))
            dataset.attrs["MATLAB_class"] = np.bytes_(classes.get(name, "double"))
    with path.open("r+b") as handle:
        handle.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 2024 HDF5")


def _mat_v73(tmp: Path) -> None:
    pytest.importorskip("h5py")
    n = 60
    path = tmp / "v73.mat"
    command = np.arange(n, dtype=float)
    write_mat73(
        path, {"command": command, "inclination": 0.5 * command, "time": 0.05 * command}, {}
    )
    data = IOData.from_mat(path, ["command"], ["inclination"], time="time")
    assert data.ts == pytest.approx(0.05) and np.allclose(data.y[:, 0], 0.5 * command)
    write_mat73(path, {"command": np.frombuffer(b"ab" * n, dtype=np.uint16),
                       "inclination": command}, {"command": "char"})  # fmt: skip
    with pytest.raises(ValueError, match=r"v73\.mat: variable 'command' holds text"):
        IOData.from_mat(path, ["command"], ["inclination"], ts=0.1)
    with pytest.MonkeyPatch.context() as patch:
        patch.setitem(sys.modules, "h5py", None)  # not installed
        refused(tmp, *_identify_args(path, tmp / "m.npz"), "--ts", "0.1",
                match="v73.mat is a MATLAB v7.3 file \\(HDF5\\), which needs h5py: pip install h5py")  # fmt: skip


def _cut_last_line(tmp: Path) -> None:
    log = _log(tmp)
    text = log.read_text()
    cut = tmp / "cut.csv"
    cut.write_text(text[: text.rstrip("\n").rfind(",")])  # the last line loses its last field
    refused(tmp, *_identify_args(cut, tmp / "m.npz"),
            match="cut.csv: the last line \\(row 399, .*\\) has 2 field\\(s\\) where the header has 3.*cut short")  # fmt: skip
    assert not (tmp / "m.npz").exists()


def _rls_more_unknowns(tmp: Path) -> None:
    log = _log(tmp, n=2000)
    args = _identify_args(log, tmp / "m.npz")
    args[args.index("arx")], args[args.index("1/1")] = "rls", "1-1500/1"
    refused(
        tmp, *args, match="1501 unknowns per output but the training logs give only 500 equations"
    )
    assert not (tmp / "m.npz").exists()


# ------------------------------------------------------------- model files and logs from anywhere
def _model_file_damaged(kind: str) -> Callable[[Path], None]:
    """A model file crafted or damaged: refused by ``info`` and ``validate`` before allocating."""

    def check(tmp: Path) -> None:
        import tracemalloc

        from test_model_files import declared_shape, zip_bomb

        log = _log(tmp)
        model = _model(tmp, log)
        path = tmp / f"{kind}.npz"
        if kind == "shape":
            declared_shape(path, model, (10**12,))
            match = (
                r"shape\.npz is damaged: entry 'coef' declares shape \(1000000000000,\) of"
                r" float64 \(7\.3 TB\) but holds 16 B of values; refused before reading it"
            )
        else:
            zip_bomb(path, model)
            match = (
                r"bomb\.npz is damaged: its 1\.6 MB inflate to 1\.6 GB of arrays \(\d+"
                r" times; entry 'coef' alone 1\.6 GB\).*zip bomb"
            )
        tracemalloc.start()
        try:
            refused(tmp, "info", path, match=match)
            refused(tmp, "validate", path, log, match=match)
        finally:
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
        assert peak < 64 * 2**20, f"{peak / 2**20:.0f} MB allocated"

    return check


def _model_file_dtypes(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    coef = np.array([[0.9], [0.5]])
    for value, match in (
        (coef + 1j, "entry 'coef' holds complex numbers, dtype complex128"),
        (coef.astype(str), "entry 'coef' holds text, dtype <U32"),
        (coef.astype("datetime64[s]"), "entry 'coef' holds dates"),
        (
            coef > 0.6,
            r"entry 'coef' holds booleans \(dtype bool\); a LinearARX file holds real"
            r" numbers there \(dtype float64\)",
        ),
    ):
        _edit_model(model, arrays={"coef": value})
        refused(tmp, "validate", model, log, match=match)
    content = dict(np.load(model, allow_pickle=False))
    content["coef"] = np.array([None, 1.0], dtype=object)
    np.savez(model, **content)
    refused(
        tmp,
        "info",
        model,
        match="entry 'coef' holds Python objects, dtype object, which would need pickle to read",
    )


def _model_file_numbers(tmp: Path) -> None:
    log = _log(tmp)
    for key, value, match in (
        (
            "ts",
            float("nan"),
            r"header key 'meta\.ts': ts must be a positive number of seconds; got nan",
        ),
        ("ts", float("inf"), r"header key 'meta\.ts': .*got inf"),
        (
            "training_ranges",
            {"command": [1.0, -1.0], "inclination": [0.0, 1.0]},
            r"header key 'meta\.training_ranges\.command' must be \[low, high\], two finite numbers"
            r" with low <= high; got \[1\.0, -1\.0\]",
        ),
        (
            "training_ranges",
            {"command": [float("nan"), 1.0], "inclination": [0.0, 1.0]},
            r"'meta\.training_ranges\.command' .*got \[nan, 1\.0\]",
        ),
        ("n_samples", -5, r"header key 'meta\.n_samples' must be a whole number >= 0; got -5"),
    ):
        model = _model(tmp, log, f"{key}.npz")
        _edit_model(model, meta=lambda m, key=key, value=value: m.update({key: value}))
        refused(tmp, "validate", model, log, match=match)


def _model_file_newer(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    with np.load(model, allow_pickle=False) as archive:
        header = json.loads(str(archive["__neckid__"]))
    _edit_model(model, header={**header, "version": 2, "neckid_version": "9.1.0"})
    refused(
        tmp,
        "info",
        model,
        match="has model-file version 2, written by neckid 9.1.0, newer than this neckid reads"
        f" \\(neckid {re.escape(neckid.__version__)} reads versions up to 1\\); upgrade neckid to"
        " load it",
    )


def _model_file_structure(tmp: Path) -> None:
    model = _model(tmp, _log(tmp))
    with np.load(model, allow_pickle=False) as archive:
        content = {k: archive[k] for k in archive.files}
    content["__neckid__"] = np.array("[" * 100_000 + "]" * 100_000)
    np.savez(model, **content)
    with pytest.raises(ValueError, match="header is nested too deeply"):
        neckid.load_model(model)
    content["__neckid__"] = np.array('{"version": ' + "9" * 5000 + "}")
    np.savez(model, **content)
    with pytest.raises(ValueError, match="header is not valid JSON"):
        neckid.load_model(model)
    single = tmp / "single.npz"
    np.save(tmp / "single.npy", np.ones(3))
    (tmp / "single.npy").rename(single)
    with pytest.raises(ValueError, match=r"a single \.npy array, not an \.npz archive"):
        neckid.load_model(single)


def _model_file_memory(tmp: Path) -> None:
    import neckid.utils.memory

    model = _model(tmp, _log(tmp))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(neckid.utils.memory, "available_bytes", lambda: 4096)
        with pytest.raises(
            ValueError,
            match=r"reading its arrays \(entry .* alone .*\) needs about"
            r" .* of memory, and this machine has 4\.0 KB available: refused",
        ):
            neckid.load_model(model)


def _model_files_of_every_kind(tmp: Path) -> None:
    data = IOData.from_csv(_log(tmp), ["command"], ["inclination"])
    for name in ("arx", "poly", "sm"):  # real, integer and boolean arrays
        model = neckid.methods()[name].make(Lags.arx(1, 1), quick=True).fit(data)
        loaded = neckid.load_model(model.save(tmp / f"{name}.npz"))
        np.testing.assert_array_equal(loaded.simulate(data).y, model.simulate(data).y)


def _parquet_damaged(tmp: Path) -> None:
    log = _log(tmp)
    model = _model(tmp, log)
    data = IOData.from_csv(log, ["command"], ["inclination"])
    path = tmp / "log.parquet"
    data.to_parquet(path)
    raw = path.read_bytes()
    for damage, match in (
        (raw[: len(raw) // 2], r"log\.parquet is not a readable Parquet file \("),
        (raw[:100] + b"\x00" * 40 + raw[140:], r"log\.parquet is not a readable Parquet file \("),
    ):
        path.write_bytes(damage)
        refused(tmp, "validate", model, path, match=match)
    import pyarrow as pa
    import pyarrow.parquet as pq

    values = pa.array(np.arange(400) * 0.02)
    pq.write_table(
        pa.Table.from_arrays(
            [values, values, values, values], names=["time", "command", "command", "inclination"]
        ),
        path,
    )
    refused(
        tmp, "validate", model, path, match=r"log\.parquet: column name 'command' appears 2 times"
    )


def _parquet_page_checksum(tmp: Path) -> None:
    import pyarrow.parquet as pq

    log = _log(tmp)
    model = _model(tmp, log)
    path = tmp / "log.parquet"
    IOData.from_csv(log, ["command"], ["inclination"]).to_parquet(path)
    chunk = pq.ParquetFile(path).metadata.row_group(0).column(1)
    raw = bytearray(path.read_bytes())
    raw[chunk.data_page_offset + chunk.total_compressed_size - 1] ^= 0x01
    path.write_bytes(bytes(raw))
    refused(
        tmp, "validate", model, path, match=r"log\.parquet is not a readable Parquet file .*CRC"
    )


def _logs_beyond_memory(tmp: Path) -> None:
    from scipy.io import savemat

    import neckid.utils.memory

    data = IOData.from_csv(_log(tmp), ["command"], ["inclination"])
    data.to_parquet(tmp / "log.parquet")
    savemat(tmp / "log.mat", {"command": data.u[:, 0], "inclination": data.y[:, 0]})
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(neckid.utils.memory, "available_bytes", lambda: 10_000)
        with pytest.raises(
            ValueError,
            match=r"^log\.parquet: reading 3 column\(s\) of 400 rows"
            r" needs about 28\.1 KB of memory, and this machine has 9\.8 KB",
        ):
            IOData.from_parquet(tmp / "log.parquet", ["command"], ["inclination"])
        with pytest.raises(
            ValueError,
            match=r"^log\.mat: reading the variables \['command',"
            r" 'inclination'\] \(800 values\) needs about 6\.2 KB",
        ):
            IOData.from_mat(tmp / "log.mat", ["command"], ["inclination"], ts=0.02)


def _time_stamps_beyond_floats(tmp: Path) -> None:
    import pandas as pd

    n = 50
    stamps = 1_700_000_000 * 10**9 + np.arange(n) * 20_000_000  # ns since 1970, as integers
    frame = pd.DataFrame({"time": stamps, "command": np.ones(n), "inclination": np.arange(n)})
    frame.to_parquet(tmp / "stamps.parquet")
    model = _model(tmp, _log(tmp))
    refused(
        tmp,
        "validate",
        model,
        tmp / "stamps.parquet",
        match="time column 'time' holds the whole number 1700000000000000000 at row 0, beyond"
        " 2\\*\\*53",
    )


# ---------------------------------------------------------------------------- units, repeats, info
def _log_in(folder: Path, name: str, output_unit: str, input_unit: str = "rad/s") -> Path:
    data = IOData.from_csv(_log(folder, name), ["command"], ["inclination"])
    data = data.replace(input_units=[input_unit], output_units=[output_unit])
    path = folder / f"u_{name}"
    data.to_csv(path)
    return path


def _units_across_runs(tmp: Path) -> None:
    deg = IOData.from_csv(_log(tmp, "a.csv"), ["command"], ["inclination"]).replace(
        output_units=["deg"], name="a"
    )
    rad = deg.replace(output_units=["rad"], name="b")
    with pytest.raises(ValueError, match=r"data\[1\] \(b\) has inclination in rad, but data\[0\]"):
        neckid.LinearARX(Lags.arx(1, 1)).fit([deg, rad])


def _model_on_other_units(tmp: Path) -> None:
    model = neckid.LinearARX(Lags.arx(1, 1)).fit(
        deg_log := IOData.from_csv(_log(tmp), ["command"], ["inclination"]).replace(
            output_units=["deg"], name="run"
        )
    )
    path = model.save(tmp / "deg.npz")
    with pytest.raises(
        ValueError,
        match="has inclination in rad, but the model was identified with inclination in deg",
    ):
        neckid.load_model(path).simulate(deg_log.replace(output_units=["rad"]))


def _same_log_twice(tmp: Path) -> None:
    log = _log(tmp)
    refused(
        tmp,
        "identify",
        log,
        tmp / "." / log.name,
        "--inputs",
        "command",
        "--outputs",
        "inclination",
        "--method",
        "arx",
        "--save",
        tmp / "m.npz",
        match="is given twice",
    )
    refused(
        tmp,
        "compare",
        log,
        "--test",
        log,
        "--inputs",
        "command",
        "--outputs",
        "inclination",
        match="a test log must not be a training log",
    )
    assert not (tmp / "m.npz").exists()


def _info_other_formats(tmp: Path) -> None:
    import scipy.io

    data = IOData.from_csv(_log(tmp), ["command"], ["inclination"])
    t = data.time.copy()
    t[10] = t[9]
    scipy.io.savemat(tmp / "run.mat", {"time": t, "command": data.u[:, 0], "label": "bench"})
    code, output = cli("info", tmp / "run.mat")
    assert (
        code == 0
        and "1 repeated time stamp(s)" in output
        and "not channels: label (text)" in output
    )


def _too_much_memory(tmp: Path) -> None:
    import neckid.utils.memory

    data = IOData.from_csv(_log(tmp, n=4000), ["command"], ["inclination"])
    original = neckid.utils.memory.available_bytes
    neckid.utils.memory.available_bytes = lambda: 1024**2  # type: ignore[assignment]
    try:
        with pytest.raises(
            ValueError, match=r"needs about .* of memory, and this machine has 1.0 MB"
        ):
            neckid.LinearARX(Lags.arx(40, 40)).fit(data)
    finally:
        neckid.utils.memory.available_bytes = original  # type: ignore[assignment]


def _label_not_seen(tmp: Path) -> None:
    data = IOData.from_csv(_log(tmp), ["command"], ["inclination"])
    runs = [data.replace(conditions={"neck": n}, name=n) for n in ("A", "B")]
    runs[1] = runs[1].replace(y=runs[1].y + 1.0)
    model = neckid.LinearARX(Lags(1, 1, conditions=["neck"])).fit(runs)
    with pytest.raises(ValueError, match="neck='C', a label the model was not identified with"):
        model.simulate(data.replace(conditions={"neck": "C"}))


def _empty_benchmark_folder(tmp: Path) -> None:
    refused(tmp, "benchmark", "--data-dir", tmp, "--out", tmp / "out", match="nothing to run")
    assert not (tmp / "out").exists()


def _lone_output_lag(tmp: Path) -> None:
    code, output = cli(
        "identify",
        _log(tmp),
        "--inputs",
        "command",
        "--outputs",
        "inclination",
        "--method",
        "arx",
        "--lags",
        "3/1",
        "--save",
        tmp / "m.npz",
    )
    assert code == 0 and "the output lag 3 alone, y(t-3)" in output
    refused(
        tmp,
        "identify",
        _log(tmp),
        "--inputs",
        "command",
        "--outputs",
        "inclination",
        "--lags",
        "1/1",
        "--orders",
        "1,1,1",
        "--save",
        tmp / "m2.npz",
        match="not both",
    )


# ---------------------------------------------------------------------------- a model in the lab's loop
def _pi_run(tmp: Path) -> tuple[Path, Path, object]:
    """A model file and a bench log (six columns) that the lab's PI made with it as the neck."""
    from test_lab_loop import _logged_loop, _plant_model
    from test_loop_checks import _softneck_file

    model = _plant_model(np.random.default_rng(0))
    log = _logged_loop(model)
    return model.save(tmp / "model.npz"), _softneck_file(log, tmp / "int000stepresponse.csv"), log


def _loop_wrong_controller(tmp: Path) -> None:
    model, log, _ = _pi_run(tmp)
    args = ("validate", model, log, "--in-loop", "--controller", "fra", "--json", tmp / "l.json")
    refused(
        tmp,
        *args,
        match=r"int000stepresponse\.csv: the controller fra does not reproduce"
        r" the log's commands: the controller check .* is \d\.\d+ rad/s, beyond the"
        r" tolerance 1e-04 rad/s .*--force runs it anyway",
    )
    assert not (tmp / "l.json").exists()
    code, output = cli(*args, "--force")
    assert code == 0 and "warning (--force)" in output, output


def _loop_parameter_logs(tmp: Path) -> None:
    from test_loop_checks import _adaptive_file

    model, log, _ = _pi_run(tmp)
    folder = tmp / "adaptive"
    folder.mkdir()
    _adaptive_file(folder, "000")
    refused(
        tmp,
        "validate",
        model,
        log,
        "--in-loop",
        "--controller",
        folder,
        match=r"int000stepresponse\.csv was made by the PI \(int\), as its name says",
    )
    ada = tmp / "ada200response.csv"
    ada.write_bytes(log.read_bytes())
    refused(
        tmp,
        "validate",
        model,
        ada,
        "--in-loop",
        "--controller",
        _adaptive_file(folder, "400"),
        match=r"ada200response\.csv is the 200 g adaptive run but the parameter log"
        r" adacon400\.csv is the 400 g one",
    )


def _loop_controller_period(tmp: Path) -> None:
    from test_loop_checks import _designed

    model, log, _ = _pi_run(tmp)
    slow = _designed(tmp, "slow.json", ts=0.05)
    refused(
        tmp,
        "validate",
        model,
        log,
        "--in-loop",
        "--controller",
        slow,
        match=r"runs every 0\.05 s but the log is sampled every 0\.025 s",
    )


def _loop_controller_gains(tmp: Path) -> None:
    from test_loop_checks import _designed, _edit

    model, log, _ = _pi_run(tmp)
    nan = _edit(_designed(tmp, "nan.json"), lambda d: d["gains"].__setitem__("kp", float("nan")))
    refused(
        tmp,
        "validate",
        model,
        log,
        "--in-loop",
        "--controller",
        nan,
        match=r"nan\.json: gains\.kp must be a finite number; got nan",
    )
    lonely = _edit(_designed(tmp, "ki.json"), lambda d: d["gains"].__setitem__("ki", 0.9))
    refused(
        tmp,
        "validate",
        model,
        log,
        "--in-loop",
        "--controller",
        lonely,
        match=r"ki\.json: gains\.ki = 0\.9 disagrees with gains\.kf = 0\.8237 .* edit both",
    )


def _loop_diverges(tmp: Path) -> None:
    from test_lab_loop import _plant_model

    _, log, _ = _pi_run(tmp)
    unstable = _plant_model(np.random.default_rng(5))
    unstable.coef_ = unstable.coef_.copy()
    unstable.coef_[0] = 1.6
    model = unstable.save(tmp / "unstable.npz")
    out = tmp / "loop.json"
    code, output = cli("validate", model, log, "--in-loop", "--json", out)
    assert code == 3, output
    assert re.search(r"diverged: int000stepresponse\.csv: .* at row \d+ \(t = ", output), output
    assert json.loads(out.read_text())["logs"][0]["diverged_at"] is not None


def _loop_log_options(tmp: Path) -> None:
    import pandas as pd

    model, _, log = _pi_run(tmp)
    header = tmp / "int000stepresponse.csv"
    columns = {n: log.channel(n) for n in ("motor_position", "velocity_command", "motor_velocity")}
    pd.DataFrame({"time": log.time, **columns, "incl_sensor": log.channel("inclination")}).to_csv(
        header, index=False
    )
    code, output = cli("validate", model, header, "--in-loop", "--map", "inclination=incl_sensor")
    assert code == 0 and "in the loop with int" in output, output
    refused(
        tmp,
        "validate",
        model,
        header,
        "--in-loop",
        "--map",
        "inclination=incl_sensor",
        "--tilt",
        match="--tilt: the lab's loop measures the inclination alone",
    )
    refused(
        tmp,
        "validate",
        model,
        header,
        "--in-loop",
        "--channel",
        "inclination=/imu:x:output:deg",
        match=r"--channel names the channels of a ROS 2 bag \(--layout rosbag\)",
    )


def _two_outputs_drawn(tmp: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import neckid.cli.models as models

    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(-1, 1, (30, 2)), 20, axis=0)
    y = np.zeros((600, 2))
    for t in range(1, 600):
        y[t] = [0.9 * y[t - 1, 0] + 0.8 * u[t - 1, 0], 0.7 * y[t - 1, 1] - 0.5 * u[t - 1, 1] + 3]
    IOData(u, y, ts=0.02, input_names=["m1", "m2"], output_names=["tilt_x", "tilt_y"]).to_csv(
        tmp / "run.csv"
    )
    model = tmp / "m.npz"
    code, output = cli(
        "identify",
        tmp / "run.csv",
        "--inputs",
        "m1,m2",
        "--outputs",
        "tilt_x,tilt_y",
        "--method",
        "arx",
        "--orders",
        "1,1,1",
        "--save",
        model,
    )
    assert code == 0, output
    drawn: list = []
    original = models._save_figure
    models._save_figure = lambda fig, path: drawn.append(fig)
    try:
        code, output = cli("validate", model, tmp / "run.csv", "--plot", tmp / "v.png")
    finally:
        models._save_figure = original
    assert code == 0, output
    (fig,) = drawn
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["tilt_x [-]", "error y − ŷ [-]", "tilt_y [-]", "error y − ŷ [-]"], labels
    np.testing.assert_allclose(fig.axes[2].lines[0].get_ydata(), y[:, 1], atol=1e-9)
    plt.close(fig)


CASES = [
    Case("C1", "CLI", "`simulate --out` names the measured log", "refused: is an input of this command (even with --force); the log is unchanged", "clear", _simulate_onto_the_log),
    Case("C2", "CLI", "`simulate --out` names the model file", "refused: is an input; the model is unchanged", "clear", _simulate_onto_the_model),
    Case("C3", "CLI", "`simulate --out` names an existing file", "refused: exists already; use --force (then replaced atomically)", "clear", _existing_output),
    Case("C4", "CLI", "`--out` / `--plot` into a missing folder", "refused before the run: folder ... does not exist", "clear", _missing_folder),
    Case("C5", "CLI", "`--plot` into a read-only folder", "refused before the run: folder ... is not writable", "clear", _read_only_folder),
    Case("C6", "CLI", "`identify --save` onto an existing model", "refused: exists already; the old model is unchanged", "clear", _identify_existing_model),
    Case("C32", "CLI", "`identify --set` with a misspelt setting, no `=`, or a bad value", "refused: method 'sm' has no setting 'lipschits'; its settings are ... / --set takes NAME=VALUE / lipschitz must be ... / give random_state with --seed; no model written", "clear", _unknown_setting),
    Case("C7", "CLI", "constant output with arx, nn, rls, sm", "refused: output 'inclination' is constant; no model file written", "clear", _constant_output),
    Case("C8", "CLI", "values of 1e300 with arx, nn", "refused: input 'command' reaches 3e+300 ... rescale the channel", "clear", _huge_values),
    Case("C9", "CLI", "`simulate` / `validate` of an unstable model", "exit 3, diverged at sample N (t = ... s); no file unless --keep-diverged", "clear", _diverging_free_run),
    Case("C10", "CLI", "a model at 0.02 s on a log at 0.01 s", "refused: sampled every 0.01 s but the model every 0.02 s", "clear", _other_sampling_time),
    Case("C11", "CLI", "a truncated model file", "refused: is not a neckid model file (...)", "clear", _model_file("truncated")),
    Case("C12", "CLI", "a 0-byte model file", "refused: is not a neckid model file (it is empty)", "clear", _model_file("empty")),
    Case("C13", "CLI", "random bytes as a model file", "refused: is not a neckid model file (...)", "clear", _model_file("random")),
    Case("C14", "CLI", "model header JSON that is a list", "refused: the header must be a JSON object", "clear", _model_file("list header")),
    Case("C15", "CLI", "a model file without an array it needs", "refused: this LinearARX file has no 'coef' entry", "clear", _model_file("missing key")),
    Case("C16", "CLI", "a model file with an unknown parameter", "refused: invalid LinearARX file: unexpected keyword argument 'speed'", "clear", _model_file("unknown parameter")),
    Case("C17", "CLI", "a model file with an array of the wrong shape", "refused on load: coef must have shape (2, 1); got (3, 1)", "clear", _model_file("wrong shape")),
    Case("C18", "CLI", "a model file with ts < 0", "refused on load: ts must be a positive number of seconds", "clear", _model_file("negative ts")),
    Case("C19", "CLI", "an empty log file", "refused: log file ... is empty", "clear", _csv("empty")),
    Case("C20", "CLI", "a CSV whose header repeats a column", "refused: column name 'command' appears 2 times", "clear", _csv("duplicated column")),
    Case("C21", "CLI", "text in a time cell", "refused: time column 'time' is not numeric: row 1 holds 'abc'", "clear", _csv("text in time")),
    Case("C22", "CLI", "an input column that is not in the log", "refused: columns ['command'] are not in the table; it has [...]", "clear", _csv("missing column")),
    Case("C30", "CLI", "a log separated by ';'", "without --sep: the columns it has are listed; with --sep ';' it is read", "correct", _semicolon_log),
    Case("C31", "CLI", "`bandwidth` with the command in deg and the response in rad", "refused: the response's amplitude is 0.02 times the command's ... check the units", "clear", _chirp_in_two_units),
    Case("C23", "CLI", "`demo --out` an existing file", "refused: is a file; give a folder; the file is unchanged", "clear", _demo_out_is_a_file),
    Case("C24", "CLI", "`demo --seed -1`", "refused by the option's range", "clear", _demo_negative_seed),
    Case("C25", "CLI", "two runs into one `--out` folder", "the second is refused: another neckid run is writing into ...", "clear", _demo_folder_in_use),
    Case("C26", "CLI", "`demo --out` a folder holding the user's files", "refused: holds files already; use --force", "clear", _demo_folder_with_files),
    Case("C27", "CLI", "Ctrl-C during a command", "interrupted (Ctrl-C): stopped before the end; no output was written and an existing one is unchanged (exit 130)", "clear", _interrupted),
    Case("C28", "CLI", "an unexpected internal error", "one line with its type and 'rerun with --debug' (exit 1)", "clear", _unexpected),
    Case("C29", "CLI", "`benchmark` where some rows failed", "exit 1: N row(s) failed (method on benchmark)", "clear", _benchmark_failures),
    Case("C33", "CLI", "`--out` / `--save` a named pipe, a symlink to one, or a folder, with `--force`", "refused: is a named pipe, not a regular file; neckid replaces only regular files (even with --force); the pipe is unchanged", "clear", _special_files_refused),
    Case("C34", "CLI", "two `identify --save same.npz` at once", "one saves; the other is refused: another neckid run is writing --save ... (or: exists already); never two 'model saved'", "clear", _concurrent_saves),
    Case("C35", "CLI", "`--save` a file another run holds", "refused before the fit: another neckid run is writing --save ... (it holds the lock ...)", "clear", _locked_output),
    Case("C36", "CLI", "outputs under umask 022; `--force` over a 0640 file", "written 0644 (the umask's mode); a replaced file keeps its mode", "correct", _umask_kept),
    Case("C37", "CLI", "SIGTERM or SIGHUP during a command", "interrupted (SIGTERM) / (SIGHUP), exit 143 / 129; no output written, no temporary left", "clear", _terminated),
    Case("C38", "CLI", "temporary files of a killed run beside the output; a killed run's staging folder", "removed by the next run into the same place; other files kept", "correct", _stale_temporaries),
    Case("C39", "CLI", "`--out` / `--plot` named '', '.' or '..'", "refused: names no file; give a file name", "clear", _degenerate_names),
    Case("C40", "CLI", "`--plot fit.pdf`, `simulate --out sim.parquet`", "refused: the file is written as PNG / CSV, so its name must end in .png / .csv", "clear", _wrong_extension),
    Case("C41", "CLI", "`identify ... \\| head -0` (standard output closed)", "the model is saved, exit 0, no error", "correct", _closed_stdout),
    Case("C42", "CLI", "`--condition payload=0,4kg`, `1,000kg`, `1 000g`; `0.4kg!`, `2 kg m`", "refused: the number holds a decimal comma or a thousands separator; write it with a decimal point / '...' after the number is not a unit", "clear", _condition_numbers),
    Case("C43", "CLI", "`--ts` 0, -0.1, nan, inf, 1e307 or 0,01", "refused by the option: ts must be a positive number of seconds (at most 1e+06)", "clear", _bad_ts_option),
    Case("C44", "CLI", "an integer beyond 2**53 in a column; dates as a channel's values", "refused: column 'command' holds the whole number ... beyond 2**53 / holds datetimes, not numbers", "clear", _values_beyond_floats),
    Case("C45", "CLI", "a Parquet or pandas time column of datetimes (naive or with a zone) or timedeltas", "read as seconds since the first sample: ts = 0.02 s, not 2e7", "correct", _datetime_time_column),
    Case("C46", "CLI", "`.mat` variables that are matrices, complex, text, cells, empty or of unequal lengths", "refused: FILE: variable 'command' is a 50x3 matrix / holds complex numbers / holds text / unequal lengths (...)", "clear", _mat_variables),
    Case("C47", "CLI", "a MATLAB v7.3 (HDF5) file", "read with h5py; without h5py refused: is a MATLAB v7.3 file (HDF5), which needs h5py: pip install h5py", "correct", _mat_v73),
    Case("C48", "CLI", "a CSV whose last line is cut short (fewer fields than the header)", "refused: the last line (row N, ...) has 2 field(s) where the header has 3: the file seems cut short", "clear", _cut_last_line),
    Case("C49", "CLI", "`--method rls --lags 1-1500/1` on 2,000 rows", "refused: 1501 unknowns per output but the training logs give only 500 equations", "clear", _rls_more_unknowns),
    Case("M1", "CLI", "a model file whose entry declares 10**12 values in 16 bytes", "refused by `info` and `validate`: is damaged: entry 'coef' declares shape (1000000000000,) of float64 (7.3 TB) but holds 16 B of values; refused before reading it (nothing allocated)", "clear", _model_file_damaged("shape")),
    Case("M2", "CLI", "a zip bomb as a model file: 1.6 MB that inflates to 1.6 GB", "refused in a fraction of a second, under 64 MB allocated: is damaged: its 1.6 MB inflate to 1.6 GB of arrays (1027 times; ...): a zip bomb or a damaged archive", "clear", _model_file_damaged("bomb")),
    Case("M3", "CLI", "a model file whose array holds complex numbers, text, dates, Python objects, or booleans where real numbers belong", "refused: entry 'coef' holds complex numbers, dtype complex128 ... / holds booleans (dtype bool); a LinearARX file holds real numbers there (dtype float64); never unpickled", "clear", _model_file_dtypes),
    Case("M4", "CLI", "a model file with `ts` NaN or infinite, a training range reversed or NaN, `n_samples` < 0", "refused: header key 'meta.ts': ts must be a positive number of seconds; got nan / header key 'meta.training_ranges.command' must be [low, high], two finite numbers with low <= high; got [1.0, -1.0]", "clear", _model_file_numbers),
    Case("M5", "CLI", "a model file from a newer neckid (format version 2)", "refused: has model-file version 2, written by neckid 9.1.0, newer than this neckid reads (neckid 0.1.0 reads versions up to 1); upgrade neckid to load it", "clear", _model_file_newer),
    Case("M6", "API", "a model header nested 100,000 deep, a 5,000-digit number in it, a lone `.npy` file", "ValueError: the header is nested too deeply / is not valid JSON / a single .npy array, not an .npz archive", "clear", _model_file_structure),
    Case("M7", "API", "a model file whose arrays need more than half the memory available", "ValueError before reading: reading its arrays (entry 'x_train' alone ...) needs about ... of memory, and this machine has ... available", "clear", _model_file_memory),
    Case("M8", "API", "model files with real, integer and boolean arrays (arx, poly, sm)", "loaded after every check, and simulate exactly as the models saved", "correct", _model_files_of_every_kind),
    Case("L1", "CLI", "a Parquet log cut short or with bytes zeroed; one repeating the column read", "refused: log.parquet is not a readable Parquet file (ArrowInvalid: ...) / column name 'command' appears 2 times in the file", "clear", _parquet_damaged),
    Case("L2", "CLI", "a byte changed in a page of values of a Parquet log neckid wrote", "refused by the page's checksum (... CRC ...), never read as another number", "clear", _parquet_page_checksum),
    Case("L3", "API", "a Parquet or `.mat` log whose columns need more than half the memory available", "ValueError before reading: reading 3 column(s) of N rows needs about ... of memory / reading the variables [...] (N values) needs ...", "clear", _logs_beyond_memory),
    Case("L4", "CLI", "integer time stamps beyond 2**53 (nanoseconds since 1970)", "refused: time column 'time' holds the whole number ... beyond 2**53, not rounded", "clear", _time_stamps_beyond_floats),
    Case("U1", "API", "runs fitted together, one's inclination in deg, the other's in rad", "ValueError: data[1] (b) has inclination in rad, but data[0] (a) in deg: runs fitted together must agree on units", "clear", _units_across_runs),
    Case("U2", "API", "a model identified in deg run on a log in rad", "ValueError: run has inclination in rad, but the model was identified with inclination in deg: convert the log's inclination to deg", "clear", _model_on_other_units),
    Case("U3", "CLI", "the same log twice to `identify` (another spelling of its path); a test log that is a training log in `compare`", "refused: ... is given twice (also as ...) / a test log must not be a training log; no model written", "clear", _same_log_twice),
    Case("U4", "CLI", "`info` on a `.mat` log with a repeated time stamp and a text variable", "the description, 1 repeated time stamp(s), not channels: label (text)", "correct", _info_other_formats),
    Case("U5", "API", "lags that need more memory than the machine has (40 + 40 terms, 1 MB available)", "ValueError before allocating: the regressor of ... needs about ... of memory, and this machine has 1.0 MB available: use fewer lags, ...", "clear", _too_much_memory),
    Case("U6", "API", "a label condition the model was not identified with", "ValueError: ... has neck='C', a label the model was not identified with (it knows A, B)", "clear", _label_not_seen),
    Case("U7", "CLI", "`benchmark --data-dir` of a folder with none of the data sets", "refused: nothing to run: none of the data sets ... is under ...; no output folder", "clear", _empty_benchmark_folder),
    Case("U8", "CLI", "`--lags 3/1` (meant as na = 3); `--lags` with `--orders`", "a note: the output lag 3 alone, y(t-3); for the lags 1 to 3 write --lags 1-3/... or --orders 3,NB,NK / refused: give the regressor once", "clear", _lone_output_lag),
    Case("K1", "CLI", "`validate --in-loop` with a controller that did not make the log (the fra controller on a PI's log)", "refused: LOG: the controller fra does not reproduce the log's commands: the controller check ... is 9.97 rad/s, beyond the tolerance 1e-04 rad/s (...); --force runs it anyway (then a warning: the figures compare two different loops); nothing written", "clear", _loop_wrong_controller),
    Case("K2", "CLI", "`--in-loop --controller FOLDER` of adaptive parameter logs on a log another controller made; a parameter file of another payload", "refused: int000stepresponse.csv was made by the PI (int), as its name says; ... give --controller int / ada200response.csv is the 200 g adaptive run but the parameter log adacon400.csv is the 400 g one", "clear", _loop_parameter_logs),
    Case("K3", "CLI", "`--in-loop --controller` a designed controller at 0.05 s on a log at 0.025 s", "refused: LOG: the controller ... runs every 0.05 s but the log is sampled every 0.025 s", "clear", _loop_controller_period),
    Case("K4", "CLI", "a controller file with a NaN gain, or `ki` edited and its twin `kf` left unchanged", "refused: FILE: gains.kp must be a finite number; got nan / FILE: gains.ki = 0.9 disagrees with gains.kf = 0.8237 (ki is the same gain as kf ...): edit both, or remove gains.ki", "clear", _loop_controller_gains),
    Case("K5", "CLI", "`validate --in-loop` of a model whose loop diverges", "diverged: LOG: the loop's inclination left ±1000 deg ... at row N (t = ... s); the JSON written; exit 3, as a diverged free run", "clear", _loop_diverges),
    Case("K6", "CLI", "`validate --in-loop` with `--map`, `--tilt`, `--channel`", "--map renames the log's columns (and the model's stored mapping applies); refused: --tilt: the lab's loop measures the inclination alone ... / --channel names the channels of a ROS 2 bag (--layout rosbag)", "clear", _loop_log_options),
    Case("K7", "CLI", "`validate --plot` of a two-output model (tilt_x, tilt_y)", "each output in its own axes with its unit (and its errors below), its band and the domain marks on it", "correct", _two_outputs_drawn),
    Case("A1", "API", "a complex array given to IOData", "TypeError: u holds complex numbers", "clear", _complex_array),
    Case("A2", "API", "a free run that diverges", "DivergenceError naming sample and time; the run in .result", "clear", _diverging_api),
    Case("A3", "API", "an SM model file with gamma < 0", "ValueError on load: gamma must be > 0", "clear", _sm_negative_gamma),
    Case("A4", "API", "`simulator().reset(y0=...)` of the wrong shape", "ValueError: y0 must have shape (1,) or (1, 1); got (3, 2)", "clear", _reset_shape),
    Case("A5", "API", "a hyper-parameter out of range", "ValueError at fit naming it, its rule and value", "clear", _bad_hyper_parameter),
    Case("A6", "API", "a write interrupted half way", "the old file stays, no temporary left", "correct", _output_written_whole),
    Case("A7", "API", "`ts` True, '0.1', complex, 1e307 or NaN", "TypeError: ts must be a number of seconds; got True / ValueError: ... at most 1e+06", "clear", _ts_not_a_number),
]  # fmt: skip

# The held-out campaign's classes of bad data, files and model files: one case per class.
CASES += INPUT_CASES  # type: ignore[arg-type]
# What the command line shows (issue 39): readable when piped, progress that tells the truth,
# options no longer accepted then ignored.
CASES += OUTPUT_CASES  # type: ignore[arg-type]
# Runs that are stopped (issue 39): every long run stops when asked.
CASES += INTERRUPT_CASES  # type: ignore[arg-type]


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_case(case: Case, tmp_path: Path) -> None:
    case.check(tmp_path)


#: The pages of the table: one per class of case, by the letter of its id. Each page stays under
#: the user guide's 12,000 characters (tests/test_docs_size.py); a new class gets a row here.
PAGES = (
    ("commands", "Commands: outputs, logs, model files and signals", "C",
     "What a command does with the files it is given and the files it writes, logs it cannot read,"
     " model files that are damaged, and a run that is stopped or fails."),
    ("files", "Logs and model files: what they hold", "ILM",
     "Numbers that are not what they look like, logs that are incomplete or contradict the options,"
     " Parquet and `.mat` logs, and model files checked in full before they are used."),
    ("runs", "Runs: units, loops, outputs, stops and the API", "UKOSA",
     "Runs that disagree on units or conditions, controllers in the lab's loop, what the command"
     " line prints when piped, runs that are stopped, and the library's own checks."),
)  # fmt: skip

_HEADER = ["| case | where | the user gives | the user sees | outcome |", "|---|---|---|---|---|"]


def _cell(text: str) -> str:
    """Table text as written: ``2**53`` stays two stars, not the start of bold type."""
    return text.replace("**", "\\*\\*")


def _page_of(case: Case) -> str:
    letter = case.id.rstrip("0123456789")
    for name, _, letters, _ in PAGES:
        if letter in letters:
            return name
    raise AssertionError(f"case {case.id}: its letter {letter!r} is on no page of PAGES")


def render() -> dict[Path, str]:
    """``docs/reliability.md`` and its pages under ``docs/reliability/``: the tables of the cases."""
    counts = {k: sum(c.outcome == k for c in CASES) for k in ("clear", "correct")}
    lines = [
        "# Reliability: what a user sees on bad input",
        "",
        "Generated from `tests/test_reliability.py` (`python tests/test_reliability.py` rewrites it;",
        "the test suite checks that it is up to date). Every row of the pages below is a test:",
        "*clear* means refused with one line naming what is wrong and no traceback; *correct* means",
        "accepted and right. The command line exits with status 2 for bad input, 3 for a diverging",
        "free run, 130 after Ctrl-C, 143 after SIGTERM, 129 after SIGHUP and 1 for an unexpected",
        "error (its traceback with `neckid --debug`). A stopped run stops within a second or two at",
        "its next safe point, never inside a compiled kernel (a kernel being compiled, on the first",
        "run after an install, is compiled to its end first), writes nothing and leaves an existing",
        "output as it was: `tests/test_interrupt.py` interrupts every registered method's `identify`",
        "in a subprocess; rows S1-S5 are the cases of a stop.",
        "",
        f"Cases: {len(CASES)}; clear {counts['clear']}, correct {counts['correct']}, vague 0,"
        " traceback 0, silent 0.",
        "",
        "| page | what it covers | cases |",
        "|---|---|---|",
    ]
    pages: dict[Path, str] = {}
    for name, title, _, about in PAGES:
        cases = [c for c in CASES if _page_of(c) == name]
        lines.append(f"| [{title}](reliability/{name}.md) | {about} | {len(cases)} |")
        body = [f"# {title}", "", about, "", "Generated from `tests/test_reliability.py`;",
                "[Reliability](../reliability.md) says what the outcomes and exit codes mean.", "",
                *_HEADER]  # fmt: skip
        body += [
            f"| {c.id} | {c.surface} | {_cell(c.given)} | {_cell(c.sees)} | {c.outcome} |"
            for c in cases
        ]
        pages[DOC.parent / "reliability" / f"{name}.md"] = "\n".join(body) + "\n"
    lines += _fuzzing()
    return {DOC: "\n".join(lines) + "\n", **pages}


def _fuzzing() -> list[str]:
    """The section on fuzzing: what ``tests/test_fuzz_files.py`` feeds each reader."""
    from test_fuzz_files import COVERAGE

    lines = [
        "",
        "## Fuzzing",
        "",
        "Beyond these cases, `tests/test_fuzz_files.py` feeds every reader generated files (Hypothesis,",
        "derandomized: the same examples on every run). Each one is read into a log whose values are",
        "finite and whose lengths agree (for the typed Parquet and `.mat` logs: exactly the values",
        "written, and every valid log is read), loaded into a model that runs and whose header numbers",
        "are possible, or refused with `ValueError`, `KeyError`, `TypeError` or `FileNotFoundError`",
        "(exactly those types) in one line naming the file; never a traceback, a `MemoryError`, a raw",
        "NumPy, pyarrow or SciPy exception, nor a silent wrong result.",
        "",
        f"Examples per run: {sum(n for _, _, n in COVERAGE)}.",
        "",
        "| files | what is fuzzed | examples |",
        "|---|---|---|",
    ]
    lines += [f"| {files} | {_cell(what)} | {n} |" for files, what, n in COVERAGE]
    return lines


@pytest.mark.parametrize("page", sorted(render()), ids=lambda p: p.name)
def test_the_reliability_tables_are_up_to_date(page: Path) -> None:
    assert page.exists() and page.read_text(encoding="utf-8") == render()[page], (
        f"{page.relative_to(DOC.parents[1])} is stale: run `python tests/test_reliability.py`"
    )


def test_every_case_is_on_a_page() -> None:
    for case in CASES:
        _page_of(case)


if __name__ == "__main__":
    for path, text in render().items():
        path.parent.mkdir(exist_ok=True)
        path.write_text(text, encoding="utf-8")
        sys.stdout.write(f"wrote {path}\n")
