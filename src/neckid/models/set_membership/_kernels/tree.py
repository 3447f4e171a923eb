"""Compiled kernels for Set Membership identification, and the plain NumPy references beside them.

Everything here works on *scaled* regressors (the caller multiplies each component by its weight),
so the distance is the plain Euclidean one.

Kernels
-------
- :func:`build_tree`: a kd-tree over the training regressors (median split on the widest
  component by an in-place quickselect, leaves of at most ``LEAF_SIZE`` points); every node
  keeps its bounding box. The node arrays are allocated once, at their exact size.
- :class:`SMTree`: the tree plus, per node and per output, the min and max of the targets ỹ, and
  the exact branch-and-bound evaluation of

      f_u(w) = min_k (ỹ_k + γ‖w − w̃_k‖) + ε,      f_l(w) = max_k (ỹ_k − γ‖w − w̃_k‖) − ε.

  A node is skipped when ``min ỹ(node) + γ·dist(w, box)`` cannot lower the best upper value found
  so far *and* ``max ỹ(node) − γ·dist(w, box)`` cannot raise the best lower value. The squared
  box distance is a sum of a subset of the very terms that make up a contained point's squared
  distance, summed in the same order, so (floating-point addition and multiplication being
  monotone) the pruning test never skips a point that would have changed the result: the bounds
  are *bit for bit* those of a linear scan with the same formula. With ``overwrite_points`` it
  reorders the caller's matrix in place (:func:`_permute_rows`, one spare row) instead of
  keeping a reordered copy: the estimator's one copy of its training points.
- the screens of the walks whose result does not depend on the visiting order are in
  :mod:`.screens`.
- the compiled free-run loop (:mod:`.free_run`) (regressor from the simulated history, linear
  part, both bounds, central value fed back).
- γ*(ε) (:func:`~neckid.models.set_membership._kernels.gamma.gamma_star`): = max_{i≠j} (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖ for a whole grid of ε,
  by branch and bound over the kd-tree (or, for few points, over all pairs); the kernels are in
  :mod:`neckid.models.set_membership._kernels.gamma`. A Python callback reports progress between blocks of rows.

The plain NumPy references (vectorised over training points) are beside this module, in
:mod:`_sm_reference`; tests check that the kernels agree with them.
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from neckid.models.set_membership._kernels.frame import (
    empty_box,
    node_boxes,
    principal_frame,
    widen_box,
)
from neckid.models.set_membership._kernels.screens import _push_pair
from neckid.utils.types import FloatArray, IntArray

__all__ = [
    "LEAF_SIZE",
    "SMTree",
    "build_tree",
]


logger = logging.getLogger(__name__)

#: Largest number of training points in a leaf of the kd-tree.
LEAF_SIZE = 16
#: Depth of the traversal stack; a median-split tree over 2**60 points is shallower.
STACK_DEPTH = 128


# ---------------------------------------------------------------------------------- tree build
@njit(cache=True)
def _count_nodes(n_points: int, leaf_size: int) -> int:
    """Nodes of the median-split tree over ``n_points`` (fewer if identical points stop a split)."""
    sizes = np.empty(STACK_DEPTH, np.int64)
    sizes[0] = n_points
    top = 1
    count = 0
    while top > 0:
        top -= 1
        size = sizes[top]
        count += 1
        if size > leaf_size:
            sizes[top] = size // 2
            sizes[top + 1] = size - size // 2
            top += 2
    return count


@njit(cache=True)
def _select(points: FloatArray, perm: IntArray, dim: int, first: int, stop: int, k: int) -> None:
    """Reorder ``perm[first:stop]`` so that the points before ``k`` are <= those from ``k`` on.

    Quickselect on component ``dim`` with a median-of-three pivot and a three-way partition (runs
    of equal values, as identical regressors make, end it at once); no memory is allocated.
    """
    while stop - first > 1:
        a = points[perm[first], dim]
        b = points[perm[(first + stop) // 2], dim]
        c = points[perm[stop - 1], dim]
        pivot = max(min(a, b), min(max(a, b), c))
        below = first
        p = first
        above = stop
        while p < above:
            v = points[perm[p], dim]
            if v < pivot:
                perm[below], perm[p] = perm[p], perm[below]
                below += 1
                p += 1
            elif v > pivot:
                above -= 1
                perm[above], perm[p] = perm[p], perm[above]
            else:
                p += 1
        if k < below:
            stop = below
        elif k >= above:
            first = above
        else:
            return


@njit(cache=True)
def _build_tree_kernel(
    points: FloatArray, leaf_size: int
) -> tuple[IntArray, IntArray, IntArray, IntArray, IntArray, FloatArray, FloatArray]:
    n_points, n_dims = points.shape
    max_nodes = _count_nodes(n_points, leaf_size)
    perm = np.arange(n_points)
    start = np.zeros(max_nodes, np.int64)
    end = np.zeros(max_nodes, np.int64)
    left = np.full(max_nodes, -1, np.int64)
    right = np.full(max_nodes, -1, np.int64)
    lo = np.empty((max_nodes, n_dims))
    hi = np.empty((max_nodes, n_dims))
    stack = np.empty(STACK_DEPTH, np.int64)
    start[0] = 0
    end[0] = n_points
    n_nodes = 1
    stack[0] = 0
    top = 1
    while top > 0:
        top -= 1
        node = stack[top]
        s = start[node]
        e = end[node]
        empty_box(lo, hi, node)
        for p in range(s, e):
            widen_box(lo, hi, node, points, perm[p])
        if e - s <= leaf_size:
            continue
        dim = 0
        widest = -1.0
        for k in range(n_dims):
            spread = hi[node, k] - lo[node, k]
            if spread > widest:
                widest = spread
                dim = k
        if widest <= 0.0:  # all points identical: one leaf, however many
            continue
        mid = s + (e - s) // 2
        _select(points, perm, dim, s, e, mid)
        child = n_nodes
        n_nodes += 2
        start[child] = s
        end[child] = mid
        start[child + 1] = mid
        end[child + 1] = e
        left[node] = child
        right[node] = child + 1
        stack[top] = child
        stack[top + 1] = child + 1
        top += 2
    if n_nodes == max_nodes:
        return perm, start, end, left, right, lo, hi
    return (
        perm,
        start[:n_nodes].copy(),
        end[:n_nodes].copy(),
        left[:n_nodes].copy(),
        right[:n_nodes].copy(),
        lo[:n_nodes].copy(),
        hi[:n_nodes].copy(),
    )


@njit(cache=True)
def _permute_rows(points: FloatArray, perm: IntArray) -> None:
    """``points[p] = points[perm[p]]`` for every p, in place: one row and one flag per row spare."""
    n_points, n_dims = points.shape
    done = np.zeros(n_points, np.bool_)
    row = np.empty(n_dims)
    for first in range(n_points):
        if done[first]:
            continue
        for k in range(n_dims):
            row[k] = points[first, k]
        p = first
        while True:  # follow the cycle of the permutation through ``first``
            done[p] = True
            q = perm[p]
            if q == first:
                for k in range(n_dims):
                    points[p, k] = row[k]
                break
            for k in range(n_dims):
                points[p, k] = points[q, k]
            p = q


@njit(cache=True)
def _node_ranges_kernel(
    targets: FloatArray, start: IntArray, end: IntArray
) -> tuple[FloatArray, FloatArray]:
    n_nodes = start.shape[0]
    n_out = targets.shape[1]
    ymin = np.empty((n_nodes, n_out))
    ymax = np.empty((n_nodes, n_out))
    for node in range(n_nodes):
        for c in range(n_out):
            low = np.inf
            high = -np.inf
            for p in range(start[node], end[node]):
                v = targets[p, c]
                if v < low:
                    low = v
                if v > high:
                    high = v
            ymin[node, c] = low
            ymax[node, c] = high
    return ymin, ymax


def build_tree(points: FloatArray, leaf_size: int = LEAF_SIZE) -> dict[str, NDArray]:
    """Build the kd-tree over ``points`` (shape ``(n_points, n_dims)``, already scaled).

    Returns a dict with ``perm`` (tree order of the points), per-node ``start``/``end`` (range in
    tree order), ``left``/``right`` (children, -1 for a leaf) and the bounding box ``lo``/``hi``.
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    perm, start, end, left, right, lo, hi = _build_tree_kernel(points, int(leaf_size))
    return {
        "perm": perm,
        "start": start,
        "end": end,
        "left": left,
        "right": right,
        "lo": lo,
        "hi": hi,
    }


