r"""Compiled loops of the polynomial NARX: the free run and its parameter sensitivities.

The monomials of degree <= d of the standardised regressor ``x̃ = (w − center) / scale`` are
built one product at a time: monomial ``m`` is monomial ``parent[m]`` times ``x̃[var[m]]``
(:func:`neckid.models.polynomial.monomials.monomial_tables`), so all of them cost one multiplication each. The derivative of
monomial ``m`` with respect to ``x̃_j`` is ``powers[m, j]`` times monomial ``lower[m, j]`` (the one
with one factor ``x̃_j`` fewer). The monomials of degree >= 2 are built from ``x̃`` held inside
its training range ``[low, high]``, the degree-1 ones from ``x̃`` itself: outside the data the
model continues linearly instead of growing like a cube.

:func:`poly_free_run` is the model's free run; :func:`poly_sensitivity` runs it and, alongside,
the forward sensitivity recursion of the simulated outputs to every coefficient,

.. math::

    \frac{\partial \hat y_c(t)}{\partial θ_{m c'}} = δ_{c c'} φ_m(t)
        + \sum_{j \in \text{output terms}} \frac{\partial f_c}{\partial x̃_j}
          \frac{1}{s_j} \frac{\partial \hat y_{ch(j)}(t − l_j)}{\partial θ_{m c'}},

the exact Jacobian of the simulation error that Levenberg–Marquardt needs (Ljung 1999, §10.3,
the gradient of an output-error criterion through the model's own recursion).

References
----------
L. Ljung, *System Identification: Theory for the User*, 2nd ed., Prentice Hall, 1999.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["poly_free_run", "poly_sensitivity"]

from neckid.utils.types import FloatArray, IntArray


@njit(cache=True)
def _regressor(
    y: FloatArray,
    u: FloatArray,
    t: int,
    source: IntArray,
    channel: IntArray,
    lag: IntArray,
    center: FloatArray,
    scale: FloatArray,
    low: FloatArray,
    high: FloatArray,
    raw: FloatArray,
    held: FloatArray,
) -> None:
    """The standardised regressor at ``t`` (``raw``) and the same held in ``[low, high]``."""
    for j in range(source.shape[0]):
        value = y[t - lag[j], channel[j]] if source[j] == 0 else u[t - lag[j], channel[j]]
        x = (value - center[j]) / scale[j]
        raw[j] = x
        held[j] = min(max(x, low[j]), high[j])


@njit(cache=True)
def _monomials(x: FloatArray, parent: IntArray, var: IntArray, out: FloatArray) -> None:
    out[0] = 1.0
    for m in range(1, parent.shape[0]):
        out[m] = out[parent[m]] * x[var[m]]


@njit(cache=True)
def poly_free_run(
    u: FloatArray,
    y: FloatArray,
    source: IntArray,
    channel: IntArray,
    lag: IntArray,
    center: FloatArray,
    scale: FloatArray,
    low: FloatArray,
    high: FloatArray,
    parent: IntArray,
    var: IntArray,
    coef: FloatArray,
    max_lag: int,
    limit_low: FloatArray,
    limit_high: FloatArray,
) -> None:
    """Free run in place: ``y[t]`` for ``t >= max_lag`` from ``u`` and the rows of ``y`` before.

    Outputs are clipped to ``[limit_low, limit_high]`` (NaN goes to ``limit_high``), as in
    :func:`poly_sensitivity`; pass infinite limits for the model's plain free run.
    """
    n_mono, n_out = coef.shape
    n_terms = source.shape[0]
    x = np.empty(n_terms)
    held = np.empty(n_terms)
    phi = np.empty(n_mono)
    for t in range(max_lag, u.shape[0]):
        _regressor(y, u, t, source, channel, lag, center, scale, low, high, x, held)
        _monomials(held, parent, var, phi)
        for j in range(n_terms):
            phi[1 + j] = x[j]  # the linear terms are never held
        for c in range(n_out):
            value = 0.0
            for m in range(n_mono):
                value += phi[m] * coef[m, c]
            if value < limit_low[c]:
                value = limit_low[c]
            elif not value <= limit_high[c]:
                value = limit_high[c]
            y[t, c] = value


@njit(cache=True)
def poly_sensitivity(
    u: FloatArray,
    y: FloatArray,
    source: IntArray,
    channel: IntArray,
    lag: IntArray,
    center: FloatArray,
    scale: FloatArray,
    low: FloatArray,
    high: FloatArray,
    parent: IntArray,
    var: IntArray,
    powers: IntArray,
    lower: IntArray,
    coef: FloatArray,
    max_lag: int,
    limit_low: FloatArray,
    limit_high: FloatArray,
    jacobian: FloatArray,
) -> None:
    """Free run in place (as :func:`poly_free_run`) and ``jacobian[t − max_lag, c, p]`` = ∂ŷ_c(t)/∂θ_p.

    ``p = m · n_outputs + c'`` indexes ``coef[m, c']``. A simulated output outside
    ``[limit_low, limit_high]`` is clipped there and its sensitivities set to 0: a diverging
    trial step of the optimiser then shows as a large but finite error, and is rejected.
    """
    n_mono, n_out = coef.shape
    n_terms = source.shape[0]
    x = np.empty(n_terms)
    held = np.empty(n_terms)
    phi = np.empty(n_mono)
    grad = np.zeros((n_terms, n_out))
    for t in range(max_lag, u.shape[0]):
        row = t - max_lag
        _regressor(y, u, t, source, channel, lag, center, scale, low, high, x, held)
        _monomials(held, parent, var, phi)  # phi of the held terms: what the derivatives use
        # ∂f_c/∂x̃_j for the output terms (inputs are fixed data), chain rule through 1/scale:
        # the linear coefficient, plus the higher monomials' where x̃_j is inside its range
        for j in range(n_terms):
            if source[j] != 0 or t - lag[j] < max_lag:
                continue
            inside = low[j] < x[j] < high[j]
            for c in range(n_out):
                total = coef[1 + j, c]
                if inside:
                    for m in range(1 + n_terms, n_mono):
                        k = lower[m, j]
                        if k >= 0:
                            total += coef[m, c] * powers[m, j] * phi[k]
                grad[j, c] = total / scale[j]
        for j in range(n_terms):
            phi[1 + j] = x[j]  # the linear terms are never held
        for c in range(n_out):
            value = 0.0
            for m in range(n_mono):
                value += phi[m] * coef[m, c]
            if value < limit_low[c] or not value <= limit_high[c]:
                y[t, c] = limit_low[c] if value < limit_low[c] else limit_high[c]
                continue
            y[t, c] = value
            for m in range(n_mono):
                jacobian[row, c, m * n_out + c] = phi[m]
            for j in range(n_terms):
                past = t - lag[j]
                if source[j] != 0 or past < max_lag:
                    continue
                g = grad[j, c]
                if g == 0.0:
                    continue
                jacobian[row, c, :] += g * jacobian[past - max_lag, channel[j], :]
