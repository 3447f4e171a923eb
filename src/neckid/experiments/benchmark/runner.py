"""Run the benchmark: select each method's hyper-parameters, fit, simulate, report.

For every data set found (:mod:`~neckid.experiments.benchmark.datasets`) and every method
(:mod:`~neckid.experiments.benchmark.settings`), :func:`run_benchmark`

1. lists the method's candidates on that data set (after the fits its grid shares with others,
   :func:`~neckid.experiments.benchmark.settings.shared_fits`, and, for a method of
   :data:`~neckid.experiments.benchmark.settings.BUILDS_ON`, on the lags its base method chose);
2. fits each on the first :data:`~neckid.experiments.benchmark.settings.SELECTION_FRACTION` of
   the training record and ranks them by free-run RMSE on the rest, or, given several training
   experiments, on held-out experiments (:func:`neckid.selection.lags.score_candidates`); a candidate
   whose held-out free run is not finite or leaves the divergence envelope of the training
   outputs is out (its RMSE is infinite);
3. refits the best one on the whole training record and simulates every test record once, in free
   run (:func:`neckid.selection.lags.free_run`, with the protocol's initial samples).

The work of all data sets and methods runs together (:func:`~.plans.run_plans`): at each stage,
every unit that can start (a shared fit, a candidate, a final fit with its test runs) goes to the
workers, longest first; a fit several grids need is done once (:mod:`~.shared`).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import pandas as pd
from joblib import delayed

from neckid.data.iodata import IOData, as_experiments
from neckid.datasets.benchmarks import BenchmarkData
from neckid.experiments.benchmark.datasets import BENCHMARKS, PROTOCOLS, load_benchmark
from neckid.experiments.benchmark.peers import peer_unavailable
from neckid.experiments.benchmark.plans import MethodPlan, choose, run_plans
from neckid.experiments.benchmark.published import published_frame
from neckid.experiments.benchmark.report import TABLE_COLUMNS, BenchmarkReport
from neckid.experiments.benchmark.settings import (
    BENCHMARK_METHODS,
    BUILDS_ON,
    DEFAULT_METHODS,
    PEER_METHODS,
    SELECTION_FOLDS,
    SELECTION_FRACTION,
    Candidate,
    runs_on,
)
from neckid.experiments.benchmark.shared import SharedFits
from neckid.experiments.benchmark.stages import score_unit
from neckid.registry import DEPRECATED_NAMES, get_method
from neckid.utils.files import output_folder
from neckid.utils.parallel import check_backend, run_jobs

__all__ = ["TABLE_COLUMNS", "BenchmarkReport", "run_benchmark"]

logger = logging.getLogger(__name__)


# ---------------------------------------------------------------------------- selection
@dataclass(frozen=True)
class _Sweep:
    """Where the candidates' fits run: ``n_jobs`` and ``backend`` of :func:`score_candidates`."""

    n_jobs: int | None = None
    backend: str | None = None

    def options(self) -> dict[str, Any]:
        """The keyword arguments of :func:`~neckid.selection.lags.score_candidates`."""
        return {"n_jobs": self.n_jobs, "backend": self.backend}


def _select(
    options: Sequence[Candidate],
    train: IOData | Sequence[IOData],
    n_initial: int | None,
    sweep: _Sweep | None = None,
) -> tuple[Candidate, list[dict[str, Any]]]:
    """The candidate with the smallest free-run RMSE on held-out training data.

    One training record: fitted on its first :data:`SELECTION_FRACTION`, scored on the rest. A
    list of two or more experiments: scored on held-out experiments (:data:`SELECTION_FOLDS`,
    leave-one-experiment-out by default), by the mean RMSE over the folds; each score then also
    says the scheme and the worst fold's RMSE. ``sweep`` says where the fits run. The same
    units and rule as :func:`run_benchmark` (:func:`~.stages.score_unit`, :func:`~.plans.choose`).
    """
    if not options:
        raise ValueError("the method has no candidate on this data set")
    if len(options) == 1:
        return options[0], []
    sweep = sweep or _Sweep()
    units = (
        delayed(score_unit)(
            name, estimator, train, n_initial, fraction=SELECTION_FRACTION, folds=SELECTION_FOLDS
        )
        for name, estimator in options
    )
    outcomes = run_jobs(units, total=len(options), **sweep.options())
    for outcome in outcomes:
        if outcome.error is not None:
            raise outcome.error
    return choose(options, [outcome.value for outcome in outcomes])


