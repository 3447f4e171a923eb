"""The compiled free run of a sparse NARX: only the functions it kept, evaluated at each step.

Each kept library function is a monomial of the raw regressor terms, or ``sin``/``cos`` of one
term (:mod:`neckid.models.sindy.library`; user functions are Python code and run through the
generic loop of :class:`~neckid.models.base.NarxModel` instead).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from neckid.utils.types import FloatArray, IntArray

__all__ = ["sparse_free_run"]


@njit(cache=True)
def _function(
    x: FloatArray, held: FloatArray, kind: int, powers: IntArray, var: int, frequency: float
) -> float:
    """One library function at the regressor ``x`` (kind 0 monomial, 1 sin, 2 cos).

    A monomial of degree >= 2 takes the terms ``held`` in their range; a linear one ``x``.
    """
    if kind == 1:
        return np.sin(frequency * x[var])
    if kind == 2:
        return np.cos(frequency * x[var])
    degree = 0
    for j in range(powers.shape[0]):
        degree += powers[j]
    source = x if degree < 2 else held
    value = 1.0
    for j in range(powers.shape[0]):
        for _ in range(powers[j]):
            value *= source[j]
    return value


@njit(cache=True)
def sparse_free_run(
    u: FloatArray,
    y: FloatArray,
    source: IntArray,
    channel: IntArray,
    lag: IntArray,
    kind: IntArray,
    powers: IntArray,
    var: IntArray,
    frequency: FloatArray,
    coef: FloatArray,
    max_lag: int,
    hold_low: FloatArray,
    hold_high: FloatArray,
    low: FloatArray,
    high: FloatArray,
) -> None:
    """Free-run ``y`` in place from row ``max_lag`` on: ``y(t) = Σ_k coef[k] θ_k(w(t))``.

    ``kind``, ``powers``, ``var``, ``frequency`` and ``coef`` hold the kept functions only;
    the monomials of degree >= 2 take each term held in ``[hold_low, hold_high]``; each simulated
    output is clipped into ``[low, high]`` (``±inf``: not clipped).
    """
    n_terms = source.shape[0]
    x = np.empty(n_terms)
    held = np.empty(n_terms)
    for t in range(max_lag, y.shape[0]):
        for j in range(n_terms):
            if source[j] == 0:
                x[j] = y[t - lag[j], channel[j]]
            else:
                x[j] = u[t - lag[j], channel[j]]
            held[j] = min(max(x[j], hold_low[j]), hold_high[j])
        for o in range(y.shape[1]):
            y[t, o] = 0.0
        for k in range(kind.shape[0]):
            value = _function(x, held, kind[k], powers[k], var[k], frequency[k])
            for o in range(y.shape[1]):
                y[t, o] += coef[k, o] * value
        for o in range(y.shape[1]):
            y[t, o] = min(max(y[t, o], low[o]), high[o])
