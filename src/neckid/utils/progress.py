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

Every ``advance`` is also a safe point for a stop signal (:func:`neckid.utils.interrupt.check`):
a Ctrl-C that a library swallowed inside a step stops the loop at the next step.
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager, nullcontext
from contextvars import ContextVar
from typing import IO, Any, Protocol

from neckid.utils.interrupt import check as check_interrupted
from neckid.utils.interrupt import stop_requested

__all__ = [
    "LineReporter",
    "Plan",
    "Reporter",
    "TerminalReporter",
    "active",
    "counting",
    "default_reporter",
    "planned_task",
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


def _nothing_but_check(steps: float = 1.0) -> None:
    """``advance`` when nobody listens: only a safe point for a stop signal."""
    check_interrupted()


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
        yield _nothing_but_check
        return
    handle = reporter.start(label, total)

    def advance(steps: float = 1.0) -> None:
        check_interrupted()  # a step is a safe point: a swallowed Ctrl-C stops the loop here
        handle.advance(steps)

    try:
        yield advance
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


def _unheard_advance() -> Advance:
    """The ``advance`` :func:`task` gives when nobody listens (what a step does besides counting)."""
    with reporting(None), task("") as advance:
        return advance


@contextmanager
def planned_task(
    label: str, units: Sequence[tuple[str, str, float]]
) -> Iterator[Callable[[], None]]:
    """Report a loop over ``units`` done in order; yields ``done()``, called after each unit.

    Each unit is ``(what, group, cost)``: what the user calls it (``"ss, fold 2/6"``), the group
    of units that cost alike (a candidate's folds) and its expected cost (see :class:`Plan`,
    which turns them and the times measured into the time left). The reporter shows what runs
    now and that estimate (a reporter without ``note`` shows its own).

    Examples
    --------
    >>> units = [("arx, fold 1/2", "arx", 1.0), ("arx, fold 2/2", "arx", 1.0)]
    >>> with planned_task("scoring 1 candidate on 2 folds", units) as done:
    ...     for _ in units:
    ...         done()
    """
    reporter, safe_point = _REPORTER.get(), _unheard_advance()
    if reporter is None:
        yield safe_point
        return
    clock = getattr(reporter, "clock", time.monotonic)
    handle = reporter.start(label, len(units))
    plan = Plan([g for _, g, _ in units], [c for _, _, c in units], start=clock())
    note = getattr(handle, "note", None)
    if note is not None and units:
        note(units[0][0], plan.left)

    def done() -> None:
        safe_point()  # as any task's step
        plan.finish(clock())
        finished = len(plan.ends) - 1
        if note is not None and finished < len(units):
            note(units[finished][0], plan.left)
        handle.advance(1.0)

    try:
        yield done
    finally:
        handle.stop()


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


class Plan:
    """The time left of units done in order, from their expected costs and their measured times.

    A unit (one candidate on one fold) is expected to take the mean time of the units of its
    group (the candidate's other folds) once one of them is done; before that, its cost (its
    method's cost at its settings and size, :func:`neckid.selection.work.unit_cost`, say) times
    the seconds per cost of the units done so far: a slow method is counted as slow before it has run. The unit running now
    counts what is left of its estimate; once it has run longer than that, every unmeasured unit
    of its group counts at least as long as it has run, and the estimate is a lower bound.

    Parameters
    ----------
    groups : sequence of str
        The group of each unit, in the order the units are done.
    costs : sequence of float
        The expected cost of each unit (any unit; only ratios matter), >= 0.
    start : float
        The time the first unit started [s, on the clock of the reporter].

    Examples
    --------
    >>> plan = Plan(["arx", "arx", "ss", "ss"], [1.0, 1.0, 30.0, 30.0], start=0.0)
    >>> plan.finish(0.1)
    >>> plan.finish(0.2)
    >>> plan.left(0.2)  # the ss folds: 30 times an arx fold each
    (6.0, False)
    >>> plan.left(10.0)  # the first ss fold has run 9.8 s, more than its 3 s: at least 9.8 s more
    (9.8, True)
    """

    def __init__(self, groups: Sequence[str], costs: Sequence[float], start: float) -> None:
        self.groups = list(groups)
        self.costs = [max(float(c), 0.0) for c in costs]
        if len(self.costs) != len(self.groups):
            raise ValueError(f"groups and costs differ in length: {len(groups)} and {len(costs)}")
        self.ends = [float(start)]  # the start, then the end of every unit done

    def finish(self, now: float) -> None:
        """The next unit is done at ``now``."""
        self.ends.append(float(now))

    def left(self, now: float) -> tuple[float | None, bool]:
        """Seconds left (``None``: not known yet) and whether that is a lower bound."""
        done = len(self.ends) - 1
        if done >= len(self.costs):
            return 0.0, False
        times = [b - a for a, b in zip(self.ends, self.ends[1:], strict=False)]
        spent = sum(times)
        paid = sum(self.costs[:done])
        measured: dict[str, list[float]] = {}
        for group, seconds in zip(self.groups, times, strict=False):
            measured.setdefault(group, []).append(seconds)
        if not measured or paid <= 0:
            return None, False
        rate = spent / paid

        def expected(i: int) -> float:
            mine = measured.get(self.groups[i])
            return sum(mine) / len(mine) if mine else self.costs[i] * rate

        running = max(now - self.ends[-1], 0.0)
        current = expected(done)
        overrun = running > current
        total = max(current - running, 0.0)
        group = self.groups[done]
        for i in range(done + 1, len(self.costs)):
            mine = expected(i)
            if overrun and self.groups[i] == group and group not in measured:
                mine = max(mine, running)
            total += mine
        return total, overrun


def _left_text(left: tuple[float | None, bool]) -> str:
    seconds, at_least = left
    if seconds is None:
        return "time left not known yet"
    if at_least and seconds < 0.5:  # the last unit overran its estimate: nothing to bound it
        return "longer than expected, time left not known"
    return f"{'at least' if at_least else 'about'} {_duration(seconds)} left"


class _LineHandle:
    def __init__(self, owner: LineReporter, label: str, total: float | None) -> None:
        self.owner, self.label, self.total = owner, label, total
        self.done = 0.0
        self.started = owner.clock()
        self.last_line = -float("inf")  # the first line comes once the quiet time is over
        self.detail = ""
        self.estimate: Callable[[float], tuple[float | None, bool]] | None = None

    def advance(self, steps: float = 1.0) -> None:
        self.done += steps
        if not (self.total and self.done >= self.total):  # the last step: "done in" follows
            self.line_if_due(self.owner.clock())

    def note(self, detail: str, estimate: Callable[[float], tuple[float | None, bool]]) -> None:
        """What runs now, in the user's words, and the time left at a given time."""
        self.detail, self.estimate = detail, estimate

    def line_if_due(self, now: float) -> None:
        """Write the task's line once it has run ``quiet`` seconds, then every ``every``."""
        if now - self.started >= self.owner.quiet and now - self.last_line >= self.owner.every:
            self.last_line = now
            detail = f" {self.detail}:" if self.detail else ""
            self.owner.write(f"{self.label}:{detail} {self._state(now)}")

    def _state(self, now: float) -> str:
        elapsed = now - self.started
        if self.estimate is not None:
            done = f"{self.done:g}/{self.total:g} done" if self.total else f"{self.done:g} done"
            return f"{done}, {_duration(elapsed)}, {_left_text(self.estimate(now))}"
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
        self.owner.forget(self)
        elapsed = self.owner.clock() - self.started
        if elapsed >= self.owner.quiet:
            # A task ended by a stop signal is not done: say so (neckid.utils.interrupt).
            ended = "interrupted after" if stop_requested() is not None else "done in"
            self.owner.write(f"{self.label}: {ended} {_duration(elapsed)}")


class LineReporter:
    """Plain progress lines on a stream (standard error by default), for logs and CI.

    A task says nothing during its first ``quiet`` seconds, then writes a line at most every
    ``every`` seconds (share done, time spent, time left) and one when it ends. The lines come
    on time even while one step runs for minutes (one fit of a slow method): a thread looks at
    the running tasks every ``heartbeat`` seconds (:meth:`tick`; ``None``: no thread, only the
    steps write lines).
    """

    def __init__(
        self,
        stream: IO[str] | None = None,
        *,
        quiet: float = 5.0,
        every: float = 10.0,
        clock: Callable[[], float] = time.monotonic,
        heartbeat: float | None = 1.0,
    ) -> None:
        self.stream = stream
        self.quiet = quiet
        self.every = every
        self.clock = clock
        self.heartbeat = heartbeat
        self._running: list[_LineHandle] = []
        self._lock = threading.Lock()
        self._beating = False

    def write(self, line: str) -> None:
        """Write one line (and flush: the reader may be a pipe)."""
        stream = self.stream if self.stream is not None else sys.stderr
        with self._lock:
            stream.write(line + "\n")
            stream.flush()

    def start(self, label: str, total: float | None) -> _LineHandle:
        """Start a task (and the heartbeat thread, if it is not running)."""
        handle = _LineHandle(self, label, total)
        with self._lock:
            self._running.append(handle)
            beat = self.heartbeat is not None and not self._beating
            self._beating = self._beating or beat
        if beat:
            threading.Thread(target=self._beat, name="neckid-progress", daemon=True).start()
        return handle

    def forget(self, handle: _LineHandle) -> None:
        """A task ended: no more lines for it."""
        with self._lock:
            if handle in self._running:
                self._running.remove(handle)

    def tick(self) -> None:
        """Write the line of every running task that is due (the heartbeat calls it)."""
        with self._lock:
            running = list(self._running)
        now = self.clock()
        for handle in running:
            handle.line_if_due(now)

    def _beat(self) -> None:
        while True:
            time.sleep(float(self.heartbeat or 1.0))
            with self._lock:
                if not self._running:
                    self._beating = False
                    return
            self.tick()


class _BarHandle:
    def __init__(self, progress: Any, task_id: Any, label: str) -> None:
        self.progress, self.task_id, self.label = progress, task_id, label

    def advance(self, steps: float = 1.0) -> None:
        self.progress.advance(self.task_id, steps)

    def note(self, detail: str, estimate: Callable[[float], tuple[float | None, bool]]) -> None:
        """What runs now, beside the label; the time left from ``estimate`` (see :class:`Plan`)."""
        self.progress.update(self.task_id, description=f"{self.label}: {detail}", estimate=estimate)

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
                _time_left_column(TimeRemainingColumn()),
                console=Console(stderr=True),
                transient=True,
            )
            self._progress.start()
        return _BarHandle(self._progress, self._progress.add_task(label, total=total), label)


def _time_left_column(by_speed: Any) -> Any:
    """The bar's time left: a :class:`Plan`'s estimate where a task has one, rich's otherwise."""
    from rich.progress import ProgressColumn
    from rich.text import Text

    class TimeLeft(ProgressColumn):
        def render(self, task: Any) -> Any:
            estimate = task.fields.get("estimate")
            if estimate is None:
                return by_speed.render(task)
            return Text(_left_text(estimate(time.monotonic())), style="progress.remaining")

    return TimeLeft()


def default_reporter(stream: IO[str] | None = None) -> Reporter:
    """A bar when ``stream`` (standard error by default) is a terminal, plain lines otherwise."""
    target = stream if stream is not None else sys.stderr
    isatty = getattr(target, "isatty", None)
    return TerminalReporter() if isatty is not None and isatty() else LineReporter(stream)
