"""Plain NumPy references of the Set Membership kernels (brute force, written as the equations read).

The kernels of :mod:`neckid.models.set_membership._kernels` compute the same quantities with a
kd-tree and compiled loops; the tests check that both agree (bit for bit for the bounds, to 1e-12 for γ*(ε)).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from neckid.models.set_membership._kernels import SMTree
from neckid.models.set_membership.training import prior_tolerance

__all__ = [
    "bounds_reference",
    "gamma_star_reference",
    "prior_holds_by_query",
    "smallest_epsilon_by_query",
]

FloatArray = NDArray[np.float64]


def bounds_reference(
    points: FloatArray, targets: FloatArray, queries: FloatArray, epsilon: float, gamma: float
) -> tuple[FloatArray, FloatArray]:
    """Brute-force SM bounds for one output, vectorised over the training points (NumPy).

    Parameters
    ----------
    points : ndarray, shape (n_points, n_dims)
    targets : ndarray, shape (n_points,)
    queries : ndarray, shape (n_queries, n_dims)
    epsilon, gamma : float

    Returns
    -------
    lower, upper : ndarray, shape (n_queries,)
        ``max_k (ỹ_k − ε − γ‖w − w̃_k‖)`` and ``min_k (ỹ_k + ε + γ‖w − w̃_k‖)``.
    """
    lower = np.empty(queries.shape[0])
    upper = np.empty(queries.shape[0])
    for i, w in enumerate(queries):
        distance = np.sqrt(np.sum((points - w) ** 2, axis=1))
        upper[i] = np.min(targets + epsilon + gamma * distance)
        lower[i] = np.max(targets - epsilon - gamma * distance)
    return lower, upper


def gamma_star_reference(
    points: FloatArray, targets: FloatArray, epsilons: FloatArray
) -> FloatArray:
    """Brute-force γ*(ε) = max_{i≠j} (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖ for one output (NumPy).

    Parameters
    ----------
    points : ndarray, shape (n_points, n_dims)
    targets : ndarray, shape (n_points,)
    epsilons : ndarray, shape (n_eps,)

    Returns
    -------
    ndarray, shape (n_eps,)
        ``inf`` where identical regressors have targets more than 2ε apart.
    """
    epsilons = np.asarray(epsilons, dtype=np.float64)
    best = np.zeros(epsilons.shape[0])
    for i in range(points.shape[0] - 1):
        distance = np.sqrt(np.sum((points[i + 1 :] - points[i]) ** 2, axis=1))
        delta = np.abs(targets[i + 1 :] - targets[i])
        for e, eps in enumerate(epsilons):
            num = delta - 2.0 * eps
            positive = num > 0
            with np.errstate(divide="ignore"):
                ratio = np.where(distance > 0, num / np.where(distance > 0, distance, 1.0), np.inf)
            ratio = np.where(positive, ratio, 0.0)
            if ratio.size:
                best[e] = max(best[e], float(ratio.max()))
    return best


def prior_holds_by_query(tree: SMTree, epsilon: FloatArray, gamma: FloatArray) -> NDArray[np.bool_]:
    """Reference of :func:`prior_holds`: ``f_u(w̃_k) >= ỹ_k − ε − τ`` and ``f_l(w̃_k) <= ỹ_k + ε + τ``.

    Evaluates the bounds at every training point (N queries of the tree: about N^1.4 on
    neck-like data); kept to test :func:`prior_holds` against.
    """
    lower, upper = tree.bounds(tree.points, epsilon, gamma)
    y = tree.targets
    tolerance = prior_tolerance(y, epsilon)
    ok_upper = np.all(upper >= y - epsilon - tolerance, axis=0)
    ok_lower = np.all(lower <= y + epsilon + tolerance, axis=0)
    return np.asarray(ok_upper & ok_lower, dtype=bool)


def smallest_epsilon_by_query(tree: SMTree, gamma: FloatArray) -> FloatArray:
    """Reference of :func:`smallest_epsilon`: ½ max_k (ỹ_k − f_u(w̃_k)) with f_u at ε = 0.

    Evaluates the bounds at every training point (N queries of the tree).
    """
    _, upper = tree.bounds(tree.points, np.zeros_like(gamma), gamma)
    return np.maximum(0.5 * np.max(tree.targets - upper, axis=0), 0.0)
