"""The kd-tree branch and bound of γ*(ε): one pair, one leaf's search, the kernels over leaves.

:func:`~neckid.models.set_membership._kernels.gamma.gamma_star_blocked` runs these over blocks of
leaves of the tree built by :func:`neckid.models.set_membership._kernels.tree.build_tree`
(Bentley 1975; Friedman, Bentley & Finkel 1977): the points of one leaf search together for the
partners that could still raise the running maximum, and skip every node whose bound on the
ratio, (max |ỹ_i − ỹ_j| − 2ε) / min ‖w̃_i − w̃_j‖ over the node, cannot exceed it, or, with slope
bounds (:mod:`~neckid.models.set_membership._kernels.slope`), whose bound by a linear model of
the targets cannot. A pair that is not skipped is evaluated with the same arithmetic as the
all-pairs kernel (:func:`_raise`), so the result is bit for bit that of all pairs.

References
----------
M. Milanese and C. Novara, "Set Membership identification of nonlinear systems", Automatica 40(6),
957-975, 2004.
J. L. Bentley, "Multidimensional binary search trees used for associative searching", Commun. ACM
18(9), 509-517, 1975.
J. H. Friedman, J. L. Bentley and R. A. Finkel, "An algorithm for finding best matches in
logarithmic expected time", ACM Trans. Math. Softw. 3(3), 209-226, 1977.
A. G. Gray and A. W. Moore, "'N-body' problems in statistical learning", Advances in Neural
Information Processing Systems 13, 521-527, 2001.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, prange

from neckid.models.set_membership._kernels.slope import slope_skips
from neckid.models.set_membership._kernels.tree import STACK_DEPTH
from neckid.utils.types import FloatArray, IntArray

__all__: list[str] = []


# ------------------------------------------------------------------------- one pair
@njit(cache=True, inline="always")
def _raise_with_pair(
    g: FloatArray,
    dd: float,
    targets: FloatArray,
    i: int,
    j: int,
    twice_eps: FloatArray,
    reach2: FloatArray,
    bins_per_unit: FloatArray,
) -> None:
    """Raise the running maxima ``g`` (E, m) with the pair ``(i, j)`` at squared distance ``dd``.

    ``reach2[b, c]`` bounds from above the squared distance below which a pair whose output
    difference Δ falls in bin ``b - 1`` (``Δ * bins_per_unit[c]``) can still raise ``g`` at
    some ε; other pairs are skipped without a square root or a division. For a pair, the ratio
    ℓ_e = (Δ − 2ε_e)/d is affine in ε and the running maximum G_e is convex in ε (a maximum of
    such lines, sampled on the grid), so ℓ_e − G_e is concave along the grid: once it is <= 0 and
    not increasing it stays <= 0, and the loop over the grid stops. ``twice_eps`` is sorted.
    """
    n_out = targets.shape[1]
    n_eps = twice_eps.shape[0]
    n_bins = reach2.shape[0]
    if dd == 0.0:
        for c in range(n_out):
            delta = abs(targets[i, c] - targets[j, c])
            for e in range(n_eps):
                if delta - twice_eps[e, c] <= 0.0:
                    break
                g[e, c] = np.inf
        return
    for c in range(n_out):
        delta = abs(targets[i, c] - targets[j, c])
        b = int(delta * bins_per_unit[c]) + 1
        if b >= n_bins:
            b = n_bins - 1
        if dd >= reach2[b, c]:
            continue
        d = math.sqrt(dd)
        previous = -np.inf
        for e in range(n_eps):
            num = delta - twice_eps[e, c]
            if num <= 0.0:
                break
            ratio = num / d
            gap = ratio - g[e, c]
            if gap > 0.0:
                g[e, c] = ratio
            elif gap <= previous and previous > -np.inf and twice_eps[e, c] > twice_eps[e - 1, c]:
                # (a repeated ε of the grid has its own entry: never stop on it)
                break
            previous = gap


@njit(cache=True, inline="always")
def _raise_margin_with_pair(
    g: FloatArray,
    dd: float,
    targets: FloatArray,
    i: int,
    j: int,
    gamma: FloatArray,
    reach2: FloatArray,
    bins_per_unit: FloatArray,
) -> None:
    """Raise the running maxima ``g`` (1, m) of ``Δ − γ d`` with the pair ``(i, j)``.

    ``gamma`` (1, m) holds γ; ``reach2[b, c]`` bounds the squared distance below which a pair
    with Δ in bin ``b - 1`` can exceed ``g`` (``d < (Δ − g) / γ``); other pairs are skipped.
    """
    n_bins = reach2.shape[0]
    for c in range(targets.shape[1]):
        delta = abs(targets[i, c] - targets[j, c])
        margin = delta
        if dd > 0.0:
            b = min(int(delta * bins_per_unit[c]) + 1, n_bins - 1)
            if dd >= reach2[b, c]:
                continue
            margin = delta - gamma[0, c] * math.sqrt(dd)
        if margin > g[0, c]:
            g[0, c] = margin


@njit(cache=True, inline="always")
def _raise(
    margin: bool,
    g: FloatArray,
    dd: float,
    targets: FloatArray,
    i: int,
    j: int,
    twice_eps: FloatArray,
    reach2: FloatArray,
    bins_per_unit: FloatArray,
) -> None:
    """:func:`_raise_margin_with_pair` if ``margin`` (``twice_eps`` holds γ), else the γ* one."""
    if margin:
        _raise_margin_with_pair(g, dd, targets, i, j, twice_eps, reach2, bins_per_unit)
    else:
        _raise_with_pair(g, dd, targets, i, j, twice_eps, reach2, bins_per_unit)


# ------------------------------------------------------------------------- kd-tree
@njit(cache=True, inline="always")
def _search_points(
    q: int,
    node: int,
    points: FloatArray,
    targets: FloatArray,
    twice_eps: FloatArray,
    g: FloatArray,
    reach2: FloatArray,
    bins_per_unit: FloatArray,
    tree: Any,
    margin: bool,
) -> tuple[int, int]:
    """The points ``i`` of leaf ``q`` against the points ``j > i`` of leaf ``node``.

    Each point is tested with its own distance to the node's box and its own Δ_max, then each
    pair with its own Δ and, last, its squared distance (see :func:`_search_leaf`). Returns the
    pair and box distances computed.
    """
    start, end, _, _, lo, hi, ymin, ymax = tree
    n_dims = points.shape[1]
    n_out = targets.shape[1]
    n_bins = reach2.shape[0]
    first, last = start[q], end[q]
    computed = 0
    tested = 0
    for i in range(first, min(last, end[node] - 1)):
        reach = 0.0
        for c in range(n_out):
            y = targets[i, c]
            delta = max(abs(y - ymin[node, c]), abs(y - ymax[node, c]))
            b = min(int(delta * bins_per_unit[c]) + 1, n_bins - 1)
            reach = max(reach, reach2[b, c])
        if reach == 0.0:
            continue
        tested += 1
        acc = 0.0
        for k in range(n_dims):
            v = points[i, k]
            gap = max(lo[node, k] - v, v - hi[node, k], 0.0)
            acc += gap * gap
        if acc >= reach:
            continue
        for j in range(max(start[node], i + 1), end[node]):
            reach = 0.0
            for c in range(n_out):
                b = int(abs(targets[i, c] - targets[j, c]) * bins_per_unit[c]) + 1
                reach = max(reach, reach2[min(b, n_bins - 1), c])
            if reach == 0.0:
                continue
            dd = 0.0
            for k in range(n_dims):
                diff = points[j, k] - points[i, k]
                dd += diff * diff
            computed += 1
            if dd < reach or dd == 0.0:
                _raise(margin, g, dd, targets, i, j, twice_eps, reach2, bins_per_unit)
    return computed, tested


@njit(cache=True)
def _search_leaf(
    q: int,
    points: FloatArray,
    targets: FloatArray,
    twice_eps: FloatArray,
    g: FloatArray,
    reach2: FloatArray,
    bins_per_unit: FloatArray,
    tree: Any,
    stack: IntArray,
    margin: bool,
    slopes: Any,
    monotone: bool,
) -> tuple[int, int, int, int]:
    """Raise ``g`` (E, m) with the pairs ``(i, j > i)``, ``i`` in leaf ``q``, by branch and bound.

    ``points`` and ``targets`` are in tree order and ``i``, ``j`` are tree positions; ``tree`` is
    ``(start, end, left, right, lo, hi, ymin, ymax)`` of :class:`~neckid.models.set_membership._kernels.tree.SMTree`.
    The points of a leaf are close together, so they search the tree together (node-to-node
    bounds, as in the dual-tree algorithms of Gray & Moore 2001): a node is opened only if it
    holds a position after the leaf's first one and, for some output c,

        dist²(box(q), box(node)) < reach2[bin(Δ_max), c],
        Δ_max = max(max ỹ(q) − min ỹ(node), max ỹ(node) − min ỹ(q)).

    In a leaf that passes, :func:`_search_points` tests each point ``i`` of ``q`` again with its
    own distance to the box and its own Δ_max = max(|ỹ_i − min ỹ(node)|, |ỹ_i − max ỹ(node)|),
    then each pair with its own Δ (no distance when the table is 0 there) and, last, its squared
    distance.

    With ``slopes`` (:class:`~neckid.models.set_membership._kernels.slope.SlopeBounds`, empty to
    go without; never with ``margin``) a node that passes the box test is also tested with the
    bound of a linear model of the targets
    (:func:`~neckid.models.set_membership._kernels.slope.slope_skips`), which skips only what
    cannot raise ``g`` either; ``monotone`` says that ``g`` does not increase along the grid.
    (Testing each point of ``q`` against a leaf the same way cost more than the pairs it
    skipped, in two dimensions and more so in six: it is not done.)

    Every pair (i, j) under a node has Δ <= Δ_max and ‖w̃_i − w̃_j‖² >= each box distance² in
    floating point too: differences, absolute values, squares and sums are monotone, and a box
    distance sums a subset of the terms of the point distance in the same order (the others
    are 0). The table grows with Δ, so a skipped node holds only pairs that the same test in
    :func:`_raise_with_pair` would skip: the result is bit for bit that of all pairs.

    Returns
    -------
    computed, tested, sloped, skipped : int
        Squared distances of pairs computed, box distances computed (nodes and leaf points),
        slope bounds evaluated, and nodes they skipped.
    """
    start, end, left, right, lo, hi, ymin, ymax = tree
    n_dims = points.shape[1]
    n_out = targets.shape[1]
    n_bins = reach2.shape[0]
    first = start[q]
    stack[0] = 0
    top = 1
    computed = 0
    tested = 0
    sloped = 0
    skipped = 0
    use_slopes = slopes[0].shape[0] > 0 and not margin
    region = slopes[2][q] if use_slopes else 0
    while top > 0:
        top -= 1
        node = stack[top]
        if end[node] <= first + 1:
            continue
        reach = 0.0
        for c in range(n_out):
            delta = max(ymax[q, c] - ymin[node, c], ymax[node, c] - ymin[q, c], 0.0)
            b = min(int(delta * bins_per_unit[c]) + 1, n_bins - 1)
            reach = max(reach, reach2[b, c])
        if reach == 0.0:
            continue
        tested += 1
        acc = 0.0
        for k in range(n_dims):
            gap = max(lo[node, k] - hi[q, k], lo[q, k] - hi[node, k], 0.0)  # 0 if they overlap
            acc += gap * gap
        if acc >= reach:
            continue
        sloped += use_slopes
        if use_slopes and slope_skips(
            slopes,
            region,
            slopes[3][q],
            slopes[4][q],
            lo[q],
            hi[q],
            node,
            lo,
            hi,
            acc,
            twice_eps,
            g,
            monotone,
        ):
            skipped += 1
            continue
        child = left[node]
        if child >= 0:
            stack[top] = right[node]
            stack[top + 1] = child
            top += 2
            continue
        points_computed, points_tested = _search_points(
            q, node, points, targets, twice_eps, g, reach2, bins_per_unit, tree, margin
        )
        computed += points_computed
        tested += points_tested
    return computed, tested, sloped, skipped


@njit(cache=True, parallel=True)
def _tree_leaves_kernel(
    points: FloatArray,
    targets: FloatArray,
    twice_eps: FloatArray,
    leaves: IntArray,
    out: FloatArray,
    reach2: FloatArray,
    bins_per_unit: FloatArray,
    tree: Any,
    work: IntArray,
    margin: bool,
    slopes: Any,
    monotone: bool,
) -> None:
    """:func:`_search_leaf` for each leaf of ``leaves`` (threads); ``work[r]`` its four counts."""
    for r in prange(leaves.shape[0]):
        stack = np.empty(STACK_DEPTH, np.int64)
        work[r, 0], work[r, 1], work[r, 2], work[r, 3] = _search_leaf(
            leaves[r],
            points,
            targets,
            twice_eps,
            out[r],
            reach2,
            bins_per_unit,
            tree,
            stack,
            margin,
            slopes,
            monotone,
        )


@njit(cache=True)
def _tree_leaves_serial(
    points: FloatArray,
    targets: FloatArray,
    twice_eps: FloatArray,
    leaves: IntArray,
    out: FloatArray,
    reach2: FloatArray,
    bins_per_unit: FloatArray,
    tree: Any,
    work: IntArray,
    margin: bool,
    slopes: Any,
    monotone: bool,
) -> None:  # pragma: no cover - compiled; the same leaves as the threaded kernel
    """:func:`_tree_leaves_kernel` without threads, for blocks with little work.

    Waking the thread pool costs more than a small block, and much more on a busy machine.
    """
    stack = np.empty(STACK_DEPTH, np.int64)
    for r in range(leaves.shape[0]):
        work[r, 0], work[r, 1], work[r, 2], work[r, 3] = _search_leaf(
            leaves[r],
            points,
            targets,
            twice_eps,
            out[r],
            reach2,
            bins_per_unit,
            tree,
            stack,
            margin,
            slopes,
            monotone,
        )
