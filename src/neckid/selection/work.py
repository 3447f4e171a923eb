"""What a selection's units of work are called and what they are expected to cost, for its progress.

A selection (:func:`neckid.selection.lags.score_candidates`) fits every candidate on every
split of the training logs. Its progress names the unit that runs in the user's words (the
method, the candidate, the fold) and estimates the time left from each unit's expected cost
(:func:`unit_cost`): the cost function the registry names for the candidate's method
(:attr:`~neckid.registry.Method.cost`, :mod:`neckid.selection.costs`), of the estimator's own
settings and the training data's size, or the method's constant
:attr:`~neckid.registry.Method.unit_cost` times the training samples for a method without one.
:class:`neckid.utils.progress.Plan` turns the costs into seconds at the seconds per cost unit of
the units done so far, and replaces a candidate's expected cost by the time of its first fold
once that is measured.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from typing import Any

from neckid.data.folds import Split
from neckid.data.iodata import IOData
from neckid.registry import Method, method_of

__all__ = ["progress_label", "progress_units", "unit_cost"]

#: The cost of a unit of a baseline (the training mean, a replay): nothing is fitted.
BASELINE_COST = 0.01

#: The cost of a unit of an estimator the registry does not know.
UNKNOWN_COST = 1.0


def _who(name: str, estimator: Any) -> str:
    """How the progress names a candidate: its method first."""
    method = method_of(estimator)
    if method is None:
        return name
    return name if name.split(" ")[0] == method.name else f"{method.name} {name}"


def _cost_function(method: Method) -> Callable[[Any, int, int], float] | None:
    if not method.cost:
        return None
    module, _, function = method.cost.partition(":")
    found: Callable[[Any, int, int], float] = getattr(importlib.import_module(module), function)
    return found


def _terms(estimator: Any, records: Sequence[IOData], method: Method) -> int:
    """The candidate's regressor terms on ``records`` (a lag-free model: the channels)."""
    channels = records[0].n_inputs + records[0].n_outputs if records else 1
    lags = estimator.get_params(deep=False).get("lags") if not method.lag_free else None
    if lags is None:
        return channels
    try:  # with its conditions as inputs, as the model adds them when it fits
        return int(lags.resolve(lags.conditioned(list(records))).n_terms)
    except (AttributeError, KeyError, TypeError, ValueError):  # the fit will say what is wrong
        return channels


def unit_cost(estimator: Any, records: Sequence[IOData], name: str = "") -> float:
    """The expected cost of fitting ``estimator`` on ``records`` (and scoring it), any unit.

    The registry's cost function of its method (:attr:`~neckid.registry.Method.cost`) from
    its settings, the training samples and the regressor terms; without one, the method's
    :attr:`~neckid.registry.Method.unit_cost` per sample; a baseline (``name`` starting with
    ``"baseline"``) and an estimator the registry does not know count per sample too.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, methods
    >>> runs = [IOData(np.ones(1000), np.arange(1000.0), ts=0.1)]
    >>> one = methods()["nn"].make(n_networks=1)
    >>> unit_cost(one, runs) < unit_cost(methods()["nn"].make(), runs)
    True
    """
    samples = sum(record.n_samples for record in records)
    method = method_of(estimator)
    if method is None:
        return (BASELINE_COST if name.startswith("baseline") else UNKNOWN_COST) * samples
    function = _cost_function(method)
    if function is None:
        return method.unit_cost * samples
    return float(function(estimator, samples, _terms(estimator, records, method)))


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
    >>> what, group, cost = units[1]
    >>> what, group, cost == unit_cost(methods()["ss"].make(), [runs[0]])
    ('ss, fold 2/2 (held out: run1)', 'ss', True)
    """
    units = []
    for name, estimator in candidates:
        who = _who(name, estimator)
        for j, split in enumerate(splits):
            count = f"{j + 1}/{len(splits)}"
            if len(split.folds) == 1:
                held = ", ".join(record.name or "a block" for record in split.folds[0])
                what = f"{who}, fold {count} (held out: {held})"
            else:
                what = f"{who}, fit {count}, scored on {len(split.folds)} folds"
            units.append((what, name, unit_cost(estimator, split.fit_on, name)))
    return units


def progress_label(n_candidates: int, splits: Sequence[Split]) -> str:
    """The task's label: ``"fitting and scoring 14 candidates on 6 folds"``."""
    n_folds = sum(len(split.folds) for split in splits)
    plural = "s" if n_candidates != 1 else ""
    return f"fitting and scoring {n_candidates} candidate{plural} on {n_folds} folds"
