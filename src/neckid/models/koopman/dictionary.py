r"""The observables of the Koopman model: radial basis functions or monomials of the regressor.

Each observable is a function of the standardised regressor ``r`` (the model's lag terms of lag
``>= 1``, each channel centred and scaled by its training mean and standard deviation):

- ``"thin-plate"``: :math:`\varphi_k(r) = d_k^2 \log d_k`, :math:`d_k = \lVert r - c_k \rVert`
  (0 at :math:`d_k = 0`), the dictionary of Korda & Mezić (2018);
- ``"gaussian"``: :math:`\varphi_k(r) = \exp(-d_k^2 / (2 w^2))`, the width :math:`w` the median
  distance from a centre to its nearest other centre;
- ``"monomials"``: products of the terms of total degree 2 and 3 in graded lexicographic order
  (``r1^2, r1 r2, …, r1^3, …``), the first ``n_observables`` of them.

RBF centres are the k-means centres (scikit-learn ``KMeans``, seeded, :data:`KMEANS_INITS` run)
of the training regressor rows, at most :data:`KMEANS_ROWS` of them drawn at random. Every observable is then standardised
by its mean and standard deviation over the training rows, so that one ridge penalty weighs them
alike.

References
----------
M. Korda, I. Mezić, "Linear predictors for nonlinear dynamical systems: Koopman operator meets
model predictive control", Automatica 93, 149–160, 2018.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Literal

import numpy as np

from neckid.utils.types import FloatArray, IntArray

__all__ = [
    "DICTIONARIES",
    "KMEANS_ROWS",
    "Observables",
    "fit_observables",
    "fit_observables_with_values",
    "monomial_powers",
]

#: The kinds of observables.
DICTIONARIES = ("thin-plate", "gaussian", "monomials")

#: Most training rows k-means sees (drawn at random without replacement, seeded).
KMEANS_ROWS = 5000
#: Runs of k-means++ and Lloyd per dictionary (the one of least inertia kept). One, as
#: scikit-learn's own default for k-means++: on the training folds of the benchmark's data sets
#: the chosen candidate's mean fold fit moved by -0.27 to +0.16 points against three runs, inside
#: the spread over four seeds (up to 1.1 points on the robot arm), for 30-45 % less time per fit
#: (docs/benchmarks/runs.md, 2026-12-03 evening).
KMEANS_INITS = 1

Kind = Literal["thin-plate", "gaussian", "monomials"]


def monomial_powers(n_terms: int, limit: int) -> IntArray:
    """Exponents of the first ``limit`` monomials of degree 2 and 3 of ``n_terms`` terms.

    Graded lexicographic order: every degree-2 product before the degree-3 ones.

    Examples
    --------
    >>> monomial_powers(2, 4).tolist()
    [[2, 0], [1, 1], [0, 2], [3, 0]]
    """
    rows: list[list[int]] = []
    for degree in (2, 3):
        for combo in itertools.combinations_with_replacement(range(n_terms), degree):
            row = [0] * n_terms
            for k in combo:
                row[k] += 1
            rows.append(row)
            if len(rows) >= limit:
                return np.array(rows, dtype=np.int64)
    return np.array(rows, dtype=np.int64).reshape(-1, n_terms)


@dataclass(frozen=True)
class Observables:
    """A fitted set of observables: evaluate it with :meth:`__call__`.

    Attributes
    ----------
    kind : {"thin-plate", "gaussian", "monomials"}
    centres : ndarray, shape (n_observables, n_terms)
        RBF centres in standardised regressor units (empty for monomials).
    powers : ndarray of int, shape (n_observables, n_terms)
        Monomial exponents (empty for RBFs).
    width : float
        Gaussian width ``w`` (1.0 otherwise).
    mean, std : ndarray, shape (n_observables,)
        The observables' training mean and standard deviation (the standardisation).
    """

    kind: str
    centres: FloatArray
    powers: IntArray
    width: float
    mean: FloatArray
    std: FloatArray

    @property
    def size(self) -> int:
        """Number of observables."""
        return int(self.mean.shape[0])

    def raw(self, r: FloatArray) -> FloatArray:
        """The observables of rows ``r`` (``(n_rows, n_terms)``), before standardisation."""
        if self.kind == "monomials":
            out = np.ones((r.shape[0], self.powers.shape[0]))
            for k, row in enumerate(self.powers):
                for j in np.flatnonzero(row):
                    out[:, k] *= r[:, j] ** int(row[j])
            return out
        squared = (
            np.sum(r * r, axis=1)[:, None]
            - 2.0 * r @ self.centres.T
            + np.sum(self.centres * self.centres, axis=1)[None, :]
        )
        squared = np.maximum(squared, 0.0)
        if self.kind == "gaussian":
            return np.asarray(np.exp(-squared / (2.0 * self.width**2)))
        with np.errstate(divide="ignore", invalid="ignore"):
            values = 0.5 * squared * np.log(squared)  # d² log d = ½ d² log d²
        return np.asarray(np.where(squared > 0.0, values, 0.0))

    def __call__(self, r: FloatArray) -> FloatArray:
        """The standardised observables of rows ``r``: ``(n_rows, n_observables)``."""
        if self.size == 0:
            return np.zeros((r.shape[0], 0))
        return np.asarray((self.raw(r) - self.mean) / self.std)


def _centres(r: FloatArray, n: int, seed: int) -> FloatArray:
    """``n`` k-means centres of rows ``r`` (at most :data:`KMEANS_ROWS` rows, seeded)."""
    from sklearn.cluster import KMeans

    rng = np.random.default_rng(seed)
    rows = r if r.shape[0] <= KMEANS_ROWS else r[rng.choice(r.shape[0], KMEANS_ROWS, False)]
    distinct = np.unique(rows, axis=0).shape[0]
    if distinct < n:
        raise ValueError(
            f"n_observables={n} radial basis functions need as many distinct training regressors;"
            f" the training data have {distinct}: use fewer observables"
        )
    means = KMeans(n_clusters=n, n_init=KMEANS_INITS, random_state=seed).fit(rows)
    return np.ascontiguousarray(means.cluster_centers_, dtype=np.float64)


def fit_observables(r: FloatArray, kind: str, n: int, seed: int = 0) -> Observables:
    """The observables of kind ``kind`` and size ``n`` fitted on the training regressor rows ``r``.

    :func:`fit_observables_with_values` without the values.

    Parameters
    ----------
    r : ndarray, shape (n_rows, n_terms)
        Standardised training regressors.
    kind : {"thin-plate", "gaussian", "monomials"}
    n : int
        Number of observables (for monomials at most the number of degree-2 and -3 monomials).
    seed : int, default 0
        Seed of k-means and of its row sample.

    Examples
    --------
    >>> r = np.random.default_rng(0).normal(size=(200, 2))
    >>> phi = fit_observables(r, "thin-plate", 5)
    >>> phi(r).shape, bool(np.allclose(phi(r).mean(axis=0), 0.0))
    ((200, 5), True)
    """
    return fit_observables_with_values(r, kind, n, seed)[0]


def fit_observables_with_values(
    r: FloatArray, kind: str, n: int, seed: int = 0
) -> tuple[Observables, FloatArray]:
    """:func:`fit_observables`, and the standardised observables of ``r`` it computed on the way.

    The values are ``observables(r)``, the same floats (the standardisation needs them, and the
    Gram sums of the same rows use them instead of computing them again).
    """
    n_terms = r.shape[1]
    empty_int = np.zeros((0, n_terms), dtype=np.int64)
    centres, powers, width = np.zeros((0, n_terms)), empty_int, 1.0
    if n > 0 and kind == "monomials":
        powers = monomial_powers(n_terms, n)
    elif n > 0:
        centres = _centres(r, n, seed)
        if kind == "gaussian":
            gaps = np.linalg.norm(centres[:, None, :] - centres[None, :, :], axis=2)
            np.fill_diagonal(gaps, np.inf)
            nearest = gaps.min(axis=1) if n > 1 else np.array([1.0])
            width = float(np.median(nearest)) if np.isfinite(nearest).all() else 1.0
            width = width if width > 0 else 1.0
    provisional = Observables(kind, centres, powers, width, np.zeros(0), np.ones(0))
    size = powers.shape[0] if kind == "monomials" else centres.shape[0]
    if size == 0:
        empty = Observables(kind, centres, powers, width, np.zeros(0), np.ones(0))
        return empty, np.zeros((r.shape[0], 0))
    values = provisional.raw(r)
    mean = values.mean(axis=0)
    std = values.std(axis=0)
    std = np.where(std > 1e-12 * np.maximum(np.abs(mean), 1.0), std, 1.0)
    values -= mean  # in place: what Observables.__call__ computes, element by element
    values /= std
    return Observables(kind, centres, powers, width, mean, std), values
