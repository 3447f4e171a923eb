r"""Compiled loops of the polynomial nonlinear state-space model: free run and sensitivities.

All in the model's internal (normalised) units. With ``w(t) = [x(t); u(t)]`` (``n`` states,
``m`` inputs) and ``z = (w − center) / scale`` held in ``[low, high]``, ``ζ(t)`` are the
monomials of degree 2 … ``degree`` of the held ``z`` (rows ``1 + n + m`` on of the tables of
:func:`neckid.models.polynomial.monomial_tables`; monomial ``k`` is monomial ``parent[k]`` times
``z[var[k]]``):

.. math::

    x(t+1) = A x(t) + B u(t) + E ζ(t), \qquad y(t) = C x(t) + D u(t) + c + F ζ(t).

:func:`pnlss_sensitivity` runs the forward sensitivity recursion alongside the free run. With
``S(t) = ∂x(t)/∂θ_s`` (``θ_s`` the state-equation parameters ``A``, ``B``, ``E``; ``S = 0`` at
the initial state, which does not depend on ``θ``) and ``J(t) = ∂ζ/∂x`` (zero for a held
state),

.. math::

    S(t+1) = (A + E J(t))\, S(t) + \frac{\partial f}{\partial θ_s}\Big|_{x(t)}, \qquad
    \frac{\partial y(t)}{\partial θ} = (C + F J(t))\, S(t) + \frac{\partial g}{\partial θ}\Big|_{x(t)},

the exact Jacobian of the free-run error (Paduart et al. 2010, §4.2). Parameters are laid out
``[A, B, E, C, D, c, F]`` (each row-major). A run whose output leaves ``[limit_low,
limit_high]`` or whose state is no longer finite stops there: the rest of the outputs are set
to the limit it crossed (the upper one for NaN) with zero sensitivities, so a diverging trial
step of the optimiser shows as a large, finite error and is rejected.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from neckid.utils.types import FloatArray, IntArray

__all__ = ["pnlss_run", "pnlss_sensitivity"]


@njit(cache=True)
def _monomials(
    x: FloatArray,
    u: FloatArray,
    center: FloatArray,
    scale: FloatArray,
    low: FloatArray,
    high: FloatArray,
    parent: IntArray,
    var: IntArray,
    z: FloatArray,
    inside: FloatArray,
    phi: FloatArray,
) -> None:
    """``phi`` (all monomials of the held ``z``) and ``inside`` (1 where ``z`` is not held)."""
    n = x.shape[0]
    for j in range(z.shape[0]):
        w = x[j] if j < n else u[j - n]
        value = (w - center[j]) / scale[j]
        inside[j] = 1.0 if low[j] < value < high[j] else 0.0
        z[j] = min(max(value, low[j]), high[j])
    phi[0] = 1.0
    for k in range(1, parent.shape[0]):
        phi[k] = phi[parent[k]] * z[var[k]]


@njit(cache=True)
def _diverged(y: FloatArray, row: int, out: FloatArray, low: FloatArray, high: FloatArray) -> None:
    """Fill rows ``row`` on with the limit each output crossed (or its last value)."""
    for i in range(out.shape[0]):
        if out[i] < low[i]:
            out[i] = low[i]
        elif not out[i] <= high[i]:
            out[i] = high[i]
    for t in range(row, y.shape[0]):
        for i in range(out.shape[0]):
            y[t, i] = out[i]


@njit(cache=True)
def _output(
    x: FloatArray,
    ut: FloatArray,
    phi: FloatArray,
    c: FloatArray,
    d: FloatArray,
    offset: FloatArray,
    f: FloatArray,
    first: int,
    limit_low: FloatArray,
    limit_high: FloatArray,
    out: FloatArray,
) -> bool:
    """``out = C x + D u + c + F η``; whether an output left its limits."""
    n_nl = f.shape[1]
    bad = False
    for i in range(out.shape[0]):
        value = offset[i]
        for j in range(x.shape[0]):
            value += c[i, j] * x[j]
        for j in range(ut.shape[0]):
            value += d[i, j] * ut[j]
        for k in range(n_nl):
            value += f[i, k] * phi[first + k]
        out[i] = value
        if not limit_low[i] <= value <= limit_high[i]:
            bad = True
    return bad


@njit(cache=True)
def _next_state(
    x: FloatArray,
    ut: FloatArray,
    phi: FloatArray,
    a: FloatArray,
    b: FloatArray,
    e: FloatArray,
    first: int,
    new: FloatArray,
) -> None:
    """``new = A x + B u + E ζ``."""
    n_nl = e.shape[1]
    for i in range(x.shape[0]):
        value = 0.0
        for j in range(x.shape[0]):
            value += a[i, j] * x[j]
        for j in range(ut.shape[0]):
            value += b[i, j] * ut[j]
        for k in range(n_nl):
            value += e[i, k] * phi[first + k]
        new[i] = value


@njit(cache=True)
def pnlss_run(
    a: FloatArray,
    b: FloatArray,
    c: FloatArray,
    d: FloatArray,
    offset: FloatArray,
    e: FloatArray,
    f: FloatArray,
    u: FloatArray,
    x: FloatArray,
    center: FloatArray,
    scale: FloatArray,
    low: FloatArray,
    high: FloatArray,
    parent: IntArray,
    var: IntArray,
    limit_low: FloatArray,
    limit_high: FloatArray,
    y: FloatArray,
) -> int:
    """Free run over the rows of ``u`` from state ``x`` (updated in place), outputs into ``y``.

    Returns the row where the run left the limits (then ``y`` from there holds the limit), or
    ``-1``; with infinite limits it never stops and is the model's plain free run.
    """
    n, p, n_nl = a.shape[0], c.shape[0], e.shape[1]
    first = parent.shape[0] - n_nl
    z = np.empty(center.shape[0])
    inside = np.empty(center.shape[0])
    phi = np.empty(parent.shape[0])
    out = np.empty(p)
    new = np.empty(n)
    for t in range(u.shape[0]):
        ut = u[t]
        _monomials(x, ut, center, scale, low, high, parent, var, z, inside, phi)
        if _output(x, ut, phi, c, d, offset, f, first, limit_low, limit_high, out):
            _diverged(y, t, out, limit_low, limit_high)
            return t
        for i in range(p):
            y[t, i] = out[i]
        _next_state(x, ut, phi, a, b, e, first, new)
        for i in range(n):
            x[i] = new[i]
    return -1


@njit(cache=True)
def _state_jacobian(
    powers: IntArray,
    lower: IntArray,
    phi: FloatArray,
    inside: FloatArray,
    scale: FloatArray,
    first: int,
    n: int,
    out: FloatArray,
) -> None:
    """``out[k, j] = ∂ζ_k/∂x_j``: 0 where ``z_j`` is held."""
    for k in range(out.shape[0]):
        mono = first + k
        for j in range(n):
            below = lower[mono, j]
            if below >= 0 and inside[j] > 0.0:
                out[k, j] = powers[mono, j] * phi[below] / scale[j]
            else:
                out[k, j] = 0.0


@njit(cache=True)
def _advance(
    trans: FloatArray,
    sens: FloatArray,
    work: FloatArray,
    x: FloatArray,
    ut: FloatArray,
    phi: FloatArray,
    first: int,
    n_nl: int,
) -> None:
    """``S ← (A + E J) S + ∂f/∂θ_s`` in place (columns of ``A``, ``B``, ``E``)."""
    n, m, n_state = x.shape[0], ut.shape[0], sens.shape[1]
    o_b, o_e = n * n, n * (n + m)
    for i in range(n):
        for q in range(n_state):
            total = 0.0
            for j in range(n):
                total += trans[i, j] * sens[j, q]
            work[i, q] = total
        for j in range(n):
            work[i, i * n + j] += x[j]
        for j in range(m):
            work[i, o_b + i * m + j] += ut[j]
        for k in range(n_nl):
            work[i, o_e + i * n_nl + k] += phi[first + k]
    for i in range(n):
        for q in range(n_state):
            sens[i, q] = work[i, q]


@njit(cache=True)
def pnlss_sensitivity(
    a: FloatArray,
    b: FloatArray,
    c: FloatArray,
    d: FloatArray,
    offset: FloatArray,
    e: FloatArray,
    f: FloatArray,
    u: FloatArray,
    x: FloatArray,
    center: FloatArray,
    scale: FloatArray,
    low: FloatArray,
    high: FloatArray,
    parent: IntArray,
    var: IntArray,
    powers: IntArray,
    lower: IntArray,
    limit_low: FloatArray,
    limit_high: FloatArray,
    y: FloatArray,
    jacobian: FloatArray,
) -> int:
    """:func:`pnlss_run` and ``jacobian[t, i, q] = ∂y_i(t)/∂θ_q`` (``θ = [A, B, E, C, D, c, F]``)."""
    n, m, p, n_nl = a.shape[0], b.shape[1], c.shape[0], e.shape[1]
    first = parent.shape[0] - n_nl
    n_state = n * (n + m + n_nl)  # columns of A, B, E
    o_c = n_state
    o_d, o_off = o_c + p * n, o_c + p * (n + m)
    o_f = o_off + p
    z = np.empty(center.shape[0])
    inside = np.empty(center.shape[0])
    phi = np.empty(parent.shape[0])
    zeta_x = np.empty((n_nl, n))
    sens = np.zeros((n, n_state))
    sens_new = np.zeros((n, n_state))
    gain = np.empty((p, n))
    trans = np.empty((n, n))
    out = np.empty(p)
    new = np.empty(n)
    for t in range(u.shape[0]):
        ut = u[t]
        _monomials(x, ut, center, scale, low, high, parent, var, z, inside, phi)
        _state_jacobian(powers, lower, phi, inside, scale, first, n, zeta_x)
        if _output(x, ut, phi, c, d, offset, f, first, limit_low, limit_high, out):
            _diverged(y, t, out, limit_low, limit_high)
            return t
        for i in range(p):
            y[t, i] = out[i]
            for j in range(n):
                total = c[i, j]
                for k in range(n_nl):
                    total += f[i, k] * zeta_x[k, j]
                gain[i, j] = total
            for q in range(n_state):
                total = 0.0
                for j in range(n):
                    total += gain[i, j] * sens[j, q]
                jacobian[t, i, q] = total
            for j in range(n):
                jacobian[t, i, o_c + i * n + j] = x[j]
            for j in range(m):
                jacobian[t, i, o_d + i * m + j] = ut[j]
            jacobian[t, i, o_off + i] = 1.0
            for k in range(n_nl):
                jacobian[t, i, o_f + i * n_nl + k] = phi[first + k]
        _next_state(x, ut, phi, a, b, e, first, new)
        finite = True
        for i in range(n):
            for j in range(n):
                total = a[i, j]
                for k in range(n_nl):
                    total += e[i, k] * zeta_x[k, j]
                trans[i, j] = total
            finite = finite and np.isfinite(new[i])
        _advance(trans, sens, sens_new, x, ut, phi, first, n_nl)
        for i in range(n):
            x[i] = new[i]
        if not finite and t + 1 < u.shape[0]:
            out[:] = np.nan
            _diverged(y, t + 1, out, limit_low, limit_high)
            return t + 1
    return -1
