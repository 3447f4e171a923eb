"""Reliability cases for runs that are stopped (issue 39): every long run stops when asked.

Ctrl-C, SIGTERM and SIGHUP during a neural network's training (the signal arrives inside an
epoch, as it does from a terminal), during a compiled kernel's compilation (numba), over an existing model, and with a signal
the parent ignored. Each runs the command line in this process (its handler is installed as in
the ``neckid`` script) and sends the signal from inside the work; :mod:`test_interrupt` does the
same from outside, in a subprocess, for every registered method. :mod:`test_reliability` lists
them in its table (``docs/reliability.md``).
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import neckid
from _reliability_inputs import Case, cli
from neckid import IOData


def _log(folder: Path, name: str = "run.csv", n: int = 600, seed: int = 0) -> Path:
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, n // 10), 10)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.9 * y[t - 1] + 0.5 * np.tanh(u[t - 1]) + 0.01 * rng.standard_normal()
    path = folder / name
    IOData(u, y, ts=0.02, input_names=["command"], output_names=["inclination"]).to_csv(path)
    return path


@contextmanager
def _signal_at_epoch(signum: int, epoch_at: int = 3) -> Iterator[list[int]]:
    """``signum`` sent to this process inside the trainer's epoch ``epoch_at``.

    Yields the list of epochs run (one entry each): a fit that goes on after the signal shows
    more than ``epoch_at`` + 1 of them.
    """
    import neckid.models.neural._training as training

    epochs: list[int] = []
    epoch = training.adam_epoch

    def counted(*args: Any) -> None:
        epochs.append(1)
        if len(epochs) == epoch_at:
            os.kill(os.getpid(), signum)  # the handler runs at the next bytecode
        epoch(*args)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(training, "adam_epoch", counted)
        yield epochs


def _identify(log: Path, save: Path, *extra: object) -> tuple[int, str]:
    return cli(
        "identify", log, "--inputs", "command", "--outputs", "inclination", "--method", "nn",
        "--set", "max_iter=200", "--save", save, *extra,
    )  # fmt: skip


def _network_interrupted(tmp: Path) -> None:
    log = _log(tmp)
    for signum, name in ((signal.SIGINT, "Ctrl-C"), (signal.SIGTERM, "SIGTERM")):
        save = tmp / f"nn-{signum}.npz"
        with _signal_at_epoch(signum) as epochs:
            code, shown = _identify(log, save)
        assert code == 128 + signum, shown
        assert f"interrupted ({name})" in shown and "no output was written" in shown, shown
        assert len(epochs) <= 4, f"{len(epochs)} epochs: the fit went on after the signal"
        assert not save.exists()
        assert sorted(p.name for p in tmp.iterdir() if p.name.startswith(".")) == []


def _comparison_interrupted(tmp: Path) -> None:
    train = [_log(tmp, f"train{k}.csv", seed=k) for k in range(2)]
    test = _log(tmp, "test.csv", seed=2)
    report = tmp / "compare.json"
    with _signal_at_epoch(signal.SIGINT) as epochs:
        code, shown = cli(
            "compare", *train, "--test", test, "--inputs", "command", "--outputs",
            "inclination", "--methods", "arx,nn", "--json", report,
        )  # fmt: skip
    assert code == 130 and "interrupted (Ctrl-C)" in shown, shown
    assert len(epochs) <= 4 and not report.exists()


def _compiling_interrupted(tmp: Path) -> None:
    import numba

    def kernel(values: np.ndarray) -> float:
        total = 0.0
        for k in range(values.shape[0]):
            total += np.sin(values[k]) * np.cos(values[k] ** 2) + np.sqrt(abs(values[k]))
        return total

    log = _log(tmp)
    subspace = neckid.methods()["ss"].estimator_class()
    fit = subspace.fit
    for _ in range(5):
        compiled = numba.njit(kernel)  # no cache: compiled during the fit below
        seen: dict[str, bool] = {}

        def send(compiled: Any = compiled, seen: dict[str, bool] = seen) -> None:
            seen["compiling"] = not compiled.signatures
            os.kill(os.getpid(), signal.SIGTERM)

        def compiling_fit(self: Any, *args: Any, compiled: Any = compiled, **kwargs: Any) -> Any:
            threading.Timer(0.02, send).start()
            compiled(np.linspace(0.0, 1.0, 10))  # the signal arrives inside numba's compiler
            time.sleep(5)
            return fit(self, *args, **kwargs)

        save = tmp / "ss.npz"
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(subspace, "fit", compiling_fit)
            code, shown = cli(
                "identify", log, "--inputs", "command", "--outputs", "inclination",
                "--method", "ss", "--save", save,
            )  # fmt: skip
        assert code == 143 and "interrupted (SIGTERM)" in shown, shown
        assert "SystemError" not in shown and "unexpected" not in shown, shown
        assert not save.exists()
        if seen.get("compiling"):
            assert compiled.signatures, "the compilation was cut half way"
            return
    raise AssertionError("the signal never arrived during a compilation (each took < 20 ms)")


def _forced_model_kept(tmp: Path) -> None:
    log = _log(tmp)
    save = tmp / "model.npz"
    data = IOData.from_csv(log, ["command"], ["inclination"])
    neckid.LinearARX(neckid.Lags.arx(1, 1)).fit(data).save(save)
    before = save.read_bytes()
    with _signal_at_epoch(signal.SIGINT):
        code, shown = _identify(log, save, "--force")
    assert code == 130 and "an existing one is unchanged" in shown, shown
    assert save.read_bytes() == before
    assert sorted(p.name for p in tmp.iterdir() if p.name.startswith(".")) == []


def _ignored_signal_stays_ignored(tmp: Path) -> None:
    log = _log(tmp)
    save = tmp / "model.npz"
    simulate = neckid.LinearARX.simulate

    def hung_up(*args: Any, **kwargs: Any) -> Any:
        os.kill(os.getpid(), signal.SIGHUP)  # the terminal closed under nohup
        time.sleep(0.1)
        return simulate(*args, **kwargs)

    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)  # nohup starts neckid so
    try:
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(neckid.LinearARX, "simulate", hung_up)
            code, shown = cli(
                "identify", log, "--inputs", "command", "--outputs", "inclination",
                "--method", "arx", "--save", save,
            )  # fmt: skip
        assert code == 0 and save.exists(), shown
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, previous)


def _with_ctrl_c(check: Callable[[Path], None]) -> Callable[[Path], None]:
    """``check`` with Python's SIGINT handler, even in a test run started with SIGINT ignored."""

    def checked(tmp: Path) -> None:
        previous = signal.signal(signal.SIGINT, signal.default_int_handler)
        try:
            check(tmp)
        finally:
            signal.signal(signal.SIGINT, previous)

    return checked