# ---------------------------------------------------------------------------- rows
def _row(bench: BenchmarkData, test: str, method: str, **values: Any) -> dict[str, Any]:
    row: dict[str, Any] = {
        "benchmark": bench.name,
        "test": test,
        "method": method,
        "rmse": math.nan,
        "rmse_unit": bench.rmse_unit,
        "fit_percent": math.nan,
        "n_initial": bench.n_initial,
        "train_time_s": math.nan,
        "simulate_time_s": math.nan,
        "settings": "",
        "note": "",
    }
    row.update(values)
    return row


def _plan_rows(plan: MethodPlan) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The table rows and details of a plan that ran."""
    bench, method = plan.bench, plan.method
    if plan.error is not None or plan.final is None or plan.chosen is None:
        error = plan.error or RuntimeError("the plan did not finish")
        note = f"failed: {type(error).__name__}: {error}"
        rows = [_row(bench, test, method, note=note) for test in bench.tests]
        return rows, {"error": f"{type(error).__name__}: {error}"}
    settings = plan.chosen[0]
    train_time = (
        plan.seconds.get("grid", 0.0)
        + plan.seconds.get("shared_fits", 0.0)
        + sum(plan.seconds.get("candidates", []))
        + plan.final.fit_time_s
    )
    rows = []
    for run in plan.final.tests:
        note = ""
        if run.diverged_at is not None:
            note = (
                f"free run diverged at sample {run.diverged_at} (not finite, or beyond the"
                " training outputs' divergence envelope)"
            )
        rows.append(
            _row(
                bench,
                run.test,
                method,
                rmse=run.rmse,
                fit_percent=run.fit_percent,
                n_initial=run.n_initial,
                train_time_s=train_time,
                simulate_time_s=run.simulate_time_s,
                settings=settings,
                note=note,
            )
        )
    return rows, {"selection": plan.scores, "chosen": settings}


def _plan_timings(plan: MethodPlan) -> dict[str, Any]:
    """Seconds of work of a plan's grid, shared fits, candidates, final fit and free runs."""
    times: dict[str, Any] = {
        "grid_s": plan.seconds.get("grid", 0.0),
        "shared_fits_s": plan.seconds.get("shared_fits", 0.0),
        "selection_s": float(sum(plan.seconds.get("candidates", []))),
        "final_fit_s": plan.final.fit_time_s if plan.final is not None else math.nan,
        "simulate_s": (
            float(sum(r.simulate_time_s for r in plan.final.tests))
            if plan.final is not None
            else math.nan
        ),
        "cpu_s": plan.seconds.get("cpu", 0.0),
        "n_candidates": len(plan.options or []),
    }
    if plan.options and len(plan.options) > 1:
        times["candidates_s"] = {
            name: seconds
            for (name, _), seconds in zip(plan.options, plan.seconds["candidates"], strict=True)
        }
    return times


