"""Run the benchmark: select each method's hyper-parameters, fit, simulate, report.

For every data set found (:mod:`~neckid.experiments.benchmark.datasets`) and every method
(:mod:`~neckid.experiments.benchmark.settings`), :func:`run_benchmark`

1. lists the method's candidates on that data set;
2. fits each on the first :data:`~neckid.experiments.benchmark.settings.SELECTION_FRACTION` of
   the training record and ranks them by free-run RMSE on the rest, or, given several training
   experiments, on held-out experiments (:func:`neckid.selection.score_candidates`); a candidate
   whose held-out free run is not finite or leaves the divergence envelope of the training
   outputs is out (its RMSE is infinite);
3. refits the best one on the whole training record and simulates every test record once, in free
   run (:func:`neckid.selection.free_run`, with the protocol's initial samples).
"""

from __future__ import annotations

import json
import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from sklearn.base import clone

from neckid._parallel import check_backend
from neckid.data.iodata import IOData, as_experiments
from neckid.datasets.benchmarks import BenchmarkData
from neckid.experiments.benchmark.datasets import BENCHMARKS, PROTOCOLS, load_benchmark
from neckid.experiments.benchmark.peers import peer_candidates, peer_unavailable
from neckid.experiments.benchmark.published import published_frame
from neckid.experiments.benchmark.settings import (
    BENCHMARK_METHODS,
    DEFAULT_METHODS,
    PEER_METHODS,
    SELECTION_FOLDS,
    SELECTION_FRACTION,
    Candidate,
    candidates,
    runs_on,
)
from neckid.metrics import fit_percent, rmse
from neckid.outputs import StagedFolder, output_folder
from neckid.registry import DEPRECATED_NAMES, get_method
from neckid.selection import free_run, score_candidates

__all__ = ["TABLE_COLUMNS", "BenchmarkReport", "run_benchmark"]

logger = logging.getLogger(__name__)

#: Columns of :attr:`BenchmarkReport.table`.
TABLE_COLUMNS = (
    "benchmark",
    "test",
    "method",
    "rmse",
    "rmse_unit",
    "fit_percent",
    "n_initial",
    "train_time_s",
    "simulate_time_s",
    "settings",
    "note",
)


