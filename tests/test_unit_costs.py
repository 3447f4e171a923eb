"""The selection's unit costs from each method's own settings and the data's size (issue 42).

No timing here: the costs order the units as :mod:`neckid.selection.costs` documents, every
registered cost function resolves, and a compare's progress lines show a time left.
"""

from __future__ import annotations

import importlib
import io
import math
import re

import numpy as np
import pytest

from neckid import IOData, Lags, compare, methods
from neckid.selection import costs
from neckid.selection.work import progress_units, unit_cost
from neckid.utils.progress import LineReporter, reporting


def _logs(n: int = 2, samples: int = 300, seed: int = 0) -> list[IOData]:
    rng = np.random.default_rng(seed)
    logs = []
    for i in range(n):
        u = np.repeat(rng.uniform(-1, 1, samples // 10), 10)
        y = np.zeros(samples)
        for t in range(1, samples):
            y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1] + 0.01 * rng.normal()
        logs.append(
            IOData(u, y, ts=0.02, input_names=["command"], output_names=["angle"], name=f"run{i}")
        )
    return logs


#: The regressor of the lag methods' candidates.
LAGS = Lags.arx(2, 2)


def _cost(name: str, logs: list[IOData], lags: Lags = LAGS, **settings: object) -> float:
    method = methods()[name]
    return unit_cost(method.make(None if method.lag_free else lags, **settings), logs)


def test_every_registered_cost_resolves_and_is_positive_at_defaults_and_quick() -> None:
    logs = _logs()
    for name, method in methods().items():
        if not method.cost:
            continue
        module, _, function = method.cost.partition(":")
        assert module == "neckid.selection.costs", name
        assert callable(getattr(importlib.import_module(module), function)), name
        for quick in (False, True):
            lags = None if method.lag_free else Lags.arx(2, 2)
            value = unit_cost(method.make(lags, quick=quick), logs)
            assert math.isfinite(value) and value > 0, (name, quick, value)
    assert {"nn", "ss", "pnlss", "sm", "sm-multistep", "poly", "arx", "koopman", "sindy"} <= {
        n for n, m in methods().items() if m.cost
    }


def test_the_costs_order_the_units_as_documented() -> None:
    logs = _logs()
    assert _cost("nn", logs, n_networks=5) > _cost("nn", logs, n_networks=1)
    assert _cost("nn", logs) > _cost("nn", logs, quick=True) * 10  # five 2x25 against two of 8
    assert _cost("nn", logs, hidden_layer_sizes=(50, 50)) > _cost("nn", logs)
    assert _cost("ss", logs, order=8) > _cost("ss", logs, order=2)
    assert _cost("ss", logs) > _cost("ss", logs, max_iter=20)
    assert _cost("ss", logs, refine=False) < _cost("ss", logs)
    assert _cost("pnlss", logs, degree=3) > _cost("pnlss", logs, degree=2)
    assert _cost("sm-multistep", logs, horizon=40) > _cost("sm-multistep", logs, horizon=3)
    assert _cost("poly", logs, degree=3) > _cost("poly", logs, degree=2)
    assert _cost("poly", logs, max_iter=100) > _cost("poly", logs, max_iter=10)
    assert _cost("koopman", logs) > _cost("koopman", logs, n_observables=10, ridge=1e-6)
    assert _cost("sindy", logs) > _cost("sindy", logs, quick=True)
    assert _cost("arx", logs, Lags.arx(4, 4)) > _cost("arx", logs, Lags.arx(1, 1))
    assert _cost("arx", logs) < _cost("sm", logs) < _cost("nn", logs)
    assert _cost("sm-parallel", logs, base="koopman") > _cost("sm-parallel", logs)


def test_set_membership_grows_as_n_log_n_and_the_others_with_the_samples() -> None:
    short, long = _logs(1, 1000), _logs(1, 8000)
    assert _cost("sm", long) / _cost("sm", short) == pytest.approx(
        8 * math.log(8000) / math.log(1000)
    )
    assert _cost("nn", long) / _cost("nn", short) == pytest.approx(8.0)
    # A model the registry does not know counts per sample, a baseline almost nothing.
    assert unit_cost(object(), short) == pytest.approx(1000 * 1.0)
    assert unit_cost(object(), short, "baseline: training mean") < unit_cost(object(), short)
    assert costs.set_membership_cost(None, 20_000, 3) > 2 * costs.set_membership_cost(
        None, 10_000, 3
    )


def test_a_selections_units_carry_the_cost_of_their_own_settings() -> None:
    from neckid.data.folds import Split

    first, second = _logs()
    splits = [Split((first,), ((second,),)), Split((second,), ((first,),))]
    nn = methods()["nn"]
    candidates = [
        ("nn", nn.make(Lags.arx(2, 2))),
        ("nn quick", nn.make(Lags.arx(2, 2), quick=True)),
    ]
    units = progress_units(candidates, splits)
    by_group = {group: cost for _, group, cost in units}
    assert by_group["nn"] > 5 * by_group["nn quick"]


def test_a_compares_progress_lines_show_a_time_left() -> None:
    stream = io.StringIO()
    reporter = LineReporter(stream, quiet=0.0, every=0.0, heartbeat=None)
    train, test = _logs(2, 300), _logs(1, 300, seed=1)
    with reporting(reporter):
        compare(train, test, methods=["arx", "ss"], lags=Lags.arx(1, 1), progress=True)
    lines = [line for line in stream.getvalue().splitlines() if "fitting and scoring" in line]
    left = [line for line in lines if re.search(r"(about|at least) (\d+ min )?\d+ s left", line)]
    assert left, lines
    assert any(": ss, " in line for line in left), lines
