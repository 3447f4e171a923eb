r"""A distance for Set Membership learnt from the data: each regressor term weighted by its slope.

SM bounds a function by a Lipschitz constant γ in a weighted Euclidean norm
``‖w‖ = ‖diag(v) w‖``. With every term scaled to unit standard deviation, a term the function
barely depends on (an input lag a linear part already explains) counts as much in the distance
as the one it varies along, so the nearest training points of a query are found in the wrong
directions and γ must cover the steepest direction everywhere. Weighting each term by how much
the function changes along it — the root mean square of its partial derivative over the data,
the diagonal of the expected gradient outer product — makes the norm close to isotropic for the
function: the same γ then fits every direction.

The derivatives are those of a ridge-regularised polynomial (degree 3 by default) fitted by
least squares to the SM targets over the standardised regressor; only their relative sizes are
used. The weights come from the training data only, like γ and ε; the prior is then "Lipschitz
in this norm", and every guarantee of SM holds for it unchanged.

References
----------
S. Trivedi, J. Wang, S. Kpotufe, G. Shakhnarovich, "A consistent estimator of the expected
gradient outerproduct", Proc. 30th Conference on Uncertainty in Artificial Intelligence, 2014.
S. Kpotufe, A. Boularias, T. Schultz, K. Kim, "Gradients weights improve regression and
classification", Journal of Machine Learning Research 17(22), 1-34, 2016.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from neckid.models.polynomial.monomials import monomial_tables
from neckid.utils.types import FloatArray

__all__ = ["GRADIENT_DEGREE", "GRADIENT_FLOOR", "gradient_relevance", "learnt_weights"]


#: Degree of the polynomial whose derivatives give the weights.
GRADIENT_DEGREE = 3
#: Smallest relative weight: a term the fit finds flat still counts a little in the distance (a
#: zero weight would merge regressors that differ only there).
GRADIENT_FLOOR = 0.01
#: Ridge penalty relative to the mean diagonal of the normal equations.
RIDGE = 1e-8
#: Largest number of rows the polynomial is fitted on (evenly spaced rows beyond it).
MAX_ROWS = 20_000


def _monomials(z: FloatArray, parent: NDArray[np.int64], var: NDArray[np.int64]) -> FloatArray:
    """Every monomial of :func:`~neckid.models.polynomial._kernels.monomial_tables`, per row of ``z``."""
    out = np.empty((z.shape[0], parent.shape[0]))
    out[:, 0] = 1.0
    for m in range(1, parent.shape[0]):
        out[:, m] = out[:, parent[m]] * z[:, var[m]]
    return out


def gradient_relevance(
    x: FloatArray, targets: FloatArray, degree: int = GRADIENT_DEGREE
) -> FloatArray:
    """Relative weight of each column of ``x`` in the SM distance, from the slope of the targets.

    Parameters
    ----------
    x : ndarray, shape (n_rows, n_terms)
        Regressors, already scaled (the weights multiply that scaling).
    targets : ndarray, shape (n_rows, n_outputs)
        What SM interpolates (the output, or the residual of a linear part).
    degree : int, default 3
        Degree of the polynomial fitted to differentiate.

    Returns
    -------
    ndarray, shape (n_terms,)
        ``sqrt(mean over rows and outputs of (∂p/∂x_k)² / var(target))``, divided by its largest
        value and floored at :data:`GRADIENT_FLOOR`; all ones when the targets are constant.
    """
    n_rows, n_terms = x.shape
    step = max(1, n_rows // MAX_ROWS)
    z = x[::step]
    center, scale = z.mean(axis=0), z.std(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    z = (z - center) / scale
    t = targets[::step]
    spread = t.std(axis=0)
    keep = spread > 0
    if not keep.any():
        return np.ones(n_terms)
    t = (t[:, keep] - t[:, keep].mean(axis=0)) / spread[keep]
    powers, parent, var, lower = monomial_tables(n_terms, degree)
    while powers.shape[0] >= z.shape[0] // 2 and degree > 1:  # too few rows for the monomials
        degree -= 1
        powers, parent, var, lower = monomial_tables(n_terms, degree)
    features = _monomials(z, parent, var)
    gram = features.T @ features
    gram[np.diag_indices_from(gram)] += RIDGE * np.trace(gram) / gram.shape[0]
    coef = np.linalg.solve(gram, features.T @ t)
    squared = np.empty(n_terms)
    for k in range(n_terms):
        # ∂(monomial m)/∂z_k = powers[m, k] · (monomial m with one z_k fewer, ``lower[m, k]``).
        has = powers[:, k] > 0
        derivative = features[:, lower[has, k]] @ (powers[has, k][:, None] * coef[has])
        squared[k] = np.mean(derivative**2)
    relevance = np.sqrt(squared) / scale  # back to the units of x
    top = relevance.max()
    if not np.isfinite(top) or top <= 0:
        return np.ones(n_terms)
    return np.maximum(relevance / top, GRADIENT_FLOOR)


def learnt_weights(
    scaling: Any, weights: FloatArray, x: FloatArray, targets: FloatArray
) -> FloatArray:
    """``weights``, times :func:`gradient_relevance` of ``targets`` when ``scaling="gradient"``."""
    if isinstance(scaling, str) and scaling == "gradient":
        return weights * gradient_relevance(x * weights, targets)
    return weights