# ---------------------------------------------------------------------------- the report
@dataclass(frozen=True)
class BenchmarkReport:
    """What :func:`run_benchmark` measured.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per (benchmark, test, method) with columns ``benchmark``, ``test``, ``method``
        (the registry name: ``"sm-linear"``), ``rmse`` (free run, in ``rmse_unit``),
        ``rmse_unit``, ``fit_percent`` (NRMSE fit), ``n_initial`` (initial samples skipped),
        ``train_time_s`` (selection and final fit), ``simulate_time_s``, ``settings`` (the chosen
        hyper-parameters) and ``note``. On the soft-neck logs a row with ``test == "mean"`` holds
        the mean over the validation logs.
    published : pandas.DataFrame
        The published figures next to which the table is read: ``benchmark``, ``test``,
        ``method``, ``rmse``, ``rmse_unit``, ``source``.
    details : dict
        JSON-serialisable extras: the command settings, the selection scores of every candidate,
        per benchmark the protocol text, and for the soft-neck logs the per-log difference
        ``fit(method) - fit(arx)`` (``"<method>_minus_arx"``).
    """

    table: pd.DataFrame
    published: pd.DataFrame
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The whole report as a JSON-serialisable dict (``table`` and ``published`` as records)."""
        return {
            "table": _records(self.table),
            "published": _records(self.published),
            "details": self.details,
        }

    def comparison(self) -> pd.DataFrame:
        """Our RMSE beside the published ones: one row per (benchmark, test, method)."""
        ours = self.table[["benchmark", "test", "method", "rmse", "rmse_unit"]].assign(
            source="neckid"
        )
        return pd.concat([ours, self.published], ignore_index=True)

    def write(self, output_dir: str | Path, *, force: bool = False) -> dict[str, Path]:
        """Write ``benchmark.csv``, ``published.csv`` and ``benchmark.json`` into a folder.

        The folder is locked while it is written and the files move in together
        (:func:`neckid.outputs.output_folder`); a folder that holds files already is refused
        unless ``force``.

        Returns
        -------
        dict of str to Path
            The files written, by kind (``"table"``, ``"published"``, ``"json"``).
        """
        with output_folder(output_dir, force=force) as staged:
            return self.write_into(staged)

    def write_into(self, staged: StagedFolder) -> dict[str, Path]:
        """Write the three files into a staged output folder; return their final paths."""
        names = {"table": "benchmark.csv", "published": "published.csv", "json": "benchmark.json"}
        self.table.to_csv(staged.path(names["table"]), index=False)
        self.published.to_csv(staged.path(names["published"]), index=False)
        staged.path(names["json"]).write_text(
            json.dumps(self.to_dict(), indent=2, default=_json_default)
        )
        return {kind: staged.final(name) for kind, name in names.items()}

    def rich_table(self) -> Any:
        """A :class:`rich.table.Table` of the results, for the CLI to print.

        One row per (data set, test, method), narrow enough for an 80-column terminal: the
        published figures are in :meth:`published_rich_table`, the wall times and settings in the
        written files.
        """
        from rich.markup import escape
        from rich.table import Table

        table = Table(title="neckid benchmark: free run (RMSE in each data set's unit)")
        table.add_column("data set / test", overflow="fold")
        table.add_column("method", no_wrap=True)
        table.add_column("RMSE", justify="right", no_wrap=True)
        table.add_column("fit [%]", justify="right", no_wrap=True)
        table.add_column("train [s]", justify="right", no_wrap=True)
        table.add_column("note", overflow="fold")
        previous = None
        for row in self.table.itertuples(index=False):
            where = f"{row.benchmark} / {row.test}"
            table.add_row(
                where if where != previous else "",
                str(row.method),
                _fmt(row.rmse, f" {row.rmse_unit!s}" if row.rmse_unit else ""),
                _fmt(row.fit_percent, digits=3),
                _fmt(row.train_time_s, digits=2),
                escape(str(row.note or "")),  # a note may hold brackets: neckid[peers]
                end_section=False,
            )
            previous = where
        return table

    def published_rich_table(self) -> Any:
        """The published free-run RMSE next to which the results are read (a rich table)."""
        from rich.table import Table

        table = Table(title="published free-run RMSE (same split)")
        for column in ("data set / test", "method", "RMSE"):
            table.add_column(column, overflow="fold")
        for row in self.published.itertuples(index=False):
            table.add_row(
                f"{row.benchmark} / {row.test}",
                str(row.method),
                _fmt(row.rmse, f" {row.rmse_unit}"),
            )
        return table


def _fmt(value: Any, suffix: str = "", digits: int = 4) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return f"{float(value):.{digits}g}{suffix}"


def _json_default(value: Any) -> Any:
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def _records(frame: pd.DataFrame) -> list[dict[str, Any]]:
    return [
        {
            str(k): (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in record.items()
        }
        for record in frame.to_dict(orient="records")
    ]


# ---------------------------------------------------------------------------- selection
@dataclass(frozen=True)
class _Sweep:
    """Where the candidates' fits run: ``n_jobs`` and ``backend`` of :func:`score_candidates`."""

    n_jobs: int | None = None
    backend: str | None = None

    def options(self) -> dict[str, Any]:
        """The keyword arguments of :func:`~neckid.selection.score_candidates`."""
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
    says the scheme and the worst fold's RMSE. ``sweep`` says where the fits run.
    """
    if not options:
        raise ValueError("the method has no candidate on this data set")
    if len(options) == 1:
        return options[0], []
    experiments = as_experiments(train, "train")
    if len(experiments) > 1:
        table = score_candidates(
            options,
            experiments,
            None,
            criteria=("simulation",),
            n_initial=n_initial,
            folds=SELECTION_FOLDS,
            **(sweep or _Sweep()).options(),
        )
    else:
        fit_part, check_part = experiments[0].split(SELECTION_FRACTION)
        table = score_candidates(
            options,
            fit_part,
            check_part,
            criteria=("simulation",),
            n_initial=n_initial,
            **(sweep or _Sweep()).options(),
        )
    values = table["rmse_simulation"].to_numpy(dtype=np.float64)
    worst = table["rmse_simulation_worst"].to_numpy(dtype=np.float64)
    scores: list[dict[str, Any]] = []
    for row, value, fold in zip(table.itertuples(index=False), values, worst, strict=True):
        score: dict[str, Any] = {"settings": str(row.name), "holdout_rmse": float(value)}
        if row.scheme != "validation":
            score.update(scheme=str(row.scheme), worst_fold_rmse=float(fold))
        if row.error:
            score["error"] = str(row.error)
        scores.append(score)
    if np.isinf(values).all():
        raise ValueError(f"every candidate failed or diverged on the held-out end: {scores}")
    return options[int(np.argmin(values))], scores


# ---------------------------------------------------------------------------- evaluation
def _first_non_finite(y: NDArray[np.float64], skip: int) -> int | None:
    """Index of the first non-finite simulated sample after ``skip``, or None."""
    bad = np.flatnonzero(~np.isfinite(y[skip:]).all(axis=1))
    return int(bad[0]) + skip if bad.size else None


def _first_runaway(model: Any, y: NDArray[np.float64], skip: int) -> int | None:
    """The first sample after ``skip`` that is not finite or leaves the model's envelope."""
    first = _first_non_finite(y, skip)
    away = model.first_runaway(y, skip) if hasattr(model, "first_runaway") else None
    if away is not None and (first is None or away[0] < first):
        first = away[0]
    return first


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


