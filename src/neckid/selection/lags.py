"""Choosing the regressor: validation search over lag sets, and the Lipschitz order index.

Two complementary tools:

- :func:`select_lags` trains a copy of any estimator (NeuralNARX, SetMembership, LinearARX, ...)
  on every candidate lag set and ranks them by one-step or free-run fit on a validation record, as
  the seed paper chose its network's regressor, or, given no validation record, by how well a
  model fitted on the other experiments fits each held-out one (leave-one-experiment-out, k
  folds of experiments, or 3 time blocks of a single record). The scoring itself is
  :func:`score_candidates` (any list of named estimators, also what the benchmark ranks its
  candidates with), and a free run with a protocol's initial samples is :func:`free_run`.
- :func:`lipschitz_quotients` (in :mod:`neckid.selection.lipschitz`, re-exported here) computes He
  & Asada's order index from the data alone, no model needed.

The choice among the scored candidates follows the safe rule of :mod:`neckid.data.folds`.
"""

from __future__ import annotations

import itertools
import math
import time
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
import pandas as pd
from joblib import delayed
from sklearn.base import clone

from neckid.data.folds import (
    FoldPlan,
    Ranking,
    fold_records,
    holdout_plan,
    rank_candidates,
    refuse_resting_runs,
)
from neckid.data.iodata import IOData, as_experiments
from neckid.metrics import fit_percent, rmse
from neckid.models.adapted import adapted_outputs
from neckid.models.base import DivergenceError, ExtrapolationWarning, check_is_fitted
from neckid.registry import get_method
from neckid.regressors import Lags
from neckid.selection.baselines import baseline_candidates, baseline_warnings
from neckid.selection.lipschitz import lipschitz_quotients
from neckid.selection.work import progress_label, progress_units
from neckid.utils.parallel import check_backend, run_jobs
from neckid.utils.types import FloatArray

__all__ = [
    "CandidateScores",
    "LagSelection",
    "free_run",
    "lag_grid",
    "lipschitz_quotients",
    "score_candidates",
    "score_plan",
    "select_lags",
]

Criterion = Literal["prediction", "simulation"]
#: How candidates were scored: on the validation records given, or on held-out experiments.
Scheme = Literal[
    "validation",
    "leave-one-experiment-out",
    "experiments × time-blocks",
    "grouped-k-fold",
    "time-blocks",
    "time-blocks of one period",
]
#: How :func:`select_lags` picks: the safe rule of :mod:`neckid.data.folds` (the paired one
#: standard error), the unpaired rule of earlier versions, or the top mean fit.
Rule = Literal["safe", "unpaired", "best"]

#: The rule of :func:`neckid.data.folds.rank_candidates` each :data:`Rule` applies.
RULE_OF = {"safe": "paired", "unpaired": "unpaired", "best": "best"}


# ---------------------------------------------------------------------- candidates
def _orders(values: int | Iterable[int], argument: str, minimum: int) -> list[int]:
    if isinstance(values, bool):
        raise TypeError(f"{argument} must be an int or a list of ints; got {values!r}")
    items = [values] if isinstance(values, int | np.integer) else list(values)
    if not items:
        raise ValueError(f"{argument} is empty; give at least one value")
    out = []
    for v in items:
        if isinstance(v, bool) or not isinstance(v, int | np.integer):
            raise TypeError(f"{argument} must hold ints; got {v!r} in {items!r}")
        if v < minimum:
            raise ValueError(f"{argument} must hold values >= {minimum}; got {v} in {items!r}")
        out.append(int(v))
    return sorted(set(out))


def lag_grid(
    output_orders: int | Iterable[int],
    input_orders: int | Iterable[int],
    input_delays: int | Iterable[int] = 1,
) -> list[Lags]:
    """All ARX-type lag sets ``Lags.arx(na, nb, delay)`` over a grid of orders and delays.

    Parameters
    ----------
    output_orders : int or iterable of int
        Output orders ``na`` (lags ``1..na`` of every output), each >= 0.
    input_orders : int or iterable of int
        Input orders ``nb`` (lags ``delay..delay+nb-1`` of every input), each >= 0.
    input_delays : int or iterable of int, default 1
        Input delays (dead time, in samples), each >= 0.

    Returns
    -------
    list of Lags
        One per combination, in the order output order, input order, delay; combinations with no
        term (``na = nb = 0``) are left out, and with ``nb = 0`` the delay is irrelevant so only
        one such candidate per ``na`` is kept.

    Raises
    ------
    ValueError
        If an order or delay is negative or a list is empty.

    Examples
    --------
    >>> lag_grid([1, 2], [1], input_delays=[0, 1])
    [Lags(outputs=[1], inputs=[0]), Lags(outputs=[1], inputs=[1]), Lags(outputs=[1, 2], inputs=[0]), Lags(outputs=[1, 2], inputs=[1])]
    """
    nas = _orders(output_orders, "output_orders", 0)
    nbs = _orders(input_orders, "input_orders", 0)
    delays = _orders(input_delays, "input_delays", 0)
    grid: list[Lags] = []
    for na, nb in itertools.product(nas, nbs):
        if na == 0 and nb == 0:
            continue
        for delay in delays[:1] if nb == 0 else delays:
            grid.append(Lags.arx(na=na, nb=nb, delay=delay))
    if not grid:
        raise ValueError(
            "lag_grid has no candidate: output_orders and input_orders are both only 0"
        )
    return grid


