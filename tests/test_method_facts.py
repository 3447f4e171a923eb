"""Facts about a method live on its registry entry; facts about a fitted model on its contract.

The tables other layers read (the selection's complexity ranks, the benchmark's unit costs, ...)
are derived from :class:`neckid.registry.Method`; the values they held as hand-written tables
before issue 41 are written out here, so a change of any is a visible change. What the command
line and the export read of a fitted model goes through :class:`neckid.models.facts.ModelFacts`.
"""

from __future__ import annotations

import importlib
import warnings

import numpy as np
import pytest

import neckid
from neckid import IOData, Lags
from neckid.experiments.benchmark.plans import UNIT_COST
from neckid.experiments.benchmark.settings import (
    BUILDS_ON,
    ONLY_ON,
    PUBLIC_BENCHMARKS,
    SOFTNECK_BENCHMARKS,
    STATE_MODEL_PARAMS,
)
from neckid.models.facts import SetMembershipPrior, StateOrder
from neckid.selection.comparison import COMPLEXITY, LAG_FREE_METHODS

#: The hand-written tables as they were before the facts moved to the registry (issue 41).
COMPLEXITY_BEFORE = {
    "arx": 0, "rls": 1, "scheduled": 1, "ss": 2, "greybox-neck": 2, "greybox-tanks": 2,
    "sm-linear": 2, "sm": 3, "sm-parallel": 3, "sm-multistep": 4, "poly": 4, "pnlss": 4,
    "sm-parallel-poly": 5, "nn": 6,
}  # fmt: skip
UNIT_COST_BEFORE = {
    "arx": 0.01, "ss": 0.3, "pnlss": 20.0, "sm": 1.0, "sm-linear": 1.0, "sm-parallel": 2.0,
    "sm-parallel-poly": 3.0, "poly": 10.0, "nn": 8.0, "scheduled": 0.01, "greybox-neck": 1.0,
}  # fmt: skip
ONLY_ON_BEFORE = {
    "scheduled": "softneck", "poly": "public", "sm-parallel-poly": "public",
    "greybox-neck": "softneck", "sysidentpy-frols": "public",
}  # fmt: skip


def test_the_tables_are_read_from_the_registry_and_hold_what_they_held() -> None:
    entries = neckid.methods()
    groups = {"public": PUBLIC_BENCHMARKS, "softneck": SOFTNECK_BENCHMARKS}
    for name, method in entries.items():
        assert COMPLEXITY[name] == method.complexity
        assert UNIT_COST[name] == method.unit_cost
        assert (name in LAG_FREE_METHODS) == method.lag_free
        assert BUILDS_ON.get(name) == method.builds_on
        assert (ONLY_ON.get(name) is None) == (method.only_on is None)
        if name in COMPLEXITY_BEFORE:  # methods registered before the move rank as they did
            assert method.complexity == COMPLEXITY_BEFORE[name]
        if name in UNIT_COST_BEFORE:
            assert method.unit_cost == UNIT_COST_BEFORE[name]
    assert {n: g for n, g in ONLY_ON.items() if n in ONLY_ON_BEFORE} == {
        n: groups[g] for n, g in ONLY_ON_BEFORE.items()
    }
    assert {"ss", "pnlss", "greybox-neck", "greybox-tanks"} <= LAG_FREE_METHODS
    assert dict(BUILDS_ON) == {
        "sm-parallel-poly": "poly",
        "sm-parallel-sindy": "sindy",
        "sm-parallel-koopman": "koopman",
    }
    assert all(not params for params in STATE_MODEL_PARAMS.values())
    assert {"ss", "greybox-neck"} <= set(STATE_MODEL_PARAMS)


def test_every_class_has_one_describer_and_one_control_form() -> None:
    by_class: dict[str, tuple[str, str]] = {}
    for method in neckid.methods().values():
        module, _, function = method.describer.partition(":")
        assert callable(getattr(importlib.import_module(module), function)), method.name
        assert method.control_form in ("tf", "ss")
        facts = (method.describer, method.control_form)
        assert by_class.setdefault(method.class_name, facts) == facts, method.class_name
    assert {m.name for m in neckid.methods().values() if m.control_form == "ss"} >= {
        "ss",
        "pnlss",
        "scheduled",
        "scheduled-position",
    }


def _record(n: int = 400, seed: int = 0) -> IOData:
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1.0, 1.0, n // 10), 10)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.8 * y[t - 1] + 0.4 * np.tanh(2.0 * u[t - 1])
    return IOData(u, y + 0.01 * rng.normal(size=n), ts=0.02)


@pytest.fixture(scope="module")
def fitted() -> dict[str, object]:
    data = _record()
    made = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in ("arx", "sm", "sm-parallel", "sm-multistep", "ss"):
            made[name] = neckid.methods()[name].make(Lags.arx(1, 1), quick=True).fit(data)
    return made


def test_the_set_membership_prior_is_the_models(fitted) -> None:
    sm, parallel, multistep = fitted["sm"], fitted["sm-parallel"], fitted["sm-multistep"]
    prior = sm.set_membership_prior()
    assert isinstance(prior, SetMembershipPrior) and prior.horizons is None
    np.testing.assert_array_equal(prior.epsilon, sm.epsilon_)
    np.testing.assert_array_equal(prior.gamma, sm.gamma_)
    assert (prior.lipschitz, prior.distance, prior.estimate) == ("global", "std", None)
    inner = parallel.set_membership_prior()
    np.testing.assert_array_equal(inner.gamma, parallel.sm_.gamma_)
    assert inner.estimate == str(parallel.estimate)
    ahead = multistep.set_membership_prior()
    assert ahead.horizons == tuple(int(k) for k in multistep.horizons_)
    assert ahead.epsilon.shape == (len(ahead.horizons), 1)
    assert fitted["arx"].set_membership_prior() is None
    assert fitted["ss"].set_membership_prior() is None


def test_the_descriptive_contract_of_every_estimator(fitted) -> None:
    arx, ss = fitted["arx"], fitted["ss"]
    assert arx.preprocessing_ is None and arx.state_order() is None
    assert arx.channel_map_ is None and arx.schedule_summary() == {}
    assert arx.fitted_lags() is arx.lags_
    assert arx.training_box() == arx.training_ranges_
    assert arx.regressor_box() == arx.regressor_ranges_
    assert arx.training_samples() == arx.n_samples_
    order = ss.state_order()
    assert isinstance(order, StateOrder) and order.order == ss.order_
    np.testing.assert_array_equal(order.singular_values, ss.singular_values_)
    assert ss.fitted_lags() is None and ss.regressor_box() == {}
    rls = neckid.methods()["rls"].make(Lags.arx(1, 1)).fit(_record())
    np.testing.assert_array_equal(rls.intercept_, [0.0])  # CFF-RLS fits none


def test_the_schedule_summary_is_what_info_shows() -> None:
    i = np.array([5.0, 15.0, 25.0])
    model = neckid.GainScheduledModel.from_points(i, 1.0 + 0 * i, 0.5 + 0 * i, ts=0.02, delay=1)
    assert model.schedule_summary() == {"schedule": model.describe_schedule()}
