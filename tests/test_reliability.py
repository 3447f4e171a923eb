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
    from neckid.outputs import output_folder

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
        refused(tmp, "simulate", model, log, "--out", out, match="interrupted", code=130)
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
    from neckid.outputs import atomic_path

    target = tmp / "model.npz"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_path(target) as temporary:
        temporary.write_text("half")
        raise RuntimeError("the disk is full")
    assert target.read_text() == "old"
    assert [p.name for p in tmp.iterdir()] == ["model.npz"]


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
    Case("C27", "CLI", "Ctrl-C during a command", "interrupted (exit 130); no file half written", "clear", _interrupted),
    Case("C28", "CLI", "an unexpected internal error", "one line with its type and 'rerun with --debug' (exit 1)", "clear", _unexpected),
    Case("C29", "CLI", "`benchmark` where some rows failed", "exit 1: N row(s) failed (method on benchmark)", "clear", _benchmark_failures),
    Case("A1", "API", "a complex array given to IOData", "TypeError: u holds complex numbers", "clear", _complex_array),
    Case("A2", "API", "a free run that diverges", "DivergenceError naming sample and time; the run in .result", "clear", _diverging_api),
    Case("A3", "API", "an SM model file with gamma < 0", "ValueError on load: gamma must be > 0", "clear", _sm_negative_gamma),
    Case("A4", "API", "`simulator().reset(y0=...)` of the wrong shape", "ValueError: y0 must have shape (1,) or (1, 1); got (3, 2)", "clear", _reset_shape),
    Case("A5", "API", "a hyper-parameter out of range", "ValueError at fit naming it, its rule and value", "clear", _bad_hyper_parameter),
    Case("A6", "API", "a write interrupted half way", "the old file stays, no temporary left", "correct", _output_written_whole),
]  # fmt: skip


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_case(case: Case, tmp_path: Path) -> None:
    case.check(tmp_path)


def render() -> str:
    """``docs/reliability.md``: the table of the cases."""
    counts = {k: sum(c.outcome == k for c in CASES) for k in ("clear", "correct")}
    lines = [
        "# Reliability: what a user sees on bad input",
        "",
        "Generated from `tests/test_reliability.py` (`python tests/test_reliability.py` rewrites it;",
        "the test suite checks that it is up to date). Every row is a test: *clear* means refused",
        "with one line naming what is wrong and no traceback; *correct* means accepted and right.",
        "The command line exits with status 2 for bad input, 3 for a diverging free run, 130",
        "after Ctrl-C and 1 for an unexpected error (its traceback with `neckid --debug`).",
        "",
        f"Cases: {len(CASES)}; clear {counts['clear']}, correct {counts['correct']}, vague 0,"
        " traceback 0, silent 0.",
        "",
        "| case | where | the user gives | the user sees | outcome |",
        "|---|---|---|---|---|",
    ]
    for c in CASES:
        lines.append(f"| {c.id} | {c.surface} | {c.given} | {c.sees} | {c.outcome} |")
    return "\n".join(lines) + "\n"


def test_the_reliability_table_is_up_to_date() -> None:
    assert DOC.read_text(encoding="utf-8") == render(), (
        "docs/reliability.md is stale: run `python tests/test_reliability.py`"
    )


if __name__ == "__main__":
    DOC.write_text(render(), encoding="utf-8")
    sys.stdout.write(f"wrote {DOC}\n")