# ---------------------------------------------------------------------- select_lags
@dataclass(frozen=True)
class LagSelection:
    """The result of :func:`select_lags`.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per candidate, best first. Columns: ``candidate`` (position in the list given),
        ``lags`` (repr), ``n_terms``, ``max_lag``, ``fit_prediction`` and ``fit_simulation`` (mean
        NRMSE fit in % over outputs and validation records, then over folds; ``-inf`` for a
        failed candidate), ``fit_prediction_worst`` and ``fit_simulation_worst`` (the fit of the
        worst fold), ``fit_prediction[<output>]`` / ``fit_simulation[<output>]`` per output (mean
        over folds), ``fit_<criterion>_se`` (the standard error of the mean over folds),
        ``fit_<criterion>_diff`` and ``fit_<criterion>_diff_se`` (the mean per-fold difference
        to the best candidate and its standard error: what the paired rule reads),
        ``fit_<criterion>_folds`` (each fold's fit),
        ``fit_time_s`` (seconds to train, summed over folds), ``score_time_s`` (seconds to
        score), ``scheme``, ``n_folds``, ``error`` (empty, or the error of a failed candidate), ``status`` (``"chosen"``, ``"accepted"``
        or ``"rejected"``) and ``reason`` (why rejected: it failed, or its free run diverged, in
        a fold).
    candidates : tuple of Lags
        The candidates, in the order given (``table.candidate`` indexes into it).
    criterion : {"prediction", "simulation"}
        The column the table is sorted by (``fit_<criterion>``).
    scheme : {"validation", "leave-one-experiment-out", "grouped-k-fold", "time-blocks"}
        How the fits were measured (see :func:`score_candidates`); with ``"validation"`` there
        is one fold, so the worst-fold fit equals the mean; ``"time-blocks"``: one record cut
        into contiguous blocks, each held out once.
    chosen : int or None
        The candidate the rule chose (its position in :attr:`candidates`); ``None`` when every
        candidate was rejected.
    rule : {"safe", "unpaired", "best"}
        The rule :attr:`best_lags` follows.
    folds : list of list of str
        The held-out records of each fold.
    ranking : Ranking or None
        What :func:`neckid.data.folds.rank_candidates` chose and why (indices are positions in
        :attr:`candidates`); ``None`` when every candidate was rejected.
    baselines : dict of str to float
        The naive references scored on the same folds (:mod:`neckid.selection.baselines`):
        name -> mean fold fit [%]; a reference that does not apply is left out.
    """

    table: pd.DataFrame
    candidates: tuple[Lags, ...]
    criterion: Criterion
    scheme: Scheme = "validation"
    chosen: int | None = None
    rule: Rule = "best"
    folds: list[list[str]] = field(default_factory=list)
    ranking: Ranking | None = None
    baselines: dict[str, float] = field(default_factory=dict)
    column: str = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "column", f"fit_{self.criterion}")

    @property
    def best_lags(self) -> Lags:
        """The lag set the rule chose.

        With ``rule="safe"``: the fewest regressor terms among the candidates that never failed
        nor diverged and whose mean difference to the best, fold by fold, is within one
        standard error of that difference (:func:`neckid.data.folds.rank_candidates`);
        ``rule="unpaired"``: within one standard error of the best mean; ``rule="best"``: the
        first row of :attr:`table`.
        """
        if self.rule != "best":
            if self.chosen is None:
                raise ValueError(
                    "every candidate was rejected (failed or diverged in a fold); see the"
                    f" 'reason' column of the table: {self.table['reason'].iloc[0]}"
                )
            return self.candidates[self.chosen]
        return self.best()

    @property
    def warnings(self) -> list[str]:
        """One line when the chosen lag set fits below 0 % or below a baseline on the folds."""
        if self.chosen is None:
            return []
        row = self.table[self.table["candidate"] == self.chosen].iloc[0]
        return baseline_warnings(str(row["lags"]), float(row[self.column]), self.baselines)

    def explain(self, names: Sequence[str] | None = None) -> str:
        """The best, the chosen, the rule and the bar in one sentence ('' when none chosen).

        ``names``: how to call each candidate (default its ``repr``).
        """
        if self.ranking is None:
            return ""
        return self.ranking.explain(names or [repr(c) for c in self.candidates])

    def best(self, tolerance: float = 0.0) -> Lags:
        """The most parsimonious lag set whose fit is within ``tolerance`` points of the best.

        Parameters
        ----------
        tolerance : float, default 0.0
            Percentage points of fit given up for fewer regressor terms. 0 returns the top row.

        Returns
        -------
        Lags

        Raises
        ------
        ValueError
            If ``tolerance`` is negative, or every candidate failed.
        """
        if not math.isfinite(tolerance) or tolerance < 0:
            raise ValueError(f"tolerance must be a finite number >= 0; got {tolerance!r}")
        fits = self.table[self.column].to_numpy(dtype=np.float64)
        if not np.isfinite(fits).any():
            raise ValueError(
                "every candidate failed; see the 'error' column of the table:"
                f" {self.table['error'].iloc[0]}"
            )
        top = float(np.nanmax(fits))
        close = self.table[fits >= top - tolerance]
        if tolerance == 0.0:
            row = close.iloc[0]
        else:
            row = close.sort_values(
                ["n_terms", self.column], ascending=[True, False], kind="mergesort"
            ).iloc[0]
        return self.candidates[int(row["candidate"])]


