"""Every long run stops when asked: each registered method's CLI fit, interrupted in the middle.

Each case runs ``neckid identify LOG --method M --save out.npz`` in a subprocess on a simulated
neck log this module writes, waits until the fit has run :data:`INTERRUPT_AFTER` seconds, sends
the signal, and checks that the command said it stopped within :data:`STOP_WITHIN` seconds and
exited with status 128 + the signal (130 for Ctrl-C, 143 for SIGTERM), that the fit had not
finished, and that no file appeared (nor a temporary one). Ctrl-C is sent as a terminal sends
it, to the whole process group; SIGTERM to the process alone, as ``kill`` and ``timeout`` send
it. Every method gets Ctrl-C, ``sm`` SIGTERM too, and a ``compare`` of arx and nn gets Ctrl-C
during its networks; one more case interrupts ``--force`` over an existing model and checks
that the model is byte for byte unchanged. The cases run :data:`PARALLEL` at a time (about
55 s on 2 cores).

The fit's start and end are seen through a small launcher (:data:`LAUNCHER`): it runs the
command line's ``app`` exactly as the ``neckid`` script does, after wrapping the method's
``fit`` so that it writes a line to standard error when it starts and when it returns (and one
per numba compilation, which a signal waits for). It also sets SIGINT to Python's default
handler first: a shell starts a background job (and so a test run in one) with SIGINT ignored,
which neckid, like Python, leaves ignored.

The logs (40,000 samples; 80,000 for the polynomial family) and the settings (:data:`LONG`: a
higher order or more terms, local Lipschitz constants) make every fit last well beyond the
signal. ``arx``, ``rls``, ``scheduled``, ``scheduled-position``, ``sm-linear`` and
``sm-parallel`` fit them in a fraction of a second whatever the settings (one least-squares
solve, one pass of a compiled recursion, a Set Membership prior on a small residual): they get
the signal as soon as their fit has started (:data:`QUICK`).

The tests after them check the handler of :mod:`neckid.utils.interrupt` in this process: a
signal inside numba's frames or a numba compilation waits for their end, a swallowed interrupt
is raised again, a deferred block runs whole, an ignored signal stays ignored, and the neural
NARX does not swallow Ctrl-C.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import neckid
from neckid.utils.interrupt import (
    STOP_SIGNALS,
    Interrupted,
    check,
    deferred,
    stop_requested,
    stop_signals,
)

#: Seconds of fit before the signal.
INTERRUPT_AFTER = 2.0

#: Seconds from the signal to the command's "interrupted" line: the run has stopped (the longest
#: compiled call of these fits lasts 0.7 s on 2 cores; the cases run side by side).
STOP_WITHIN = 3.0

#: Seconds from the signal to the end of the process: the interpreter's exit after the line
#: (0.3-0.5 s on an idle machine, 2-3 s when it is loaded: it frees numba's, SciPy's and
#: scikit-learn's modules).
EXIT_WITHIN = 15.0

#: Cases run at the same time (each is one process, mostly waiting).
PARALLEL = max(2, min(4, os.cpu_count() or 2))

#: Longest a case may take before the test gives up on it (a fit that ignores the signal).
GIVE_UP_AFTER = 120.0

STARTED, FINISHED = "<neckid-test: fit started>", "<neckid-test: fit finished>"
COMPILED = "<neckid-test: compiled for "

#: Runs the command line as the ``neckid`` script does, announcing the fit's start and end, and
#: every numba compilation longer than 0.2 s (a kernel whose cache is missing or stale: a signal
#: waits for its end, so the test allows for it).
LAUNCHER = f"""
import signal, sys, time
signal.signal(signal.SIGINT, signal.default_int_handler)  # a terminal's, not a background job's
import neckid
from numba.core import dispatcher
compile_for_args = dispatcher._DispatcherBase._compile_for_args
def timed(self, *args, **kwargs):
    start = time.monotonic()
    try:
        return compile_for_args(self, *args, **kwargs)
    finally:
        if time.monotonic() - start > 0.2:
            sys.stderr.write({COMPILED!r} + f"{{time.monotonic() - start:.2f}} s>\\n")
            sys.stderr.flush()
