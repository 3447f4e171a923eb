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

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from neckid.utils.types import BoolArray, FloatArray

__all__ = ["Normal", "Sums", "independent_columns", "stlsq"]

#: Relative size (of QR's ``|R_kk|``) below which a column counts as a combination of the earlier ones.
RANK_TOLERANCE = 1e-6


#: Rows of the library evaluated at a time while its Gram matrix is summed (bounds the memory).
CHUNK_ROWS = 16_384


@dataclass(frozen=True)
class Sums:
    """Sums over rows of the raw library columns ``Θ`` and outputs ``y``: ``ΘᵀΘ``, ``Θᵀy``, ``Σy``, ``Σy²``, ``N``.

    They add over records, so a selection split's normal equations are the sum of its records'.
    """

    gram: FloatArray
    rhs: FloatArray
    y_sum: FloatArray
    y_square: FloatArray
    n: int

    def __add__(self, other: Sums) -> Sums:
        return Sums(
            self.gram + other.gram,
            self.rhs + other.rhs,
            self.y_sum + other.y_sum,
            self.y_square + other.y_square,
            self.n + other.n,
        )

    @classmethod
    def of_rows(
        cls,
        columns: Callable[[FloatArray], FloatArray],
        x: FloatArray,
        y: FloatArray,
        weights: FloatArray | None = None,
    ) -> Sums:
        """The sums of rows ``x`` (library ``columns(x)``), chunk by chunk; ``weights`` per row."""
        p = columns(x[:1]).shape[1]
        gram, rhs = np.zeros((p, p)), np.zeros((p, y.shape[1]))
        for first in range(0, x.shape[0], CHUNK_ROWS):
            theta = columns(x[first : first + CHUNK_ROWS])
            target = y[first : first + CHUNK_ROWS]
            if weights is not None:
                w = weights[first : first + CHUNK_ROWS, None]
                gram += theta.T @ (theta * w)
                rhs += theta.T @ (target * w)
            else:
                gram += theta.T @ theta
                rhs += theta.T @ target
        w_all = np.ones(x.shape[0]) if weights is None else weights
        return cls(gram, rhs, w_all @ y, w_all @ y**2, round(float(w_all.sum())))

    def column_rms(self) -> FloatArray:
        """Root mean square of each library column (1 where it is 0)."""
        rms = np.sqrt(np.maximum(np.diag(self.gram), 0.0) / max(self.n, 1))
        return np.where(rms > 0, rms, 1.0)

    def y_std(self) -> FloatArray:
        """Standard deviation of each output (1 where it is 0)."""
        n = max(self.n, 1)
        var = np.maximum(self.y_square / n - (self.y_sum / n) ** 2, 0.0)
        sd = np.sqrt(var)
        return np.where(sd > 0, sd, 1.0)

    def normal(self, scale: FloatArray, y_scale: FloatArray) -> Normal:
        """The scaled normal equations, columns divided by ``scale``, outputs by ``y_scale``."""
        n = max(self.n, 1)
        gram = self.gram / np.outer(scale, scale) / n
        rhs = self.rhs / scale[:, None] / y_scale[None, :] / n
        return Normal(gram, rhs)


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


def independent_columns(gram: FloatArray) -> BoolArray:
    """The columns that are not, to 1e-6, combinations of the ones before them (library order).

    From the scaled Gram matrix (unit diagonal): a Cholesky factorisation in order, a column
    whose remaining variance ``d_k`` (the square of QR's ``|R_kk|`` over ``N``) is below
    ``RANK_TOLERANCE²`` left out (a condition with two values in training makes its square such
    a combination).

    Examples
    --------
    >>> g = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    >>> independent_columns(g).tolist()
    [True, False, True]
    """
    p = gram.shape[0]
    factor = np.zeros((p, p))
    keep = np.zeros(p, dtype=bool)
    for k in range(p):
        row = factor[k, :k]
        d = gram[k, k] - row @ row
        if d <= RANK_TOLERANCE**2 * max(gram[k, k], 1e-300):
            continue
        keep[k] = True
        factor[k, k] = np.sqrt(d)
        rest = np.arange(k + 1, p)
        factor[rest, k] = (gram[rest, k] - factor[rest, :k] @ row) / factor[k, k]
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