@dataclass(frozen=True)
class CandidateScores:
    """The result of :func:`score_candidates`: every candidate on the same folds.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per candidate, in the order given (see :func:`score_candidates`).
    fold_fits : dict of str to ndarray
        ``"fit_<criterion>"`` -> ``(n_candidates, n_folds)``: each candidate's fit [%] on each
        fold (``-inf`` where it failed or diverged).
    folds : list of list of str
        The held-out records of each fold, by name.
    scheme : str
        How the folds were made (``"validation"``, ``"leave-one-experiment-out"``,
        ``"grouped-k-fold"``, ``"experiments × time-blocks"``, ``"time-blocks"``).
    """

    table: pd.DataFrame
    fold_fits: dict[str, FloatArray]
    folds: list[list[str]]
    scheme: str


def free_run(
    model: Any,
    record: IOData,
    n_initial: int | None = None,
    *,
    diverged: Literal["raise", "keep"] = "raise",
    adapt: tuple[float, str] | None = None,
) -> tuple[FloatArray, int]:
    """Free-run simulation of ``record`` by a fitted ``model``, with a protocol's initial samples.

    Parameters
    ----------
    model : fitted estimator
        Any neckid model: ``max_lag_`` (the initial samples of a free run) and ``simulate(data)``.
    record : IOData
        Inputs and measured outputs.
    n_initial : int, optional
        Measured samples a benchmark protocol hands the model as initial conditions (Silverbox:
        50). The simulation then starts at sample ``n_initial − max_lag_``, so that its initial
        conditions are the last ``max_lag_`` of them, and a figure of merit starts at
        ``n_initial``. ``None`` (or fewer than ``max_lag_``): the first ``max_lag_`` measured
        samples are the initial conditions.
    diverged : {"raise", "keep"}, default "raise"
        When the run leaves the finite numbers: raise the model's ``DivergenceError``, or return
        the run as it is, non-finite from there (a benchmark that reports where it diverged).
    adapt : (float, str), optional
        ``(seconds, mode)``: a copy of the model first adapts on the record's first ``seconds``
        (:func:`~neckid.models.online.adaptive_free_run`, ``mode`` ``"offset"``, ``"update"``
        or ``"both"``), then runs free from there; ``skip`` is then the warm-up's samples, so a
        figure of merit counts only what the adaptation had not read.

    Returns
    -------
    y : ndarray, shape (n_samples, n_outputs)
        The measured outputs before the simulation starts, the simulated ones from there on (a
        free run, never a one-step prediction).
    skip : int
        Samples a figure of merit leaves out: ``n_initial``, or ``max_lag_``.

    Raises
    ------
    NotFittedError
        If ``model`` is not fitted.
    DivergenceError
        If the run diverges and ``diverged="raise"``.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> u = np.sin(np.arange(200) / 5.0)
    >>> y = np.zeros(200)
    >>> for t in range(1, 200):
    ...     y[t] = 0.5 * y[t - 1] + u[t - 1]
    >>> data = IOData(u, y, ts=0.1)
    >>> model = LinearARX(Lags.arx(1, 1, 1)).fit(data)
    >>> simulated, skip = free_run(model, data, n_initial=50)
    >>> skip, bool(np.allclose(simulated[skip:, 0], y[skip:]))
    (50, True)
    """
    if diverged not in ("raise", "keep"):
        raise ValueError(f"diverged must be 'raise' or 'keep'; got {diverged!r}")
    check_is_fitted(model)
    if adapt is not None:
        return adapted_outputs(model, record, *adapt, diverged=diverged)
    lag = int(model.max_lag_)
    if n_initial is None or n_initial < lag:
        start, skip = 0, lag
    else:
        start, skip = int(n_initial) - lag, int(n_initial)
    try:
        with warnings.catch_warnings():
            # The share outside the training range stays in result.extras; scores say the rest.
            warnings.simplefilter("ignore", ExtrapolationWarning)
            result = model.simulate(record[start:] if start else record)
    except DivergenceError as exc:
        if diverged == "raise":
            raise
        result = exc.result
    y = np.array(record.y, dtype=np.float64)
    y[start:] = result.y
    return y, skip