# ---------------------------------------------------------------------------------- queries
@njit(cache=True, inline="always")
def box_distance2(w: FloatArray, lo: FloatArray, hi: FloatArray, node: int) -> float:
    """Squared distance from ``w`` to the bounding box of ``node`` (0 inside)."""
    acc = 0.0
    for k in range(w.shape[0]):
        v = w[k]
        if v < lo[node, k]:
            diff = lo[node, k] - v
            acc += diff * diff
        elif v > hi[node, k]:
            diff = v - hi[node, k]
            acc += diff * diff
    return acc


@njit(cache=True, inline="always")
def squared_distance(w: FloatArray, points: FloatArray, p: int) -> float:
    """Squared distance from ``w`` to ``points[p]``, summed in component order."""
    acc = 0.0
    for k in range(w.shape[0]):
        diff = w[k] - points[p, k]
        acc += diff * diff
    return acc


@njit(cache=True, inline="always")
def squared_distance_capped(w: FloatArray, points: FloatArray, p: int, cap: float) -> float:
    """:func:`squared_distance`, or a partial sum above ``cap`` as soon as one exceeds it.

    The terms are non-negative and added in the same order, so a rounded partial sum never
    exceeds the rounded full one: a result ``<= cap`` is the full sum bit for bit, and a result
    ``> cap`` says that the full sum is above ``cap`` too (partial distance search). NaN
    components never stop the sum (NaN compares false), as in :func:`squared_distance`.
    """
    acc = 0.0
    for k in range(w.shape[0]):
        diff = w[k] - points[p, k]
        acc += diff * diff
        if acc > cap:
            return acc
    return acc


