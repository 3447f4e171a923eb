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
3. **One standard error toward the simpler model.** Among the rest, the best mean fold fit
   ``m*`` (free run, NRMSE %) and its standard error ``s* = std(fold fits) / sqrt(k)`` set a
   bar ``m* − s*``; the simplest candidate above it is chosen (Hastie, Tibshirani & Friedman
   2009, §7.10: the one-standard-error rule). Simplicity is :data:`COMPLEXITY` (linear ARX
   first), then fewer regressor terms.

:func:`compare` runs that selection over methods and lag sets (linear ARX always among them, the
reference), fits each method's best candidate on all training logs, and runs one free run per
test log: fit and RMSE, the share of samples outside the training range, and the band's kind,
width and coverage. The test logs are touched once, after every choice is made.

References
----------
T. Hastie, R. Tibshirani and J. Friedman, *The Elements of Statistical Learning*, 2nd ed.,
Springer, 2009, §7.10.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from sklearn.base import clone

from neckid.data.folds import (
    MIN_BLOCKS,
    fold_records,
    fold_statistics,
    one_standard_error,
    time_blocks,
)
from neckid.data.iodata import IOData, as_experiments
from neckid.metrics import coverage, fit_percent, mean_width, rmse
from neckid.models.bands import band_meaning
from neckid.models.base import DivergenceError, ModelResult
from neckid.registry import get_method
from neckid.regressors import Lags
from neckid.selection.lags import score_candidates

__all__ = [
    "COMPLEXITY",
    "Comparison",
    "SafeSelection",
    "compare",
    "input_reach",
    "select_safely",
    "stretched",
    "time_blocks",
]

#: How simple each method is, for the one-standard-error rule (smaller is simpler; a method
#: not listed counts as the most complex).
COMPLEXITY: Mapping[str, int] = {
    "arx": 0,
    "rls": 1,
    "scheduled": 1,
    "ss": 2,
    "greybox-neck": 2,
    "greybox-tanks": 2,
    "sm-linear": 2,
    "sm": 3,
    "sm-parallel": 3,
    "sm-multistep": 4,
    "poly": 4,
    "pnlss": 4,
    "sm-parallel-poly": 5,
    "nn": 6,
}

#: Methods whose regressor is not their lags (the subspace model: its order comes from the
#: singular values): one candidate each, not one per lag set.
LAG_FREE_METHODS = frozenset({"ss", "pnlss", "greybox-neck", "greybox-tanks"})