def _run_method(
    method: str, bench: BenchmarkData, quick: bool, seed: int, sweep: _Sweep | None = None
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Select, fit and simulate one method on one data set; return table rows and details."""
    start = time.perf_counter()
    if method in PEER_METHODS:
        options = peer_candidates(method, bench.name, quick)
    else:
        options = candidates(method, bench.name, bench.train, quick=quick, seed=seed)
    (settings, estimator), scores = _select(options, bench.train, bench.n_initial, sweep)
    model = clone(estimator).fit(bench.train)
    train_time = time.perf_counter() - start
    rows = []
    for test, record in bench.tests.items():
        t0 = time.perf_counter()
        y, skip = free_run(model, record, bench.n_initial, diverged="keep")
        sim_time = time.perf_counter() - t0
        diverged = _first_runaway(model, y, skip)
        if diverged is None:
            error = float(rmse(record.y, y, skip=skip)[0]) * bench.rmse_scale
            fit = float(fit_percent(record.y, y, skip=skip)[0])
            note = ""
        else:
            error, fit = math.inf, -math.inf
            note = (
                f"free run diverged at sample {diverged} (not finite, or beyond the training"
                " outputs' divergence envelope)"
            )
        rows.append(
            _row(
                bench,
                test,
                method,
                rmse=error,
                fit_percent=fit,
                n_initial=skip,
                train_time_s=train_time,
                simulate_time_s=sim_time,
                settings=settings,
                note=note,
            )
        )
    return rows, {"selection": scores, "chosen": settings}


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
        :data:`~neckid.experiments.benchmark.settings.BENCHMARK_METHODS`: ``"arx"``, ``"sm"``,
        ``"sm-linear"``, ``"sm-parallel"``, ``"sm-parallel-poly"``, ``"poly"``, ``"nn"``,
        ``"scheduled"`` (the scheduled model runs on the soft-neck logs only, the polynomial ones
        on the public benchmarks only: ``ONLY_ON``), and the peer ``"sysidentpy-frols"``
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
        Parallel workers (joblib) over the hyper-parameter candidates and folds of a method;
        ``None`` means 1 unless inside a ``joblib.parallel_config`` context, or every worker of
        the cluster with ``backend="dask"``.
    backend : str or None, default None
        The joblib backend the candidates are fitted on: ``None`` is the active
        ``joblib.parallel_config`` (joblib's default outside one); ``"dask"`` the cluster of
        the active ``distributed.Client`` (``pip install neckid[dask]``). The report is the
        same as a run on this machine but for the wall times.

    Returns
    -------
    BenchmarkReport
        The table (free-run RMSE in each benchmark's unit, NRMSE fit, wall times), the published
        figures, and details.

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
    Protocols: see ``docs/benchmarks.md``. RMSE and fit skip the protocol's initial samples
    (Silverbox: 50) or, where the protocol gives none, the model's own ``max_lag_`` samples.
    Hyper-parameters are chosen on the training record only; test records are simulated once.
    Wall times are measured with :func:`time.perf_counter` on whatever machine runs this; they
    include the hyper-parameter selection.
    """
    check_backend(backend)  # before the output folder is locked and any data is read
    arguments = (data_dir, methods, benchmarks, quick, seed, errors, _Sweep(n_jobs, backend))
    if output_dir is None:
        return _run(*arguments)
    with output_folder(output_dir, force=force) as staged:
        report = _run(*arguments)
        report.write_into(staged)
    return report


def _run(
    data_dir: str | Path,
    methods: str | Sequence[str] | None,
    benchmarks: Sequence[str] | None,
    quick: bool,
    seed: int,
    errors: Literal["record", "raise"],
    sweep: _Sweep,
) -> BenchmarkReport:
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

    rows: list[dict[str, Any]] = []
    details: dict[str, Any] = {
        "settings": {
            "data_dir": str(root),
            "methods": names,
            "quick": quick,
            "seed": seed,
            "selection_fraction": SELECTION_FRACTION,
        },
        "missing": [],
        "benchmarks": {},
    }
    ran: list[str] = []
    # Every data set is read before any method runs: a file that cannot be read (a missing
    # optional reader, a damaged file) stops the run at once, not after an hour of fits.
    loaded = {name: load_benchmark(name, root, quick=quick) for name in datasets}
    if all(bench is None for bench in loaded.values()):
        raise FileNotFoundError(
            f"nothing to run: none of the data sets {', '.join(datasets)} is under {root} (it"
            " should hold softneck/ and benchmarks/NAME/; see docs/benchmarks.md)"
        )
    for name in datasets:
        bench = loaded[name]
        if bench is None:
            details["missing"].append(name)
            continue
        ran.append(name)
        n_train = sum(r.n_samples for r in as_experiments(bench.train, "train"))
        bench_details: dict[str, Any] = {
            "description": bench.description,
            "citation": bench.citation,
            "n_train": n_train,
            "tests": {k: v.n_samples for k, v in bench.tests.items()},
            "methods": {},
        }
        bench_rows: list[dict[str, Any]] = []
        for method in names:
            if not runs_on(method, name):
                continue
            skipped = peer_unavailable(method) if method in PEER_METHODS else None
            if skipped is not None:  # a peer that is not installed: say so in its rows
                bench_rows.extend(_row(bench, test, method, note=skipped) for test in bench.tests)
                bench_details["methods"][method] = {"skipped": skipped}
                continue
            logger.info("benchmark %s: %s (%d training samples)", name, method, n_train)
            try:
                method_rows, method_details = _run_method(method, bench, quick, seed, sweep)
            except Exception as exc:  # a failing method must not stop the others
                if errors == "raise":
                    raise
                logger.warning("%s on %s failed: %s", method, name, exc, exc_info=True)
                note = f"failed: {type(exc).__name__}: {exc}"
                method_rows = [_row(bench, test, method, note=note) for test in bench.tests]
                method_details = {"error": f"{type(exc).__name__}: {exc}"}
            bench_rows.extend(method_rows)
            bench_details["methods"][method] = method_details
        finished = [r for r in bench_rows if not math.isnan(r["fit_percent"])]
        if PROTOCOLS[name].mean_over_tests and finished:
            summary, margins = _mean_over_tests(bench, finished)
            bench_rows.extend(summary)
            bench_details.update(margins)
        rows.extend(bench_rows)
        details["benchmarks"][name] = bench_details
    report = BenchmarkReport(
        table=pd.DataFrame(rows, columns=list(TABLE_COLUMNS)),
        published=published_frame(ran),
        details=details,
    )
    return report