@njit(cache=True, inline="always")
def reach_cap(reach: float) -> float:
    """A squared distance above which a point lies farther than ``reach`` even after rounding.

    ``reach`` is a distance (>= 0, or inf for no cap); the cap is ``reach² (1 + 1e-9)``, or no
    cap (inf) where the square would underflow. A point whose squared distance exceeds it has
    ``fl(sqrt(d²)) > reach (1 + 4e-10)``.
    """
    if not reach < np.inf or reach < 1e-100:
        return np.inf
    return reach * reach * (1.0 + 1e-9)


@njit(cache=True, inline="always")
def improving_reach(v: float, slope: float, lower: float, upper: float) -> float:
    """The distance within which a point can still change a running bound, or -1 if none.

    A point of target ``v`` at distance ``d`` lowers ``upper`` when ``v + slope·d < upper`` and
    raises ``lower`` when ``v − slope·d > lower``. Beyond the returned reach (with the margin of
    :func:`reach_cap`) neither happens in floating point: the gaps ``upper − v`` and
    ``v − lower`` are widened by ``1e-15 (|upper| + |v| + |lower|)``, more than their rounding.
    inf (no cap) where a bound is still infinite, the slope is 0 and ``v`` itself improves a
    bound, or the slope is not a finite positive number.
    """
    if not (upper < np.inf and lower > -np.inf and slope < np.inf):
        return np.inf
    tol = 1e-15 * (abs(upper) + abs(v) + abs(lower))
    gap = max(upper - v, v - lower) + tol
    if gap < 0.0:
        return -1.0
    if not slope > 0.0:
        return np.inf
    return gap / slope


@njit(cache=True, inline="always")
def box_distance(w: FloatArray, lo: FloatArray, hi: FloatArray, node: int) -> float:
    return math.sqrt(box_distance2(w, lo, hi, node))


@njit(cache=True, inline="always")
def push_children(
    w: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    left: IntArray,
    right: IntArray,
    node: int,
    node_stack: IntArray,
    dist_stack: FloatArray,
    top: int,
) -> int:
    """Push the two children of ``node`` with their box distances, the nearer one on top."""
    child = left[node]
    other = right[node]
    d_left = box_distance(w, lo, hi, child)
    d_right = box_distance(w, lo, hi, other)
    return _push_pair(child, other, d_left, d_right, node_stack, dist_stack, top)


