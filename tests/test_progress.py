"""Progress of long work: silent without a listener, lines with the time left in a log."""

from __future__ import annotations

import io
import warnings

import numpy as np

from _progress_recorder import Recorder
from _synthetic import arx_system
from neckid import Lags, NeuralNARX
from neckid.utils.progress import LineReporter, active, counting, reporting, task


class Clock:
    """A clock the test moves by hand [s]."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_a_task_without_a_listener_does_nothing() -> None:
    assert active() is None
    with task("nothing", total=2) as advance:
        advance()
        advance(1.0)


def test_lines_after_the_quiet_time_with_the_time_left() -> None:
    stream, clock = io.StringIO(), Clock()
    reporter = LineReporter(stream, quiet=5.0, every=10.0, clock=clock)
    with reporting(reporter), task("fitting", total=4) as advance:
        clock.now = 1.0
        advance()  # 25 % after 1 s: still quiet
        assert stream.getvalue() == ""
        clock.now = 6.0
        advance()  # 50 % after 6 s: 6 s left
        clock.now = 8.0
        advance()  # less than 10 s since the last line: silent
        clock.now = 30.0
    lines = stream.getvalue().splitlines()
    assert lines == ["fitting: 50% (2/4), 6 s, about 6 s left", "fitting: done in 30 s"]
    assert active() is None  # the listener ends with its block


def test_a_short_task_says_nothing() -> None:
    stream, clock = io.StringIO(), Clock()
    with reporting(LineReporter(stream, clock=clock)), task("quick", total=None) as advance:
        clock.now = 2.0
        advance()
    assert stream.getvalue() == ""


def test_the_network_reports_each_member_it_trains() -> None:
    counting = Recorder()
    data = arx_system(300, 0)
    model = NeuralNARX(Lags.arx(2, 2, 3), hidden_layer_sizes=(4,), n_networks=3, max_iter=5)
    with reporting(counting), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit(data)
    assert counting.started == [("training 3 networks", 3)]
    assert counting.steps == 3
    assert np.all(np.isfinite(model.predict(data).y))


def test_a_long_set_membership_free_run_reports_its_blocks_and_is_the_same(monkeypatch) -> None:
    import importlib

    kernels = importlib.import_module("neckid.models.set_membership._kernels.free_run")
    from neckid import SetMembership

    data = arx_system(3000, 4)
    model = SetMembership(Lags.arx(2, 2, 3), progress=False).fit(data[:1500])
    whole = model.simulate(data[1500:])
    monkeypatch.setattr(kernels, "FREE_RUN_CHUNK", 400)  # 1,496 steps in 4 blocks
    started: list[tuple[str, float | None]] = []
    steps: list[float] = []

    class Recording:
        def start(self, label: str, total: float | None) -> Recording:
            started.append((label, total))
            return self

        def advance(self, n: float = 1.0) -> None:
            steps.append(n)

        def stop(self) -> None:
            pass

    with reporting(Recording()):
        blocks = model.simulate(data[1500:])
    assert started == [("Set Membership free run", 1496)] and steps == [400, 400, 400, 296]
    np.testing.assert_array_equal(blocks.y, whole.y)
    np.testing.assert_array_equal(blocks.lower, whole.lower)


def test_counting_advances_once_per_call_and_returns_the_value() -> None:
    recorder = Recorder()
    with reporting(recorder), task("calls", total=3) as advance:
        twice = counting(lambda x: 2 * x, advance)
        assert [twice(1), twice(2)] == [2, 4]
    assert recorder.started == [("calls", 3)] and recorder.steps == 2


def test_the_polynomial_free_run_fit_reports_its_evaluations_within_its_budget() -> None:
    from neckid import PolynomialNARX

    data = arx_system(600, 1)
    recorder = Recorder()
    with reporting(recorder):
        model = PolynomialNARX(Lags.arx(2, 2, 1), degree=2, max_iter=7).fit(data)
    assert recorder.started == [("polynomial NARX free-run fit (evaluations, at most)", 7)]
    assert recorder.steps == model.fit_report_["evaluations"] <= 7
