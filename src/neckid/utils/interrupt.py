"""Stopping when asked: SIGINT, SIGTERM and SIGHUP end a run at a safe point, never in compiled code.

Python runs a signal handler in the main thread between two bytecodes, and its default SIGINT
handler raises ``KeyboardInterrupt`` wherever that is. Three places make that wrong:

- **numba's dispatcher.** A compiled kernel calls back into Python (numba's
  ``serialize._numba_unpickle`` when it builds a Python object, the compiler on a first call);
  an exception raised there comes out of the call as ``SystemError: CPUDispatcher(...) returned
  a result with an exception set``.
- **llvmlite's ctypes callbacks** (its object cache, during the first compilation after an
  install): ctypes prints an exception raised there and drops it, so the run goes on.
- **a library that catches KeyboardInterrupt and goes on**: scikit-learn's ``MLPRegressor``,
  for one, ends its training loop, warns "Training interrupted by user." and returns a
  half-trained network (neckid's networks are trained by its own loop, which checks between
  epochs).

:func:`stop_signals` (the command line holds it around every command) installs one handler for
SIGINT, SIGTERM and SIGHUP. The handler records the signal, then

- raises nothing while the main thread is inside numba or llvmlite (a frame of theirs is on its
  stack: compilation, dispatch, boxing a kernel's result) or inside a :func:`deferred` block: the
  signal is delivered again every :data:`REDELIVER_AFTER` seconds until the thread is out of
  them, and a :func:`deferred` block raises when it ends; a kernel's compilation or its call is
  never cut in half;
- raises :class:`Interrupted` (a ``KeyboardInterrupt`` carrying the signal number) anywhere else;
- after it raised once, records nothing more: a second Ctrl-C does not cut the clean-up short.

:func:`check` raises the same :class:`Interrupted` again once a stop was requested. Code that
calls a library which may swallow the interrupt calls it afterwards (the neural NARX after each
network); so do the progress of every long loop (:func:`neckid.utils.progress.task`) and the last
step of every output, its rename into place (:func:`neckid.utils.files.atomic_path`): a
swallowed interrupt neither lets a run go on nor lets it write a file.

A signal ignored when the block starts (``nohup`` ignores SIGHUP; a shell starts a background job
with SIGINT ignored) stays ignored. Outside :func:`stop_signals` nothing changes: Python's own
SIGINT handler raises ``KeyboardInterrupt`` as usual, and :func:`check` never raises. A Python
user gets the command line's behaviour with the same block::

    from neckid.utils.interrupt import stop_signals

    with stop_signals():
        model.fit(data)  # Ctrl-C: Interrupted (a KeyboardInterrupt) at a safe point
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

__all__ = [
    "COMPILED_MODULES",
    "REDELIVER_AFTER",
    "STOP_SIGNALS",
    "Interrupted",
    "check",
    "deferred",
    "signal_name",
    "stop_requested",
    "stop_signals",
]

#: The signals that stop a run: 128 + the signal is the command line's exit status.
STOP_SIGNALS: tuple[int, ...] = tuple(
    int(getattr(signal, name)) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)

#: Top-level packages whose frames on the main thread's stack mean it runs compiled code's
#: machinery (a kernel's dispatch or compilation), where no exception may be raised.
COMPILED_MODULES: tuple[str, ...] = ("numba", "llvmlite")

#: Seconds between two deliveries of a deferred signal, while the main thread is inside
#: numba or llvmlite.
REDELIVER_AFTER = 0.02


class Interrupted(KeyboardInterrupt):
    """A stop signal (SIGINT, SIGTERM, SIGHUP) received during a run; ``signum`` says which.

    A ``KeyboardInterrupt``, so that code which cleans up after Ctrl-C cleans up after SIGTERM
    alike; the command line exits with status ``128 + signum`` (130, 143, 129).
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = int(signum)

    def __str__(self) -> str:
        return f"stopped by {signal_name(self.signum)}"


def signal_name(signum: int) -> str:
    """How a user names the signal: ``"Ctrl-C"`` for SIGINT, else ``"SIGTERM"``, ``"SIGHUP"``.

    Examples
    --------
    >>> signal_name(signal.SIGINT), signal_name(signal.SIGTERM)
    ('Ctrl-C', 'SIGTERM')
    """
    if signum == signal.SIGINT:
        return "Ctrl-C"
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


class _State:
    """What the handler knows, for the one :func:`stop_signals` block of the process."""

    def __init__(self) -> None:
        self.active = False  # a stop_signals block holds the handlers
        self.requested: int | None = None  # the first stop signal received
        self.raised = False  # the handler (or check) raised Interrupted once
        self.deferring = 0  # depth of deferred() blocks
        self.wake = threading.Event()  # asks the redelivery thread for another delivery
        self.closing = False  # the block ends: no more deliveries
        # Taken between a delivery and the end of the block (never in the handler).
        self.lock = threading.Lock()