CASES = [
    Case("S1", "CLI", "Ctrl-C or SIGTERM during a neural NARX fit (`--method nn`; the signal arrives inside an epoch)", "interrupted (Ctrl-C) / (SIGTERM) within one epoch, exit 130 / 143; no next network, no model written", "clear", _with_ctrl_c(_network_interrupted)),
    Case("S2", "CLI", "Ctrl-C during a `compare` (or `select`, `benchmark`) whose methods include `nn`", "interrupted (Ctrl-C), exit 130: the comparison stops, no JSON written", "clear", _with_ctrl_c(_comparison_interrupted)),
    Case("S3", "CLI", "SIGTERM or Ctrl-C while numba compiles a kernel (the first run after an install) or runs one (`ss`)", "the compilation or the kernel call runs to its end, then interrupted (SIGTERM), exit 143; never a SystemError, never swallowed, no model written", "clear", _with_ctrl_c(_compiling_interrupted)),
    Case("S4", "CLI", "`identify --force` over an existing model, interrupted during the fit", "interrupted, exit 130; the old model byte for byte as it was, no temporary left", "clear", _with_ctrl_c(_forced_model_kept)),
    Case("S5", "CLI", "SIGHUP (or SIGINT) ignored by whoever started neckid (`nohup`, a script's background job)", "stays ignored, as Python leaves it: the run goes on and saves its model; SIGTERM still stops it", "correct", _ignored_signal_stays_ignored),
]  # fmt: skip