@njit(cache=True)
def query_one(
    w: FloatArray,
    points: FloatArray,
    targets: FloatArray,
    col: int,
    gamma: float,
    start: IntArray,
    end: IntArray,
    left: IntArray,
    right: IntArray,
    lo: FloatArray,
    hi: FloatArray,
    ymin: FloatArray,
    ymax: FloatArray,
    node_stack: IntArray,
    dist_stack: FloatArray,
    point_gamma: FloatArray,
) -> tuple[float, float]:
    """Return ``(max_k ỹ_k − L_k d_k, min_k ỹ_k + L_k d_k)`` for one query (ε not included).

    ``L_k = γ`` with an empty ``point_gamma`` (shape ``(0, n_outputs)``: one global constant),
    else ``max(γ, point_gamma[k, col])`` (local constants, :mod:`neckid.models.set_membership._kernels.local`,
    where ``γ`` is the query's own constant); the node test uses ``γ``, a lower bound of every
    ``L_k``.
    """
    local = point_gamma.shape[0] > 0
    best_upper = np.inf
    best_lower = -np.inf
    node_stack[0] = 0
    dist_stack[0] = box_distance(w, lo, hi, 0)
    top = 1
    while top > 0:
        top -= 1
        node = node_stack[top]
        reach = gamma * dist_stack[top]
        if ymin[node, col] + reach >= best_upper and ymax[node, col] - reach <= best_lower:
            continue
        child = left[node]
        if child < 0:
            for p in range(start[node], end[node]):
                slope = max(gamma, point_gamma[p, col]) if local else gamma
                v = targets[p, col]
                reach = improving_reach(v, slope, best_lower, best_upper)
                if reach < 0.0:
                    continue
                cap = reach_cap(reach)
                acc = squared_distance_capped(w, points, p, cap)
                if acc > cap:
                    continue  # farther than any distance at which it changes a bound
                gd = slope * math.sqrt(acc)
                if v + gd < best_upper:
                    best_upper = v + gd
                if v - gd > best_lower:
                    best_lower = v - gd
        else:  # the nearer child is explored first
            top = push_children(w, lo, hi, left, right, node, node_stack, dist_stack, top)
    return best_lower, best_upper


@njit(cache=True, parallel=True)
def _bounds_many_kernel(
    queries: FloatArray,
    points: FloatArray,
    targets: FloatArray,
    gamma: FloatArray,
    start: IntArray,
    end: IntArray,
    left: IntArray,
    right: IntArray,
    lo: FloatArray,
    hi: FloatArray,
    ymin: FloatArray,
    ymax: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
) -> None:
    n_out = targets.shape[1]
    no_points = np.empty((0, n_out))
    for i in prange(queries.shape[0]):
        node_stack = np.empty(STACK_DEPTH, np.int64)
        dist_stack = np.empty(STACK_DEPTH)
        w = queries[i]
        for c in range(n_out):
            low, high = query_one(
                w,
                points,
                targets,
                c,
                gamma[c],
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
                no_points,
            )
            lower[i, c] = low
            upper[i, c] = high


@njit(cache=True)
def _bounds_few_kernel(
    queries: FloatArray, gamma: FloatArray, tree: Any, lower: FloatArray, upper: FloatArray
) -> None:  # pragma: no cover - compiled; tested against the parallel kernel and the reference
    """:func:`_bounds_many_kernel` without threads, for a few rows (a simulator's one step).

    Starting the thread pool costs more than a handful of queries, and much more on a busy
    machine; the results are identical (same traversal, same sums).
    """
    points, targets, start, end, left, right, lo, hi, ymin, ymax = tree  # SMTree.kernel_arrays()
    node_stack = np.empty(STACK_DEPTH, np.int64)
    dist_stack = np.empty(STACK_DEPTH)
    no_points = np.empty((0, targets.shape[1]))
    for i in range(queries.shape[0]):
        for c in range(targets.shape[1]):
            lower[i, c], upper[i, c] = query_one(
                queries[i],
                points,
                targets,
                c,
                gamma[c],
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
                no_points,
            )


#: Below this many queries the bounds are evaluated without threads.
SERIAL_QUERIES = 64


def _reordered(rows: FloatArray, perm: IntArray, in_place: bool) -> FloatArray:
    """``rows[perm]``: ``rows`` itself reordered in place when allowed and writeable, else a copy."""
    if in_place and rows.flags.writeable:
        _permute_rows(rows, perm)
        return rows
    return np.ascontiguousarray(rows[perm])