def _mean_over_tests(
    bench: BenchmarkData, rows: list[dict[str, Any]]
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Mean per method over the test records, and ``fit(method) - fit(arx)`` per record."""
    frame = pd.DataFrame(rows)
    summary = [
        _row(
            bench,
            "mean",
            str(method),
            rmse=float(group["rmse"].mean()),
            fit_percent=float(group["fit_percent"].mean()),
            n_initial=math.nan,
            train_time_s=float(group["train_time_s"].iloc[0]),
            simulate_time_s=float(group["simulate_time_s"].sum()),
            settings=str(group["settings"].iloc[0]),
            note=f"mean over {len(group)} validation logs",
        )
        for method, group in frame.groupby("method", sort=False)
    ]
    margins: dict[str, Any] = {}
    fits = frame.pivot(index="test", columns="method", values="fit_percent")
    if "arx" in fits:
        for method in fits.columns.drop("arx"):
            margin = (fits[method] - fits["arx"]).dropna()
            margins[f"{method}_minus_arx"] = {str(k): float(v) for k, v in margin.items()}
            margins[f"{method}_beats_arx_by_5_on_every_log"] = bool(
                len(margin) == len(fits) and (margin >= 5.0).all()
            )
    return summary, margins


# ---------------------------------------------------------------------------- run
def _method_names(names: str | Sequence[str] | None) -> list[str]:
    """Registry names of the methods asked for; an earlier spelling warns (``FutureWarning``)."""
    if names is None:
        return list(DEFAULT_METHODS)
    asked = [names] if isinstance(names, str) else list(names)
    known = (*BENCHMARK_METHODS, *PEER_METHODS)
    unknown = [m for m in asked if m not in known and m not in DEPRECATED_NAMES]
    if unknown:
        raise ValueError(f"methods must be among {list(known)}; got {unknown}")
    return [m if m in PEER_METHODS else get_method(m).name for m in asked]


def run_benchmark(
    data_dir: str | Path,
    methods: str | Sequence[str] | None = None,
    *,
    benchmarks: Sequence[str] | None = None,
    quick: bool = False,
    seed: int = 0,
    errors: Literal["record", "raise"] = "record",
    output_dir: str | Path | None = None,
    force: bool = False,
    n_jobs: int | None = None,
    backend: str | None = None,
) -> BenchmarkReport:
    """Run the identification methods on the real data sets found under ``data_dir``.

    Parameters
    ----------
    data_dir : str or Path
        The folder that holds ``softneck/`` and ``benchmarks/<name>/`` (the layout of the shared
        data folder); ``<name>/`` directly under it works too. Data sets not found are skipped
        (listed in ``details["missing"]``).
    methods : str or sequence of str, optional
        Registry names (:func:`neckid.methods`) among
        :data:`~neckid.experiments.benchmark.settings.BENCHMARK_METHODS`: ``"arx"``, ``"ss"``,
        ``"pnlss"``, ``"sm"``, ``"sm-linear"``, ``"sm-parallel"``, ``"sm-parallel-poly"``,
        ``"poly"``, ``"nn"``, ``"scheduled"``, ``"greybox-neck"`` (the scheduled model and the
        grey-box neck run on the soft-neck logs only, the polynomial NARX ones on the public
        benchmarks only: ``ONLY_ON``), and the peer ``"sysidentpy-frols"``
        (:mod:`~neckid.experiments.benchmark.peers`, public benchmarks only; a row that says it
        was skipped when SysIdentPy is not installed); default all of them
        (:data:`~neckid.experiments.benchmark.settings.DEFAULT_METHODS`). The spellings of the
        previous release
        (``"sm_linear"``, ``"sm_parallel"``, ``"neural"``) still work for one release, with a
        ``FutureWarning``.
    benchmarks : sequence of str, optional
        Keys of :data:`~neckid.experiments.benchmark.datasets.BENCHMARKS` to run; default all that
        are found.
    quick : bool, default False
        A smoke run: at most 1500 training and 600 test samples per record, three test records,
        one hyper-parameter candidate, the registry's small settings. Not for reporting.
    seed : int, default 0
        Seed of the neural network's initialisation and batches.
    errors : {"record", "raise"}, default "record"
        What to do when a method fails on a data set: ``"record"`` logs a warning and puts the
        message in the ``note`` column; ``"raise"`` re-raises.
    output_dir : str or Path, optional
        When given, the report is written there (:meth:`BenchmarkReport.write`); the folder is
        checked and locked *before* the run, so a second run into it is refused at once.
    force : bool, default False
        Replace the files of an ``output_dir`` that holds some already.
    n_jobs : int or None, default None
        Parallel workers (joblib) over the work units of every data set and method (shared
        fits, candidates, final fits with their test runs; :mod:`~.plans`); ``None`` means 1
        unless inside a ``joblib.parallel_config`` context, or every worker of the cluster with
        ``backend="dask"``; -1 every local core (the command line's default).
    backend : str or None, default None
        The joblib backend the units run on: ``None`` is the active ``joblib.parallel_config``
        (joblib's default outside one); ``"dask"`` the cluster of the active
        ``distributed.Client`` (``pip install neckid[dask]``). The table and details are the
        same as a run on this machine with any ``n_jobs`` (every unit runs with one BLAS
        thread); only the times differ.

    Returns
    -------
    BenchmarkReport
        The table (free-run RMSE in each benchmark's unit, NRMSE fit, seconds of work), the
        published figures, details, and timings (where the time went).

    Raises
    ------
    ValueError
        If a method or benchmark key is unknown, ``backend`` is unknown, or ``backend="dask"``
        and no ``distributed.Client`` is active.
    ImportError
        If ``backend="dask"`` and the ``distributed`` package is not installed.
    FileNotFoundError
        If ``data_dir`` is not a folder, or holds none of the data sets asked for.

    Notes
    -----
    Protocols: see ``docs/benchmarks/methods.md``. RMSE and fit skip the protocol's initial samples
    (Silverbox: 50) or, where the protocol gives none, the model's own ``max_lag_`` samples.
    Hyper-parameters are chosen on the training record only; test records are simulated once.
    Fits that several grids need are done once per run (:mod:`~.shared`), and SM on the
    polynomial runs on the lags the polynomial's selection chose
    (:data:`~neckid.experiments.benchmark.settings.BUILDS_ON`). Times are measured with
    :func:`time.perf_counter` on whatever machine runs this: a unit's seconds of work;
    ``train_time_s`` sums those of a method's grid, shared fits, candidates and final fit.
    """
    check_backend(backend)  # before the output folder is locked and any data is read
    arguments = (data_dir, methods, benchmarks, quick, seed, errors, _Sweep(n_jobs, backend))
    if output_dir is None:
        return _run(*arguments)
    with output_folder(output_dir, force=force) as staged:
        report = _run(*arguments)
        report.write_into(staged)
    return report


def _plans(
    loaded: dict[str, BenchmarkData], names: list[str], quick: bool, seed: int
) -> tuple[list[MethodPlan], dict[str, list[dict[str, Any]]], dict[str, dict[str, Any]]]:
    """A plan per (data set, method) that runs; the rows of the peers that are not installed.

    A method of :data:`BUILDS_ON` whose base method was not asked for gets the base as a hidden
    plan (its choice is needed; it gives no rows).
    """
    plans: list[MethodPlan] = []
    skipped_rows: dict[str, list[dict[str, Any]]] = {}
    skipped: dict[str, dict[str, Any]] = {}
    for name, bench in loaded.items():
        wanted = [m for m in names if runs_on(m, name)]
        for method in wanted:
            reason = peer_unavailable(method) if method in PEER_METHODS else None
            if reason is not None:  # a peer that is not installed: say so in its rows
                skipped_rows.setdefault(name, []).extend(
                    _row(bench, test, method, note=reason) for test in bench.tests
                )
                skipped.setdefault(name, {})[method] = {"skipped": reason}
                continue
            plans.append(MethodPlan(bench, method, quick=quick, seed=seed))
        for method in wanted:
            base = BUILDS_ON.get(method)
            if base is not None and base not in wanted and runs_on(base, name):
                plans.append(MethodPlan(bench, base, quick=quick, seed=seed, hidden=True))
    return plans, skipped_rows, skipped


def _run(
    data_dir: str | Path,
    methods: str | Sequence[str] | None,
    benchmarks: Sequence[str] | None,
    quick: bool,
    seed: int,
    errors: Literal["record", "raise"],
    sweep: _Sweep,
) -> BenchmarkReport:
    start = time.perf_counter()
    root = Path(data_dir)
    if not root.is_dir():
        raise FileNotFoundError(f"data_dir {root} is not a folder")
    names = _method_names(methods)
    datasets = list(BENCHMARKS if benchmarks is None else benchmarks)
    bad = [b for b in datasets if b not in BENCHMARKS]
    if bad:
        raise ValueError(f"benchmarks must be among {list(BENCHMARKS)}; got {bad}")
    if errors not in ("record", "raise"):
        raise ValueError(f"errors must be 'record' or 'raise'; got {errors!r}")

    # Every data set is read before any method runs: a file that cannot be read (a missing
    # optional reader, a damaged file) stops the run at once, not after an hour of fits.
    loaded = {name: load_benchmark(name, root, quick=quick) for name in datasets}
    if all(bench is None for bench in loaded.values()):
        raise FileNotFoundError(
            f"nothing to run: none of the data sets {', '.join(datasets)} is under {root} (it"
            " should hold softneck/ and benchmarks/NAME/; see docs/benchmarks/runs.md)"
        )
    found = {name: bench for name, bench in loaded.items() if bench is not None}
    plans, skipped_rows, skipped = _plans(found, names, quick, seed)
    for plan in plans:
        if not plan.hidden:
            n_train = sum(r.n_samples for r in as_experiments(plan.bench.train, "train"))
            logger.info(
                "benchmark %s: %s planned (%d training samples)",
                plan.bench.name,
                plan.method,
                n_train,
            )
    shared = SharedFits()
    stages = run_plans(plans, shared, n_jobs=sweep.n_jobs, backend=sweep.backend, errors=errors)
    rows, details, timings = _assemble(found, names, plans, skipped_rows, skipped)
    details = {
        "settings": {
            "data_dir": str(root),
            "methods": names,
            "quick": quick,
            "seed": seed,
            "selection_fraction": SELECTION_FRACTION,
        },
        "missing": [name for name in datasets if loaded[name] is None],
        "benchmarks": details,
    }
    report_timings = {
        "wall_time_s": time.perf_counter() - start,
        "n_jobs": sweep.n_jobs,
        "backend": sweep.backend,
        "stages": stages,
        "benchmarks": timings,
        "shared": dict(shared.reused),
    }
    return BenchmarkReport(
        table=pd.DataFrame(rows, columns=list(TABLE_COLUMNS)),
        published=published_frame(list(found)),
        details=details,
        timings=report_timings,
    )


def _assemble(
    found: dict[str, BenchmarkData],
    names: list[str],
    plans: list[MethodPlan],
    skipped_rows: dict[str, list[dict[str, Any]]],
    skipped: dict[str, dict[str, Any]],
) -> tuple[list[dict[str, Any]], dict[str, Any], dict[str, Any]]:
    """Rows, details and timings per data set, methods in the order asked for."""
    rows: list[dict[str, Any]] = []
    details: dict[str, Any] = {}
    timings: dict[str, Any] = {}
    for name, bench in found.items():
        by_method = {p.method: p for p in plans if p.bench is bench and not p.hidden}
        bench_details: dict[str, Any] = {
            "description": bench.description,
            "citation": bench.citation,
            "n_train": sum(r.n_samples for r in as_experiments(bench.train, "train")),
            "tests": {k: v.n_samples for k, v in bench.tests.items()},
            "methods": {},
        }
        bench_rows: list[dict[str, Any]] = []
        bench_timings: dict[str, Any] = {}
        for method in names:
            if method in skipped.get(name, {}):
                bench_rows += [r for r in skipped_rows[name] if r["method"] == method]
                bench_details["methods"][method] = skipped[name][method]
            elif method in by_method:
                method_rows, method_details = _plan_rows(by_method[method])
                bench_rows += method_rows
                bench_details["methods"][method] = method_details
                bench_timings[method] = _plan_timings(by_method[method])
        hidden = [p for p in plans if p.bench is bench and p.hidden]
        for plan in hidden:
            users = [m for m in names if BUILDS_ON.get(m) == plan.method]
            bench_timings[f"{plan.method} (for {', '.join(users)})"] = _plan_timings(plan)
        finished = [r for r in bench_rows if not math.isnan(r["fit_percent"])]
        if PROTOCOLS[name].mean_over_tests and finished:
            summary, margins = _mean_over_tests(bench, finished)
            bench_rows.extend(summary)
            bench_details.update(margins)
        rows.extend(bench_rows)
        details[name] = bench_details
        timings[name] = {
            "work_s": float(
                sum(
                    t["grid_s"]
                    + t["shared_fits_s"]
                    + t["selection_s"]
                    + (0.0 if math.isnan(t["final_fit_s"]) else t["final_fit_s"])
                    + (0.0 if math.isnan(t["simulate_s"]) else t["simulate_s"])
                    for t in bench_timings.values()
                )
            ),
            "methods": bench_timings,
        }
    return rows, details, timings