dispatcher._DispatcherBase._compile_for_args = timed
cls = neckid.methods()[sys.argv[1]].estimator_class()
fit, depth = cls.fit, [0]
def announced(self, *args, **kwargs):
    depth[0] += 1
    if depth[0] == 1:
        sys.stderr.write({STARTED!r} + "\\n"); sys.stderr.flush()
    try:
        result = fit(self, *args, **kwargs)
    finally:
        depth[0] -= 1
    if depth[0] == 0:
        sys.stderr.write({FINISHED!r} + "\\n"); sys.stderr.flush()
    return result
cls.fit = announced
from neckid.cli import app
app(sys.argv[2:], prog_name="neckid")
"""

#: Methods whose fit of this log is over in well under INTERRUPT_AFTER whatever the settings
#: (measured on 2 cores, 40,000 samples: arx 0.02 s, rls and scheduled-position 0.1 s,
#: scheduled 0.2 s, sm-linear and sm-parallel 0.2-0.4 s, also with local Lipschitz constants
#: or an ε grid): they get the signal as soon as the fit has started.
QUICK = frozenset({"arx", "rls", "scheduled", "scheduled-position", "sm-linear", "sm-parallel"})

#: Extra ``identify`` arguments that make a method's fit long, as CPU seconds measured on
#: this log (the others' defaults are long enough: ss 4 s, pnlss 11 s, nn 8 s (its own
#: trainer; 25 s with scikit-learn's), greybox-neck 9 s, greybox-tanks and sm-multistep over a
#: minute).
LONG: dict[str, tuple[str, ...]] = {
    "ss": ("--set", "order=5", "--set", "max_iter=1000"),  # 31 s (4 s with max_iter=100)
    "sm": ("--set", "lipschitz=local"),  # 5 s
    "poly": ("--set", "degree=2"),  # 14 s with the lags below, on the long log
    "sm-parallel-poly": ("--set", "parallel_degree=2"),  # 15 s, ditto
    "lpv": ("--set", "degree=1"),  # 5 s, ditto
    "sindy": ("--set", "ensemble=20"),  # 5 s with the lags below (1.9 s with 1-2/1-3, no bags)
}

#: Lags by method (the scheduled model and RLS read the velocity command, the others the
#: motor position).
LAGS = {
    "rls": "1-2/1-2",
    "scheduled": "1/1",
    "scheduled-position": "1/1",
    "poly": "1-4/1-6",
    "sm-parallel-poly": "1-4/1-6",
    "lpv": "1-4/1-6",
    "sindy": "1-4/1-6",
    "sm-parallel-sindy": "1-4/1-6",  # 5 s
}

#: Methods fitted on the long log (80,000 samples): a polynomial fit is a least-squares
#: solve, one QR factorisation of all its rows (about 1 s here, a call that cannot stop half
#: way), then a free-run fit about ten times as long; a longer fit needs more rows, not more
#: terms, or the QR alone would outlast "a second or two".
ON_THE_LONG_LOG = frozenset({"poly", "sm-parallel-poly", "lpv"})


@pytest.fixture(scope="module")
def neck_logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The simulated neck, open loop, as CSV: 40,000 samples (13 min) and 80,000 ("long")."""
    from neckid.plant import SoftNeck
    from neckid.signals import multisine

    neck = SoftNeck(seed=3)
    n = 80_000
    position = 2.5 + 2.0 * multisine(n, neck.ts, band=(0.05, 4.0), phases="random", seed=1)
    velocity = np.concatenate(
        [np.full(150, position[0] / 3.0), np.diff(position, prepend=position[0]) / neck.ts]
    )
    neck.reset()
    run = neck.run(velocity)[150:]
    folder = tmp_path_factory.mktemp("interrupt")
    logs = {"short": folder / "neck.csv", "long": folder / "neck-long.csv"}
    run[: n // 2].to_csv(logs["short"])
    run.to_csv(logs["long"])
    return logs


def _log_of(logs: dict[str, Path], method: str) -> Path:
    return logs["long" if method in ON_THE_LONG_LOG else "short"]


@dataclass
class Outcome:
    """What one interrupted run did."""

    command: str  # identify, compare
    method: str
    code: int | None
    stopped_after: float  # seconds from the signal to the "interrupted" line
    ended_after: float  # seconds from the signal to the end of the process
    fit_ran: float  # seconds of fit before the signal
    finished_fit: bool
    compiling: float  # seconds spent compiling kernels after the fit started
    stderr: str
    leftovers: list[str]


def _identify(log: Path, method: str, save: Path, *extra: str) -> list[str]:
    """The ``identify`` arguments of ``method``'s long fit of ``log``, saved to ``save``."""
    inputs = "velocity_command" if method in ("rls", "scheduled") else "motor_position"
    return [
        "identify",
        str(log),
        "--inputs",
        inputs,
        "--outputs",
        "inclination",
        "--method",
        method,
        "--lags",
        LAGS.get(method, "1-2/1-3"),
        "--save",
        str(save),
        *LONG.get(method, ()),
        *extra,
    ]


def interrupt(
    log: Path,
    method: str,
    folder: Path,
    *,
    signum: int = signal.SIGINT,
    after: float | None = None,
    extra: tuple[str, ...] = (),
    command: list[str] | None = None,
) -> Outcome:
    """Run ``identify`` of ``method`` (or ``command``, a neckid command whose fits of ``method``
    are watched) in ``folder``; send ``signum`` once the fit ran ``after`` seconds."""
    folder.mkdir(parents=True, exist_ok=True)
    before = set(os.listdir(folder))
    args = command or _identify(log, method, folder / "out.npz", *extra)
    wait = (0.0 if method in QUICK else INTERRUPT_AFTER) if after is None else after
    err_path = folder / "stderr.txt"
    with err_path.open("w") as err, (folder / "stdout.txt").open("w") as out:
        process = subprocess.Popen(
            [sys.executable, "-c", LAUNCHER, method, *args],
            stdout=out,
            stderr=err,
            start_new_session=True,  # its own process group, as a terminal's foreground job
        )
    try:
        deadline = time.monotonic() + GIVE_UP_AFTER
        while STARTED not in err_path.read_text() and process.poll() is None:
            if time.monotonic() > deadline:
                raise AssertionError(f"{method}: the fit did not start in {GIVE_UP_AFTER} s")
            time.sleep(0.02)
        started = time.monotonic()
        while time.monotonic() < started + wait and process.poll() is None:
            time.sleep(0.02)
        sent = time.monotonic()
        if process.poll() is None:
            if signum == signal.SIGINT:
                os.killpg(process.pid, signum)  # Ctrl-C reaches the terminal's whole group
            else:
                process.send_signal(signum)
        said = None
        while process.poll() is None and time.monotonic() < sent + GIVE_UP_AFTER:
            if said is None and "interrupted" in err_path.read_text():
                said = time.monotonic()
            time.sleep(0.02)
        code = process.poll()
        ended = time.monotonic()
        said = ended if said is None else said
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    stderr = err_path.read_text()
    leftovers = sorted(set(os.listdir(folder)) - before - {"stderr.txt", "stdout.txt"})
    compiling = sum(
        float(line[len(COMPILED) :].split()[0])
        for line in stderr.partition(STARTED)[2].splitlines()
        if line.startswith(COMPILED)
    )
    return Outcome(
        args[0],
        method,
        code,
        said - sent,
        ended - sent,
        sent - started,
        FINISHED in stderr,
        compiling,
        stderr,
        leftovers,
    )


def _check(outcome: Outcome, code: int) -> None:
    name, tail = f"{outcome.command} {outcome.method}", outcome.stderr[-2000:]
    assert outcome.method in QUICK or not outcome.finished_fit, (
        f"{name}: the fit finished {outcome.fit_ran:.1f} s after it started, before the signal:"
        f" make it longer in LONG (or list the method in QUICK)\n{tail}"
    )
    assert outcome.code == code, f"{name}: exit status {outcome.code}\n{tail}"
    # A kernel compiling when the signal came is compiled to its end first (never cut half way).
    assert outcome.stopped_after <= STOP_WITHIN + outcome.compiling, (
        f"{name}: stopped {outcome.stopped_after:.1f} s after the signal\n{tail}"
    )
    assert outcome.ended_after <= EXIT_WITHIN + outcome.compiling, (
        f"{name}: ended {outcome.ended_after:.1f} s after the signal\n{tail}"
    )
    assert outcome.leftovers == [], f"{name}: left {outcome.leftovers}\n{tail}"
    assert "interrupted" in outcome.stderr and "Traceback" not in outcome.stderr, tail


def _compare(logs: dict[str, Path], folder: Path) -> list[str]:
    """``compare`` of arx and nn on three parts of the short log, tested on the fourth."""
    import pandas as pd

    folder.mkdir(parents=True, exist_ok=True)
    frame = pd.read_csv(logs["short"])
    parts = []
    for k in range(4):
        parts.append(folder / f"part{k}.csv")
        frame.iloc[k * 10_000 : (k + 1) * 10_000].to_csv(parts[-1], index=False)
    return [
        "compare",
        *map(str, parts[:3]),
        "--test",
        str(parts[3]),
        "--inputs",
        "motor_position",
        "--outputs",
        "inclination",
        "--methods",
        "arx,nn",
        "--json",
        str(folder / "compare.json"),
    ]


def test_every_method_stops_on_ctrl_c_and_sigterm(
    neck_logs: dict[str, Path], tmp_path: Path
) -> None:
    """Ctrl-C during each method's fit: exit 130, no file; SIGTERM once: exit 143, no file.

    And Ctrl-C during the networks of a ``compare`` that includes ``nn``: exit 130, no JSON.
    """
    cases = [(m, signal.SIGINT, None) for m in neckid.methods()]
    cases += [("sm", signal.SIGTERM, None), ("nn", signal.SIGINT, "compare")]

    def run(case: tuple[str, int, str | None]) -> Outcome:
        method, signum, command = case
        folder = tmp_path / f"{command or 'identify'}-{method}-{signum}"
        return interrupt(
            _log_of(neck_logs, method),
            method,
            folder,
            signum=signum,
            # compare's first network fits (on a third of the log each) last about 1 s
            after=0.5 if command == "compare" else None,
            command=_compare(neck_logs, folder) if command == "compare" else None,
        )

    with ThreadPoolExecutor(PARALLEL) as pool:
        outcomes = list(pool.map(run, cases))
    report = "\n".join(
        f"{o.command} {o.method}: exit {o.code}, fit ran {o.fit_ran:.1f} s, stopped"
        f" {o.stopped_after:.2f} s after the signal (ended {o.ended_after:.2f} s), compiled"
        f" {o.compiling:.1f} s,"
        f" fit finished {o.finished_fit}"
        for o in outcomes
    )
    sys.stdout.write(report + "\n")
    for (_, signum, _), outcome in zip(cases, outcomes, strict=True):
        _check(outcome, 128 + int(signum))


def test_force_over_a_model_keeps_it_when_interrupted(
    neck_logs: dict[str, Path], tmp_path: Path
) -> None:
    """``--force`` over an existing model, interrupted during the fit: the old file is unchanged."""
    old = tmp_path / "out.npz"
    neckid.LinearARX(neckid.Lags.arx(1, 1)).fit(
        neckid.IOData.from_csv(neck_logs["short"], ["motor_position"], ["inclination"])
    ).save(old)
    before = old.read_bytes()
    outcome = interrupt(neck_logs["short"], "nn", tmp_path, extra=("--force",))
    _check(outcome, 130)
    assert old.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


# ---------------------------------------------------------------- the handler, in this process
@pytest.fixture(autouse=True)
def _signals_as_in_a_terminal() -> Any:
    """Python's own SIGINT handler and SIGTERM, SIGHUP not ignored, as in a terminal, even when
    the test run was started with them ignored (``nohup make test``, a background job)."""
    previous = {s: signal.getsignal(s) for s in STOP_SIGNALS}
    signal.signal(signal.SIGINT, signal.default_int_handler)
    for number, handler in previous.items():
        if number != signal.SIGINT and handler is signal.SIG_IGN:
            signal.signal(number, signal.SIG_DFL)
    yield
    for number, handler in previous.items():
        if handler is not None:
            signal.signal(number, handler)


def _send_soon(signum: int, delay: float = 0.03) -> threading.Timer:
    timer = threading.Timer(delay, os.kill, (os.getpid(), signum))
    timer.start()
    return timer


def test_a_stop_signal_raises_interrupted_with_its_number_and_the_handlers_come_back() -> None:
    before = {s: signal.getsignal(s) for s in STOP_SIGNALS}
    for signum in STOP_SIGNALS:
        with pytest.raises(Interrupted) as caught, stop_signals():
            assert stop_requested() is None
            os.kill(os.getpid(), signum)
            time.sleep(5)  # cut short by the signal
        assert caught.value.signum == signum and isinstance(caught.value, KeyboardInterrupt)
    assert {s: signal.getsignal(s) for s in STOP_SIGNALS} == before
    assert not [t for t in threading.enumerate() if t.name == "neckid-stop-signals"]


def test_outside_the_block_nothing_changes() -> None:
    assert stop_requested() is None
    check()  # no stop asked for: nothing
    with deferred():
        pass
    with pytest.raises(KeyboardInterrupt) as caught:  # Python's own handler, as before
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5)
    assert not isinstance(caught.value, Interrupted)


