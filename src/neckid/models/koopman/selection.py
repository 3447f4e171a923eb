"""The Koopman model's dictionary size and ridge penalty, chosen on the training logs only.

Every candidate ``(n_observables, ridge)`` of the grid is fitted on each fold's training part
and scored by its free-run fit [%] (mean over the outputs, the first ``max_lag`` samples the
initial conditions) on the part held out: the folds of :func:`neckid.data.folds.fold_plan`
(leave one log out, or time blocks of one log). A candidate that fails or runs away in a fold is
out; the paired one-standard-error rule (:func:`neckid.data.folds.rank_candidates`) then picks
the simplest candidate (fewer observables, then the larger penalty) within one standard error of
the best, or within half a point.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from neckid.data.folds import fold_plan, rank_candidates
from neckid.data.iodata import IOData

__all__ = ["RIDGES", "SIZES", "Choice", "choose"]

#: Dictionary sizes tried when ``n_observables`` is None (0: the delays alone, a linear model).
SIZES = (0, 10, 25, 50, 100)

#: Ridge penalties (per training row, on standardised regressors) tried when ``ridge`` is None.
RIDGES = (1e-8, 1e-6, 1e-4, 1e-2)


@dataclass(frozen=True)
class Choice:
    """The chosen candidate and how the rule got there.

    Attributes
    ----------
    n_observables : int
    ridge : float
    candidates : list of (int, float)
        Every candidate, in the order of ``means``.
    means : list of float
        Mean fold fit [%] (``-inf``: failed or ran away in a fold).
    explanation : str
        One sentence (:meth:`neckid.data.folds.Ranking.explain`).
    scheme : str
        The folds (``"time-blocks"``, ``"leave-one-experiment-out"``, ...).
    """

    n_observables: int
    ridge: float
    candidates: list[tuple[int, float]]
    means: list[float]
    explanation: str
    scheme: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (model files, ``info``)."""
        return {
            "n_observables": self.n_observables,
            "ridge": self.ridge,
            "candidates": [[int(n), float(r)] for n, r in self.candidates],
            "mean_fold_fits": [float(v) if np.isfinite(v) else None for v in self.means],
            "explanation": self.explanation,
            "scheme": self.scheme,
        }


def _fit_percent(y: np.ndarray, estimate: np.ndarray, start: int) -> float:
    """Mean over outputs of ``100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖)`` from sample ``start`` on."""
    y, estimate = y[start:], estimate[start:]
    if not np.all(np.isfinite(estimate)):
        return -np.inf
    error = np.linalg.norm(y - estimate, axis=0)
    spread = np.linalg.norm(y - y.mean(axis=0), axis=0)
    return float(np.mean(100.0 * (1.0 - error / np.where(spread > 0, spread, 1.0))))


def choose(
    train: Sequence[IOData],
    sizes: Sequence[int],
    ridges: Sequence[float],
    fit_fold: Callable[[Sequence[IOData], Sequence[int]], Callable[[int, float, IOData], Any]],
) -> Choice:
    """Score every ``(size, ridge)`` on the folds of ``train``; the paired rule's choice.

    ``fit_fold(records, sizes)`` prepares one fold's training part and returns
    ``run(size, ridge, held_out) -> (y_free_run, start)`` (raising ``ValueError`` or returning a
    non-finite run for a candidate that fails there).
    """
    plan = fold_plan(list(train))
    grid = [(int(n), float(r)) for n in sizes for r in ridges]
    scores = np.full((len(grid), plan.n_folds), -np.inf)
    column = 0
    for split in plan.splits:
        try:
            run = fit_fold(split.fit_on, sizes)
        except ValueError:
            column += len(split.folds)
            continue
        for held in split.folds:
            for i, (size, ridge) in enumerate(grid):
                try:
                    estimate, start = run(size, ridge, held[0])
                except ValueError:
                    continue
                scores[i, column] = _fit_percent(held[0].y, estimate, start)
            column += 1
    ranking = rank_candidates(scores, [(n, -r) for n, r in grid])
    names = [f"n_observables={n}, ridge={r:g}" for n, r in grid]
    size, ridge = grid[ranking.chosen]
    return Choice(
        size,
        ridge,
        grid,
        [float(v) for v in ranking.means],
        ranking.explain(names),
        plan.scheme,
    )
