"""The benchmark's work units: what runs on a worker, and what comes back.

Three kinds of unit, each a module-level function with picklable arguments (estimators, records,
the polynomial states it may reuse) that never raises (an error comes back in its
:class:`Outcome`) and measures its own seconds of work:

- :func:`fit_unit`: one fit that several candidates share (the polynomial that ``poly`` refits
  and ``sm-parallel-poly`` runs in parallel), done once before them;
- :func:`score_unit`: one candidate ranked on the training data, exactly as
  :func:`neckid.selection.lags.score_candidates` ranks it among the others (its own fits and folds);
- :func:`final_unit`: the chosen candidate refitted on the whole training data, and the free run
  of every test record.

Every unit runs its fits under a :class:`~neckid.experiments.benchmark.shared.RecordingCache`:
a polynomial fitted by an earlier unit (in any process) is taken from it, and the states it fits
come back for the later units. Every unit runs with one BLAS thread (``threadpoolctl``), as a
joblib worker on two cores does anyway: a multi-threaded BLAS sums in another order, and a
polynomial fitted for simulation on 65,000 rows carries that difference to the 9th digit, so
the table would depend on where a unit ran (the limit is per process: units on joblib's
``threading`` backend share it). The runner
(:mod:`~neckid.experiments.benchmark.runner`) hands the units of a stage to joblib, longest
first.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from sklearn.base import clone
from threadpoolctl import threadpool_limits

from neckid.data.iodata import IOData, as_experiments
from neckid.datasets.benchmarks import BenchmarkData
from neckid.experiments.benchmark.shared import PolynomialEntry, RecordingCache
from neckid.metrics import fit_percent, rmse
from neckid.models.cache import use_caches
from neckid.selection.lags import free_run, score_candidates

__all__ = ["FinalRun", "Outcome", "TestRun", "final_unit", "fit_unit", "score_unit"]


@dataclass(frozen=True)
class Outcome:
    """What a unit returns.

    Attributes
    ----------
    value : object
        The fitted model (:func:`fit_unit`), the candidate's score row (:func:`score_unit`) or a
        :class:`FinalRun` (:func:`final_unit`); ``None`` when it failed.
    error : Exception or None
        What stopped it.
    seconds : float
        Wall seconds of the unit on its worker (its seconds of work).
    polynomial_fits : tuple of (bytes, object)
        The ``polynomial_fits`` states it computed (not those it reused).
    cpu_seconds : float
        CPU seconds of the worker's process during the unit (all its threads): unlike
        ``seconds``, not stretched when other work shares the machine.
    """

    value: Any = None
    error: Exception | None = None
    seconds: float = 0.0
    polynomial_fits: tuple[PolynomialEntry, ...] = ()
    cpu_seconds: float = 0.0


@dataclass(frozen=True)
class TestRun:
    """The free run of one test record by the final model."""

    test: str
    rmse: float
    fit_percent: float
    n_initial: int
    simulate_time_s: float
    diverged_at: int | None


@dataclass(frozen=True)
class FinalRun:
    """The chosen candidate fitted on the whole training data and run on every test record.

    ``model`` is the fitted model when the unit was asked to keep it, else ``None``.
    """

    model: Any
    fit_time_s: float
    tests: tuple[TestRun, ...]


def _recorded(work: Callable[[], Any], known: Iterable[PolynomialEntry]) -> Outcome:
    """Run ``work()`` with the known polynomial states; never raises."""
    cache = RecordingCache(known)
    start, cpu = time.perf_counter(), time.process_time()
    value, error = None, None
    try:
        with use_caches(polynomial_fits=cache), threadpool_limits(limits=1, user_api="blas"):
            value = work()
    except Exception as exc:  # a failing unit must not stop the others
        error = exc
    seconds = time.perf_counter() - start
    return Outcome(value, error, seconds, tuple(cache.added), time.process_time() - cpu)


def fit_unit(
    estimator: Any, data: IOData | Sequence[IOData], known: Sequence[PolynomialEntry] = ()
) -> Outcome:
    """``clone(estimator).fit(data)``: a fit that several candidates share."""

    def work() -> Any:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return clone(estimator).fit(data)

    return _recorded(work, known)


def score_unit(
    name: str,
    estimator: Any,
    train: IOData | Sequence[IOData],
    n_initial: int | None,
    *,
    fraction: float,
    folds: int | None,
    known: Sequence[PolynomialEntry] = (),
) -> Outcome:
    """One candidate's selection row: free-run RMSE on held-out training data.

    One training record: fitted on its first ``fraction``, scored on the rest. Several
    experiments: scored on held-out experiments (``folds``, see
    :func:`~neckid.selection.lags.score_candidates`). The row is the candidate's row of
    :func:`~neckid.selection.lags.score_candidates` over the whole grid (each candidate's fits and
    scores are independent of the others').
    """

    def work() -> dict[str, Any]:
        experiments = as_experiments(train, "train")
        options = [(name, estimator)]
        common: dict[str, Any] = {"criteria": ("simulation",), "n_initial": n_initial, "n_jobs": 1}
        if len(experiments) > 1:
            table = score_candidates(options, experiments, None, folds=folds, **common).table
        else:
            fit_part, check_part = experiments[0].split(fraction)
            table = score_candidates(options, fit_part, check_part, **common).table
        row = table.iloc[0]
        return {
            "name": str(row["name"]),
            "rmse_simulation": float(row["rmse_simulation"]),
            "rmse_simulation_worst": float(row["rmse_simulation_worst"]),
            "scheme": str(row["scheme"]),
            "error": str(row["error"]),
            "fit_time_s": float(row["fit_time_s"]),
        }

    return _recorded(work, known)


def first_runaway(
    model: Any, y: NDArray[np.float64], skip: int, record: IOData | None = None
) -> int | None:
    """The first sample after ``skip`` that is not finite or leaves the model's envelope.

    With ``record`` (the log the run read), the envelope widens with how far its inputs reach
    beyond the training ranges (:meth:`~neckid.models.base.Estimator.divergence_envelope`).
    """
    bad = np.flatnonzero(~np.isfinite(y[skip:]).all(axis=1))
    first = int(bad[0]) + skip if bad.size else None
    away = model.first_runaway(y, skip, record) if hasattr(model, "first_runaway") else None
    if away is not None and (first is None or away[0] < first):
        first = away[0]
    return first


def _test_run(model: Any, bench: BenchmarkData, test: str, record: IOData) -> TestRun:
    start = time.perf_counter()
    y, skip = free_run(model, record, bench.n_initial, diverged="keep")
    seconds = time.perf_counter() - start
    diverged = first_runaway(model, y, skip, record)
    if diverged is None:
        error = float(rmse(record.y, y, skip=skip)[0]) * bench.rmse_scale
        fit = float(fit_percent(record.y, y, skip=skip)[0])
    else:
        error, fit = math.inf, -math.inf
    return TestRun(test, error, fit, skip, seconds, diverged)


def final_unit(
    estimator: Any,
    bench: BenchmarkData,
    known: Sequence[PolynomialEntry] = (),
    *,
    keep_model: bool = False,
) -> Outcome:
    """The candidate fitted on the whole training data, then the free run of every test record.

    Warnings of the fit are not silenced (as in a run of one method at a time); the free runs
    are those of :func:`neckid.selection.lags.free_run` with the protocol's initial samples. The
    fitted model comes back only with ``keep_model`` (another grid reads it).
    """

    def work() -> FinalRun:
        start = time.perf_counter()
        model = clone(estimator).fit(bench.train)
        fitted = time.perf_counter() - start
        runs = tuple(_test_run(model, bench, test, record) for test, record in bench.tests.items())
        return FinalRun(model if keep_model else None, fitted, runs)

    return _recorded(work, known)
