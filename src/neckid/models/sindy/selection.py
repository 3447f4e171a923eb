"""The STLSQ threshold (and the library's degree) by the selection rule, on training data only.

Each candidate, a largest monomial degree and a threshold, is fitted on the fit part of every split of
:func:`neckid.data.folds.fold_plan` (time blocks of one record, or the other runs), scored by the
free-run fit [%] of the held-out part, and ranked by :func:`neckid.data.folds.rank_candidates`
(paired one standard error toward the candidate with fewer terms). A candidate whose free run
diverges on any fold is out.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from neckid.data.folds import fold_plan, rank_candidates
from neckid.data.iodata import IOData
from neckid.metrics import fit_percent
from neckid.utils.types import FloatArray

__all__ = ["DEFAULT_THRESHOLDS", "choose_threshold"]

#: Candidate thresholds ``λ`` on the scaled coefficients (share of the output's standard
#: deviation a function carries at its typical size), largest (sparsest) first.
DEFAULT_THRESHOLDS: tuple[float, ...] = (0.3, 0.1, 0.03, 0.01, 0.003, 0.001, 0.0003)

#: ``fit(records, (degree, threshold)) -> coef`` and ``run(coef, record) -> simulated outputs``.
Fitter = Callable[[Sequence[IOData], tuple[int, float]], FloatArray]
Runner = Callable[[FloatArray, IOData], FloatArray]


def _fold_fit(coef: FloatArray, fold: Sequence[IOData], run: Runner, skip: int) -> float:
    """Mean free-run fit [%] over a fold's records and outputs (``-inf`` on a runaway)."""
    fits = []
    for record in fold:
        if record.n_samples <= skip + 1:
            continue
        with np.errstate(all="ignore"):
            simulated = run(coef, record)
            fit = fit_percent(record.y, simulated, skip=skip)
        fits.append(float(np.mean(fit)) if np.all(np.isfinite(fit)) else -np.inf)
    return float(np.mean(fits)) if fits else -np.inf


def choose_threshold(
    experiments: Sequence[IOData],
    candidates: Sequence[tuple[int, float]],
    n_terms: Sequence[int],
    fit: Fitter,
    run: Runner,
    skip: int,
) -> tuple[tuple[int, float], dict[str, Any]]:
    """The chosen ``(degree, threshold)`` and a report of the selection.

    Parameters
    ----------
    experiments : sequence of IOData
        The training records (with the model's conditions as inputs).
    candidates : sequence of (int, float)
        Largest monomial degree and threshold of each candidate.
    n_terms : sequence of int
        Functions each candidate keeps on the whole training data (its simplicity).
    fit, run
        Fit a candidate on records; free-run a fitted candidate on a record.
    skip : int
        Initial samples of a free run (the model's largest lag).
    """
    plan = fold_plan(list(experiments))
    scores = np.full((len(candidates), plan.n_folds), -np.inf)
    column = 0
    for split in plan.splits:
        for i, candidate in enumerate(candidates):
            coef = fit(split.fit_on, candidate)
            for f, fold in enumerate(split.folds):
                scores[i, column + f] = _fold_fit(coef, fold, run, skip)
        column += len(split.folds)
    keys = [(int(k), d, -float(t)) for k, (d, t) in zip(n_terms, candidates, strict=True)]
    try:
        chosen = rank_candidates(scores, keys).chosen
        how = "paired one standard error toward fewer terms"
    except ValueError:  # every candidate ran away on some fold: the best finite mean
        counts = np.sum(np.isfinite(scores), axis=1)
        means = np.array(
            [np.mean(r[np.isfinite(r)]) if np.isfinite(r).any() else -1e300 for r in scores]
        )
        chosen = int(np.lexsort((-means, -counts))[0])
        how = "every candidate ran away on some fold: the most finite folds, then the best mean"
    mean_fit = [float(np.mean(row)) if np.all(np.isfinite(row)) else None for row in scores]
    report = {
        "degrees": [int(d) for d, _ in candidates],
        "thresholds": [float(t) for _, t in candidates],
        "n_terms": [int(k) for k in n_terms],
        "mean_fit": mean_fit,
        "chosen": float(candidates[chosen][1]),
        "chosen_degree": int(candidates[chosen][0]),
        "scheme": plan.scheme,
        "n_folds": int(plan.n_folds),
        "rule": how,
    }
    return (int(candidates[chosen][0]), float(candidates[chosen][1])), report
