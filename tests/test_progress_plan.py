"""Progress that tells the truth (issue 39): lines on time, in the user's words, with a time left
built from the candidates' own costs. Every test moves a fake clock by hand; none is timed."""

from __future__ import annotations

import io
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from neckid import IOData, methods
from neckid.data.folds import Split
from neckid.selection.work import progress_label, progress_units, unit_cost
from neckid.utils.progress import LineReporter, Plan, planned_task, reporting


class Clock:
    """A clock the test moves by hand [s]."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


#: compare's case: two cheap ARX folds, then two folds of a method 30 times as costly.
UNITS = [
    ("arx, fold 1/2", "arx", 1.0),
    ("arx, fold 2/2", "arx", 1.0),
    ("ss, fold 1/2", "ss", 30.0),
    ("ss, fold 2/2", "ss", 30.0),
]


def test_a_slow_method_is_counted_as_slow_before_it_runs() -> None:
    plan = Plan([g for _, g, _ in UNITS], [c for _, _, c in UNITS], start=0.0)
    assert plan.left(0.05) == (None, False)  # nothing measured: no number made up
    plan.finish(1.0)
    plan.finish(2.0)  # half the units done in 2 s; by count, "about 2 s left"
    assert plan.left(2.0) == (60.0, False)  # by cost: 30 s per ss fold


def test_a_candidates_measured_fold_replaces_its_expected_cost() -> None:
    plan = Plan([g for _, g, _ in UNITS], [c for _, _, c in UNITS], start=0.0)
    for now in (1.0, 2.0, 59.0):  # the first ss fold took 57 s, not 30
        plan.finish(now)
    assert plan.left(59.0) == (57.0, False)
    assert plan.left(69.0) == (47.0, False)


def test_a_fold_running_longer_than_expected_makes_the_estimate_a_lower_bound() -> None:
    plan = Plan([g for _, g, _ in UNITS], [c for _, _, c in UNITS], start=0.0)
    plan.finish(1.0)
    plan.finish(2.0)
    seconds, at_least = plan.left(102.0)  # the first ss fold has run 100 s (30 expected)
    assert at_least and seconds == pytest.approx(100.0)  # its twin: at least as long


def test_lines_come_every_10_s_during_one_long_unit_naming_it() -> None:
    stream, clock = io.StringIO(), Clock()
    reporter = LineReporter(stream, clock=clock, heartbeat=None)  # the test ticks by hand
    with (
        reporting(reporter),
        planned_task("fitting and scoring 2 candidates on 2 folds", UNITS) as done,
    ):
        for now in (1.0, 2.0):
            clock.now = now
            done()
        for now in (5.0, 9.0, 15.0, 25.0, 35.0):  # the first ss fold: no step for 33 s
            clock.now = now
            reporter.tick()
        clock.now = 62.0
        done()
        clock.now = 90.0
        done()
    lines = stream.getvalue().splitlines()
    label = "fitting and scoring 2 candidates on 2 folds: ss, fold 1/2"
    assert lines == [
        f"{label}: 2/4 done, 5 s, about 57 s left",
        f"{label}: 2/4 done, 15 s, about 47 s left",
        f"{label}: 2/4 done, 25 s, about 37 s left",
        # 33 s into a fold expected to take 30: its twin takes at least as long
        f"{label}: 2/4 done, 35 s, at least 33 s left",
        # measured: 60 s a fold
        "fitting and scoring 2 candidates on 2 folds: ss, fold 2/2: 3/4 done, 1 min 02 s,"
        " about 1 min 00 s left",
        "fitting and scoring 2 candidates on 2 folds: done in 1 min 30 s",
    ]


def test_the_heartbeat_thread_writes_without_a_step(monkeypatch: pytest.MonkeyPatch) -> None:
    """The thread calls :meth:`LineReporter.tick`; its sleep is replaced, so nothing is timed."""
    import neckid.utils.progress as progress

    stream, clock = io.StringIO(), Clock()
    reporter = LineReporter(stream, clock=clock, heartbeat=1.0)
    beats: list[float] = []
    handles: list[Any] = []
    started = threading.Event()

    def sleep(seconds: float) -> None:  # each beat moves the clock on 6 s
        started.wait()
        beats.append(seconds)
        clock.now += 6.0
        if len(beats) == 2:
            handles[0].stop()

    monkeypatch.setattr(progress.time, "sleep", sleep)
    handles.append(reporter.start("one long fit", None))
    started.set()
    thread = next(t for t in threading.enumerate() if t.name == "neckid-progress")
    thread.join()
    assert beats == [1.0, 1.0]
    assert stream.getvalue().splitlines() == [
        "one long fit: 0 done, 6 s",
        "one long fit: done in 12 s",
    ]


def _runs(n: int = 2) -> list[IOData]:
    return [IOData(np.ones(100), np.arange(100.0), ts=0.1, name=f"run{i}") for i in range(n)]


def test_a_selections_units_are_named_and_costed_by_the_registry() -> None:
    first, second = _runs()
    splits = [Split((first,), ((second,),)), Split((second,), ((first,),))]
    candidates = [
        ("Lags(outputs=[1], inputs=[1])", methods()["sm"].make()),
        ("ss", methods()["ss"].make()),
        ("baseline: training mean", object()),
    ]
    units = progress_units(candidates, splits)
    assert [what for what, _, _ in units[::2]] == [
        "sm Lags(outputs=[1], inputs=[1]), fold 1/2 (held out: run1)",
        "ss, fold 1/2 (held out: run1)",
        "baseline: training mean, fold 1/2 (held out: run1)",
    ]
    costs = {group: cost for _, group, cost in units}
    # Each candidate's cost is its method's cost function of its own settings (issue 42).
    assert costs["ss"] == pytest.approx(unit_cost(candidates[1][1], [first]))
    sm = unit_cost(candidates[0][1], [first])
    assert costs["Lags(outputs=[1], inputs=[1])"] == pytest.approx(sm)
    assert costs["baseline: training mean"] < min(sm, costs["ss"])
    assert progress_label(3, splits) == "fitting and scoring 3 candidates on 2 folds"


class _Recording:
    """A reporter that keeps the labels, the units named and the time-left estimates."""

    def __init__(self) -> None:
        self.labels: list[str] = []
        self.notes: list[str] = []
        self.clock = Clock()

    def start(self, label: str, total: float | None) -> _Recording:
        self.labels.append(label)
        return self

    def note(self, detail: str, estimate: Any) -> None:
        self.notes.append(detail)

    def advance(self, steps: float = 1.0) -> None:
        self.clock.now += 1.0

    def stop(self) -> None:
        pass


def test_select_reports_when_standard_error_is_not_a_terminal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``select`` used to pass ``progress=console.is_terminal``: nothing in a log or a pipe."""
    import neckid.utils.progress as progress
    from neckid.cli import app

    logs = []
    for i, run in enumerate(_runs(2)):
        rng = np.random.default_rng(i)
        u = np.repeat(rng.uniform(-1, 1, 30), 10)
        y = np.zeros(300)
        for t in range(1, 300):
            y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
        path = tmp_path / f"{run.name}.csv"
        IOData(u, y, ts=0.02, input_names=["command"], output_names=["inclination"]).to_csv(path)
        logs.append(path)
    recording = _Recording()
    monkeypatch.setattr(progress, "default_reporter", lambda stream=None: recording)
    result = CliRunner().invoke(
        app,
        [
            "select",
            *map(str, logs),
            *("--inputs", "command", "--outputs", "inclination", "--method", "arx"),
            *("--lags", "1/1", "--lags", "1-2/1"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert recording.labels[0].startswith("fitting and scoring 4 candidates on "), recording.labels
    assert recording.notes[0] == "arx Lags(outputs=[1], inputs=[1]), fit 1/2, scored on 3 folds", (
        recording.notes
    )
    assert any(note.startswith("arx Lags(outputs=[1, 2], inputs=[1])") for note in recording.notes)
