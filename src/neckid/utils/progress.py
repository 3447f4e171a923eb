"""Progress of long work: the library says how far it is, whoever runs it chooses how to show it.

Estimators and selections wrap their long loops in :func:`task` and call its ``advance``; that
costs nothing when nobody listens. The command line listens for the whole command
(:func:`reporting`): a rich bar with the time left when standard error is a terminal
(:class:`TerminalReporter`), plain lines otherwise (:class:`LineReporter`: a log file, a CI job).
A Python user can do the same::

    with neckid.utils.progress.reporting(neckid.utils.progress.LineReporter()):
        model.fit(data)

The listener lives in a :class:`contextvars.ContextVar`, so threads and asynchronous tasks each
see their own, and an estimator holds no state of it.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from contextvars import ContextVar
from typing import IO, Any, Protocol

__all__ = [
    "LineReporter",
    "Reporter",
    "TerminalReporter",
    "active",
    "counting",
    "default_reporter",
    "reporting",
    "shown_task",
    "task",
]

Advance = Callable[..., None]


class Handle(Protocol):
    """One running task of a reporter."""

    def advance(self, steps: float = 1.0) -> None:
        """Count ``steps`` more steps done."""

    def stop(self) -> None:
        """End the task (it is no longer shown)."""


class Reporter(Protocol):
    """Shows tasks: ``start`` returns the handle its task advances and stops."""

    def start(self, label: str, total: float | None) -> Handle:
        """Show a new task of ``total`` steps (``None``: unknown)."""


_REPORTER: ContextVar[Reporter | None] = ContextVar("neckid_progress", default=None)


def active() -> Reporter | None:
    """The reporter of the current context (``None``: nobody listens)."""
    return _REPORTER.get()


def _nothing(steps: float = 1.0) -> None:
    """``advance`` when nobody listens."""


@contextmanager
def task(label: str, total: float | None = None) -> Iterator[Advance]:
    """Report a long loop of ``total`` steps (``None``: unknown); yields its ``advance(steps=1)``.

    Examples
    --------
    >>> with task("fitting networks", total=3) as advance:
    ...     for _ in range(3):
    ...         advance()
    """
    reporter = _REPORTER.get()
    if reporter is None:
        yield _nothing
        return
    handle = reporter.start(label, total)
    try:
        yield handle.advance
    finally:
        handle.stop()


def counting(function: Callable[..., Any], advance: Advance) -> Callable[..., Any]:
    """``function`` that counts one step of ``advance`` per call.

    For an optimiser whose budget is a number of evaluations (``max_nfev`` of
    :func:`scipy.optimize.least_squares`): wrap its residuals in a :func:`task` of that total,
    and the time left shown is that of the whole budget, an upper bound when it converges
    earlier.
    """

    def counted(*args: Any, **kwargs: Any) -> Any:
        value = function(*args, **kwargs)
        advance()
        return value

    return counted


@contextmanager
def shown_task(
    label: str, total: float | None = None, *, terminal_only: bool = False
) -> Iterator[Advance]:
    """:func:`task` shown by the context's reporter or, with none, by a bar of its own.

    The bar (:class:`TerminalReporter`, on standard error) is left out with ``terminal_only``
    when standard error is not a terminal: for work that reports without being asked to.
    """
    own = _REPORTER.get() is None and not (terminal_only and not sys.stderr.isatty())
    with reporting(TerminalReporter()) if own else nullcontext(), task(label, total) as advance:
        yield advance


@contextmanager
def reporting(reporter: Reporter | None) -> Iterator[None]:
    """Show the tasks started inside the block with ``reporter`` (``None``: show nothing)."""
    token = _REPORTER.set(reporter)
    try:
        yield
    finally:
        _REPORTER.reset(token)


def _duration(seconds: float) -> str:
    minutes, rest = divmod(round(seconds), 60)
    return f"{minutes} min {rest:02d} s" if minutes else f"{rest} s"


class _LineHandle:
    def __init__(self, owner: LineReporter, label: str, total: float | None) -> None:
        self.owner, self.label, self.total = owner, label, total
        self.done = 0.0
        self.started = owner.clock()
        self.last_line = -float("inf")  # the first line comes once the quiet time is over

    def advance(self, steps: float = 1.0) -> None:
        self.done += steps
        now = self.owner.clock()
        if now - self.started >= self.owner.quiet and now - self.last_line >= self.owner.every:
            self.last_line = now
            self.owner.write(f"{self.label}: {self._state(now)}")

    def _state(self, now: float) -> str:
        elapsed = now - self.started
        if not self.total:
            return f"{self.done:g} done, {_duration(elapsed)}"
        share = min(self.done / self.total, 1.0)
        left = elapsed * (1.0 - share) / share if share > 0 else float("nan")
        eta = "" if left != left else f", about {_duration(left)} left"
        counted = (
            f" ({self.done:g}/{self.total:g})"
            if float(self.total).is_integer() and self.total > 1
            else ""
        )
        return f"{share:.0%}{counted}, {_duration(elapsed)}{eta}"

    def stop(self) -> None:
        elapsed = self.owner.clock() - self.started
        if elapsed >= self.owner.quiet:
            self.owner.write(f"{self.label}: done in {_duration(elapsed)}")


class LineReporter:
    """Plain progress lines on a stream (standard error by default), for logs and CI.

    A task says nothing during its first ``quiet`` seconds, then writes a line at most every
    ``every`` seconds (share done, time spent, time left) and one when it ends.
    """

    def __init__(
        self,
        stream: IO[str] | None = None,
        *,
        quiet: float = 5.0,
        every: float = 10.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.stream = stream
        self.quiet = quiet
        self.every = every
        self.clock = clock

    def write(self, line: str) -> None:
        """Write one line (and flush: the reader may be a pipe)."""
        stream = self.stream if self.stream is not None else sys.stderr
        stream.write(line + "\n")
        stream.flush()

    def start(self, label: str, total: float | None) -> _LineHandle:
        """Start a task."""
        return _LineHandle(self, label, total)


class _BarHandle:
    def __init__(self, progress: Any, task_id: Any) -> None:
        self.progress, self.task_id = progress, task_id

    def advance(self, steps: float = 1.0) -> None:
        self.progress.advance(self.task_id, steps)

    def stop(self) -> None:
        self.progress.remove_task(self.task_id)
        if not self.progress.tasks:
            self.progress.stop()


class TerminalReporter:
    """A rich bar per running task on standard error: share done, time spent and time left."""

    def __init__(self) -> None:
        self._progress: Any = None

    def start(self, label: str, total: float | None) -> _BarHandle:
        """Start a task (and the live display, if it is not running)."""
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        if self._progress is None or not self._progress.live.is_started:
            self._progress = Progress(
                TextColumn("{task.description}"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeElapsedColumn(),
                TimeRemainingColumn(),
                console=Console(stderr=True),
                transient=True,
            )
            self._progress.start()
        return _BarHandle(self._progress, self._progress.add_task(label, total=total))


def default_reporter(stream: IO[str] | None = None) -> Reporter:
    """A bar when ``stream`` (standard error by default) is a terminal, plain lines otherwise."""
    target = stream if stream is not None else sys.stderr
    isatty = getattr(target, "isatty", None)
    return TerminalReporter() if isatty is not None and isatty() else LineReporter(stream)