def input_reach(train: Sequence[IOData], tests: Sequence[IOData]) -> float:
    """How far the test inputs go beyond the training inputs' range, as a share of its half-width.

    0 when every test input stays inside; 0.5 when one goes half the half-width beyond an end
    (the ``stress`` of :func:`stretched` that reaches it). A constant training input is left out.

    Examples
    --------
    >>> import numpy as np
    >>> train = IOData(np.linspace(-1.0, 1.0, 20), np.zeros(20), ts=0.1)
    >>> input_reach([train], [IOData(np.linspace(-1.5, 0.0, 20), np.zeros(20), ts=0.1)])
    0.5
    """
    u = np.vstack([d.u for d in train])
    low, high = u.min(axis=0), u.max(axis=0)
    middle, half = 0.5 * (low + high), 0.5 * (high - low)
    varied = half > 0
    reach = 0.0
    for record in tests:
        if not record.n_samples or not varied.any():
            continue
        extent = np.abs(record.u - middle).max(axis=0)
        reach = max(reach, float(np.max(extent[varied] / half[varied] - 1.0)))
    return reach


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
        ``fold_fits`` (each fold's fit), ``status`` (``"chosen"``, ``"accepted"`` or
        ``"rejected"``) and ``reason`` (why rejected; empty otherwise). Best first.
    chosen : str
        The chosen candidate's name.
    scheme : str
        ``"leave-one-experiment-out"`` or ``"time-blocks"``.
    folds : list of list of str
        The held-out records of each fold.
    bar : float
        ``m* − s*``: the best mean fold fit minus its standard error.
    """

    table: pd.DataFrame
    chosen: str
    scheme: str
    folds: list[list[str]]
    bar: float

    @property
    def rejected(self) -> dict[str, str]:
        """Rejected candidate -> the reason."""
        rows = self.table[self.table["status"] == "rejected"]
        return dict(zip(rows["name"], rows["reason"], strict=True))


def _folds_of(train: list[IOData], n_blocks: int) -> tuple[list[IOData], str]:
    return fold_records(train, n_blocks)


def _n_terms(estimator: Any, data: IOData) -> int:
    lags = estimator.get_params().get("lags")
    return lags.resolve(data).n_terms if isinstance(lags, Lags) else 0


def _stress_reason(estimator: Any, train: list[IOData], stress: float) -> str:
    """Why the candidate fitted on all of ``train`` runs away on stretched inputs ('' if not)."""
    model = clone(estimator)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model.fit(train if len(train) > 1 else train[0])
            for record in train:
                model.simulate(stretched(record, stress))
    except DivergenceError as exc:
        return f"runs away with inputs {stress:.0%} beyond the training range: {exc}"
    except Exception as exc:  # a failing candidate is out, with the reason
        return f"fails on all training logs: {type(exc).__name__}: {exc}"
    return ""


def _ranked(rows: list[dict[str, Any]]) -> tuple[pd.DataFrame, str, float]:
    """Status and order by the one-standard-error rule; the chosen name and the bar."""
    try:
        pick, bar = one_standard_error(
            [float(row["fit_mean"]) for row in rows],
            [float(row["fit_se"]) for row in rows],
            [(row["complexity"], row["n_terms"]) for row in rows],
            [row["status"] != "rejected" for row in rows],
        )
    except ValueError:
        reasons = "; ".join(f"{row['name']}: {row['reason']}" for row in rows)
        raise ValueError(f"every candidate was rejected on the training logs ({reasons})") from None
    rows[pick]["status"] = "chosen"
    table = pd.DataFrame(rows).sort_values(["fit_mean"], ascending=False, kind="mergesort")
    return table.reset_index(drop=True), str(rows[pick]["name"]), bar


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
    experiments = as_experiments(train, "train")
    records, scheme = _folds_of(experiments, n_blocks)
    scored = score_candidates(
        options,
        records,
        criteria=["simulation"],
        n_initial=n_initial,
        n_jobs=n_jobs,
        backend=backend,
        progress=progress,
    )
    fold_fits = scored.attrs["fold_scores"]["fit_simulation"]
    ranks = [int((complexity or {}).get(name, 0)) for name in names]
    terms = [_n_terms(estimator, experiments[0]) for _, estimator in options]
    rows = []
    for i, (name, estimator) in enumerate(options):
        fits = np.asarray(fold_fits[i], dtype=np.float64)
        reason = str(scored.at[i, "error"])
        if not reason and stress > 0:
            reason = _stress_reason(estimator, experiments, stress)
        mean, se, worst = fold_statistics(fits)
        finite = bool(np.isfinite(mean))
        rows.append(
            {
                "name": name,
                "complexity": ranks[i],
                "n_terms": terms[i],
                "fit_mean": mean,
                "fit_se": se,
                "fit_worst": worst,
                "fold_fits": [float(f) for f in fits],
                "status": "rejected" if reason or not finite else "accepted",
                "reason": reason or ("" if finite else "a fold's fit is not finite"),
            }
        )
    table, chosen, bar = _ranked(rows)
    return SafeSelection(table, chosen, scheme, list(scored.attrs["folds"]), bar)


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
        run, %), ``rmse`` and ``unit``, ``outside_domain`` (share of samples outside the model's
        domain: :meth:`~neckid.models.base.Estimator.domain`), ``band`` (what it bounds, or empty), ``band_width``
        (mean, output units), ``band_coverage`` (share of measured samples inside), ``error``.
    recommended : str
        The method of the chosen candidate.
    reasons : list of str
        Why it is recommended (fold scores, rejected candidates, domain).
    runs : list of dict of str to ModelResult
        Per test log (in the order given), each method's free run (not the diverged ones).
    """

    selection: SafeSelection
    models: dict[str, Any]
    settings: dict[str, dict[str, Any]]
    results: pd.DataFrame
    recommended: str
    reasons: list[str] = field(default_factory=list)
    runs: list[dict[str, ModelResult]] = field(default_factory=list)

    def summary(self) -> pd.DataFrame:
        """Per method: the mean over test logs and outputs of fit, RMSE and outside share."""
        table = self.results.groupby("method", sort=False)[
            ["fit_percent", "rmse", "outside_domain"]
        ].mean()
        return table.reset_index()

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready summary: per method its settings, fold scores and test results."""
        methods = []
        table = self.selection.table.set_index("name")
        for method, setting in self.settings.items():
            row = table.loc[setting["candidate"]]
            tests = self.results[self.results["method"] == method]
            methods.append(
                {
                    "method": method,
                    "settings": setting,
                    "fold_fits": [_plain(f) for f in row["fold_fits"]],
                    "fit_mean_folds": _plain(row["fit_mean"]),
                    "status": row["status"],
                    "reason": row["reason"],
                    "tests": [
                        {k: _plain(v) for k, v in r.items() if k != "method"}
                        for r in tests.to_dict("records")
                    ],
                }
            )
        return {
            "recommended": self.recommended,
            "reasons": self.reasons,
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
    if getattr(model, "regressor_ranges_", None) and hasattr(model, "lags_"):
        return model.domain(data).share
    ranges: dict[str, tuple[float, float]] = getattr(model, "training_ranges_", {})
    outside = np.zeros(data.n_samples, dtype=bool)
    for name in (*data.input_names, *data.output_names):
        if name in ranges:
            low, high = ranges[name]
            values = data.channel(name)
            outside |= (values < low) | (values > high)
    return float(outside.mean()) if data.n_samples else 0.0


def _test_rows(
    method: str, model: Any, record: IOData
) -> tuple[list[dict[str, Any]], ModelResult | None]:
    """One free run of ``model`` on ``record``: a row per output, and the run (None if diverged)."""
    base = {"method": method, "log": record.name or "test", "error": ""}
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


def _method_pick(
    table: pd.DataFrame, method: str, method_of: Mapping[str, str], chosen: str
) -> pd.Series:
    """The candidate of ``method`` that is run on the test logs.

    The recommended method runs the chosen candidate; every other method its own choice by the
    same rule among its accepted candidates (one standard error toward fewer terms); a method
    whose every candidate was rejected, its best rejected row (not run).
    """
    own = table[[method_of[n] == method for n in table["name"]]]
    if method_of[chosen] == method:
        return own[own["name"] == chosen].iloc[0]
    usable = own[own["status"] != "rejected"]
    if not len(usable):
        return own.iloc[0]
    pick, _ = one_standard_error(
        usable["fit_mean"].tolist(),
        usable["fit_se"].tolist(),
        list(zip(usable["complexity"], usable["n_terms"], strict=True)),
        [True] * len(usable),
    )
    return usable.iloc[pick]


def _candidates(
    methods: Sequence[str], lags: Sequence[Lags], seed: int
) -> tuple[list[tuple[str, Any]], dict[str, str], dict[str, Lags]]:
    """(name, estimator) for every method and lag set; name -> method; name -> lags."""
    chosen = list(dict.fromkeys(["arx", *methods]))  # ARX always, first: the reference
    options, method_of, lags_of = [], {}, {}
    for method in chosen:
        entry = get_method(method)
        for regressor in lags[:1] if method in LAG_FREE_METHODS else lags:
            several = len(lags) > 1 and method not in LAG_FREE_METHODS
            name = f"{method} {regressor!r}" if several else method
            estimator = entry.make(regressor)
            if "random_state" in estimator.get_params():
                estimator.set_params(random_state=seed)
            options.append((name, estimator))
            method_of[name], lags_of[name] = method, regressor
    return options, method_of, lags_of


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
    experiments = as_experiments(train, "train")
    tests = as_experiments(test, "test")
    as_experiments([experiments[0], tests[0]], "[train[0], test[0]]")
    options, method_of, lags_of = _candidates(methods, regressors, seed)
    # The stress check reaches as far as the test inputs go beyond the training range: the
    # inputs the models will be run on are known (their outputs are not looked at).
    reach = max(float(stress), input_reach(experiments, tests)) if stress > 0 else 0.0
    selection = select_safely(
        options,
        experiments,
        n_blocks=n_blocks,
        stress=reach,
        complexity={name: COMPLEXITY.get(method_of[name], 99) for name, _ in options},
        n_jobs=n_jobs,
        progress=progress,
    )
    table = selection.table
    models, settings, rows = {}, {}, []
    runs: list[dict[str, ModelResult]] = [{} for _ in tests]
    for method in dict.fromkeys(method_of.values()):
        pick = _method_pick(table, method, method_of, selection.chosen)
        name = str(pick["name"])
        settings[method] = {"candidate": name, "lags": repr(lags_of[name])}
        if pick["status"] == "rejected":
            continue  # no test run for a method whose every candidate was rejected
        estimator = clone(dict(options)[name])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            models[method] = estimator.fit(experiments if len(experiments) > 1 else experiments[0])
        for record, by_method in zip(tests, runs, strict=True):
            made, result = _test_rows(method, models[method], record)
            rows.extend(made)
            if result is not None:
                by_method[method] = result
    recommended = method_of[selection.chosen]
    chosen = table[table["name"] == selection.chosen].iloc[0]
    reasons = [
        f"{selection.chosen}: mean fold fit {chosen['fit_mean']:.1f} % (free run,"
        f" {selection.scheme}, {len(selection.folds)} folds); the simplest candidate within one"
        f" standard error of the best ({selection.bar:.1f} %)",
        *(f"rejected {n}: {r}" for n, r in selection.rejected.items()),
    ]
    if reach > 0:
        reasons.append(
            f"stress check: every candidate run on the training inputs stretched {reach:.0%}"
            " beyond their range (at least as far as the test inputs go)"
        )
    return Comparison(selection, models, settings, pd.DataFrame(rows), recommended, reasons, runs)
