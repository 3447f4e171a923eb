"""The compiled free run of a sparse NARX: every monomial built by one product, the kept ones summed.

The library's monomials come first, in the graded order of
:func:`neckid.models.polynomial.monomials.monomial_tables`: monomial ``m`` is monomial
``parent[m]`` times term ``var[m]``, so all of them cost one multiplication each per step (the
ones of degree >= 2 from the terms held in their range, the linear ones from the terms as they
are). Sines and cosines of one term are evaluated for the kept ones only. User functions are
Python code and run through the model's Python loop instead.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from neckid.utils.types import FloatArray, IntArray

__all__ = ["sparse_free_run"]


@njit(cache=True)
def sparse_free_run(
    u: FloatArray,
    y: FloatArray,
    source: IntArray,
    channel: IntArray,
    lag: IntArray,
    parent: IntArray,
    var: IntArray,
    kept: IntArray,
    kind: IntArray,
    term: IntArray,
    frequency: FloatArray,
    coef: FloatArray,
    max_lag: int,
    hold_low: FloatArray,
    hold_high: FloatArray,
    low: FloatArray,
    high: FloatArray,
) -> None:
    """Free-run ``y`` in place from row ``max_lag`` on: ``y(t) = Σ_i coef[i] θ_{kept[i]}(w(t))``.

    ``parent`` and ``var`` are the monomial tables of the library's monomials; per kept function
    ``i``: its library row ``kept[i]``, ``kind[i]`` (0 monomial, 1 sin, 2 cos), the term
    ``term[i]`` and ``frequency[i]`` of a sine or cosine, and ``coef[i]``. The monomials of
    degree >= 2 take the terms held in ``[hold_low, hold_high]``; each simulated output is
    clipped into ``[low, high]`` (``±inf``: not clipped).
    """
    n_terms = source.shape[0]
    n_mono = parent.shape[0]
    x = np.empty(n_terms)
    held = np.empty(n_terms)
    phi = np.empty(n_mono)
    for t in range(max_lag, y.shape[0]):
        for j in range(n_terms):
            if source[j] == 0:
                x[j] = y[t - lag[j], channel[j]]
            else:
                x[j] = u[t - lag[j], channel[j]]
            held[j] = min(max(x[j], hold_low[j]), hold_high[j])
        phi[0] = 1.0
        for m in range(1, n_mono):
            phi[m] = phi[parent[m]] * held[var[m]]
        for j in range(min(n_terms, n_mono - 1)):
            phi[1 + j] = x[j]  # the linear terms are never held
        for o in range(y.shape[1]):
            y[t, o] = 0.0
        for i in range(kept.shape[0]):
            if kind[i] == 0:
                value = phi[kept[i]]
            elif kind[i] == 1:
                value = np.sin(frequency[i] * x[term[i]])
            else:
                value = np.cos(frequency[i] * x[term[i]])
            for o in range(y.shape[1]):
                y[t, o] += coef[i, o] * value
        for o in range(y.shape[1]):
            y[t, o] = min(max(y[t, o], low[o]), high[o])
