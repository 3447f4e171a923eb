r"""Several Set Membership priors evaluated over one kd-tree in one traversal.

Choosing the prior of a Set Membership model (Milanese & Novara, 2004) by cross-validation
evaluates many priors on the same training points: several noise bounds ε, each with its
Lipschitz constant γ(ε), in the global form and with local constants
(:mod:`neckid.models.set_membership._kernels.local`). Each prior's bounds at a query, and each
point's local constant, are a minimum or maximum over the training points of an expression in
the *same* distance ``‖w − w̃_j‖``. These kernels walk the tree once for all the priors:

- :func:`point_gamma_grid`: each training point's steepest slope
  ``max_{j≠i} (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖`` for every ε of a grid (one traversal per
  point instead of one per ε);
- :func:`prior_bounds`: the bounds ``[f_l − ε, f_u + ε]`` of every prior at every query, the
  distance to each visited point computed once, and the ``K`` nearest neighbours (which do not
  depend on the prior) found once per query, in one walk that also records the points within
  the running ``K``-th distance (:func:`_near_constants`).

Both are *bit for bit* the single-prior kernels (:func:`~.local.point_gamma`,
:meth:`~.tree.SMTree.bounds`, :func:`~.local.local_bounds`), which stay the references: a node
is opened when any prior could use it, and a node a prior would have skipped holds no point
that changes that prior's running maximum or minimum (the argument of the single-prior kernels,
which holds at any later moment of the walk since the running values only tighten), and each
value is computed by the same floating-point operations. Every result is a minimum, a maximum
or a k-th smallest value of exactly computed terms (a steepest slope is the largest rounded
ratio, :data:`~.screens.SLOPE_PRUNE`), so it does not depend on the order of the visits.

The walks prune with distances summed in any order (``box_screen2`` and ``leaf_screen2`` of
:mod:`.screens`, which vectorise) times ``screen_shrink``, a lower bound of the exact sum; only a
point the screen leaves within reach gets the exact sum in component order. At horizon 40 of
the soft-neck payload split (84 terms) this made one fold's slopes 1.6× and its bounds 1.5×
faster (``docs/benchmarks/sm_speed.md``). ``tests/test_sm_partial_distance.py`` checks every
kernel against a brute force; ``tests/test_sm_multistep.py`` the equality with the references.

References
----------
M. Milanese and C. Novara, "Set membership identification of nonlinear systems", Automatica
40(6), 957-975, 2004.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from neckid.models.set_membership._kernels.screens import (
    SLOPE_PRUNE,
    box_screen2,
    frame_lower2,
    frame_query,
    leaf_screen2,
    push_framed,
    screen_shrink,
)
from neckid.models.set_membership._kernels.tree import (
    STACK_DEPTH,
    improving_reach,
    query_one,
    reach_cap,
    squared_distance_capped,
)
from neckid.utils.types import FloatArray, IntArray

if TYPE_CHECKING:
    from neckid.models.set_membership._kernels.tree import SMTree

__all__ = ["PROGRESS_BLOCKS", "point_gamma_grid", "prior_bounds", "walk_priors"]


# ---------------------------------------------------------------------------------- constants
@njit(cache=True)
def _steepest_grid(
    i: int,
    c: int,
    twice_eps: FloatArray,
    tree: tuple[NDArray, ...],
    frame: tuple[NDArray, ...],
    qz: FloatArray,
    slack: float,
    node_stack: IntArray,
    dist_stack: FloatArray,
    best: FloatArray,
    screen: FloatArray,
) -> None:  # pragma: no cover - compiled; tested against point_gamma
    """``best[e]`` = max_{j≠i} fl((|t_i − t_j| − 2ε_e)⁺ / d_ij); ``twice_eps`` ascending.

    The maximum of the rounded ratios, whatever the order of the visits (:data:`SLOPE_PRUNE`).
    """
    points, targets, start, end, left, right, _, _, ymin, ymax = tree
    zpoints, zlo, zhi, _, _, _ = frame
    w = points[i]
    t = targets[i, c]
    n_eps = twice_eps.shape[0]
    best[:] = 0.0
    shrink = screen_shrink(w.shape[0])
    node_stack[0] = 0
    dist_stack[0] = math.sqrt(frame_lower2(box_screen2(qz, zlo, zhi, 0), shrink, slack))
    top = 1
    while top > 0:
        top -= 1
        node = node_stack[top]
        spread = max(t - ymin[node, c], ymax[node, c] - t)
        wanted = False
        for e in range(n_eps):
            gap = spread - twice_eps[e]
            if gap <= 0.0:
                break  # and for every larger ε
            if not gap <= best[e] * dist_stack[top] * SLOPE_PRUNE:
                wanted = True
                break
        if not wanted:
            continue
        child = left[node]
        if child < 0:
            first = start[node]
            leaf_screen2(qz, zpoints, first, end[node], screen)
            for p in range(first, end[node]):
                if p == i:
                    continue
                diff = abs(t - targets[p, c])
                reach = -1.0
                for e in range(n_eps):
                    rise = diff - twice_eps[e]
                    if rise <= 0.0:
                        break
                    reach = max(reach, rise / best[e] if best[e] > 0.0 else np.inf)
                if reach < 0.0:
                    continue  # no ε of the grid leaves a rise
                cap = reach_cap(reach)
                if frame_lower2(screen[p - first], shrink, slack) > cap:
                    continue  # farther than the cap, exactly too
                acc = squared_distance_capped(w, points, p, cap)
                if acc > cap:
                    continue  # too far for rise / d > best at any ε
                d = math.sqrt(acc)
                for e in range(n_eps):
                    rise = diff - twice_eps[e]
                    if rise <= 0.0:
                        break
                    slope = np.inf if d == 0.0 else rise / d
                    if slope > best[e]:
                        best[e] = slope
        else:
            top = push_framed(
                qz, frame, left, right, node, node_stack, dist_stack, top, shrink, slack, False
            )


@njit(cache=True, parallel=True)
def _point_gamma_grid_kernel(
    first: int,
    stop: int,
    twice_eps: FloatArray,
    tree: tuple[NDArray, ...],
    frame: tuple[NDArray, ...],
    max_leaf: int,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled; tested against point_gamma
    n_eps, _, n_out = out.shape
    points = tree[0]
    for i in prange(first, stop):
        node_stack = np.empty(STACK_DEPTH, np.int64)
        dist_stack = np.empty(STACK_DEPTH)
        best = np.empty(n_eps)
        screen = np.empty(max_leaf)
        qz = np.empty(frame[0].shape[1])
        slack = frame_query(points[i], frame, qz)
        for c in range(n_out):
            _steepest_grid(
                i,
                c,
                twice_eps[:, c],
                tree,
                frame,
                qz,
                slack,
                node_stack,
                dist_stack,
                best,
                screen,
            )
            for e in range(n_eps):
                out[e, i, c] = best[e]


#: Blocks of points between two calls of :func:`point_gamma_grid`'s callback.
PROGRESS_BLOCKS = 32


def point_gamma_grid(
    tree: SMTree,
    epsilons: FloatArray,
    callback: Callable[[int, int], None] | None = None,
) -> FloatArray:
    """:func:`~.local.point_gamma` at every ε of a grid, in one traversal per point.

    Parameters
    ----------
    tree : SMTree
        The training points (scaled) and targets.
    epsilons : ndarray, shape (n_eps, n_outputs)
        Noise bounds, ascending along the first axis in every column (>= 0).
    callback : callable, optional
        ``callback(points_done, points_total)``, called from Python between
        :data:`PROGRESS_BLOCKS` blocks of points.

    Returns
    -------
    ndarray, shape (n_eps, n_points, n_outputs)
        ``out[e]`` is ``point_gamma(tree, epsilons[e])``, bit for bit; its largest value over
        the points is γ*(ε) (both ends of every pair carry the pair's slope).

    Raises
    ------
    ValueError
        If ``epsilons`` is not ascending in some column.
    """
    epsilons = np.ascontiguousarray(epsilons, dtype=np.float64)
    if epsilons.shape[0] > 1 and np.any(np.diff(epsilons, axis=0) < 0):
        raise ValueError("epsilons must be ascending along the grid in every output column")
    twice = np.ascontiguousarray(2.0 * epsilons)
    n_points = tree.points.shape[0]
    out = np.empty((epsilons.shape[0], n_points, tree.targets.shape[1]))
    arrays, frame = tree.kernel_arrays(), tree.frame_arrays()
    if callback is None:
        _point_gamma_grid_kernel(0, n_points, twice, arrays, frame, tree.max_leaf, out)
        return out
    edges = np.linspace(0, n_points, PROGRESS_BLOCKS + 1).astype(np.int64)
    for first, stop in itertools.pairwise(edges):
        _point_gamma_grid_kernel(int(first), int(stop), twice, arrays, frame, tree.max_leaf, out)
        callback(int(stop), n_points)
    return out


# ---------------------------------------------------------------------------------- bounds
@njit(cache=True)
def _neighbour_gammas(
    w: FloatArray,
    radius2: float,
    gammas: FloatArray,
    tree: tuple[NDArray, ...],
    frame: tuple[NDArray, ...],
    qz: FloatArray,
    slack: float,
    node_stack: IntArray,
    dist_stack: FloatArray,
    out: FloatArray,
    screen: FloatArray,
) -> None:  # pragma: no cover - compiled; the second half of local._neighbour_gamma
    """``out[l, c]``: the largest ``gammas[p, l, c]`` within the squared radius, ties included."""
    points, _, start, end, left, right, _, _, _, _ = tree
    zpoints, zlo, zhi, _, _, _ = frame
    if not radius2 < np.inf:
        out[:, :] = np.inf
        return
    out[:, :] = 0.0
    shrink = screen_shrink(w.shape[0])
    node_stack[0] = 0
    dist_stack[0] = frame_lower2(box_screen2(qz, zlo, zhi, 0), shrink, slack)
    top = 1
    while top > 0:
        top -= 1
        node = node_stack[top]
        if dist_stack[top] > radius2:
            continue
        if left[node] < 0:
            first = start[node]
            leaf_screen2(qz, zpoints, first, end[node], screen)
            for p in range(first, end[node]):
                if frame_lower2(screen[p - first], shrink, slack) > radius2:
                    continue  # beyond the radius, exactly too
                if squared_distance_capped(w, points, p, radius2) <= radius2:
                    for m in range(out.shape[0]):
                        for c in range(out.shape[1]):
                            out[m, c] = max(out[m, c], gammas[p, m, c])
        else:
            top = push_framed(
                qz, frame, left, right, node, node_stack, dist_stack, top, shrink, slack, True
            )


@njit(cache=True)
def walk_priors(
    w: FloatArray,
    c: int,
    floor: FloatArray,
    local: IntArray,
    gammas: FloatArray,
    tree: tuple[NDArray, ...],
    frame: tuple[NDArray, ...],
    qz: FloatArray,
    slack: float,
    node_stack: IntArray,
    dist_stack: FloatArray,
    best_lower: FloatArray,
    best_upper: FloatArray,
    screen: FloatArray,
) -> None:  # pragma: no cover - compiled; query_one for every prior at once
    """``query_one`` of every prior ``s`` (slope ``max(floor[s], γ_j)`` or ``floor[s]``) at once."""
    points, targets, start, end, left, right, _, _, ymin, ymax = tree
    zpoints, zlo, zhi, _, _, _ = frame
    n_priors = floor.shape[0]
    best_upper[:] = np.inf
    best_lower[:] = -np.inf
    shrink = screen_shrink(w.shape[0])
    node_stack[0] = 0
    dist_stack[0] = math.sqrt(frame_lower2(box_screen2(qz, zlo, zhi, 0), shrink, slack))
    top = 1
    while top > 0:
        top -= 1
        node = node_stack[top]
        wanted = False
        for s in range(n_priors):
            reach = floor[s] * dist_stack[top]
            if not (
                ymin[node, c] + reach >= best_upper[s] and ymax[node, c] - reach <= best_lower[s]
            ):
                wanted = True
                break
        if not wanted:
            continue
        child = left[node]
        if child < 0:
            first = start[node]
            leaf_screen2(qz, zpoints, first, end[node], screen)
            for p in range(first, end[node]):
                v = targets[p, c]
                reach = -1.0
                for s in range(n_priors):
                    m = local[s]
                    slope = max(floor[s], gammas[p, m, c]) if m >= 0 else floor[s]
                    reach = max(reach, improving_reach(v, slope, best_lower[s], best_upper[s]))
                if reach < 0.0:
                    continue  # it changes no prior's bounds at any distance
                cap = reach_cap(reach)
                if frame_lower2(screen[p - first], shrink, slack) > cap:
                    continue  # farther than the cap, exactly too
                acc = squared_distance_capped(w, points, p, cap)
                if acc > cap:
                    continue  # farther than any distance at which it changes one
                d = math.sqrt(acc)
                for s in range(n_priors):
                    m = local[s]
                    slope = max(floor[s], gammas[p, m, c]) if m >= 0 else floor[s]
                    gd = slope * d
                    if v + gd < best_upper[s]:
                        best_upper[s] = v + gd
                    if v - gd > best_lower[s]:
                        best_lower[s] = v - gd
        else:
            top = push_framed(
                qz, frame, left, right, node, node_stack, dist_stack, top, shrink, slack, False
            )


#: Points a query's nearest-neighbour walk records (those within the running k-th distance
#: when visited); beyond it the constants are found by a second walk (:func:`_neighbour_gammas`).
NEAR_RECORD = 1024


@njit(cache=True)
def _near_constants(
    w: FloatArray,
    k_near: int,
    gammas: FloatArray,
    tree: tuple[NDArray, ...],
    frame: tuple[NDArray, ...],
    qz: FloatArray,
    slack: float,
    node_stack: IntArray,
    dist_stack: FloatArray,
    near_d: FloatArray,
    screen: FloatArray,
    record_p: IntArray,
    record_d: FloatArray,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled; kth_radius2 then _neighbour_gammas, in one walk
    """``out[l, c]``: the largest ``gammas[p, l, c]`` within the ``k_near``-th distance, ties in.

    One walk of ``kth_radius2``'s that also records every point within the running k-th distance
    when it is visited: the running distance only shrinks, so every point within the final one is
    recorded (its node is opened, its screen and its exact sum are within the running distance).
    If more than :data:`NEAR_RECORD` are, the second walk of :func:`_neighbour_gammas` is made.
    """
    points, _, start, end, left, right, _, _, _, _ = tree
    zpoints, zlo, zhi, _, _, _ = frame
    k_near = min(k_near, points.shape[0])
    shrink = screen_shrink(w.shape[0])
    for k in range(k_near):
        near_d[k] = np.inf
    n_rec = 0
    node_stack[0] = 0
    dist_stack[0] = frame_lower2(box_screen2(qz, zlo, zhi, 0), shrink, slack)
    top = 1
    while top > 0:
        top -= 1
        node = node_stack[top]
        if dist_stack[top] > near_d[k_near - 1]:
            continue
        if left[node] < 0:
            first = start[node]
            leaf_screen2(qz, zpoints, first, end[node], screen)
            for p in range(first, end[node]):
                radius = near_d[k_near - 1]
                if frame_lower2(screen[p - first], shrink, slack) > radius:
                    continue
                acc = squared_distance_capped(w, points, p, radius)
                if not acc <= radius:
                    continue
                if n_rec < record_p.shape[0]:
                    record_p[n_rec] = p
                    record_d[n_rec] = acc
                n_rec += 1
                if acc < radius:
                    slot = k_near - 1
                    while slot > 0 and near_d[slot - 1] > acc:
                        near_d[slot] = near_d[slot - 1]
                        slot -= 1
                    near_d[slot] = acc
        else:
            top = push_framed(
                qz, frame, left, right, node, node_stack, dist_stack, top, shrink, slack, True
            )
    radius2 = near_d[k_near - 1]
    if n_rec > record_p.shape[0]:
        _neighbour_gammas(
            w, radius2, gammas, tree, frame, qz, slack, node_stack, dist_stack, out, screen
        )
        return
    if not radius2 < np.inf:
        out[:, :] = np.inf
        return
    out[:, :] = 0.0
    for j in range(n_rec):
        if record_d[j] <= radius2:
            p = record_p[j]
            for m in range(out.shape[0]):
                for c in range(out.shape[1]):
                    out[m, c] = max(out[m, c], gammas[p, m, c])


@njit(cache=True, parallel=True)
def _prior_bounds_kernel(
    queries: FloatArray,
    k_near: int,
    gamma: FloatArray,
    epsilon: FloatArray,
    local: IntArray,
    gammas: FloatArray,
    tree: tuple[NDArray, ...],
    frame: tuple[NDArray, ...],
    max_leaf: int,
    lower: FloatArray,
    upper: FloatArray,
) -> None:  # pragma: no cover - compiled; tested against tree.bounds and local_bounds
    points, targets, start, end, left, right, lo, hi, ymin, ymax = tree
    n_priors, n_out = gamma.shape
    any_local = gammas.shape[1] > 0
    for i in prange(queries.shape[0]):
        w = queries[i]
        node_stack = np.empty(STACK_DEPTH, np.int64)
        dist_stack = np.empty(STACK_DEPTH)
        near_d = np.empty(max(k_near, 1))
        near_g = np.zeros((gammas.shape[1], n_out))
        floor = np.empty(n_priors)
        best_lower = np.empty(n_priors)
        best_upper = np.empty(n_priors)
        screen = np.empty(max_leaf)
        record_p = np.empty(NEAR_RECORD if any_local else 0, np.int64)
        record_d = np.empty(NEAR_RECORD if any_local else 0)
        qz = np.empty(frame[0].shape[1])
        slack = frame_query(w, frame, qz)
        if any_local:
            _near_constants(
                w,
                k_near,
                gammas,
                tree,
                frame,
                qz,
                slack,
                node_stack,
                dist_stack,
                near_d,
                screen,
                record_p,
                record_d,
                near_g,
            )
        for c in range(n_out):
            for s in range(n_priors):
                floor[s] = near_g[local[s], c] if local[s] >= 0 else gamma[s, c]
            walk_priors(
                w,
                c,
                floor,
                local,
                gammas,
                tree,
                frame,
                qz,
                slack,
                node_stack,
                dist_stack,
                best_lower,
                best_upper,
                screen,
            )
            for s in range(n_priors):
                low, high = best_lower[s], best_upper[s]
                m = local[s]
                if m >= 0 and low - high > 2.0 * epsilon[s, c] and gamma[s, c] > floor[s]:
                    # The rounding fallback of local._local_one: the global constant.
                    low, high = query_one(
                        w,
                        points,
                        targets,
                        c,
                        gamma[s, c],
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
                        np.ascontiguousarray(gammas[:, m, :]),
                    )
                lower[i, s, c] = low - epsilon[s, c]
                upper[i, s, c] = high + epsilon[s, c]


def prior_bounds(
    tree: SMTree,
    queries: FloatArray,
    epsilon: FloatArray,
    gamma: FloatArray,
    point_gammas: FloatArray,
    local: IntArray,
    neighbours: int,
) -> tuple[FloatArray, FloatArray]:
    """The bounds ``[f_l − ε, f_u + ε]`` of several priors at every query, in one walk per query.

    Parameters
    ----------
    tree : SMTree
        Training points (scaled) and targets.
    queries : ndarray, shape (n_queries, n_dims)
        Scaled regressors.
    epsilon, gamma : ndarray, shape (n_priors, n_outputs)
        Each prior's noise bound and global Lipschitz constant (the fallback of a local prior).
    point_gammas : ndarray, shape (n_local, n_points, n_outputs)
        Per-point constants (tree order) of the local priors, as ``learn_constants`` gives them.
    local : ndarray of int, shape (n_priors,)
        ``-1`` for a global prior, else its index in ``point_gammas``.
    neighbours : int
        ``K`` of the local priors (their ``local_neighbours``).

    Returns
    -------
    lower, upper : ndarray, each (n_queries, n_priors, n_outputs)
        Prior ``s`` global: ``SMTree.bounds(queries, epsilon[s], gamma[s])``; local:
        ``local_bounds(tree, point_gammas[local[s]], queries, epsilon[s], gamma[s], K)[:2]``,
        bit for bit.
    """
    queries = np.ascontiguousarray(queries, dtype=np.float64)
    gamma = np.ascontiguousarray(gamma, dtype=np.float64)
    shape = (queries.shape[0], *gamma.shape)
    lower, upper = np.empty(shape), np.empty(shape)
    n_out = tree.targets.shape[1]
    # Point-major, so that the walk reads one point's constants of every prior together.
    gammas = np.ascontiguousarray(
        np.asarray(point_gammas, dtype=np.float64)
        .reshape(-1, tree.points.shape[0], n_out)
        .transpose(1, 0, 2)
    )
    _prior_bounds_kernel(
        queries,
        int(neighbours),
        gamma,
        np.ascontiguousarray(epsilon, dtype=np.float64),
        np.ascontiguousarray(local, dtype=np.int64),
        gammas,
        tree.kernel_arrays(),
        tree.frame_arrays(),
        tree.max_leaf,
        lower,
        upper,
    )
    return lower, upper