def test_a_swallowed_interrupt_is_raised_again_by_check() -> None:
    with pytest.raises(Interrupted) as caught, stop_signals():
        try:  # what scikit-learn's MLP does with a Ctrl-C
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)
        except KeyboardInterrupt:
            pass
        assert stop_requested() == signal.SIGINT
        check()
        pytest.fail("check() did not raise")
    assert caught.value.signum == signal.SIGINT


def test_a_deferred_block_runs_whole_and_raises_at_its_end() -> None:
    done = []
    with pytest.raises(Interrupted), stop_signals():
        with deferred():
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.1)  # not cut short
            done.append(True)
        pytest.fail("the deferred block's end did not raise")
    assert done == [True]


def test_no_exception_is_raised_inside_a_frame_of_numba() -> None:
    """A signal that arrives while numba's Python code runs waits until the thread leaves it."""
    # The signal is sent from inside the frame, to the main thread: a timer's process-directed
    # signal can come after the frame on a loaded machine, and reach another thread, which
    # does not cut the main thread's sleep short.
    source = (
        "def busy(seconds, clock, done, send):\n"
        "    end = clock() + seconds\n"
        "    send()\n"
        "    while clock() < end:\n"
        "        pass\n"
        "    done.append(clock())\n"
    )
    namespace: dict[str, object] = {"__name__": "numba.core.dispatcher_like"}
    exec(compile(source, "<numba's machinery>", "exec"), namespace)
    busy = namespace["busy"]
    done: list[float] = []
    main = threading.main_thread().ident
    assert main is not None

    def send() -> None:
        signal.pthread_kill(main, signal.SIGINT)

    with pytest.raises(Interrupted), stop_signals():
        busy(0.3, time.monotonic, done, send)  # type: ignore[operator]
        time.sleep(5)  # the signal, delivered again, ends this at once
    raised = time.monotonic()
    assert done, "the exception was raised inside the numba frame"
    assert raised - done[0] < 1.0