def _fit_and_score(
    name: str,
    estimator: Any,
    train: Sequence[IOData],
    groups: Sequence[Sequence[IOData]],
    criteria: Sequence[Criterion],
    n_initial: int | None,
    adapt: tuple[float, str] | None = None,
) -> list[dict[str, Any]]:
    """Fit a clone once and score it on every fold of ``groups``; one row per fold.

    Never raises (a failure becomes the ``error`` entry of every fold it stopped).
    """
    output_names = groups[0][0].output_names
    start = time.perf_counter()
    try:
        model = clone(estimator)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model.fit(list(train) if len(train) > 1 else train[0])
    except Exception as exc:  # a failing candidate must not stop the search
        error, spent = f"{type(exc).__name__}: {exc}", time.perf_counter() - start
        return [{"name": name, "fit_time_s": spent, "error": error} for _ in groups]
    spent = time.perf_counter() - start
    rows = []
    for j, validation in enumerate(groups):
        # the fit's time is counted once, on the split's first fold
        row: dict[str, Any] = {"name": name, "fit_time_s": spent if j == 0 else 0.0}
        scoring = time.perf_counter()
        try:
            with np.errstate(all="ignore"):
                for kind in criteria:
                    fits, errors = [], []
                    for record in validation:
                        if kind == "prediction":
                            result = model.predict(record)
                            y, skip = result.y, max(result.n_initial, n_initial or 0)
                        else:
                            y, skip = free_run(model, record, n_initial, adapt=adapt)
                        fits.append(fit_percent(record.y, y, skip=skip))
                        errors.append(rmse(record.y, y, skip=skip))
                    for label, values in (("fit", fits), ("rmse", errors)):
                        per_output = np.mean(values, axis=0)
                        for channel, value in zip(output_names, per_output, strict=True):
                            row[f"{label}_{kind}[{channel}]"] = float(value)
                        row[f"{label}_{kind}"] = float(np.mean(per_output))
        except Exception as exc:  # a diverged or failing run is this fold's score
            row["error"] = f"{type(exc).__name__}: {exc}"
        row["score_time_s"] = time.perf_counter() - scoring
        rows.append(row)
    return rows


def _combine_folds(
    folds: list[dict[str, Any]], kinds: Sequence[Criterion], output_names: Sequence[str]
) -> dict[str, Any]:
    """One candidate's row from its rows per fold: the mean and the worst fold of every score."""
    row: dict[str, Any] = {
        "name": folds[0]["name"],
        "fit_time_s": float(sum(f.get("fit_time_s", np.nan) for f in folds)),
        "score_time_s": float(sum(f.get("score_time_s", 0.0) for f in folds)),
    }
    for kind in kinds:
        for label, missing, worst in (("fit", -np.inf, np.min), ("rmse", np.inf, np.max)):
            for name in (f"{label}_{kind}", *(f"{label}_{kind}[{n}]" for n in output_names)):
                values = np.array([f.get(name, missing) for f in folds], dtype=np.float64)
                row[name] = float(np.mean(values))
                if name == f"{label}_{kind}":
                    row[f"{name}_worst"] = float(worst(values))
    errors = [(j, f["error"]) for j, f in enumerate(folds) if f.get("error")]
    if errors and len(errors) == len(folds) > 1 and len({e for _, e in errors}) == 1:
        row["error"] = f"every fold: {errors[0][1]}"  # a failed fit: said once
    elif errors:
        row["error"] = (
            errors[0][1] if len(folds) == 1 else "; ".join(f"fold {j}: {e}" for j, e in errors)
        )
    return row


