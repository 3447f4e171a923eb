r"""Sequentially thresholded least squares (STLSQ) on scaled library columns.

With the library columns ``Θ`` scaled to unit root mean square (``Θ̃ = Θ / s``) and the outputs to
unit standard deviation (``ỹ = y / σ``), STLSQ (Brunton, Proctor & Kutz 2016) solves

.. math::

    ξ̃ = \arg\min \|Θ̃ ξ − ỹ\|² + α \|ξ\|², \quad \text{then repeatedly:}\;
    ξ̃_k = 0 \text{ where } |ξ̃_k| < λ, \text{ least squares again on the rest,}

until the kept set stops changing. On the scaled columns ``|ξ̃_k|`` is the share of the output's
standard deviation that function ``k`` carries at its typical size, so one threshold ``λ`` means
the same on every channel and unit. Everything here works on the Gram matrix ``Θ̃ᵀΘ̃ / N`` and
``Θ̃ᵀỹ / N``: a fit of a subset of functions costs a solve of its size, whatever ``N``.

References
----------
S. L. Brunton, J. L. Proctor, J. N. Kutz, "Discovering governing equations from data by sparse
identification of nonlinear dynamical systems", PNAS 113(15), 3932-3937, 2016.
L. Zhang, H. Schaeffer, "On the convergence of the SINDy algorithm", Multiscale Modeling &
Simulation 17(3), 948-972, 2019 (STLSQ stops after at most as many steps as functions).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from neckid.utils.types import BoolArray, FloatArray

__all__ = ["Normal", "independent_columns", "stlsq"]

#: Relative size below which a scaled column counts as a combination of the ones before it.
RANK_TOLERANCE = 1e-7


@dataclass(frozen=True)
class Normal:
    """The normal equations of the scaled problem: ``gram = Θ̃ᵀΘ̃ / N``, ``rhs = Θ̃ᵀỹ / N``."""

    gram: FloatArray
    rhs: FloatArray

    @classmethod
    def from_columns(cls, scaled: FloatArray, target: FloatArray) -> Normal:
        """From the scaled columns ``(N, p)`` and scaled targets ``(N, n_outputs)``."""
        n = max(scaled.shape[0], 1)
        return cls(scaled.T @ scaled / n, scaled.T @ target / n)


def independent_columns(scaled: FloatArray) -> BoolArray:
    """The columns (unit RMS each) that are not, to 1e-7, combinations of the ones before them.

    Read off the triangular factor of a QR decomposition in library order: ``|R_kk|`` is the
    part of column ``k`` orthogonal to the columns before it (a condition with two values in
    training makes its square such a combination).
    """
    r = scipy.linalg.qr(scaled, mode="r", check_finite=False)[0]
    diag = np.abs(np.diag(r))[: scaled.shape[1]]
    keep = np.zeros(scaled.shape[1], dtype=bool)
    keep[: diag.size] = diag > RANK_TOLERANCE * np.sqrt(max(scaled.shape[0], 1))
    return keep


def _solve(normal: Normal, kept: BoolArray, output: int, ridge: float) -> FloatArray:
    """Ridge least squares of one output on the ``kept`` columns (zeros elsewhere)."""
    xi = np.zeros(kept.size)
    index = np.flatnonzero(kept)
    if index.size == 0:
        return xi
    gram = normal.gram[np.ix_(index, index)] + ridge * np.eye(index.size)
    xi[index] = scipy.linalg.lstsq(gram, normal.rhs[index, output], check_finite=False)[0]
    return xi


def stlsq(
    normal: Normal,
    threshold: float,
    allowed: BoolArray,
    *,
    ridge: float = 0.0,
    max_iter: int = 20,
) -> FloatArray:
    """STLSQ of every output: the scaled coefficients ``ξ̃``, ``(n_functions, n_outputs)``.

    Parameters
    ----------
    normal : Normal
        The scaled normal equations.
    threshold : float
        ``λ``: a scaled coefficient below it in magnitude is set to zero.
    allowed : ndarray of bool, shape (n_functions,)
        The functions the regression may use (the independent ones).
    ridge : float, default 0
        ``α`` (on the scaled problem, where the Gram matrix has a unit diagonal).
    max_iter : int, default 20
        Largest number of thresholding steps.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> theta = rng.normal(size=(500, 4))
    >>> y = theta @ np.array([[1.0], [0.0], [0.5], [0.0]])
    >>> xi = stlsq(Normal.from_columns(theta, y), 0.1, np.ones(4, dtype=bool))
    >>> np.flatnonzero(xi[:, 0]).tolist()
    [0, 2]
    """
    n_out = normal.rhs.shape[1]
    out = np.zeros((allowed.size, n_out))
    for o in range(n_out):
        kept = allowed.copy()
        xi = _solve(normal, kept, o, ridge)
        for _ in range(max_iter):
            small = kept & (np.abs(xi) < threshold)
            if not small.any():
                break
            kept &= ~small
            xi = _solve(normal, kept, o, ridge)
        out[:, o] = xi
    return out
