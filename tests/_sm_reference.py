"""Plain NumPy references of the Set Membership kernels (brute force, written as the equations read).

:mod:`neckid.models.set_membership._kernels.tree` computes the same quantities with a kd-tree and compiled loops;
the tests check that both agree (bit for bit for the bounds, to 1e-12 for γ*(ε)).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["bounds_reference", "gamma_star_reference"]

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