def test_a_signal_during_a_numba_compilation_waits_for_it() -> None:
    """Never a SystemError from the dispatcher, never a signal dropped by llvmlite."""
    import numba

    def kernel(values: np.ndarray) -> float:
        total = 0.0
        for k in range(values.shape[0]):
            total += math.sin(values[k]) * math.cos(values[k] ** 2) + math.sqrt(abs(values[k]))
        return total

    for _ in range(5):
        compiled = numba.njit(kernel)  # no cache: compiled on the first call below
        seen: dict[str, bool] = {}

        def send(compiled: Any = compiled, seen: dict[str, bool] = seen) -> None:
            seen["compiling"] = not compiled.signatures  # not compiled yet when it is sent
            os.kill(os.getpid(), signal.SIGTERM)

        timer = threading.Timer(0.02, send)
        with pytest.raises(Interrupted) as caught, stop_signals():
            timer.start()
            compiled(np.linspace(0.0, 1.0, 10))
            time.sleep(5)
        timer.join()
        assert caught.value.signum == signal.SIGTERM
        if seen["compiling"]:
            assert compiled.signatures, "the compilation was cut half way"
            return
    pytest.fail("the signal never arrived during a compilation (each was over in 20 ms)")


def test_a_signal_ignored_by_the_parent_stays_ignored() -> None:
    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)  # as nohup starts a program
    try:
        with stop_signals():
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGHUP)
            time.sleep(0.1)
            assert stop_requested() is None
    finally:
        signal.signal(signal.SIGHUP, previous)