def score_candidates(
    candidates: Sequence[tuple[str, Any]],
    train: IOData | Sequence[IOData],
    validation: IOData | Sequence[IOData] | None = None,
    *,
    criteria: Sequence[Criterion] = ("prediction", "simulation"),
    n_initial: int | None = None,
    n_jobs: int | None = None,
    progress: bool = False,
    folds: int | None = None,
    backend: str | None = None,
    blocks_per_log: int | None = 1,
    adapt: tuple[float, str] | None = None,
) -> CandidateScores:
    """Fit a copy of every candidate estimator and score it on held-out records.

    Each estimator is copied with ``sklearn.base.clone`` (the ones given are not changed), fitted
    and scored on held-out records, per criterion: one-step-ahead prediction (``"prediction"``)
    and free-run simulation (``"simulation"``, :func:`free_run`), by the NRMSE fit
    ``100 (1 − ||y − ŷ|| / ||y − mean(y)||)`` and the RMSE, each per output, skipping
    ``n_initial`` or the candidate's ``max_lag_`` initial samples, averaged over the held-out
    records of a fold (and, for the overall columns, over the outputs), then over the folds.

    Two schemes:

    - ``validation`` given (``scheme == "validation"``): one fold, fitted on ``train`` and scored
      on ``validation``.
    - ``validation`` is None and ``train`` a list of ``n >= 2`` experiments: fold ``j`` of ``k``
      holds out the experiments ``i`` with ``i mod k == j`` and fits on the others. ``k = n``
      by default (``"leave-one-experiment-out"``), ``folds=k`` otherwise (``"grouped-k-fold"``).
      A model is scored on whole experiments it has not seen, so the score says how a setting
      carries over to another run (payload, controller, tendon slack), which the tail of one
      record does not. With ``blocks_per_log`` other than 1 (and ``folds=None``), every
      held-out experiment is scored in contiguous time blocks, one fold each, by the model
      fitted on the other experiments (``"experiments × time-blocks"``,
      :func:`neckid.data.folds.fold_plan`; ``None``: enough blocks for 6 folds).

    Parameters
    ----------
    candidates : sequence of (str, estimator)
        A name for the table and an unfitted estimator, per candidate.
    train : IOData or list of IOData
        Training records (with ``validation=None``, the experiments the folds are made of).
    validation : IOData, list of IOData or None, default None
        Validation records, with the channels of ``train``; ``None`` scores on held-out
        experiments of ``train``.
    criteria : sequence of {"prediction", "simulation"}, default both
        What to score, in this order (prediction first: an unstable model keeps its one-step
        scores).
    n_initial : int, optional
        Initial samples of the validation protocol (see :func:`free_run`); default the
        candidate's own ``max_lag_``.
    n_jobs : int or None, default None
        Parallel workers (joblib) over candidates and folds; ``None`` means 1 unless inside a
        ``joblib.parallel_config`` context, or every worker of the cluster with
        ``backend="dask"``; -1 means all cores.
    progress : bool, default False
        Show a rich progress bar (on standard error).
    folds : int or None, default None
        With ``validation=None``: the number of folds ``k`` in ``[2, n]``; ``None`` is one fold
        per experiment. Must be None when ``validation`` is given.
    backend : str or None, default None
        The joblib backend the fits run on: ``None`` is the active ``joblib.parallel_config``
        (joblib's default outside one), ``"dask"`` the cluster of the active
        ``distributed.Client`` (``pip install neckid[dask]``), or any joblib backend name.
    blocks_per_log : int or None, default 1
        Time blocks each held-out experiment is scored in (see above); ``None``: the rule of
        :func:`neckid.data.folds.blocks_per_log`.
    adapt : (float, str), optional
        ``(seconds, mode)``: score each held-out record's free run after ``seconds`` of
        adaptation on its own start (:func:`free_run`), as ``compare --adapt`` runs the test logs.

    Returns
    -------
    CandidateScores
        ``table``: one row per candidate, in the order given: ``candidate`` (position), ``name``, then per
        criterion ``fit_<kind>``, ``fit_<kind>_worst`` (the worst fold's fit), ``rmse_<kind>``,
        ``rmse_<kind>_worst`` (the worst fold's RMSE), ``fit_<kind>[<output>]``,
        ``rmse_<kind>[<output>]`` (means over folds), and ``fit_time_s`` (seconds to train,
        summed over folds), ``score_time_s`` (seconds to score, summed), ``scheme``, ``n_folds``
        and ``error`` (empty, or the error of a
        failed candidate, per fold). A candidate that fails in a fold (a training error, a free
        run that diverges) has fit ``-inf`` and RMSE ``inf`` for every score not computed there,
        so its mean and worst fold are ``-inf`` / ``inf`` too. ``folds``: the names of the
        held-out records per fold; ``fold_fits["fit_<kind>"]``: every candidate's fit on every
        fold, ``(n_candidates, n_folds)``, the same folds for all (what the paired rule needs).

    Raises
    ------
    TypeError
        If a candidate is not a ``(name, estimator)`` pair, or ``folds`` is not an int.
    ValueError
        If a criterion is unknown, ``n_initial`` is negative, the records do not share
        channels, ``validation`` is None and ``train`` holds fewer than 2 experiments, or
        ``folds`` is out of range or given with ``validation``, ``backend`` is unknown, or
        ``backend="dask"`` and no ``distributed.Client`` is active.
    ImportError
        If ``backend="dask"`` and the ``distributed`` package is not installed.

    Notes
    -----
    Warnings raised while fitting (e.g. convergence warnings) are silenced. The folds are
    deterministic (no shuffling): order the experiments so that every fold mixes the conditions
    you care about, or use leave-one-experiment-out.

    Every fit is an independent unit (the estimator, the records and the settings, pickled to
    the worker; a seed travels in the estimator's parameters), and the rows come back in the
    order of the candidates, whichever finishes first: on any backend, a Dask cluster included,
    the scores are those of a run on this machine (``fit_time_s`` aside, a wall time).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, methods
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=400)
    >>> y = np.zeros(400)
    >>> for t in range(2, 400):
    ...     y[t] = 0.8 * y[t - 1] + u[t - 2]
    >>> data = IOData(u, y, ts=0.02)
    >>> options = [(f"delay {d}", methods()["arx"].make(Lags.arx(1, 1, d))) for d in (1, 2)]
    >>> table = score_candidates(options, data[:300], data[300:], criteria=["simulation"]).table
    >>> table["name"][table["rmse_simulation"].idxmin()]
    'delay 2'
    >>> runs = [data[:130], data[130:260], data[260:]]
    >>> grouped = score_candidates(options, runs, criteria=["simulation"])
    >>> grouped.scheme, grouped.fold_fits["fit_simulation"].shape
    ('leave-one-experiment-out', (2, 3))
    """
    kinds = list(criteria)
    if not kinds or any(k not in ("prediction", "simulation") for k in kinds):
        raise ValueError(f"criteria must hold 'prediction' and/or 'simulation'; got {criteria!r}")
    if n_initial is not None and (
        isinstance(n_initial, bool) or not isinstance(n_initial, int | np.integer) or n_initial < 0
    ):
        raise ValueError(f"n_initial must be an int >= 0 or None; got {n_initial!r}")
    options = list(candidates)
    for i, option in enumerate(options):
        if not (isinstance(option, tuple) and len(option) == 2 and isinstance(option[0], str)):
            raise TypeError(f"candidates[{i}] must be a (name, estimator) pair; got {option!r}")
    train_list = as_experiments(train, "train")
    plan = holdout_plan(train_list, validation, folds, blocks_per_log)
    return score_plan(
        options,
        plan,
        train_list[0].output_names,
        criteria=kinds,
        n_initial=n_initial,
        n_jobs=n_jobs,
        backend=backend,
        progress=progress,
        adapt=adapt,
    )


