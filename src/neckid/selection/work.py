"""What a selection's units of work are called and what they are expected to cost, for its progress.

A selection (:func:`neckid.selection.lags.score_candidates`) fits every candidate on every
split of the training logs. Its progress names the unit that runs in the user's words (the
method, the candidate, the fold) and estimates the time left from each unit's expected cost:
the registry's :attr:`~neckid.registry.Method.unit_cost` of the candidate's method times the
training samples it is fitted on (:class:`neckid.utils.progress.Plan` then replaces a
candidate's expected cost by the time of its first fold once that is measured).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from neckid.data.folds import Split
from neckid.registry import method_of

__all__ = ["progress_label", "progress_units"]

#: The cost of a unit of a baseline (the training mean, a replay): nothing is fitted.
BASELINE_COST = 0.01

#: The cost of a unit of an estimator the registry does not know.
UNKNOWN_COST = 1.0


def _who(name: str, estimator: Any) -> tuple[str, float]:
    """How the progress names a candidate (its method first) and its unit cost per sample."""
    method = method_of(estimator)
    if method is None:
        return name, BASELINE_COST if name.startswith("baseline") else UNKNOWN_COST
    shown = name if name.split(" ")[0] == method.name else f"{method.name} {name}"
    return shown, method.unit_cost


def progress_units(
    candidates: Sequence[tuple[str, Any]], splits: Sequence[Split]
) -> list[tuple[str, str, float]]:
    """``(what, group, cost)`` of every unit, candidate by candidate, split by split.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, methods
    >>> runs = [IOData(np.ones(100), np.arange(100.0), ts=0.1, name=f"run{i}") for i in (1, 2)]
    >>> splits = [Split((runs[0],), ((runs[1],),)), Split((runs[1],), ((runs[0],),))]
    >>> units = progress_units([("ss", methods()["ss"].make())], splits)
    >>> units[1]
    ('ss, fold 2/2 (held out: run1)', 'ss', 30.0)
    """
    units = []
    for name, estimator in candidates:
        who, cost = _who(name, estimator)
        for j, split in enumerate(splits):
            count = f"{j + 1}/{len(splits)}"
            if len(split.folds) == 1:
                held = ", ".join(record.name or "a block" for record in split.folds[0])
                what = f"{who}, fold {count} (held out: {held})"
            else:
                what = f"{who}, fit {count}, scored on {len(split.folds)} folds"
            samples = sum(record.n_samples for record in split.fit_on)
            units.append((what, name, cost * samples))
    return units


def progress_label(n_candidates: int, splits: Sequence[Split]) -> str:
    """The task's label: ``"fitting and scoring 14 candidates on 6 folds"``."""
    n_folds = sum(len(split.folds) for split in splits)
    plural = "s" if n_candidates != 1 else ""
    return f"fitting and scoring {n_candidates} candidate{plural} on {n_folds} folds"
