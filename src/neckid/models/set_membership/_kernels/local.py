r"""Local Lipschitz constants for Set Membership: one constant per training point.

A single Lipschitz constant γ is a maximum over every pair of training points, so a few close
pairs with very different targets (a controller switch, a hysteresis jump) set the slope of the
bounds everywhere. Here each training point ``j`` carries its own constant ``γ_j`` and the prior
is

.. math:: |f(w) − f(w̃_j)| \le \max(γ(w), γ_j)\,\|w − w̃_j\| \quad \text{for every } w, j,

with ``γ(w)`` the largest ``γ_j`` of the ``K`` training points nearest to ``w``. Under it, and
``|ỹ_j − f(w̃_j)| <= ε``,

.. math::

    f_u(w) = \min_j \left(ỹ_j + ε + \max(γ(w), γ_j)\,\|w − w̃_j\|\right), \qquad
    f_l(w) = \max_j \left(ỹ_j − ε − \max(γ(w), γ_j)\,\|w − w̃_j\|\right)

bound ``f`` at ``w`` (each term is the prior applied to the pair ``(w, w̃_j)``). The data are
consistent with the prior at the training points when ``|ỹ_i − ỹ_j| <= 2ε + max(γ_i, γ_j) d_ij``
for every pair; :func:`point_gamma` gives each point the steepest slope it takes part in,

.. math:: γ_i = \max_{j \ne i} \frac{(|ỹ_i − ỹ_j| − 2ε)^+}{\|w̃_i − w̃_j\|},

so *both* ends of a pair carry at least its slope ``s_ij`` (the largest ``γ_i`` is the global
γ*(ε) of Milanese & Novara). A point in a smooth region gets a small constant, and a steep pair
raises only its own two points' constants. The bounds never cross: for any two training points,
``ỹ_i − ỹ_j <= 2ε + s_ij d_ij <= 2ε + s_ij (d_i + d_j) <= 2ε + L_i d_i + L_j d_j`` with
``d_i = ‖w − w̃_i‖`` and ``L_i = max(γ(w), γ_i) >= s_ij``, so ``f_l(w) <= f_u(w)``. Only rounding
can make them cross by an ulp (with ``gamma_margin = 1``); such a query is evaluated with the
global constant, and the constant used is returned. ``γ(w)`` takes every training point within
the ``K``-th smallest distance (ties included), so it does not depend on the tree's layout.

The evaluation is the exact branch and bound of :mod:`neckid.models.set_membership._kernels.tree` (its
``query_one`` with per-point constants), the node test made with ``γ(w)``, a lower bound of
every ``max(γ(w), γ_j)`` in the node, so no point that could change a bound is skipped.

Developers: numba's on-disk cache of these kernels is keyed on this file; after editing the
kernels they call in :mod:`neckid.models.set_membership._kernels.tree` in a checkout, delete the cache (see
:mod:`neckid.utils.numba_cache`) or touch this file.

References
----------
M. Milanese and C. Novara, "Set Membership identification of nonlinear systems", Automatica
40(6), 957-975, 2004 (the global prior, its validation and the optimal bounds).
J. Calliess, S. Roberts, C. Rasmussen and J. Maciejowski, "Lazily adapted constant kinky
inference for nonparametric regression and model-reference adaptive control", Automatica 122,
109216, 2020 (Lipschitz interpolation with constants learnt from data).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from neckid.models.set_membership._kernels.screens import (
    SLOPE_PRUNE,
    box_screen2,
    push_screened,
    screen_shrink,
)
from neckid.models.set_membership._kernels.tree import (
    SERIAL_QUERIES,
    STACK_DEPTH,
    box_distance2,
    query_one,
    reach_cap,
    squared_distance_capped,
)
from neckid.utils.types import FloatArray, IntArray

if TYPE_CHECKING:
    from neckid.models.set_membership._kernels.tree import SMTree

__all__ = ["check_constants", "learn_constants", "local_bounds", "point_gamma"]

#: Points (or queries) per call of a compiled kernel: each call returns to Python within a
#: fraction of a second (4,096 points of a 40,000-point tree: 0.4 s on 2 cores), where a stop
#: signal is taken (:mod:`neckid.utils.interrupt`); one call over every point of a large log
#: would hold a Ctrl-C for seconds. Each point is computed alone, so the result is the same.
KERNEL_CHUNK = 4096


# ---------------------------------------------------------------------------------- constants
@njit(cache=True)
def _steepest(
    i: int,
    c: int,
    twice_eps: float,
    tree: tuple[NDArray, ...],
    node_stack: IntArray,
    dist_stack: FloatArray,
) -> float:
    """max_{j≠i} (|t_i − t_j| − 2ε)⁺ / d_ij for the point ``i`` (tree order), by branch and bound.

    ``tree`` is :meth:`SMTree.kernel_arrays`.
    """
    points, targets, start, end, left, right, lo, hi, ymin, ymax = tree
    w = points[i]
    t = targets[i, c]
    best = 0.0
    shrink = screen_shrink(w.shape[0])
    node_stack[0] = 0
    dist_stack[0] = math.sqrt(box_screen2(w, lo, hi, 0) * shrink)
    top = 1
    while top > 0:
        top -= 1
        node = node_stack[top]
        gap = max(t - ymin[node, c], ymax[node, c] - t) - twice_eps
        if gap <= 0.0 or gap <= best * dist_stack[top] * SLOPE_PRUNE:
            continue
        child = left[node]
        if child < 0:
            for p in range(start[node], end[node]):
                if p == i:
                    continue
                rise = abs(t - targets[p, c]) - twice_eps
                if rise <= 0.0:
                    continue
                cap = reach_cap(rise / best) if best > 0.0 else np.inf
                acc = squared_distance_capped(w, points, p, cap)
                if acc > cap:
                    continue  # too far for rise / d > best
                if acc == 0.0:
                    return np.inf
                slope = rise / math.sqrt(acc)
                if slope > best:
                    best = slope
        else:
            top = push_screened(
                w, lo, hi, left, right, node, node_stack, dist_stack, top, shrink, False
            )
    return best


@njit(cache=True, parallel=True)
def _point_gamma_kernel(
    rows: IntArray, twice_eps: FloatArray, tree: tuple[NDArray, ...], out: FloatArray
) -> None:
    for r in prange(rows.shape[0]):
        node_stack = np.empty(STACK_DEPTH, np.int64)
        dist_stack = np.empty(STACK_DEPTH)
        for c in range(out.shape[1]):
            out[r, c] = _steepest(rows[r], c, twice_eps[c], tree, node_stack, dist_stack)


def point_gamma(tree: SMTree, epsilon: FloatArray, rows: IntArray | None = None) -> FloatArray:
    """The steepest slope each training point takes part in, per output.

    Parameters
    ----------
    tree : SMTree
        The training points (scaled) and targets.
    epsilon : ndarray, shape (n_outputs,)
        Noise bound ε per output.
    rows : ndarray of int, optional
        Points (tree order) to compute; default all.

    Returns
    -------
    ndarray, shape (n_rows, n_outputs)
        ``γ_i = max_{j≠i} (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖`` (inf for a point with an
        identical regressor whose target is more than 2ε away).
    """
    n = tree.points.shape[0]
    rows = np.arange(n, dtype=np.int64) if rows is None else np.asarray(rows, dtype=np.int64)
    rows = np.ascontiguousarray(rows)
    out = np.empty((rows.shape[0], tree.targets.shape[1]))
    twice = np.ascontiguousarray(2.0 * np.asarray(epsilon, dtype=np.float64))
    arrays = tree.kernel_arrays()
    for start in range(0, rows.shape[0], KERNEL_CHUNK):  # back in Python between chunks
        stop = start + KERNEL_CHUNK
        _point_gamma_kernel(rows[start:stop], twice, arrays, out[start:stop])
    return out


# ---------------------------------------------------------------------------------- bounds
@njit(cache=True)
def kth_radius2(
    w: FloatArray,
    k_near: int,
    tree: tuple[NDArray, ...],
    node_stack: IntArray,
    dist_stack: FloatArray,
    near_d: FloatArray,
) -> float:  # pragma: no cover - compiled
    """The ``k_near``-th smallest squared distance from ``w`` to a training point."""
    points, _, start, end, left, right, lo, hi, _, _ = tree
    k_near = min(k_near, points.shape[0])
    for k in range(k_near):
        near_d[k] = np.inf
    node_stack[0] = 0
    dist_stack[0] = box_distance2(w, lo, hi, 0)
    top = 1
    while top > 0:
        top -= 1
        node = node_stack[top]
        if dist_stack[top] > near_d[k_near - 1]:
            continue
        if left[node] < 0:
            for p in range(start[node], end[node]):
                acc = squared_distance_capped(w, points, p, near_d[k_near - 1])
                if acc < near_d[k_near - 1]:
                    slot = k_near - 1
                    while slot > 0 and near_d[slot - 1] > acc:
                        near_d[slot] = near_d[slot - 1]
                        slot -= 1
                    near_d[slot] = acc
        else:
            d_left = box_distance2(w, lo, hi, left[node])
            d_right = box_distance2(w, lo, hi, right[node])
            near, far = (
                (left[node], right[node]) if d_left <= d_right else (right[node], left[node])
            )
            node_stack[top], dist_stack[top] = far, max(d_left, d_right)
            node_stack[top + 1], dist_stack[top + 1] = near, min(d_left, d_right)
            top += 2
    return near_d[k_near - 1]


@njit(cache=True)
def _neighbour_gamma(
    w: FloatArray,
    k_near: int,
    gammas: FloatArray,
    tree: tuple[NDArray, ...],
    node_stack: IntArray,
    dist_stack: FloatArray,
    near_d: FloatArray,
    out: FloatArray,
) -> None:
    """``out[c]``: the largest ``γ_j`` over the training points within the ``k_near``-th distance.

    Every point tied at that distance counts, so the result does not depend on the tree's
    layout (a quantised signal at rest gives many identical regressors). Distances are compared
    squared, as they are summed, with no square root in between. A query with no neighbour (NaN)
    gets ``inf``.
    """
    points, _, start, end, left, right, lo, hi, _, _ = tree
    # 1. the k_near-th smallest squared distance
    radius2 = kth_radius2(w, k_near, tree, node_stack, dist_stack, near_d)
    if not radius2 < np.inf:
        out[:] = np.inf
        return
    # 2. the largest constant within that distance, ties included
    out[:] = 0.0
    node_stack[0] = 0
    dist_stack[0] = box_distance2(w, lo, hi, 0)
    top = 1
    while top > 0:
        top -= 1
        node = node_stack[top]
        if dist_stack[top] > radius2:
            continue
        if left[node] < 0:
            for p in range(start[node], end[node]):
                if squared_distance_capped(w, points, p, radius2) <= radius2:
                    for c in range(out.shape[0]):
                        out[c] = max(out[c], gammas[p, c])
        else:
            for child in (left[node], right[node]):
                node_stack[top] = child
                dist_stack[top] = box_distance2(w, lo, hi, child)
                top += 1


@njit(cache=True)
def _local_one(
    w: FloatArray,
    i: int,
    k_near: int,
    gammas: FloatArray,
    epsilon: FloatArray,
    fallback: FloatArray,
    tree: tuple[NDArray, ...],
    lower: FloatArray,
    upper: FloatArray,
    used: FloatArray,
    node_stack: IntArray,
    dist_stack: FloatArray,
    near_d: FloatArray,
    near_g: FloatArray,
) -> None:
    points, targets, start, end, left, right, lo, hi, ymin, ymax = tree
    _neighbour_gamma(w, k_near, gammas, tree, node_stack, dist_stack, near_d, near_g)
    for c in range(targets.shape[1]):
        g = near_g[c]
        low, high = query_one(
            w,
            points,
            targets,
            c,
            g,
            start,
            end,
            left,
            right,
            lo,
            hi,
            ymin,
            ymax,
            node_stack,
            dist_stack,
            gammas,
        )
        if low - high > 2.0 * epsilon[c] and fallback[c] > g:  # rounding only (module notes)
            g = fallback[c]
            low, high = query_one(
                w,
                points,
                targets,
                c,
                g,
                start,
                end,
                left,
                right,
                lo,
                hi,
                ymin,
                ymax,
                node_stack,
                dist_stack,
                gammas,
            )
        lower[i, c] = low - epsilon[c]
        upper[i, c] = high + epsilon[c]
        used[i, c] = g


@njit(cache=True, parallel=True)
def _local_many_kernel(
    queries: FloatArray,
    k_near: int,
    gammas: FloatArray,
    epsilon: FloatArray,
    fallback: FloatArray,
    tree: tuple[NDArray, ...],
    lower: FloatArray,
    upper: FloatArray,
    used: FloatArray,
) -> None:
    for i in prange(queries.shape[0]):
        node_stack = np.empty(STACK_DEPTH, np.int64)
        dist_stack = np.empty(STACK_DEPTH)
        near_d = np.empty(max(k_near, 1))
        near_g = np.empty(lower.shape[1])
        _local_one(
            queries[i],
            i,
            k_near,
            gammas,
            epsilon,
            fallback,
            tree,
            lower,
            upper,
            used,
            node_stack,
            dist_stack,
            near_d,
            near_g,
        )


@njit(cache=True)
def _local_few_kernel(
    queries: FloatArray,
    k_near: int,
    gammas: FloatArray,
    epsilon: FloatArray,
    fallback: FloatArray,
    tree: tuple[NDArray, ...],
    lower: FloatArray,
    upper: FloatArray,
    used: FloatArray,
) -> None:  # pragma: no cover - compiled; tested against the parallel kernel
    node_stack = np.empty(STACK_DEPTH, np.int64)
    dist_stack = np.empty(STACK_DEPTH)
    near_d = np.empty(max(k_near, 1))
    near_g = np.empty(lower.shape[1])
    for i in range(queries.shape[0]):
        _local_one(
            queries[i],
            i,
            k_near,
            gammas,
            epsilon,
            fallback,
            tree,
            lower,
            upper,
            used,
            node_stack,
            dist_stack,
            near_d,
            near_g,
        )


def local_bounds(
    tree: SMTree,
    gammas: FloatArray,
    queries: FloatArray,
    epsilon: FloatArray,
    fallback: FloatArray,
    neighbours: int,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Bounds ``(f_l, f_u)`` under the local prior, and the constant ``γ(w)`` used per query.

    Parameters
    ----------
    tree : SMTree
        Training points (scaled) and targets.
    gammas : ndarray, shape (n_points, n_outputs)
        Constant of each training point, tree order (:func:`point_gamma` times a margin).
    queries : ndarray, shape (n_queries, n_dims)
        Scaled regressors.
    epsilon, fallback : ndarray, shape (n_outputs,)
        Noise bound, and the global constant used where the local one leaves the bounds crossed.
    neighbours : int
        ``K``: ``γ(w)`` is the largest constant of the ``K`` nearest training points.

    Returns
    -------
    lower, upper, used : ndarray, each (n_queries, n_outputs)
    """
    queries = np.ascontiguousarray(queries, dtype=np.float64)
    n_out = tree.targets.shape[1]
    shape = (queries.shape[0], n_out)
    lower, upper, used = np.empty(shape), np.empty(shape), np.empty(shape)
    args = (
        queries,
        int(neighbours),
        np.ascontiguousarray(gammas, dtype=np.float64),
        np.ascontiguousarray(epsilon, dtype=np.float64),
        np.ascontiguousarray(fallback, dtype=np.float64),
        tree.kernel_arrays(),
        lower,
        upper,
        used,
    )
    if queries.shape[0] < SERIAL_QUERIES:
        _local_few_kernel(*args)
        return lower, upper, used
    for start in range(0, queries.shape[0], KERNEL_CHUNK):  # back in Python between chunks
        part = slice(start, start + KERNEL_CHUNK)
        _local_many_kernel(queries[part], *args[1:6], lower[part], upper[part], used[part])
    return lower, upper, used


def learn_constants(
    tree: SMTree, epsilon: FloatArray, gamma: FloatArray, margin: float
) -> FloatArray:
    """Each training point's constant, ``min(margin · γ_i, γ)`` (tree order), for a model.

    For an output where every ``γ_i`` is 0 (γ*(ε) = 0), every point gets ``γ``.

    Raises
    ------
    ValueError
        If two identical regressors have targets more than 2ε apart (no constant fits them).
    """
    steepest = point_gamma(tree, epsilon)
    if not np.all(np.isfinite(steepest)):
        raise ValueError(
            "identical training regressors have outputs more than 2·epsilon apart: no Lipschitz"
            " constant fits them; use a larger epsilon"
        )
    constants = np.minimum(margin * steepest, gamma)
    # Where no pair needs a slope (γ*(ε) = 0: a constant fits), every constant would be 0 and
    # the bounds would not widen away from the data; the given global γ is used instead.
    flat = steepest.max(axis=0, initial=0.0) == 0
    constants[:, flat] = np.asarray(gamma, dtype=np.float64)[flat]
    return np.ascontiguousarray(constants)


def check_constants(
    value: FloatArray | None, lipschitz: str, n_samples: int, gamma: FloatArray
) -> None:
    """Refuse per-point constants that do not match the setting or the model (a model file)."""
    if (value is None) != (lipschitz != "local"):
        state = "missing" if value is None else "given"
        raise ValueError(
            f"point_gamma must be given exactly when lipschitz='local'; lipschitz is"
            f" {lipschitz!r} and point_gamma is {state}"
        )
    if value is None:
        return
    if value.shape != (n_samples, gamma.shape[0]):
        raise ValueError(
            f"point_gamma must have shape {(n_samples, gamma.shape[0])} (one constant per"
            f" training point and output); got {value.shape}"
        )
    if not np.all((value >= 0) & (value <= gamma)):
        raise ValueError("point_gamma must lie in [0, gamma] (each training point's constant)")