def score_plan(
    candidates: Sequence[tuple[str, Any]],
    plan: FoldPlan,
    output_names: Sequence[str],
    *,
    criteria: Sequence[Criterion] = ("prediction", "simulation"),
    n_initial: int | None = None,
    n_jobs: int | None = None,
    backend: str | None = None,
    progress: bool = False,
    adapt: tuple[float, str] | None = None,
) -> CandidateScores:
    """:func:`score_candidates` on folds already cut (:func:`~neckid.data.folds.fold_plan`).

    ``candidates`` as checked by :func:`score_candidates`; ``output_names`` the records'
    output channels (the per-output columns). The other parameters and the result are those
    of :func:`score_candidates`.
    """
    options, kinds = list(candidates), list(criteria)
    shown = progress_label(len(options), plan.splits)
    units = progress_units(options, plan.splits)  # what runs and the time left, by cost
    jobs = (
        delayed(_fit_and_score)(name, estimator, split.fit_on, split.folds, kinds, n_initial, adapt)
        for name, estimator in options
        for split in plan.splits
    )
    split_rows = run_jobs(
        jobs,
        total=len(options) * len(plan.splits),
        n_jobs=n_jobs,
        backend=backend,
        progress=progress,
        label=shown,
        units=units,
    )
    per_candidate = len(plan.splits)
    fold_rows = [
        [row for rows in split_rows[i * per_candidate : (i + 1) * per_candidate] for row in rows]
        for i in range(len(options))
    ]
    rows = [_combine_folds(candidate, kinds, output_names) for candidate in fold_rows]
    columns = ["candidate", "name"]
    for kind in kinds:
        columns += [f"fit_{kind}", f"fit_{kind}_worst", f"rmse_{kind}", f"rmse_{kind}_worst"]
        columns += [f"{label}_{kind}[{n}]" for label in ("fit", "rmse") for n in output_names]
    columns += ["fit_time_s", "scheme", "n_folds", "error"]
    for i, row in enumerate(rows):
        row.update(candidate=i, scheme=plan.scheme, n_folds=plan.n_folds)
        row.setdefault("error", "")
    # Every fold's score of every candidate, on the same folds (the paired rule needs them).
    fold_fits = {
        f"fit_{kind}": np.array(
            [[float(f.get(f"fit_{kind}", -np.inf)) for f in candidate] for candidate in fold_rows],
            dtype=np.float64,
        ).reshape(len(options), plan.n_folds)
        for kind in kinds
    }
    table = pd.DataFrame(rows, columns=columns)
    return CandidateScores(table, fold_fits, plan.names, plan.scheme)


def _checked_candidates(
    candidates: Sequence[Lags] | Lags, estimator: Any
) -> tuple[Any, list[Lags]]:
    """The estimator (a registry name made) and the candidates as a list, both checked."""
    if isinstance(estimator, str):
        estimator = get_method(estimator).make()
    try:
        params = estimator.get_params(deep=False)
    except AttributeError:
        raise TypeError(
            f"estimator must be a neckid model with a 'lags' parameter; got {type(estimator).__name__}"
        ) from None
    if "lags" not in params:
        raise TypeError(
            f"estimator must have a 'lags' parameter; {type(estimator).__name__} has {sorted(params)}"
        )
    if isinstance(candidates, Lags):
        candidates = [candidates]
    lag_list = list(candidates)
    if not lag_list:
        raise ValueError("candidates is empty; give at least one Lags (see lag_grid)")
    for i, lags in enumerate(lag_list):
        if not isinstance(lags, Lags):
            raise TypeError(f"candidates[{i}] must be a neckid.Lags; got {type(lags).__name__}")
    return estimator, lag_list


