"""One method on one data set, from its grid to its test runs, and the stages that run them all.

A :class:`MethodPlan` is what :func:`~neckid.experiments.benchmark.run_benchmark` does for one
method on one data set: list the candidates (its grid, once the fits it shares are done, see
:func:`~neckid.experiments.benchmark.settings.shared_fits`, and, for a
:data:`~neckid.experiments.benchmark.settings.BUILDS_ON` method, once its base method has
chosen), rank them on the training data, refit the best and run the tests. :func:`run_plans`
runs every plan of a run together: at each stage it collects the units every plan can start
(:mod:`~neckid.experiments.benchmark.stages`), runs them with joblib on the workers asked for,
longest first, and hands the outcomes back. Units of all data sets and methods share the workers,
so a method with one candidate (or a long final fit) no longer leaves a core idle.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
from joblib import delayed

from neckid.data.folds import rank_candidates
from neckid.data.iodata import IOData, as_experiments
from neckid.datasets.benchmarks import BenchmarkData
from neckid.experiments.benchmark.peers import peer_candidates
from neckid.experiments.benchmark.settings import (
    BUILDS_ON,
    CANDIDATE_GRIDS,
    PEER_METHODS,
    SELECTION_FOLDS,
    SELECTION_FRACTION,
    Candidate,
    GridInput,
    lag_grid,
    shared_fits,
)
from neckid.experiments.benchmark.shared import SharedFits, data_digest, fit_key
from neckid.experiments.benchmark.stages import FinalRun, Outcome, final_unit, fit_unit, score_unit
from neckid.registry import methods
from neckid.selection.work import unit_cost
from neckid.utils.parallel import run_jobs

__all__ = ["UNIT_COST", "MethodPlan", "choose", "run_plans", "selection_parts"]

logger = logging.getLogger(__name__)

#: Relative cost of one unit per training sample, by method: each method's
#: :attr:`~neckid.registry.Method.unit_cost`; a peer method counts 5. A unit's cost is its
#: method's cost function at the estimator's settings (:func:`neckid.selection.work.unit_cost`),
#: which falls back on this; it orders a stage's units (longest first). It changes the wall time
#: only, never the results.
UNIT_COST: Mapping[str, float] = MappingProxyType({m.name: m.unit_cost for m in methods().values()})


def selection_parts(train: IOData | Sequence[IOData]) -> list[IOData | list[IOData]]:
    """The data the candidates are fitted on during the selection (one per fold).

    One record: its first :data:`~neckid.experiments.benchmark.settings.SELECTION_FRACTION`.
    Several: all experiments but the held-out ones of each fold (leave-one-experiment-out, or
    :data:`~neckid.experiments.benchmark.settings.SELECTION_FOLDS` folds).
    """
    experiments = as_experiments(train, "train")
    if len(experiments) == 1:
        return [experiments[0].split(SELECTION_FRACTION)[0]]
    k = len(experiments) if SELECTION_FOLDS is None else SELECTION_FOLDS
    held_out = [set(range(j, len(experiments), k)) for j in range(k)]
    parts: list[IOData | list[IOData]] = []
    for fold in held_out:
        rest = [d for i, d in enumerate(experiments) if i not in fold]
        parts.append(rest if len(rest) > 1 else rest[0])
    return parts


def choose(
    options: Sequence[Candidate], rows: Sequence[dict[str, Any]]
) -> tuple[Candidate, list[dict[str, Any]]]:
    """The candidate with the smallest held-out free-run RMSE, and the scores of all of them.

    ``rows`` are the candidates' score rows (:func:`~.stages.score_unit`), in their order. Each
    score says the settings and the hold-out RMSE; across experiments also the scheme and the
    worst fold's RMSE; a failed candidate its error. The choice is the one ranking of every
    selection (:func:`neckid.data.folds.rank_candidates`) with its ``"best"`` rule on the
    negated mean RMSE: a benchmark scores each method at its best setting, so no tolerance
    toward the simpler one (ties: the first).

    Raises
    ------
    ValueError
        If every candidate failed or diverged.
    """
    values = np.array([r["rmse_simulation"] for r in rows], dtype=np.float64)
    scores: list[dict[str, Any]] = []
    for row in rows:
        score: dict[str, Any] = {"settings": row["name"], "holdout_rmse": row["rmse_simulation"]}
        if row["scheme"] != "validation":
            score.update(scheme=row["scheme"], worst_fold_rmse=row["rmse_simulation_worst"])
        if row["error"]:
            score["error"] = row["error"]
        scores.append(score)
    if not np.isfinite(values).any():
        raise ValueError(f"every candidate failed or diverged on the held-out end: {scores}")
    ranking = rank_candidates(-values[:, None], rule="best")
    return options[ranking.chosen], scores


@dataclass
class _Unit:
    """A unit ready to run: its call, its estimated cost, and what to do with its outcome."""

    plan: MethodPlan
    call: Any
    cost: float
    deliver: Callable[[Outcome], None]
    completes: tuple[bytes, ...] = ()


@dataclass
class MethodPlan:
    """One method on one data set through its stages (grid, selection, final fit, test runs).

    Attributes
    ----------
    bench : BenchmarkData
        The data set.
    method : str
        A registry name or a peer.
    hidden : bool
        Run only because a :data:`BUILDS_ON` method needs its choice: no rows.
    options : list of (str, estimator)
        The candidates, once the grid is built.
    chosen : (str, estimator) or None
        The candidate the selection kept.
    scores : list of dict
        Every candidate's hold-out score (empty for a single candidate).
    final : FinalRun or None
        The chosen candidate fitted on the whole training data and run on the tests.
    error : Exception or None
        What stopped the plan (its rows then say it failed).
    seconds : dict
        Seconds of work of the grid, the selection (every candidate's unit, summed), the final
        fit and the free runs; ``candidates`` the seconds of each candidate's unit.
    """

    bench: BenchmarkData
    method: str
    quick: bool = False
    seed: int = 0
    hidden: bool = False
    options: list[Candidate] | None = None
    chosen: Candidate | None = None
    scores: list[dict[str, Any]] = field(default_factory=list)
    final: FinalRun | None = None
    error: Exception | None = None
    seconds: dict[str, Any] = field(default_factory=dict)
    rows: list[dict[str, Any] | None] = field(default_factory=list, init=False, repr=False)
    waiting: int = field(default=0, init=False, repr=False)
    final_sent: bool = field(default=False, init=False, repr=False)

    @property
    def done(self) -> bool:
        """The plan failed, or its final run came back."""
        return self.error is not None or self.final is not None

    def grid_input(self, shared: SharedFits, lags: Sequence[Any] | None) -> GridInput:
        """What its grid reads."""
        return GridInput(
            self.bench.name,
            self.bench.train,
            quick=self.quick,
            seed=self.seed,
            lags=None if lags is None else tuple(lags),
            shared=shared,
        )


class _Stages:
    """The stage loop over every plan of a run (see :func:`run_plans`)."""

    def __init__(
        self,
        plans: list[MethodPlan],
        shared: SharedFits,
        n_jobs: int | None,
        backend: str | None,
        errors: str,
    ) -> None:
        self.plans, self.shared = plans, shared
        self.n_jobs, self.backend, self.errors = n_jobs, backend, errors
        self.completed: set[bytes] = set()
        self.inflight: set[bytes] = set()
        self.stages: list[dict[str, Any]] = []
        self._parts = {p.bench.name: selection_parts(p.bench.train) for p in plans}
        self._digests: dict[str, bytes] = {}
        # The fits some grid reads (the fitted model of such a final fit is kept).
        self._wanted = {
            fit_key(estimator, p.bench.train)
            for p in plans
            for estimator, _ in shared_fits(p.method, p.grid_input(shared, None))
        }
        self._scores: dict[bytes, list[Callable[[Outcome], None]] | Outcome] = {}

    # ------------------------------------------------------------------ the loop
    def run(self) -> list[dict[str, Any]]:
        while not all(plan.done for plan in self.plans):
            units: list[_Unit] = []
            for first in (True, False):  # plans that wait on nothing claim their fits first
                for plan in self.plans:
                    if not plan.done and self._independent(plan) == first:
                        units += self._ready(plan)
            if not units:
                raise RuntimeError(
                    "the benchmark's plans wait on each other: "
                    + ", ".join(f"{p.method} on {p.bench.name}" for p in self.plans if not p.done)
                )
            self._run_stage(units)
        return self.stages

    def _run_stage(self, units: list[_Unit]) -> None:
        order = sorted(range(len(units)), key=lambda i: -units[i].cost)
        start = time.perf_counter()
        logger.info("benchmark stage %d: %d units", len(self.stages) + 1, len(units))
        outcomes = run_jobs(
            (units[i].call for i in order),
            total=len(units),
            n_jobs=self.n_jobs,
            backend=self.backend,
            label="benchmark",
        )
        wall = time.perf_counter() - start
        by_unit = dict(zip(order, outcomes, strict=True))
        for i, unit in enumerate(units):  # in the order of the plans, whichever finished first
            self.completed.update(unit.completes)
            self.inflight.difference_update(unit.completes)
            cpu = unit.plan.seconds.get("cpu", 0.0) + by_unit[i].cpu_seconds
            unit.plan.seconds["cpu"] = cpu
            unit.deliver(by_unit[i])
        work = float(sum(o.seconds for o in outcomes))
        cpu = float(sum(o.cpu_seconds for o in outcomes))
        self.stages.append({"units": len(units), "wall_time_s": wall, "work_s": work, "cpu_s": cpu})

    def _fail(self, plan: MethodPlan, error: Exception) -> None:
        if self.errors == "raise":
            raise error
        logger.warning("%s on %s failed: %s", plan.method, plan.bench.name, error)
        plan.error = error

    # ------------------------------------------------------------------ one plan
    def _independent(self, plan: MethodPlan) -> bool:
        return plan.method not in BUILDS_ON and not (
            plan.options is None and shared_fits(plan.method, plan.grid_input(self.shared, None))
        )

    def _digest(self, plan: MethodPlan) -> bytes:
        if plan.bench.name not in self._digests:
            self._digests[plan.bench.name] = data_digest(plan.bench.train)
        return self._digests[plan.bench.name]

    def _known(self, plan: MethodPlan, estimator: Any) -> list[Any]:
        """The polynomial states fitted before on this data set with the estimator's lags."""
        return self.shared.polynomial_entries(self._digest(plan), _lags_of(estimator))

    def _keep_entries(self, plan: MethodPlan, estimator: Any, outcome: Outcome) -> None:
        self.shared.add_polynomial_entries(
            self._digest(plan), _lags_of(estimator), outcome.polynomial_fits
        )

    def _ready(self, plan: MethodPlan) -> list[_Unit]:
        if plan.options is None:
            return self._grid(plan)
        if plan.chosen is not None and not plan.final_sent:
            return [self._final(plan)]
        return []

    def _base_lags(self, plan: MethodPlan) -> tuple[bool, list[Any] | None]:
        """Whether the plan may build its grid, and the lags its base method chose."""
        base = BUILDS_ON.get(plan.method)
        if base is None or len(lag_grid(plan.bench.name, plan.quick)) < 2:
            return True, None
        found = [p for p in self.plans if p.bench is plan.bench and p.method == base]
        if not found or found[0].error is not None:
            return True, None  # the base failed: the whole grid
        if found[0].chosen is None:
            return False, None
        return True, [found[0].chosen[1].get_params()["lags"]]

    def _grid(self, plan: MethodPlan) -> list[_Unit]:
        ready, lags = self._base_lags(plan)
        if not ready:
            return []
        grid_input = plan.grid_input(self.shared, lags)
        units = self._shared_units(plan, grid_input)
        if units is None or units:
            return units or []
        start = time.perf_counter()
        try:
            if plan.method in PEER_METHODS:
                options = peer_candidates(plan.method, plan.bench.name, plan.quick)
            else:
                options = CANDIDATE_GRIDS[plan.method](grid_input)
            if not options:
                raise ValueError("the method has no candidate on this data set")
        except Exception as exc:  # a failing method must not stop the others
            self._fail(plan, exc)
            return []
        finally:
            plan.seconds["grid"] = time.perf_counter() - start
        plan.options = options
        if len(options) == 1:
            plan.chosen = options[0]
            return [self._final(plan)]
        return self._score_units(plan)

    def _shared_units(self, plan: MethodPlan, grid_input: GridInput) -> list[_Unit] | None:
        """Units for the shared fits the grid still needs; ``None`` while others compute them."""
        units: list[_Unit] = []
        waiting = False
        for estimator, on_parts in shared_fits(plan.method, grid_input):
            parts = [plan.bench.train, *(self._parts[plan.bench.name] if on_parts else [])]
            for part in parts:
                key = fit_key(estimator, part)
                if key in self.completed:
                    continue
                waiting = True
                if key in self.inflight:
                    continue
                self.inflight.add(key)
                units.append(self._fit(plan, estimator, part, key))
        return None if waiting and not units else units

    def _fit(self, plan: MethodPlan, estimator: Any, part: Any, key: bytes) -> _Unit:
        def deliver(outcome: Outcome) -> None:
            self._keep_entries(plan, estimator, outcome)
            if outcome.error is None:
                self.shared.add_fitted(estimator, part, outcome.value)
            plan.seconds["shared_fits"] = plan.seconds.get("shared_fits", 0.0) + outcome.seconds

        n = sum(r.n_samples for r in as_experiments(part, "data"))
        call = delayed(fit_unit)(estimator, part, self._known(plan, estimator))
        return _Unit(plan, call, _cost(plan.method, estimator, part, n), deliver, (key,))

    def _score_units(self, plan: MethodPlan) -> list[_Unit]:
        """One unit per candidate; a candidate scored before on the same data is not rescored."""
        assert plan.options is not None
        parts = self._parts[plan.bench.name]
        n = sum(r.n_samples for p in parts for r in as_experiments(p, "data"))
        plan.rows = [None] * len(plan.options)
        plan.seconds["candidates"] = [0.0] * len(plan.options)
        plan.waiting = len(plan.options)
        units = []
        for i, (name, estimator) in enumerate(plan.options):
            deliver = self._scored(plan, i)
            key = fit_key(estimator, plan.bench.train) + repr(plan.bench.n_initial).encode()
            earlier = self._scores.get(key)
            if earlier is not None:  # the same candidate on the same data: scored once
                self.shared.reused["scores"] += 1
                if isinstance(earlier, Outcome):
                    deliver(earlier)
                else:
                    earlier.append(deliver)
                continue
            self._scores[key] = [deliver]
            completes = tuple(fit_key(estimator, p) for p in parts)
            self.inflight.update(completes)
            call = delayed(score_unit)(
                name,
                estimator,
                plan.bench.train,
                plan.bench.n_initial,
                fraction=SELECTION_FRACTION,
                folds=SELECTION_FOLDS,
                known=self._known(plan, estimator),
            )
            cost = _cost(plan.method, estimator, parts[0], n)
            units.append(_Unit(plan, call, cost, self._to_all(key), completes))
        return units

    def _to_all(self, key: bytes) -> Callable[[Outcome], None]:
        """Hand a score to every plan that asked for it, and keep it for later ones."""

        def deliver(outcome: Outcome) -> None:
            waiters = self._scores[key]
            self._scores[key] = outcome
            for each in waiters if isinstance(waiters, list) else []:
                each(outcome)

        return deliver

    def _scored(self, plan: MethodPlan, i: int) -> Callable[[Outcome], None]:
        def deliver(outcome: Outcome) -> None:
            assert plan.options is not None
            name, estimator = plan.options[i]
            self._keep_entries(plan, estimator, outcome)
            plan.seconds["candidates"][i] = outcome.seconds
            if outcome.error is not None:  # score_candidates itself failed: not a bad candidate
                self._fail(plan, outcome.error)
                return
            plan.rows[i] = {**outcome.value, "name": name}
            plan.waiting -= 1
            if plan.waiting == 0 and plan.error is None:
                try:
                    plan.chosen, plan.scores = choose(plan.options, plan.rows)  # type: ignore[arg-type]
                except ValueError as exc:
                    self._fail(plan, exc)

        return deliver

    def _final(self, plan: MethodPlan) -> _Unit:
        assert plan.chosen is not None
        plan.final_sent = True
        estimator = plan.chosen[1]
        key = fit_key(estimator, plan.bench.train)
        self.inflight.add(key)

        def deliver(outcome: Outcome) -> None:
            self._keep_entries(plan, estimator, outcome)
            plan.seconds["final"] = outcome.seconds
            if outcome.error is not None:
                self._fail(plan, outcome.error)
                return
            plan.final = outcome.value
            if outcome.value.model is not None:
                self.shared.add_fitted(estimator, plan.bench.train, outcome.value.model)

        n = sum(r.n_samples for r in as_experiments(plan.bench.train, "train"))
        n += sum(r.n_samples for r in plan.bench.tests.values()) // 10
        call = delayed(final_unit)(
            estimator, plan.bench, self._known(plan, estimator), keep_model=key in self._wanted
        )
        return _Unit(
            plan, call, _cost(plan.method, estimator, plan.bench.train, n), deliver, (key,)
        )


def _lags_of(estimator: Any) -> Any:
    params = estimator.get_params(deep=False) if hasattr(estimator, "get_params") else {}
    return params.get("lags")


def _cost(method: str, estimator: Any, data: Any, n_samples: int) -> float:
    """A unit of ``n_samples``: the method's cost of ``estimator`` on ``data``, per sample of it."""
    if method not in UNIT_COST:  # a peer method
        return 5.0 * n_samples
    records = as_experiments(data, "data")
    fitted = sum(r.n_samples for r in records)
    return unit_cost(estimator, records) * n_samples / max(fitted, 1)


def run_plans(
    plans: list[MethodPlan],
    shared: SharedFits,
    *,
    n_jobs: int | None = None,
    backend: str | None = None,
    errors: str = "record",
) -> list[dict[str, Any]]:
    """Run every plan to its end, the units of all of them together; return the stages' times.

    At each stage every plan that can go on gives its units (a shared fit, a candidate's score,
    the final fit and test runs); the units run on ``n_jobs`` workers of ``backend`` (joblib,
    see :func:`neckid.utils.parallel.run_jobs`), longest first (:data:`UNIT_COST`), and their
    outcomes go back to their plans, in the order of the plans (the results do not depend on
    which worker finished first).

    Raises
    ------
    Exception
        With ``errors="raise"``, the first error of a plan (in the order outcomes are handed
        back).
    """
    return _Stages(plans, shared, n_jobs, backend, errors).run()
