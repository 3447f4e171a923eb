r"""The polynomial state-space model linearised at rest: its Jacobian at the equilibrium.

A :class:`~neckid.models.pnlss.model.PolynomialStateSpace` runs, in its internal units
(:math:`v = (u - u_c) / u_s`, :math:`y = y_c + y_s\,w`),

.. math:: x(t+1) = A x + B v + E\,\zeta(x, v), \qquad w(t) = C x + D v + c + F\,\zeta(x, v),

:math:`\zeta` the monomials of degree 2 … ``degree`` of :math:`z = ([x; v] - \text{center}) /
\text{scale}` held in :math:`[\text{low}, \text{high}]`. With the inputs held at the middle of
their training range (:math:`u = u_c`, :math:`v = 0`) the free run settles at an equilibrium
:math:`x^*`; for small deviations around it the model is the linear state space

.. math:: \delta x(t+1) = (A + E J_x)\,\delta x + (B + E J_v)\,\delta v, \qquad
   \delta w(t) = (C + F J_x)\,\delta x + (D + F J_v)\,\delta v,

:math:`J_x, J_v` the exact derivatives of :math:`\zeta` at :math:`(x^*, 0)` (zero in a variable
held at its window's edge), written here in the output units (:math:`\delta u = u_s\,\delta v`,
:math:`\delta y = y_s\,\delta w`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from neckid.models.results import check_is_fitted
from neckid.utils.types import FloatArray

__all__ = ["Linearisation", "linearise"]

#: Samples of constant input the free run is given to settle at its equilibrium, per attempt.
SETTLE_SAMPLES = 2000

#: Largest change of the state over the last sample (relative to its size) counted as settled.
SETTLE_TOLERANCE = 1e-10


@dataclass(frozen=True)
class Linearisation:
    """A linear state space around an equilibrium, in the model's output units.

    Attributes
    ----------
    a, b, c, d : ndarray
        ``δx(t+1) = a δx + b δu``, ``δy(t) = c δx + d δu``.
    state : ndarray, shape (n,)
        The internal equilibrium state :math:`x^*`.
    inputs, outputs : ndarray
        The equilibrium input (the middle of the training range) and output.
    """

    a: FloatArray
    b: FloatArray
    c: FloatArray
    d: FloatArray
    state: FloatArray
    inputs: FloatArray
    outputs: FloatArray


def _equilibrium(model: Any) -> tuple[FloatArray, FloatArray]:
    """``(x*, y*)``: where the free run with every input at the middle of its range settles."""
    u = np.tile(model.u_center_, (SETTLE_SAMPLES, 1))
    x = np.zeros(int(model.order_))
    for _ in range(5):
        y = model.run(u, x)
        before = x.copy()
        last = model.run(u[:1], x)[0]
        change = float(np.max(np.abs(x - before), initial=0.0))
        if np.all(np.isfinite(x)) and change <= SETTLE_TOLERANCE * (1.0 + np.abs(x).max()):
            return x, np.asarray(last, dtype=np.float64)
        if not np.all(np.isfinite(y)):
            break
    raise ValueError(
        "the PolynomialStateSpace does not settle with its inputs held at the middle of their"
        " training range, so it has no equilibrium to linearise at there; use to_iosystem(model)"
        " for the nonlinear system"
    )


def _monomial_jacobian(model: Any, point: FloatArray) -> FloatArray:
    """``∂ζ_k/∂s_j`` at ``s = point`` (``[x; v]``): 0 where ``z_j`` is held at its window."""
    n, m = int(model.order_), model.n_inputs_
    powers = np.asarray(model.powers_, dtype=np.int64)  # the columns of E and F
    value = (point - model.center_) / model.scale_
    inside = (model.low_ < value) & (value < model.high_)
    z = np.clip(value, model.low_, model.high_)
    jacobian = np.zeros((powers.shape[0], n + m))
    for j in range(n + m):
        if not inside[j]:
            continue
        lowered = powers.copy()
        lowered[:, j] = np.maximum(lowered[:, j] - 1, 0)
        jacobian[:, j] = powers[:, j] * np.prod(z**lowered, axis=1) / model.scale_[j]
    return jacobian


def linearise(model: Any) -> Linearisation:
    """The model linearised at rest with its inputs at the middle of their training range.

    Parameters
    ----------
    model : PolynomialStateSpace
        Fitted.

    Returns
    -------
    Linearisation
        ``(a, b, c, d)`` in the output units (deviations from the equilibrium), the equilibrium
        state, input and output.

    Raises
    ------
    ValueError
        If the free run does not settle there (no equilibrium).
    """
    check_is_fitted(model)
    n = int(model.order_)
    a, b, c, d, _, e, f = model.matrices_
    state, outputs = _equilibrium(model)
    jacobian = _monomial_jacobian(model, np.concatenate([state, np.zeros(model.n_inputs_)]))
    jx, jv = jacobian[:, :n], jacobian[:, n:]
    u_scale, y_scale = model.u_scale_, model.y_scale_
    return Linearisation(
        a=a + e @ jx,
        b=(b + e @ jv) / u_scale[None, :],
        c=y_scale[:, None] * (c + f @ jx),
        d=y_scale[:, None] * (d + f @ jv) / u_scale[None, :],
        state=state,
        inputs=np.asarray(model.u_center_, dtype=np.float64).copy(),
        outputs=outputs,
    )