def select_lags(
    train: IOData | Sequence[IOData],
    validation: IOData | Sequence[IOData] | None = None,
    candidates: Sequence[Lags] | Lags | None = None,
    estimator: Any = None,
    criterion: Criterion = "simulation",
    n_jobs: int | None = None,
    progress: bool = True,
    *,
    folds: int | None = None,
    backend: str | None = None,
    rule: Rule = "safe",
) -> LagSelection:
    """Train a copy of ``estimator`` on every candidate lag set and rank them on held-out data.

    For each candidate, ``sklearn.base.clone(estimator).set_params(lags=candidate)`` is fitted and
    its one-step-ahead prediction and free-run simulation on held-out records are scored by the
    NRMSE fit ``100 (1 - ||y - ŷ|| / ||y - mean(y)||)`` per output (skipping the candidate's
    ``max_lag`` initial samples), averaged over the held-out records and outputs, then over the
    folds (:func:`score_candidates`). The held-out records are ``validation`` when it is given
    (fitted on ``train``); with ``validation=None`` and a list of experiments as ``train``, every
    experiment is held out once and the model fitted on the others (leave-one-experiment-out),
    or ``folds=k`` groups of experiments are; with ``validation=None`` and one record, it is cut
    into 3 contiguous time blocks, each held out once.

    The choice (:attr:`LagSelection.best_lags`) follows ``rule``: ``"safe"`` (the default) puts
    out every candidate that failed or diverged in a fold and takes the fewest regressor terms
    whose mean per-fold difference to the best is within one standard error of that difference
    or half a point (the paired rule of :func:`neckid.data.folds.rank_candidates`);
    ``"unpaired"`` within one standard error of the best mean (the spread between folds);
    ``"best"`` takes the top mean fit. With several experiments and ``folds=None``, fewer than 6
    are each scored in time blocks (:func:`neckid.data.folds.fold_plan`). The training mean and,
    where a log repeats another's inputs, its replay are scored on the same folds
    (:attr:`LagSelection.baselines`, :attr:`LagSelection.warnings`).

    Parameters
    ----------
    train : IOData or list of IOData
        Training records: one record (cut into time blocks when ``validation=None``) or
        several experiments.
    validation : IOData, list of IOData or None, default None
        Validation records, with the channels of ``train``. ``None`` scores on held-out
        experiments of ``train``, which says how a lag set carries over to another run.
    candidates : sequence of Lags
        Lag sets to try, e.g. from :func:`lag_grid` (required).
    estimator : estimator with a ``lags`` parameter, or str
        A NARX model (``NeuralNARX``, ``SetMembership``, ``LinearARX``, ...); not changed. A
        registry name (``"nn"``, ``"sm-linear"``, see :func:`neckid.methods`) stands for that
        method with its default hyper-parameters.
    criterion : {"simulation", "prediction"}, default "simulation"
        Rank by free-run (``"simulation"``) or one-step (``"prediction"``) fit; ties are broken by
        fewer regressor terms.
    n_jobs : int or None, default None
        Parallel workers (joblib); ``None`` means 1 unless inside a ``joblib.parallel_config``
        context, or every worker of the cluster with ``backend="dask"``; -1 means all cores.
    progress : bool, default True
        Show a rich progress bar (on standard error).
    folds : int or None, default None
        With ``validation=None``: group the experiments into ``k`` folds (experiment ``i`` in
        fold ``i mod k``); ``None`` is leave-one-experiment-out.
    rule : {"safe", "unpaired", "best"}, default "safe"
        How :attr:`LagSelection.best_lags` chooses (see above).
    backend : str or None, default None
        The joblib backend the fits run on: ``None`` is the active ``joblib.parallel_config``
        (joblib's default outside one); ``"dask"`` runs them on the cluster of the active
        ``distributed.Client`` (``pip install neckid[dask]``; create the client first), with
        the same result as here. See :func:`score_candidates`.

    Returns
    -------
    LagSelection
        ``result.table`` (DataFrame, best first, with mean and worst-fold fits),
        ``result.scheme``, ``result.best_lags``, ``result.best(tolerance)``.

    Raises
    ------
    TypeError
        If ``candidates`` or ``estimator`` is missing, ``estimator`` has no ``lags`` parameter, or
        a candidate is not a :class:`~neckid.Lags`.
    ValueError
        If ``estimator`` is a name no registered method has, ``criterion`` is unknown,
        ``candidates`` is empty, the records do not share channels, ``validation`` is None and
        a single ``train`` record is too short for 3 blocks, ``folds`` is out of range, ``rule``
        is unknown, ``backend`` is
        unknown, or ``backend="dask"`` and no ``distributed.Client`` is active.
    ImportError
        If ``backend="dask"`` and the ``distributed`` package is not installed.

    Notes
    -----
    A candidate that fails (too few samples for its lags, an unstable free run that overflows, a
    training error) gets a row with its error text in ``error`` and fit ``-inf`` for every fit that
    could not be computed, instead of stopping the search (an unstable model keeps its one-step
    fit, which is computed first). Such rows sort last under either criterion.
    Warnings raised while fitting candidates (e.g. convergence warnings) are silenced.

    References
    ----------
    .. [1] Model Identification of a Soft Robotic Neck, Robotics Lab, Universidad Carlos III de
       Madrid: the network's regressor was chosen by training networks on candidate lag sets and
       keeping the best validation fit.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=400)
    >>> y = np.zeros(400)
    >>> for t in range(2, 400):
    ...     y[t] = 0.8 * y[t - 1] + u[t - 2]
    >>> data = IOData(u, y, ts=0.02)
    >>> result = select_lags(data[:300], data[300:], lag_grid([1, 2], [1, 2], [1, 2]),
    ...                      LinearARX(), progress=False)
    >>> result.best(tolerance=0.01)
    Lags(outputs=[1], inputs=[2])
    >>> list(result.table.columns[:4])
    ['candidate', 'lags', 'n_terms', 'max_lag']
    >>> runs = [data[:130], data[130:260], data[260:]]
    >>> grouped = select_lags(runs, None, lag_grid([1, 2], [1, 2], [1, 2]), LinearARX(),
    ...                       progress=False)
    >>> grouped.scheme, grouped.best(tolerance=0.01)
    ('leave-one-experiment-out', Lags(outputs=[1], inputs=[2]))
    """
    if candidates is None or estimator is None:
        missing = "candidates" if candidates is None else "estimator"
        raise TypeError(f"select_lags needs {missing}=; got None")
    if criterion not in ("prediction", "simulation"):
        raise ValueError(f"criterion must be 'simulation' or 'prediction'; got {criterion!r}")
    check_backend(backend)  # before any work: a missing cluster is said at once
    estimator, lag_list = _checked_candidates(candidates, estimator)
    if rule not in RULE_OF:
        raise ValueError(f"rule must be 'safe', 'unpaired' or 'best'; got {rule!r}")
    train_list = as_experiments(train, "train")
    refuse_resting_runs(train_list, "training log")
    # several logs: each held out, in time blocks when there are few (fold_plan's rule)
    blocks = None if len(train_list) >= 2 else 1
    if validation is None and folds is None and len(train_list) == 1:
        # one record: contiguous time blocks (of one period if periodic), each held out
        train_list, block_scheme = fold_records(train_list)
        plan = replace(holdout_plan(train_list, None, None, 1), scheme=block_scheme)
    else:
        plan = holdout_plan(train_list, validation, folds, blocks)
    rows: list[dict[str, Any]] = []
    for i, lags in enumerate(lag_list):
        row: dict[str, Any] = {"candidate": i, "lags": repr(lags), "max_lag": lags.max_lag}
        try:
            row["n_terms"] = lags.resolve(lags.conditioned(train_list)).n_terms
        except (KeyError, ValueError) as exc:  # not fitted: the regressor itself is impossible
            row.update(n_terms=np.nan, fit_time_s=np.nan, error=f"{type(exc).__name__}: {exc}")
        rows.append({**row, "scheme": plan.scheme, "n_folds": plan.n_folds})
    column = f"fit_{criterion}"
    fold_fits = np.full((len(rows), plan.n_folds), -np.inf)
    fitted = [row for row in rows if "error" not in row]
    options = [
        (row["lags"], clone(estimator).set_params(lags=lag_list[row["candidate"]]))
        for row in fitted
    ]
    scores = score_plan(  # on the folds just cut: they are cut once
        [*options, *baseline_candidates()],
        plan,
        train_list[0].output_names,
        n_jobs=n_jobs,
        progress=progress,
        backend=backend,
    )
    records = scores.table.to_dict(orient="records")
    for row, score, fits in zip(fitted, records, scores.fold_fits[column], strict=False):
        kept = {str(k): v for k, v in score.items() if k not in ("candidate", "name", "scheme")}
        row.update(kept)
        fold_fits[row["candidate"]] = fits
    baselines = {
        str(score["name"]).removeprefix("baseline: "): float(score[column])
        for score in records[len(fitted) :]
        if not score["error"]
    }
    table, chosen, ranking = _ranked_lags(rows, fold_fits, train_list, criterion, rule)
    return LagSelection(
        table=table,
        candidates=tuple(lag_list),
        criterion=criterion,
        scheme=plan.scheme,  # type: ignore[arg-type]
        chosen=chosen,
        rule=rule,
        folds=plan.names,
        ranking=ranking,
        baselines=baselines,
    )