_STATE = _State()


def stop_requested() -> int | None:
    """The signal that asked the current run to stop; None if none did or outside the block."""
    return _STATE.requested if _STATE.active else None


def check() -> None:
    """Raise :class:`Interrupted` when a stop signal was received; nothing otherwise.

    Call it after work that may have swallowed a ``KeyboardInterrupt`` and before anything that
    should not happen once a stop was asked for (writing an output). It does not raise inside a
    :func:`deferred` block (the block's end does) nor outside :func:`stop_signals`.
    """
    signum = stop_requested()
    if signum is not None and not _STATE.deferring:
        _STATE.raised = True
        raise Interrupted(signum)


@contextmanager
def deferred() -> Iterator[None]:
    """Run the block whole: a stop signal inside it raises :class:`Interrupted` at its end.

    For steps that must not be cut in half (moving a run's files into place). Without
    :func:`stop_signals` around it, it changes nothing.
    """
    _STATE.deferring += 1
    try:
        yield
    finally:
        _STATE.deferring -= 1
    check()


def _inside_compiled(frame: FrameType | None) -> bool:
    """Whether a frame of :data:`COMPILED_MODULES` is on the stack that ends in ``frame``."""
    while frame is not None:
        module = frame.f_globals.get("__name__") or ""
        if module.partition(".")[0] in COMPILED_MODULES:
            return True
        frame = frame.f_back
    return False


def _handler(signum: int, frame: FrameType | None) -> None:
    """The handler of :data:`STOP_SIGNALS` inside :func:`stop_signals`."""
    if _STATE.raised or _STATE.closing:
        return  # a second signal must not cut the clean-up short
    if _STATE.requested is None:
        _STATE.requested = signum
    if _STATE.deferring:
        return  # the deferred block raises when it ends
    if _inside_compiled(frame):
        _STATE.wake.set()  # delivered again once the thread may be out of compiled code
        return
    _STATE.raised = True
    raise Interrupted(_STATE.requested)


def _redeliver(main: int) -> None:
    """The redelivery thread: while a signal is deferred, deliver it again to the main thread.

    A thread of its own (started with the block, not in the handler: starting a thread from a
    handler could wait for a lock the interrupted main thread holds).
    """
    while True:
        _STATE.wake.wait()
        _STATE.wake.clear()
        if _STATE.closing:
            return
        time.sleep(REDELIVER_AFTER)
        with _STATE.lock:
            if _STATE.closing:
                return
            signum = _STATE.requested
            if signum is not None and not _STATE.raised:
                signal.pthread_kill(main, signum)


@contextmanager
def stop_signals() -> Iterator[None]:
    """SIGINT, SIGTERM and SIGHUP stop the block at a safe point with :class:`Interrupted`.

    Installs the handler described in the module's docstring for the block and restores the
    previous handlers after it. A signal ignored at the start stays ignored (and one whose
    handler was set outside Python is left to it). Does nothing in a thread other than the main
    one (signals reach the main thread only), nor inside another ``stop_signals`` block (the
    outer one keeps its state).
    """
    if threading.current_thread() is not threading.main_thread() or _STATE.active:
        yield
        return
    _STATE.requested, _STATE.raised, _STATE.deferring = None, False, 0
    _STATE.closing = False
    _STATE.wake.clear()
    _STATE.active = True
    thread = None
    if hasattr(signal, "pthread_kill"):
        thread = threading.Thread(
            target=_redeliver,
            args=(threading.main_thread().ident,),
            name="neckid-stop-signals",
            daemon=True,
        )
        thread.start()
    previous: dict[int, Any] = {}
    try:
        for number in STOP_SIGNALS:
            try:
                current = signal.getsignal(number)
                if current is signal.SIG_IGN or current is None:
                    # Ignored (nohup, a background job: whoever started neckid asked for it),
                    # or a handler set outside Python, which could not be put back after.
                    continue
                previous[number] = signal.signal(number, _handler)
            except (OSError, ValueError):  # pragma: no cover - not settable here
                continue
        yield
    finally:
        with _STATE.lock:  # no delivery after this: it would reach the handler restored below
            _STATE.closing = True
        _STATE.wake.set()
        if thread is not None:
            thread.join()
        for number, handler in previous.items():
            signal.signal(number, handler)
        _STATE.active = False
        _STATE.requested, _STATE.raised, _STATE.deferring = None, False, 0
