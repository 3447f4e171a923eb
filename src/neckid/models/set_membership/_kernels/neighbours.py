r"""The local priors' constant at many queries, from nearest neighbours screened by one BLAS product.

A local prior's slope at a query ``w`` is at least ``γ(w)``: the largest point constant ``γ_j``
over the training points within the ``K``-th smallest distance from ``w``, ties included
(:mod:`.local`). The tree walk that finds them (``priors._near_constants``) opens many nodes in
many dimensions: at horizon 40 of the soft-neck payload split (84 terms, 14,600 points) it was
the largest part of the cross-validation's bounds. Here, for a block of queries:

1. **Approximate squared distances by one matrix product**, of the points and queries centred on
   the points' mean: ``d̃² = ‖q̂‖² + ‖x̂‖² − 2 q̂·x̂``. A dot product computed in any order is
   within ``γ_n |q̂|·|x̂|`` of the exact one (Higham, *Accuracy and Stability of Numerical
   Algorithms*, 2nd ed., 2002, §3.1), so with the centring's rounding ``d̃²`` is within
   ``Δ = c_n (‖q̂‖ + max_j ‖x̂_j‖)²`` of the true squared distance (``c_n`` of
   :func:`blas_slack`, twice the bound), and the squared distance the walk sums in component
   order is within a relative ``γ_{n+2}`` of the true one.
2. **Candidates.** The ``K``-th smallest ``d̃²`` bounds the ``K``-th smallest exact squared
   distance from above; every point whose ``d̃²`` can lie below that bound is a candidate
   (a vectorised count, in chunks).
3. **Exact sums** for the candidates only (component order, as the walk sums them): their
   ``K``-th smallest is the radius, and the constant is the largest ``γ_j`` among the candidates
   within it. Both are a k-th smallest value and a maximum, which do not depend on the order in
   which the points are seen: the constants are bit for bit the walk's.

The product decides only which points get an exact sum: the results do not depend on the CPU.
``tests/test_sm_partial_distance.py`` checks them against brute force.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numba import njit, prange

from neckid.utils.types import FloatArray

if TYPE_CHECKING:
    from neckid.models.set_membership._kernels.tree import SMTree

__all__ = ["BLAS_NEIGHBOUR_DIMS", "blas_near_constants", "blas_slack", "prefers_blas"]

#: From this many regressor terms on, the local constants at the queries come from here.
BLAS_NEIGHBOUR_DIMS = 16
#: Unit roundoff of float64.
_U = 2.0**-53
#: Points per chunk of the vectorised candidate count.
_CHUNK = 256
#: Bytes of approximate squared distances per block of queries.
_BLOCK_BYTES = 32 * 2**20


def blas_slack(n_dims: int) -> float:
    """``c_n``: ``d̃²`` lies within ``c_n (‖q̂‖ + max‖x̂‖)²`` of the true squared distance."""
    gamma = (n_dims + 4) * _U / (1.0 - (n_dims + 4) * _U)
    return 2.0 * (gamma + 4.0 * _U) * (1.0 + 1e-6)


def prefers_blas(tree: SMTree, queries: FloatArray) -> bool:
    """Many terms, and every value finite (a NaN query takes the walk, which handles it)."""
    return bool(
        tree.points.shape[1] >= BLAS_NEIGHBOUR_DIMS
        and np.isfinite(queries).all()
        and np.isfinite(tree.points).all()
    )


@njit(cache=True)
def _exact2(w: FloatArray, points: FloatArray, p: int) -> float:  # pragma: no cover - compiled
    """The squared distance as the walks sum it: in component order, no reassociation."""
    acc = 0.0
    for k in range(w.shape[0]):
        diff = w[k] - points[p, k]
        acc += diff * diff
    return acc


@njit(cache=True, fastmath=True)
def _count_below(
    values: FloatArray, first: int, stop: int, bound: float
) -> int:  # pragma: no cover - compiled
    count = 0
    for p in range(first, stop):
        count += values[p] <= bound
    return count


@njit(cache=True)
def _kth_smallest(
    values: FloatArray, k_near: int, best: FloatArray
) -> float:  # pragma: no cover - compiled
    """The ``k_near``-th smallest of ``values``, by insertion into ``best``."""
    for k in range(k_near):
        best[k] = np.inf
    last = k_near - 1
    for p in range(values.shape[0]):
        x = values[p]
        if x < best[last]:
            slot = last
            while slot > 0 and best[slot - 1] > x:
                best[slot] = best[slot - 1]
                slot -= 1
            best[slot] = x
    return best[last]


@njit(cache=True, parallel=True)
def _near_kernel(
    queries: FloatArray,
    dt2: FloatArray,
    query_norm: FloatArray,
    point_norm: float,
    slack: float,
    relative: float,
    points: FloatArray,
    k_near: int,
    gammas: FloatArray,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled; tested against brute force
    n_pts = points.shape[0]
    k_near = min(k_near, n_pts)
    for i in prange(queries.shape[0]):
        w = queries[i]
        row = dt2[i]
        spread = slack * (query_norm[i] + point_norm) ** 2
        best = np.empty(k_near)
        # The k smallest exact squared distances are at most (t_K + Δ)(1 + rel): any point that
        # can be one of them, or tie with the k-th, has d̃² <= that / (1 − rel) + Δ.
        bound = (_kth_smallest(row, k_near, best) + spread) * (1.0 + relative)
        reach = bound / (1.0 - relative) + spread
        cand_p = np.empty(n_pts, np.int64)
        cand_d = np.empty(n_pts)
        n_cand = 0
        for first in range(0, n_pts, _CHUNK):
            stop = min(n_pts, first + _CHUNK)
            if _count_below(row, first, stop, reach) == 0:
                continue
            for p in range(first, stop):
                if row[p] <= reach:
                    cand_p[n_cand] = p
                    cand_d[n_cand] = _exact2(w, points, p)
                    n_cand += 1
        radius2 = _kth_smallest(cand_d[:n_cand], k_near, best)
        if not radius2 < np.inf:
            out[i] = np.inf
            continue
        out[i] = 0.0
        for j in range(n_cand):
            if cand_d[j] <= radius2:
                p = cand_p[j]
                for m in range(out.shape[1]):
                    for c in range(out.shape[2]):
                        out[i, m, c] = max(out[i, m, c], gammas[p, m, c])


def blas_near_constants(
    tree: SMTree, queries: FloatArray, gammas: FloatArray, neighbours: int
) -> FloatArray:
    """``out[i, m, c]``: the largest ``gammas[p, m, c]`` within the ``K``-th distance of query ``i``.

    Parameters
    ----------
    tree : SMTree
        The training points (tree order).
    queries : ndarray, shape (n_queries, n_dims)
        Scaled regressors, finite.
    gammas : ndarray, shape (n_points, n_local, n_outputs)
        The local priors' point constants, point-major, tree order.
    neighbours : int
        ``K``.

    Returns
    -------
    ndarray, shape (n_queries, n_local, n_outputs)
        Bit for bit ``priors._near_constants`` (``kth_radius2`` then the largest constant within
        the radius, ties included).
    """
    points = tree.points
    n_pts, n_dims = points.shape
    centre = points.mean(axis=0)
    shifted = points - centre
    squares = np.einsum("ij,ij->i", shifted, shifted)
    point_norm = math.sqrt(float(squares.max())) * (1.0 + 1e-9)
    slack = blas_slack(n_dims)
    relative = 2.0 * (n_dims + 2) * _U / (1.0 - (n_dims + 2) * _U)
    out = np.empty((queries.shape[0], gammas.shape[1], gammas.shape[2]))
    block = int(min(1024, max(8, _BLOCK_BYTES // (8 * max(n_pts, 1)))))
    for first in range(0, queries.shape[0], block):
        part = np.ascontiguousarray(queries[first : first + block])
        moved = part - centre
        norms = np.einsum("ij,ij->i", moved, moved)
        dt2 = moved @ shifted.T
        dt2 *= -2.0
        dt2 += norms[:, None]
        dt2 += squares[None, :]
        _near_kernel(
            part,
            dt2,
            np.sqrt(norms) * (1.0 + 1e-9),
            point_norm,
            slack,
            relative,
            points,
            int(neighbours),
            gammas,
            out[first : first + block],
        )
    return out
