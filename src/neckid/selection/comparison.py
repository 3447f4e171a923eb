"""Which model for this neck, and how far to trust it: safe selection and a comparison on test logs.

:func:`select_safely` chooses among candidate estimators on the *training* logs only, by a rule
meant to hold on the next run rather than on the tail of this one:

1. **Folds over runs.** With two or more training experiments, each fold holds one out
   (leave-one-experiment-out); with one, the record is cut into ``n_blocks >= 3`` contiguous
   time blocks and each fold holds one block out, so some fold tests the edges of the range.
2. **No runaway.** A candidate that fails in any fold (a training error, a free run that is not
   finite or leaves the divergence envelope of the training outputs, see
   :meth:`neckid.models.base.Estimator.divergence_envelope`) is out, with the reason kept.
   Optionally (``stress > 0``), each remaining candidate, fitted on all training logs, runs on
   the training inputs stretched ``stress`` beyond their range, and one that runs away is out.
3. **Paired one standard error toward the simpler model.** Every candidate is scored on the
   same folds (with few logs, each held-out log in time blocks:
   :func:`neckid.data.folds.fold_plan`); among the rest, candidate ``j`` is eligible when its
   mean per-fold difference to the best, ``d̄_j``, is within one standard error of that
   difference, ``d̄_j >= −std(d_j) / sqrt(k)``; the simplest eligible candidate is chosen
   (Hastie, Tibshirani & Friedman 2009, §7.10, on paired differences:
   :func:`neckid.data.folds.rank_candidates`). Simplicity is :data:`COMPLEXITY` (linear ARX
   first), then fewer regressor terms.
4. **Baselines.** The training outputs' mean and, where a training log was driven by the same
   inputs, its replay (:mod:`neckid.selection.baselines`) are scored on the same folds; a
   chosen candidate below 0 % or below one of them is said so in :attr:`SafeSelection.warnings`.

:func:`compare` runs that selection over methods and lag sets (linear ARX always among them, the
reference), fits each method's best candidate on all training logs, and runs one free run per
test log: fit and RMSE, the share of samples outside the training range (the channels' ranges
over the training logs, the same measure for every method) and outside the model's own domain,
and the band's kind, width and coverage. The test logs are touched once, after every choice is made.

References
----------
T. Hastie, R. Tibshirani and J. Friedman, *The Elements of Statistical Learning*, 2nd ed.,
Springer, 2009, §7.10.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd
from sklearn.base import clone

from neckid.data.folds import (
    MIN_BLOCKS,
    Ranking,
    fold_statistics,
    rank_candidates,
    time_blocks,
)
from neckid.data.iodata import IOData
from neckid.data.training import TrainingSet
from neckid.metrics import coverage, fit_percent, mean_width, rmse
from neckid.models.adapted import adaptation_label, adapted_run, check_adaptation, diverged_rows
from neckid.models.bands import band_meaning
from neckid.models.base import DivergenceError, ModelResult
from neckid.registry import get_method, methods
from neckid.regressors import Lags
from neckid.selection.baselines import baseline_candidates, baseline_warnings
from neckid.selection.lags import score_plan
from neckid.utils.progress import task

__all__ = [
    "COMPLEXITY",
    "Comparison",
    "SafeSelection",
    "compare",
    "select_safely",
    "stretched",
    "time_blocks",
]

#: How simple each method is, for the one-standard-error rule (smaller is simpler; a method
#: not listed counts as the most complex): each method's :attr:`~neckid.registry.Method.complexity`.
COMPLEXITY: Mapping[str, int] = MappingProxyType({m.name: m.complexity for m in methods().values()})

#: Methods whose regressor is not their lags (the subspace model: its order comes from the
#: singular values): one candidate each, not one per lag set
#: (:attr:`~neckid.registry.Method.lag_free`).
LAG_FREE_METHODS = frozenset(m.name for m in methods().values() if m.lag_free)


def stretched(data: IOData, stress: float) -> IOData:
    """The log with every input stretched about the middle of its range by ``1 + stress``.

    With ``stress = 0.1`` the inputs reach 10 % of their half-range beyond the training range
    at both ends; the outputs are left as they are (only the inputs drive a free run).
    """
    u = data.u
    middle = 0.5 * (u.min(axis=0) + u.max(axis=0))
    return data.replace(u=middle + (u - middle) * (1.0 + float(stress)))


@dataclass(frozen=True)
class SafeSelection:
    """The result of :func:`select_safely`.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per candidate: ``name``, ``complexity``, ``n_terms``, ``fit_mean`` (mean fold
        fit of the free run, %), ``fit_se`` (its standard error, points), ``fit_worst``,
        ``diff_best`` and ``diff_se`` (the mean per-fold difference to the best candidate and
        its standard error, points), ``bar`` (the mean fit it needed), ``fold_fits`` (each
        fold's fit), ``status`` (``"chosen"``, ``"accepted"`` or ``"rejected"``), ``reason``
        (why rejected; empty otherwise) and ``seconds`` (wall time of its fits and runs on the
        folds and of the stress check). Best first.
    chosen : str
        The chosen candidate's name.
    scheme : str
        ``"leave-one-experiment-out"``, ``"experiments × time-blocks"`` or ``"time-blocks"``.
    folds : list of list of str
        The held-out records of each fold.
    bar : float
        The mean fold fit the chosen candidate had to reach: the best mean minus the standard
        error of the chosen one's paired difference to the best.
    ranking : Ranking
        What :func:`neckid.data.folds.rank_candidates` chose and why (positions as given).
    names : tuple of str
        The candidates' names, in the order given (the positions of :attr:`ranking`).
    baselines : dict of str to float
        Naive references on the same folds: name -> mean fold fit [%] (one that did not apply
        is left out).
    baseline_fits : dict of str to list of float
        Their fit on each fold.
    fitted : dict of str to estimator
        From :func:`compare`: per method's candidate run on the test logs, the model the stress
        check fitted on all training runs (none without the check, or when that fit failed);
        empty from :func:`select_safely`.
    """

    table: pd.DataFrame
    chosen: str
    scheme: str
    folds: list[list[str]]
    bar: float
    ranking: Ranking | None = None
    names: tuple[str, ...] = ()
    baselines: dict[str, float] = field(default_factory=dict)
    baseline_fits: dict[str, list[float]] = field(default_factory=dict)
    fitted: dict[str, Any] = field(default_factory=dict)

    @property
    def rejected(self) -> dict[str, str]:
        """Rejected candidate -> the reason."""
        rows = self.table[self.table["status"] == "rejected"]
        return dict(zip(rows["name"], rows["reason"], strict=True))

    @property
    def best(self) -> str:
        """The candidate with the best mean fold fit."""
        return self.names[self.ranking.best] if self.ranking is not None else self.chosen

    @property
    def warnings(self) -> list[str]:
        """One line when the chosen candidate fits below 0 % or below a baseline on the folds."""
        row = self.table[self.table["name"] == self.chosen].iloc[0]
        return baseline_warnings(self.chosen, float(row["fit_mean"]), self.baselines)

    def explain(self) -> list[str]:
        """Why: the best, the chosen, the rule and the bar; when they differ, each fold's gap."""
        if self.ranking is None:
            return [f"{self.chosen}: chosen ({self.scheme}, {len(self.folds)} folds)"]
        lines = [
            f"{self.ranking.explain(self.names)}; free run, {self.scheme}, {len(self.folds)} folds"
        ]
        if self.ranking.chosen != self.ranking.best:
            gaps = self.ranking.differences[self.ranking.chosen]
            lines.append(
                f"{self.chosen} minus {self.best} per fold [points]: "
                + ", ".join(f"{g:+.1f}" for g in gaps)
            )
        return lines

    def to_json(self) -> dict[str, Any]:
        """The choice as JSON: best, chosen, bar, rule, scheme, per-fold gaps, baselines."""
        table = self.table.set_index("name")
        out: dict[str, Any] = {
            "rule": self.ranking.rule if self.ranking is not None else "",
            "scheme": self.scheme,
            "n_folds": len(self.folds),
            "best": self.best,
            "best_fit_mean": _plain(table.loc[self.best, "fit_mean"]),
            "chosen": self.chosen,
            "chosen_fit_mean": _plain(table.loc[self.chosen, "fit_mean"]),
            "bar": _plain(self.bar),
            "baselines": {k: _plain(v) for k, v in self.baselines.items()},
        }
        if self.ranking is not None:
            i = self.ranking.chosen
            out["fold_differences_to_best"] = [_plain(g) for g in self.ranking.differences[i]]
            out["difference_mean"] = _plain(self.ranking.difference_means[i])
            out["difference_se"] = _plain(self.ranking.difference_errors[i])
        return out


def _n_terms(estimator: Any, data: IOData) -> int:
    lags = estimator.get_params().get("lags")
    if not isinstance(lags, Lags):
        return 0
    return lags.resolve(lags.conditioned(data)).n_terms  # conditions as the model adds them


def _stress_reason(estimator: Any, logs: TrainingSet, stress: float) -> tuple[str, Any]:
    """Why the candidate fitted on all training runs runs away on stretched inputs ('' if not).

    Returns the reason and the model fitted on all training runs (``None`` if the fit failed),
    which :func:`compare` runs on the test logs instead of fitting it again.
    """
    model = clone(estimator)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model.fit(logs.fit_data())
    except Exception as exc:  # a failing candidate is out, with the reason
        return f"fails on all training logs: {type(exc).__name__}: {exc}", None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for record in logs.experiments:
                model.simulate(stretched(record, stress))
    except DivergenceError as exc:
        return f"runs away with inputs {stress:.0%} beyond the training range: {exc}", model
    except Exception as exc:  # a failing candidate is out, with the reason
        return f"fails on all training logs: {type(exc).__name__}: {exc}", model
    return "", model


def _ranked(rows: list[dict[str, Any]], fold_fits: np.ndarray) -> tuple[pd.DataFrame, str, Ranking]:
    """Status and order by the paired rule (:func:`rank_candidates`); the chosen name, the ranking."""
    try:
        ranking = rank_candidates(
            fold_fits,
            [(row["complexity"], row["n_terms"]) for row in rows],
            [row["status"] != "rejected" for row in rows],
        )
    except ValueError:
        reasons = "; ".join(f"{row['name']}: {row['reason']}" for row in rows)
        raise ValueError(f"every candidate was rejected on the training logs ({reasons})") from None
    for i, row in enumerate(rows):
        row["diff_best"] = float(ranking.difference_means[i])
        row["diff_se"] = float(ranking.difference_errors[i])
        row["bar"] = float(ranking.bars[i])
    rows[ranking.chosen]["status"] = "chosen"
    table = pd.DataFrame(rows).sort_values(["fit_mean"], ascending=False, kind="mergesort")
    return table.reset_index(drop=True), str(rows[ranking.chosen]["name"]), ranking


def select_safely(
    candidates: Sequence[tuple[str, Any]],
    train: IOData | Sequence[IOData],
    *,
    n_blocks: int = MIN_BLOCKS,
    stress: float = 0.0,
    complexity: Mapping[str, int] | None = None,
    n_initial: int | None = None,
    n_jobs: int | None = None,
    backend: str | None = None,
    progress: bool = False,
    adapt: tuple[float, str] | None = None,
) -> SafeSelection:
    """Choose among candidate estimators on the training logs only (see the module's rule).

    Parameters
    ----------
    candidates : sequence of (str, estimator)
        A name and an unfitted estimator each (not changed: copies are fitted).
    train : IOData or list of IOData
        The training experiments. One record is cut into ``n_blocks`` time blocks.
    n_blocks : int, default 3
        Blocks of a single training record (>= 3).
    stress : float, default 0.0
        With ``stress > 0``, reject a candidate whose free run on the training inputs stretched
        by ``1 + stress`` about their mid-range (:func:`stretched`) runs away.
    complexity : mapping of str to int, optional
        Each candidate's simplicity rank by name (smaller is simpler); default 0 for all (then
        fewer regressor terms decide).
    n_initial : int, optional
        Initial samples of each held-out record (default each candidate's ``max_lag_``).
    n_jobs : int, optional
        Parallel workers over candidates and folds (joblib).
    backend : str, optional
        The joblib backend (``"dask"`` for a cluster), as in
        :func:`~neckid.selection.lags.score_candidates`.
    progress : bool, default False
        Show a progress bar.
    adapt : (float, str), optional
        ``(seconds, mode)``: each fold scores the free run after ``seconds`` of adaptation on
        the held-out record's start (``mode`` ``"offset"``, ``"update"`` or ``"both"``;
        :func:`neckid.selection.lags.free_run`), the candidates and the baselines alike.

    Returns
    -------
    SafeSelection

    Raises
    ------
    ValueError
        If there are no candidates, two share a name, or every candidate is rejected.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, methods
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, 900)
    >>> y = np.zeros(900)
    >>> for t in range(2, 900):
    ...     y[t] = 0.7 * y[t - 1] + 0.5 * u[t - 2]
    >>> data = IOData(u, y + 0.01 * rng.normal(size=900), ts=0.02)
    >>> options = [(f"arx delay {d}", methods()["arx"].make(Lags.arx(1, 1, d))) for d in (1, 2)]
    >>> found = select_safely(options, data)
    >>> found.chosen, found.scheme, len(found.folds)
    ('arx delay 2', 'time-blocks', 3)
    """
    options = list(candidates)
    names = [name for name, _ in options]
    if not options:
        raise ValueError("candidates is empty; give at least one (name, estimator) pair")
    if len(set(names)) != len(names):
        raise ValueError(f"candidate names must differ; got {names}")
    if not math.isfinite(float(stress)) or stress < 0:
        raise ValueError(f"stress must be a finite number >= 0; got {stress!r}")
    ranks = {name: int((complexity or {}).get(name, 0)) for name in names}
    logs = TrainingSet.of(train, n_blocks)
    return _select(options, logs, ranks, stress, n_initial, n_jobs, backend, progress, adapt)


def _select(
    options: list[tuple[str, Any]],
    logs: TrainingSet,
    ranks: Mapping[str, int],
    stress: float,
    n_initial: int | None,
    n_jobs: int | None,
    backend: str | None,
    progress: bool,
    adapt: tuple[float, str] | None,
    keep_fits: bool = False,
) -> SafeSelection:
    """:func:`select_safely` on logs checked and cut once (:class:`~neckid.data.training.TrainingSet`).

    ``keep_fits``: keep the stress check's models (:attr:`SafeSelection.fitted`; otherwise each
    is dropped after its check, as a selection over many candidates cannot hold them all).
    """
    names = [name for name, _ in options]
    references = baseline_candidates()
    # The regressor's terms, bound to the runs' channels (the tie-break toward fewer terms).
    terms = [_n_terms(estimator, logs.experiments[0]) for _, estimator in options]
    scored = score_plan(
        [*options, *references],
        logs.plan,
        logs.output_names,
        criteria=["simulation"],
        n_initial=n_initial,
        n_jobs=n_jobs,
        backend=backend,
        progress=progress,
        adapt=adapt,
    )
    fold_fits = scored.fold_fits["fit_simulation"]
    rows, fitted = [], {}
    for i, (name, estimator) in enumerate(options):
        fits = np.asarray(fold_fits[i], dtype=np.float64)
        reason = str(scored.table.at[i, "error"])
        started = time.perf_counter()
        if not reason and stress > 0:
            reason, model = _stress_reason(estimator, logs, stress)
            if keep_fits:
                fitted[name] = model
        times = scored.table.reindex(columns=["fit_time_s", "score_time_s"]).iloc[i]
        spent = time.perf_counter() - started + float(np.nansum(times.to_numpy(np.float64)))
        mean, se, worst = fold_statistics(fits)
        finite = bool(np.isfinite(mean))
        rows.append(
            {
                "name": name,
                "complexity": ranks[name],
                "n_terms": terms[i],
                "fit_mean": mean,
                "fit_se": se,
                "fit_worst": worst,
                "fold_fits": [float(f) for f in fits],
                "status": "rejected" if reason or not finite else "accepted",
                "reason": reason or ("" if finite else "a fold's fit is not finite"),
                "seconds": spent,
            }
        )
    table, chosen, ranking = _ranked(rows, fold_fits[: len(options)])
    applied = [
        (name.removeprefix("baseline: "), fold_fits[len(options) + j])
        for j, (name, _) in enumerate(references)
        if not scored.table.at[len(options) + j, "error"]
    ]
    return SafeSelection(
        table,
        chosen,
        logs.plan.scheme,
        list(scored.folds),
        ranking.bar,
        ranking,
        tuple(names),
        {name: float(np.mean(fits)) for name, fits in applied},
        {name: [float(f) for f in fits] for name, fits in applied},
        {name: model for name, model in fitted.items() if model is not None},
    )


@dataclass
class Comparison:
    """The result of :func:`compare`: every method on every test log, and the recommendation.

    Attributes
    ----------
    selection : SafeSelection
        The selection on the training logs (every method and lag set a candidate).
    models : dict of str to estimator
        Per method, its best candidate fitted on all training logs.
    settings : dict of str to dict
        Per method, the chosen candidate's name and lags.
    results : pandas.DataFrame
        One row per method and test log: ``method``, ``log``, ``output``, ``fit_percent`` (free
        run, %), ``rmse`` and ``unit``, ``outside_training_range`` (share of samples at which a
        channel is outside its range over the training logs: the same for every method,
        :func:`outside_training_range`), ``outside_domain`` (share outside the model's own
        domain: :meth:`~neckid.models.base.Estimator.domain`, SM its nearest-neighbour radius), ``band`` (what it bounds, or empty), ``band_width``
        (mean, output units), ``band_coverage`` (share of measured samples inside), ``error``.
    recommended : str
        The method of the chosen candidate.
    reasons : list of str
        Why it is recommended: the best candidate and its mean fold fit, the chosen one, the
        rule and the bar, each fold's gap when they differ; the rejected candidates.
    runs : list of dict of str to ModelResult
        Per test log (in the order given), each method's free run (not the diverged ones).
    warnings : list of str
        One line when the recommended candidate fits below 0 % or below a baseline on the
        training folds (:attr:`SafeSelection.warnings`); empty otherwise.
    kind : str
        What was scored: ``"free run"``, or ``"free run after 5 s of adaptation (offset)"``
        (:func:`compare` with ``adapt``).
    seconds : dict of str to dict of str to float
        Per method, wall seconds: ``selection`` (its candidates' fits and free runs on the
        training folds and the stress check, which fits the model the test logs run) and
        ``test`` (the test logs' runs, and the fit on all training logs when the stress check
        did not make it).
    """

    selection: SafeSelection
    models: dict[str, Any]
    settings: dict[str, dict[str, Any]]
    results: pd.DataFrame
    recommended: str
    reasons: list[str] = field(default_factory=list)
    runs: list[dict[str, ModelResult]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    kind: str = "free run"
    seconds: dict[str, dict[str, float]] = field(default_factory=dict)

    def summary(self) -> pd.DataFrame:
        """Per method: the mean over test logs and outputs of fit, RMSE and outside shares."""
        table = self.results.groupby("method", sort=False)[
            ["fit_percent", "rmse", "outside_training_range", "outside_domain"]
        ].mean()
        return table.reset_index()

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready summary: per method its settings, fold scores and test results."""
        methods = []
        table = self.selection.table.set_index("name")
        reference = np.asarray(table.loc[self.settings["arx"]["candidate"], "fold_fits"])
        for method, setting in self.settings.items():
            row = table.loc[setting["candidate"]]
            tests = self.results[self.results["method"] == method]
            gaps = np.asarray(row["fold_fits"]) - reference  # paired, fold by fold, to ARX
            methods.append(
                {
                    "method": method,
                    "settings": setting,
                    "fold_fits": [_plain(f) for f in row["fold_fits"]],
                    "fit_mean_folds": _plain(row["fit_mean"]),
                    "fold_differences_to_arx": [_plain(float(g)) for g in gaps],
                    "status": row["status"],
                    "reason": row["reason"],
                    "seconds": {k: _plain(v) for k, v in self.seconds.get(method, {}).items()},
                    "tests": [
                        {k: _plain(v) for k, v in r.items() if k != "method"}
                        for r in tests.to_dict("records")
                    ],
                }
            )
        return {
            "kind": self.kind,
            "recommended": self.recommended,
            "reasons": self.reasons,
            "warnings": list(self.warnings),
            "selection": self.selection.to_json(),
            "scheme": self.selection.scheme,
            "folds": self.selection.folds,
            "rejected": self.selection.rejected,
            "methods": methods,
        }


def _plain(value: Any) -> Any:
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def _outside_domain(model: Any, data: IOData) -> float:
    """Share of the samples outside the model's domain (``Estimator.domain``).

    Its regressors' training box and, for SM models, farther than the radius from every training
    regressor; the channels' training ranges for a model without regressor ranges.
    """
    if model.regressor_box() and model.fitted_lags() is not None:
        return model.domain(data).share
    ranges = model.training_box()
    outside = np.zeros(data.n_samples, dtype=bool)
    for name in (*data.input_names, *data.output_names):
        if name in ranges:
            low, high = ranges[name]
            values = data.channel(name)
            outside |= (values < low) | (values > high)
    return float(outside.mean()) if data.n_samples else 0.0


def _test_rows(
    method: str, model: Any, record: IOData, outside_range: float = 0.0
) -> tuple[list[dict[str, Any]], ModelResult | None]:
    """One free run of ``model`` on ``record``: a row per output, and the run (None if diverged)."""
    base = {
        "method": method,
        "log": record.name or "test",
        "error": "",
        "outside_training_range": outside_range,
    }
    outside = _outside_domain(model, record)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = model.simulate(record)
    except DivergenceError as exc:
        diverged = [
            {
                **base,
                "output": name,
                "fit_percent": -np.inf,
                "rmse": np.inf,
                "unit": unit,
                "outside_domain": outside,
                "band": "",
                "band_width": np.nan,
                "band_coverage": np.nan,
                "error": f"diverged: {exc}",
            }
            for name, unit in zip(record.output_names, record.output_units, strict=True)
        ]
        return diverged, None
    skip = result.n_initial
    fits = fit_percent(record.y, result.y, skip=skip)
    errors = rmse(record.y, result.y, skip=skip)
    band, widths, held = "", np.full(len(fits), np.nan), np.full(len(fits), np.nan)
    if result.lower is not None and result.upper is not None:
        band = band_meaning(result.extras)
        widths = mean_width(result.lower, result.upper, skip=skip)
        held = coverage(record.y, result.lower, result.upper, skip=skip)
    rows = [
        {
            **base,
            "output": name,
            "fit_percent": float(fits[j]),
            "rmse": float(errors[j]),
            "unit": unit,
            "outside_domain": outside,
            "band": band,
            "band_width": float(widths[j]),
            "band_coverage": float(held[j]),
        }
        for j, (name, unit) in enumerate(zip(record.output_names, record.output_units, strict=True))
    ]
    return rows, result


def _adapted_test_rows(
    method: str, model: Any, record: IOData, outside_range: float, adapt: tuple[float, str]
) -> tuple[list[dict[str, Any]], ModelResult | None]:
    """:func:`_test_rows` after ``adapt`` of adaptation, with the un-adapted fit and the band."""
    base: dict[str, Any] = {"method": method, "log": record.name or "test", "error": ""}
    base.update(outside_training_range=outside_range, outside_domain=_outside_domain(model, record))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            run = adapted_run(model, record, *adapt)
    except DivergenceError as exc:
        failed = {"error": f"diverged: {exc}"}
        return [{**base, **row, **failed} for row in diverged_rows(record)], None
    shown = run.adapted.result if run.band is None else run.band
    return [{**base, **row} for row in run.rows()], shown


def _method_pick(
    table: pd.DataFrame, method: str, method_of: Mapping[str, str], chosen: str
) -> pd.Series:
    """The candidate of ``method`` that is run on the test logs.

    The recommended method runs the chosen candidate; every other method its own choice by the
    same rule among its accepted candidates (the paired rule toward fewer terms); a method
    whose every candidate was rejected, its best rejected row (not run).
    """
    own = table[[method_of[n] == method for n in table["name"]]]
    if method_of[chosen] == method:
        return own[own["name"] == chosen].iloc[0]
    usable = own[own["status"] != "rejected"]
    if not len(usable):
        return own.iloc[0]
    ranking = rank_candidates(
        np.array(usable["fold_fits"].tolist(), dtype=np.float64),
        list(zip(usable["complexity"], usable["n_terms"], strict=True)),
    )
    return usable.iloc[ranking.chosen]


def _candidates(
    methods: Sequence[str], lags: Sequence[Lags], seed: int
) -> tuple[list[tuple[str, Any]], dict[str, str], dict[str, Lags]]:
    """(name, estimator) for every method and lag set; name -> method; name -> lags."""
    chosen = list(dict.fromkeys(["arx", *methods]))  # ARX always, first: the reference
    options, method_of, lags_of = [], {}, {}
    for method in chosen:
        entry = get_method(method)
        for regressor in lags[:1] if entry.lag_free else lags:
            several = len(lags) > 1 and not entry.lag_free
            name = f"{method} {regressor!r}" if several else method
            estimator = entry.make(regressor)
            if "random_state" in estimator.get_params():
                estimator.set_params(random_state=seed)
            options.append((name, estimator))
            method_of[name], lags_of[name] = method, regressor
    return options, method_of, lags_of


def _fitted_on_all(selection: SafeSelection, name: str, estimator: Any, logs: TrainingSet) -> Any:
    """Candidate ``name`` fitted on every training log: the stress check's model, or a new fit."""
    if name in selection.fitted:
        return selection.fitted[name]
    fitting = f"fitting {name} on every training log, for the test logs"  # a progress line
    with warnings.catch_warnings(), task(fitting):
        warnings.simplefilter("ignore")
        return clone(estimator).fit(logs.fit_data())


def _selection_seconds(
    table: pd.DataFrame, method_of: Mapping[str, str]
) -> dict[str, dict[str, float]]:
    """Per method, the wall seconds of its candidates in the selection (``test`` added later)."""
    seconds: dict[str, dict[str, float]] = {}
    for name, spent in zip(table["name"], table["seconds"], strict=True):
        entry = seconds.setdefault(method_of[name], {"selection": 0.0, "test": 0.0})
        entry["selection"] += float(spent)
    return seconds


def compare(
    train: IOData | Sequence[IOData],
    test: IOData | Sequence[IOData],
    methods: Sequence[str] = ("arx", "sm", "sm-parallel"),
    lags: Lags | Sequence[Lags] | None = None,
    *,
    n_blocks: int = MIN_BLOCKS,
    stress: float = 0.1,
    seed: int = 0,
    n_jobs: int | None = None,
    progress: bool = False,
    adapt: tuple[float, str] | None = None,
) -> Comparison:
    """Choose on the training logs, then run every method once on every test log.

    Parameters
    ----------
    train : IOData or list of IOData
        Training experiments (several runs: leave-one-experiment-out; one: time blocks).
    test : IOData or list of IOData
        Test logs, with the channels of ``train``; touched once, after every choice.
    methods : sequence of str, default ("arx", "sm", "sm-parallel")
        Registry names (:func:`neckid.methods`); ``"arx"`` is always added (the reference).
    lags : Lags or list of Lags, optional
        The regressors each method is tried with (default ``Lags.arx(2, 2, 1)``).
    n_blocks, n_jobs, progress
        As in :func:`select_safely`.
    stress : float, default 0.1
        The stress check of :func:`select_safely`, reaching at least ``stress`` (10 %) beyond the
        training inputs' range and as far as the test inputs go beyond it
        (:func:`input_reach`): a candidate that runs away there is out. Only the test *inputs*
        are looked at. 0 turns the check off.
    seed : int, default 0
        Seed of the methods that draw random numbers.
    adapt : (float, str), optional
        ``(seconds, mode)``: every free run, in the training folds and on the test logs, comes
        after ``seconds`` of adaptation of a copy of the model on the record's own start
        (``mode`` ``"offset"``, ``"update"`` or ``"both"``; :mod:`neckid.models.adapted`), and
        is scored on what follows; the test rows add the un-adapted fit on the same samples
        (``fit_percent_unadapted``) and a 95 % adaptive conformal band (``band_coverage`` its
        running coverage at the log's end).

    Returns
    -------
    Comparison

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> rng = np.random.default_rng(1)
    >>> def run(seed):
    ...     r = np.random.default_rng(seed)
    ...     u = np.repeat(r.uniform(-1, 1, 60), 10)
    ...     y = np.zeros(600)
    ...     for t in range(1, 600):
    ...         y[t] = 0.8 * y[t - 1] + 0.4 * np.tanh(2 * u[t - 1])
    ...     return IOData(u, y + 0.01 * r.normal(size=600), ts=0.02, name=f"run {seed}")
    >>> result = compare([run(1), run(2)], [run(3)], methods=["sm"], lags=Lags.arx(1, 1))
    >>> sorted(result.settings), result.recommended in ("arx", "sm")
    (['arx', 'sm'], True)
    """
    regressors = (
        [Lags.arx(2, 2, 1)] if lags is None else ([lags] if isinstance(lags, Lags) else list(lags))
    )
    logs = TrainingSet.of(train, n_blocks, tests=test)
    if adapt is not None:
        adapt = check_adaptation(*adapt)
    options, method_of, lags_of = _candidates(methods, regressors, seed)
    # The stress check reaches as far as the test inputs go beyond the training range: the
    # inputs the models will be run on are known (their outputs are not looked at).
    reach = max(float(stress), logs.input_reach(logs.tests)) if stress > 0 else 0.0
    if not math.isfinite(reach):
        raise ValueError(f"stress must be a finite number >= 0; got {stress!r}")
    ranks = {name: COMPLEXITY.get(method_of[name], 99) for name, _ in options}
    selection = _select(options, logs, ranks, reach, None, n_jobs, None, progress, adapt, True)
    table = selection.table
    tests = logs.tests
    reaches = {record.name: logs.outside_range(record) for record in tests}
    models, settings, rows = {}, {}, []
    runs: list[dict[str, ModelResult]] = [{} for _ in tests]
    seconds = _selection_seconds(table, method_of)
    fitted_names = set(selection.fitted)
    for method in dict.fromkeys(method_of.values()):
        pick = _method_pick(table, method, method_of, selection.chosen)
        name = str(pick["name"])
        settings[method] = {"candidate": name, "lags": repr(lags_of[name])}
        if pick["status"] == "rejected":
            continue  # no test run for a method whose every candidate was rejected
        started = time.perf_counter()
        models[method] = _fitted_on_all(selection, name, dict(options)[name], logs)
        for record, by_method in zip(tests, runs, strict=True):
            made, result = (
                _test_rows(method, models[method], record, reaches[record.name])
                if adapt is None
                else _adapted_test_rows(method, models[method], record, reaches[record.name], adapt)
            )
            rows.extend(made)
            if result is not None:
                by_method[method] = result
        seconds[method]["test"] = time.perf_counter() - started
    kept = {settings[m]["candidate"]: model for m, model in models.items()}
    selection.fitted.clear()  # the other candidates' models go
    selection.fitted.update({n: model for n, model in kept.items() if n in fitted_names})
    recommended = method_of[selection.chosen]
    reasons = [
        *selection.explain(),
        *(f"rejected {n}: {r}" for n, r in selection.rejected.items()),
    ]
    if adapt is not None:
        reasons.append(
            f"every free run, in the training folds and on the test logs: {adaptation_label(*adapt)}"
        )
    if reach > 0:
        reasons.append(
            f"stress check: every candidate run on the training inputs stretched {reach:.0%}"
            " beyond their range (at least as far as the test inputs go)"
        )
    return Comparison(
        selection,
        models,
        settings,
        pd.DataFrame(rows),
        recommended,
        reasons,
        runs,
        list(selection.warnings),
        "free run" if adapt is None else adaptation_label(*adapt),
        seconds,
    )
