r"""Sufficient statistics of a least-squares fit, kept so that new rows update it exactly.

A batch least-squares ARX (:class:`~neckid.LinearARX`) is determined by the number of rows, the
column means and the centred scatter matrix ``Z_cᵀ Z_c`` of ``Z = [X  Y]`` (regressors beside
targets): ``X_cᵀX_c`` and ``X_cᵀY_c`` are its blocks. :class:`LeastSquaresStatistics` keeps them
in square-root form, an upper-triangular ``R`` with ``RᵀR = Z_cᵀ Z_c`` (the ``R`` of a QR
factorisation of ``Z_c``), so that solving never forms the normal equations (whose condition
number is the square of the data's), and merges two sets of rows exactly: the statistics of
``fit([a, b])`` are those of ``a`` merged with those of ``b``.

References
----------
T. F. Chan, G. H. Golub and R. J. LeVeque, "Updating formulae and a pairwise algorithm for
computing sample variances", Stanford report STAN-CS-79-773, 1979 (merging centred scatter
matrices).

G. H. Golub and C. F. Van Loan, *Matrix Computations*, 4th ed., Johns Hopkins, 2013,
section 6.5 (updating a QR factorisation by appending rows; least squares from ``R``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from neckid.utils.types import FloatArray

__all__ = ["LeastSquaresStatistics"]


def _upper_factor(rows: FloatArray) -> FloatArray:
    """The square upper-triangular ``R`` of ``rows`` (``RᵀR = rowsᵀ rows``), zero-padded."""
    width = rows.shape[1]
    factor = np.zeros((0, width))
    if rows.shape[0]:
        factor = np.asarray(np.linalg.qr(rows, mode="r"), dtype=np.float64)
    square = np.zeros((width, width))
    square[: factor.shape[0]] = factor[:width]
    return square


@dataclass(frozen=True)
class LeastSquaresStatistics:
    r"""Rows, means and the square-root scatter of ``[X  Y]``: all a least-squares fit needs.

    Attributes
    ----------
    n_rows : int
        Number of rows seen.
    x_mean : ndarray, shape (n_terms,)
        Mean of the regressor rows (zeros when ``centred`` is False).
    y_mean : ndarray, shape (n_outputs,)
        Mean of the targets (zeros when ``centred`` is False).
    factor : ndarray, shape (n_terms + n_outputs, n_terms + n_outputs)
        Upper-triangular ``R`` with ``RᵀR = Σ (z − z̄)(z − z̄)ᵀ`` over the rows ``z = [x, y]``
        (``z̄`` = 0 when not centred).
    centred : bool
        Whether the rows are centred on their means (a fit with an intercept).

    Notes
    -----
    With ``R = [[R_xx, R_xy], [0, R_yy]]``, ``‖X_c b − Y_c‖² = ‖R_xx b − R_xy‖² + ‖R_yy‖²``, so
    the least-squares coefficients solve the small triangular problem ``R_xx b ≈ R_xy``.

    Merging two centred sets ``a`` and ``b`` (Chan, Golub & LeVeque, 1979): with
    ``δ = z̄_b − z̄_a`` and ``n = n_a + n_b``,
    ``S = S_a + S_b + (n_a n_b / n) δ δᵀ``, i.e. ``R`` is the triangular factor of the rows
    ``[R_a; R_b; √(n_a n_b / n) δᵀ]``, and ``z̄ = (n_a z̄_a + n_b z̄_b) / n``. Uncentred sets just
    stack ``[R_a; R_b]``. Both are exact: merging equals computing the statistics of all rows
    at once, up to rounding.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> x, y = rng.normal(size=(50, 2)), rng.normal(size=(50, 1))
    >>> whole = LeastSquaresStatistics.from_rows(x, y)
    >>> parts = LeastSquaresStatistics.from_rows(x[:20], y[:20]).merge(
    ...     LeastSquaresStatistics.from_rows(x[20:], y[20:]))
    >>> bool(np.allclose(whole.solve()[0], parts.solve()[0]))
    True
    """

    n_rows: int
    x_mean: FloatArray
    y_mean: FloatArray
    factor: FloatArray
    centred: bool

    @property
    def n_terms(self) -> int:
        """Number of regressor columns."""
        return int(self.x_mean.size)

    @classmethod
    def from_rows(
        cls, x: FloatArray, y: FloatArray, centred: bool = True
    ) -> LeastSquaresStatistics:
        """The statistics of regressor rows ``x`` (n, n_terms) and targets ``y`` (n, n_outputs)."""
        z = np.hstack([np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)])
        mean = z.mean(axis=0) if centred and z.shape[0] else np.zeros(z.shape[1])
        k = x.shape[1]
        return cls(int(z.shape[0]), mean[:k], mean[k:], _upper_factor(z - mean), bool(centred))

    def merge(self, other: LeastSquaresStatistics) -> LeastSquaresStatistics:
        """The statistics of the rows of ``self`` and ``other`` together (see Notes).

        Raises
        ------
        ValueError
            If the two do not have the same columns or centring.
        """
        if other.factor.shape != self.factor.shape or other.centred != self.centred:
            raise ValueError(
                f"cannot merge least-squares statistics of {self.factor.shape[0]} columns"
                f" (centred={self.centred}) with {other.factor.shape[0]} (centred={other.centred})"
            )
        n = self.n_rows + other.n_rows
        if other.n_rows == 0 or self.n_rows == 0:
            return other if self.n_rows == 0 else self
        stacked = [self.factor, other.factor]
        x_mean, y_mean = self.x_mean, self.y_mean
        if self.centred:
            mine = np.concatenate([self.x_mean, self.y_mean])
            theirs = np.concatenate([other.x_mean, other.y_mean])
            weight = np.sqrt(self.n_rows * other.n_rows / n)
            stacked.append(weight * (theirs - mine)[None, :])
            mean = (self.n_rows * mine + other.n_rows * theirs) / n
            x_mean, y_mean = mean[: self.n_terms], mean[self.n_terms :]
        return LeastSquaresStatistics(
            n, x_mean, y_mean, _upper_factor(np.vstack(stacked)), self.centred
        )

    def solve(self, ridge: float = 0.0) -> tuple[FloatArray, FloatArray]:
        """Least-squares ``(coef (n_terms, n_outputs), intercept (n_outputs,))`` from the statistics.

        The same problem as :func:`neckid.models.linear.arx.least_squares` (columns scaled by their
        standard deviation, ``ridge`` on the scaled coefficients), solved on ``R`` instead of the
        rows.

        Raises
        ------
        ValueError
            If fewer rows were seen than there are unknowns.
        """
        k = self.n_terms
        unknowns = k + int(self.centred)
        if self.n_rows < unknowns:
            raise ValueError(
                f"least squares needs at least as many rows as unknowns: {self.n_rows} rows for"
                f" {unknowns} parameters; use a longer record or fewer lags"
            )
        r_xx, r_xy = self.factor[:k, :k], self.factor[:k, k:]
        scale = np.sqrt(np.sum(r_xx**2, axis=0) / self.n_rows)
        scale[scale == 0] = 1.0
        matrix, rhs = r_xx / scale, r_xy
        if ridge > 0:
            matrix = np.vstack([matrix, np.sqrt(ridge * self.n_rows) * np.eye(k)])
            rhs = np.vstack([rhs, np.zeros((k, rhs.shape[1]))])
        solution, *_ = np.linalg.lstsq(matrix, rhs, rcond=None)
        coef = np.ascontiguousarray(solution / scale[:, None])
        intercept = np.asarray(self.y_mean - self.x_mean @ coef, dtype=np.float64)
        return coef, intercept

    # ------------------------------------------------------------------ files
    def to_arrays(self, prefix: str) -> dict[str, FloatArray]:
        """The arrays a model file stores, named ``<prefix>factor``, ``..x_mean``, ``..y_mean``."""
        return {
            f"{prefix}factor": self.factor,
            f"{prefix}x_mean": self.x_mean,
            f"{prefix}y_mean": self.y_mean,
        }

    @classmethod
    def from_arrays(
        cls,
        arrays: Mapping[str, Any],
        prefix: str,
        n_rows: int,
        centred: bool,
        shape: tuple[int, int],
    ) -> LeastSquaresStatistics | None:
        """Statistics read from a model file, checked; ``None`` when the file has none.

        Parameters
        ----------
        shape : (int, int)
            ``(n_terms, n_outputs)`` the model has.

        Raises
        ------
        ValueError
            If an array has the wrong shape, a non-finite value, ``factor`` is not upper
            triangular, or the means are not zero for uncentred statistics.
        """
        if f"{prefix}factor" not in arrays:
            return None
        k, p = shape
        factor = np.asarray(arrays[f"{prefix}factor"], dtype=np.float64)
        x_mean = np.asarray(arrays[f"{prefix}x_mean"], dtype=np.float64)
        y_mean = np.asarray(arrays[f"{prefix}y_mean"], dtype=np.float64)
        for name, value, expected in (
            ("factor", factor, (k + p, k + p)),
            ("x_mean", x_mean, (k,)),
            ("y_mean", y_mean, (p,)),
        ):
            if value.shape != expected or not np.all(np.isfinite(value)):
                raise ValueError(
                    f"least-squares statistics {prefix}{name} must be finite of shape {expected};"
                    f" got shape {value.shape}"
                )
        if np.any(np.tril(factor, -1) != 0):
            raise ValueError(f"least-squares statistics {prefix}factor must be upper triangular")
        if not centred and (np.any(x_mean != 0) or np.any(y_mean != 0)):
            raise ValueError(
                f"least-squares statistics without an intercept must have zero means; got"
                f" {prefix}x_mean {x_mean.tolist()}"
            )
        return cls(int(n_rows), x_mean, y_mean, factor, bool(centred))