def _ranked_lags(
    rows: list[dict[str, Any]],
    fold_fits: FloatArray,
    train: list[IOData],
    criterion: Criterion,
    rule: Rule,
) -> tuple[pd.DataFrame, int | None, Ranking | None]:
    """The table best first with ``status``, ``reason`` and the paired columns; the choice.

    A candidate is out when it failed to fit or its run was not finite in a fold (for
    ``rule="best"`` only a fit that is not finite puts it out); the rest go to
    :func:`~neckid.data.folds.rank_candidates`, simpler meaning fewer regressor terms, then a
    shorter memory.
    """
    column = f"fit_{criterion}"
    output_names = train[0].output_names
    for row, fits in zip(rows, fold_fits, strict=True):
        for kind in ("prediction", "simulation"):
            for name in (f"fit_{kind}", f"fit_{kind}_worst"):
                row.setdefault(name, -np.inf)
            for n in output_names:
                row.setdefault(f"fit_{kind}[{n}]", -np.inf)
        row[f"{column}_folds"] = [float(f) for f in fits]
        error = row.get("error") if isinstance(row.get("error"), str) else ""
        finite = bool(np.all(np.isfinite(fits)))
        row["status"] = "accepted" if finite and not error else "rejected"
        row["reason"] = error or ("" if finite else f"{column} not finite in a fold (diverged)")
    usable = [row["status"] == "accepted" or rule == "best" for row in rows]
    try:
        ranking: Ranking | None = rank_candidates(
            fold_fits,
            [(float(row["n_terms"]), int(row["max_lag"])) for row in rows],
            usable,
            rule=RULE_OF[rule],
        )
    except ValueError:
        ranking = None
    for i, row in enumerate(rows):
        row[f"{column}_se"] = np.nan if ranking is None else ranking.standard_errors[i]
        row[f"{column}_diff"] = np.nan if ranking is None else ranking.difference_means[i]
        row[f"{column}_diff_se"] = np.nan if ranking is None else ranking.difference_errors[i]
    chosen = None if ranking is None else int(rows[ranking.chosen]["candidate"])
    if chosen is not None:
        rows[chosen]["status"] = "chosen"
    columns = ["candidate", "lags", "n_terms", "max_lag", "fit_prediction", "fit_simulation"]
    columns += ["fit_prediction_worst", "fit_simulation_worst"]
    columns += [f"fit_{k}[{n}]" for k in ("prediction", "simulation") for n in output_names]
    columns += [f"{column}_se", f"{column}_diff", f"{column}_diff_se", f"{column}_folds"]
    columns += ["fit_time_s", "scheme", "n_folds", "error", "status", "reason"]
    table = pd.DataFrame(rows, columns=columns)
    table["n_terms"] = table["n_terms"].astype("Int64")
    table = table.sort_values(
        [column, "n_terms"], ascending=[False, True], kind="mergesort", na_position="last"
    ).reset_index(drop=True)
    return table, chosen, ranking