class SMTree:
    """Kd-tree over scaled training regressors with per-node target ranges, for exact SM bounds.

    The tree holds the one copy of the points, in tree order (``points[p]`` is the input row
    ``perm[p]``): each node is a range of rows, its bounding box and the range of its targets.

    Parameters
    ----------
    points : ndarray, shape (n_points, n_dims)
        Scaled training regressors w̃_k.
    targets : ndarray, shape (n_points, n_outputs)
        Training targets ỹ_k (one column per output).
    leaf_size : int, default LEAF_SIZE
        Largest number of points in a leaf.
    overwrite_points : bool, default False
        Reorder ``points`` in place into tree order and keep it as :attr:`points` instead of
        keeping a reordered copy (when it is a C-contiguous float64 array; else a copy is made
        as usual): for a caller that no longer needs the rows in their first order.
    overwrite_targets : bool, default False
        The same for ``targets`` (when it is a writeable C-contiguous float64 array).
    frame : bool, default False
        Split the tree in the principal frame of the points
        (:func:`~.frame.principal_frame`; from :data:`~.frame.FRAME_MIN_TERMS` terms on) and
        keep the rotated points and boxes for the screened walks (:meth:`frame_arrays`). Every
        result is the same; the screened walks visit fewer points where a few directions hold
        most of the spread (lagged signals, many terms), for one more copy of the points.
        :attr:`lo`/:attr:`hi` stay the boxes in the points' own coordinates.
    """

    def __init__(
        self,
        points: FloatArray,
        targets: FloatArray,
        leaf_size: int = LEAF_SIZE,
        *,
        overwrite_points: bool = False,
        overwrite_targets: bool = False,
        frame: bool = False,
    ) -> None:
        points = np.ascontiguousarray(points, dtype=np.float64)
        targets = np.ascontiguousarray(targets, dtype=np.float64)
        principal = principal_frame(points) if frame else None
        rotated = None if principal is None else (points - principal[0]) @ principal[1].T
        tree = build_tree(points if rotated is None else rotated, leaf_size)
        perm = tree["perm"]
        self.perm: IntArray = perm
        self.points: FloatArray = _reordered(points, perm, overwrite_points)
        self.targets: FloatArray = _reordered(targets, perm, overwrite_targets)
        self.start: IntArray = tree["start"]
        self.end: IntArray = tree["end"]
        self.left: IntArray = tree["left"]
        self.right: IntArray = tree["right"]
        if rotated is None or principal is None:
            self.lo: FloatArray = tree["lo"]
            self.hi: FloatArray = tree["hi"]
            self._frame: tuple[NDArray, ...] = (
                self.points,
                self.lo,
                self.hi,
                np.empty((0, 0)),
                np.empty(0),
                np.empty(2),
            )
        else:
            self.lo, self.hi = node_boxes(self.points, self.start, self.end, self.left, self.right)
            centre, rotation, error = principal
            rotated = np.ascontiguousarray(rotated[perm])
            self._frame = (rotated, tree["lo"], tree["hi"], rotation, centre, error)
        self.ymin, self.ymax = _node_ranges_kernel(self.targets, self.start, self.end)
        leaves = self.left < 0
        #: Points of the largest leaf (identical points share one leaf, however many).
        self.max_leaf: int = int((self.end - self.start)[leaves].max()) if leaves.any() else 0

    @property
    def n_nodes(self) -> int:
        """Number of nodes of the tree."""
        return int(self.start.shape[0])

    def kernel_arrays(self) -> tuple[NDArray, ...]:
        """``(points, targets, start, end, left, right, lo, hi, ymin, ymax)`` for the kernels."""
        return (
            self.points,
            self.targets,
            self.start,
            self.end,
            self.left,
            self.right,
            self.lo,
            self.hi,
            self.ymin,
            self.ymax,
        )

    @property
    def framed(self) -> bool:
        """Whether the tree was split in a principal frame (:func:`~.frame.principal_frame`)."""
        return bool(self._frame[3].shape[0])

    def frame_arrays(self) -> tuple[NDArray, ...]:
        """``(points, lo, hi, R, μ, error)`` in the screening frame, for the screened walks.

        Without a principal frame: the tree's points and boxes, and empty ``R`` and ``μ``
        (:func:`~.screens.frame_query`). With one: the rotated points in tree order, the boxes
        the tree was split by, the rotation, the centre and ``(slack of the points, factor of a
        query's norm)``.
        """
        return self._frame

    def bounds(
        self, queries: FloatArray, epsilon: FloatArray, gamma: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Return ``(f_l, f_u)``, each ``(n_queries, n_outputs)``, at scaled ``queries``."""
        queries = np.ascontiguousarray(queries, dtype=np.float64)
        gamma = np.ascontiguousarray(gamma, dtype=np.float64)
        n_out = self.targets.shape[1]
        lower = np.empty((queries.shape[0], n_out))
        upper = np.empty((queries.shape[0], n_out))
        if queries.shape[0] < SERIAL_QUERIES:
            _bounds_few_kernel(queries, gamma, self.kernel_arrays(), lower, upper)
            return lower - epsilon, upper + epsilon
        points, targets, start, end, left, right, lo, hi, ymin, ymax = self.kernel_arrays()
        _bounds_many_kernel(
            queries,
            points,
            targets,
            gamma,
            start,
            end,
            left,
            right,
            lo,
            hi,
            ymin,
            ymax,
            lower,
            upper,
        )
        return lower - epsilon, upper + epsilon