def test_a_neural_narx_fit_stops_within_an_epoch_on_ctrl_c(monkeypatch: pytest.MonkeyPatch) -> None:
    """A Ctrl-C during an epoch ends the fit after that epoch: no next one, no model."""
    import neckid.models.neural._training as training
    from _synthetic import arx_system

    epochs = []
    epoch = training.adam_epoch

    def interrupted_at_the_third_epoch(*args: Any) -> None:
        epochs.append(1)
        epoch(*args)
        if len(epochs) == 3:
            raise KeyboardInterrupt  # as Python's handler raises it, between two bytecodes

    monkeypatch.setattr(training, "adam_epoch", interrupted_at_the_third_epoch)
    model = neckid.NeuralNARX(neckid.Lags.arx(2, 2), hidden_layer_sizes=(4,), max_iter=50)
    with pytest.raises(KeyboardInterrupt):  # Python's own handler: a plain KeyboardInterrupt
        model.fit(arx_system(300, seed=0))
    assert len(epochs) == 3  # not one epoch more
    assert not hasattr(model, "coefs_")


def test_an_output_written_before_the_stop_is_named(tmp_path: Path) -> None:
    """``identify --save --json``, stopped between the two: the model is named, the JSON absent."""
    from typer.testing import CliRunner

    import neckid.cli.models
    from _synthetic import arx_system
    from neckid.cli import app

    log, save, summary = tmp_path / "run.csv", tmp_path / "model.npz", tmp_path / "fit.json"
    arx_system(400, seed=0).to_csv(log)
    describe = neckid.cli.models._identify_summary

    def stopped(*args: Any, **kwargs: Any) -> Any:
        os.kill(os.getpid(), signal.SIGINT)  # after the model was saved, before the JSON
        time.sleep(5)
        return describe(*args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(neckid.cli.models, "_identify_summary", stopped)
        result = CliRunner().invoke(
            app,
            [
                "identify", str(log), "--inputs", "cmd", "--outputs", "incl", "--method", "arx",
                "--save", str(save), "--json", str(summary),
            ],
        )  # fmt: skip
    assert result.exit_code == 130, result.output
    shown = " ".join(result.output.split())
    assert f"written whole before the stop: {save}; nothing else was written" in shown, shown
    assert save.exists() and not summary.exists()
