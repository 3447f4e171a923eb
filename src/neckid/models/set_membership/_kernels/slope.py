r"""Slope bounds for the γ*(ε) branch and bound: regional linear models of the targets.

The γ*(ε) search (:mod:`neckid.models.set_membership._kernels.gamma`) skips a pair of kd-tree
nodes when the bound ``(Δ_max − 2ε) / d_min`` on their slopes cannot exceed the running maximum.
On data whose function is nearly linear that bound is loose for distant pairs: Δ_max takes the
far corners of the two boxes, d_min the near ones, and millions of pairs within a few per cent of
γ*(ε) must be computed one by one. Writing the targets as a linear part and a residual,

.. math:: ỹ = a \cdot w̃ + r, \qquad |ỹ_i − ỹ_j| \le |a \cdot v| + |r_i − r_j|, \quad v = w̃_i − w̃_j,

and, with ``R`` the largest residual difference between the two nodes, ``t = |a·v| <= A`` (the
range of ``a·v`` over the difference of the boxes) and ``|v| >= max(d_min, t / |a|)``,

.. math::

    \frac{|ỹ_i − ỹ_j| − 2ε}{|v|} \le U = \begin{cases}
        \bigl(\min(A, |a| d_{\min}) + c\bigr) / d_{\min} & c = R − 2ε \ge 0,\\
        (A + c) / d_{\min} & c < 0,\ A \le |a| d_{\min},\\
        |a| \,(1 + c / A) & c < 0,\ A > |a| d_{\min},
    \end{cases}

the maximum over ``t`` of ``(t + c) / max(d_min, t / |a|)``. Where the residual varies by less
than the noise (``c < 0``) this is below ``|a|`` whatever the distance, so distant pairs along
the function's gradient are settled a node at a time. One gradient cannot follow a function whose
slope changes over the data, so each region of the tree (the subtrees at a fixed depth) has its
own, fitted by least squares on its points; the nodes above the regions use the regions' mean
gradient. A pair of nodes is tested with the gradient of each one's region (the other node's
residual range moved to that gradient over its box: ``r' = r + (a − a')·w̃``) and skipped if
either bound cannot exceed the running maximum at any ε of the grid.

Any gradient gives a valid bound; the fit only decides how tight it is. The bound is evaluated in
floating point with the residual ranges widened by ``SLOPE_SLACK · (1 + max |ỹ| + max ε +
max ‖a‖₁ · max |w̃|)``, which exceeds every rounding error of the residuals, the shifts, the
range of ``a·v`` and of the pair's own ratio by orders of magnitude (each is a few units in the
last place of such sums), and the node is skipped only if ``U (1 + SLOPE_SLACK)`` is at most the
running maximum: a skipped node holds no pair that the exact test would have let raise it, so the
result stays bit for bit that of all pairs.

References
----------
M. Milanese and C. Novara, "Set Membership identification of nonlinear systems", Automatica 40(6),
957-975, 2004 (γ*(ε)).
A. G. Gray and A. W. Moore, "'N-body' problems in statistical learning", Advances in Neural
Information Processing Systems 13, 521-527, 2001 (bounds between pairs of tree nodes).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from neckid.models.set_membership._kernels.tree import SMTree
from neckid.utils.types import FloatArray, IntArray

__all__ = [
    "SLOPE_REGION_DEPTH",
    "SLOPE_REGION_POINTS",
    "SLOPE_SLACK",
    "SlopeBounds",
    "no_slope_bounds",
    "slope_bounds",
]

#: Depth of the tree at which the regions start: at most ``2**SLOPE_REGION_DEPTH`` gradients.
SLOPE_REGION_DEPTH = 6
#: A region holds at least about this many points (fewer regions on small data).
SLOPE_REGION_POINTS = 2_000
#: Relative slack of the slope bound, far above the rounding of its sums (see the module notes).
SLOPE_SLACK = 1e-9


class SlopeBounds(NamedTuple):
    """The regional linear models of the targets that the γ*(ε) search bounds slopes with.

    Attributes
    ----------
    gradients : ndarray, shape (n_regions + 1, n_outputs, n_dims)
        Row k >= 1 the least-squares gradient of region k's points; row 0, for the nodes above
        the regions, their mean weighted by the regions' sizes (the least-squares gradient of
        all points when there is one region).
    norms : ndarray, shape (n_regions + 1, n_outputs)
        Their Euclidean norms.
    region : ndarray of int64, shape (n_nodes,)
        The region of each node of the tree (0 above the regions).
    low, high : ndarray, shape (n_nodes, n_outputs)
        Range of the residual ``ỹ − a·w̃`` over each node, ``a`` the gradient of its region.
    slack : ndarray, shape (n_outputs,)
        Absolute widening of every residual range (see the module notes).
    """

    gradients: FloatArray
    norms: FloatArray
    region: IntArray
    low: FloatArray
    high: FloatArray
    slack: FloatArray


def no_slope_bounds(n_outputs: int, n_dims: int) -> SlopeBounds:
    """Empty bounds: the search then tests node boxes only."""
    return SlopeBounds(
        np.zeros((0, n_outputs, n_dims)),
        np.zeros((0, n_outputs)),
        np.zeros(0, np.int64),
        np.zeros((0, n_outputs)),
        np.zeros((0, n_outputs)),
        np.zeros(n_outputs),
    )


def _region_roots(tree: SMTree, depth: int) -> list[int]:
    """The nodes at ``depth`` (a leaf above it is its own region), in tree order."""
    roots = [0]
    for _ in range(depth):
        roots = [
            child
            for node in roots
            for child in (
                (int(tree.left[node]), int(tree.right[node])) if tree.left[node] >= 0 else (node,)
            )
        ]
    return roots


def _least_squares_gradient(points: FloatArray, targets: FloatArray) -> FloatArray:
    """Gradient ``(n_outputs, n_dims)`` of the least-squares affine fit (zeros if not finite)."""
    centred = points - points.mean(axis=0)
    gram = centred.T @ centred
    cross = centred.T @ (targets - targets.mean(axis=0))
    gradient = np.linalg.lstsq(gram, cross, rcond=None)[0].T
    return gradient if np.all(np.isfinite(gradient)) else np.zeros_like(gradient)


def slope_bounds(
    tree: SMTree, twice_eps: FloatArray, region_points: int = SLOPE_REGION_POINTS
) -> SlopeBounds:
    """The regional gradients and residual ranges of a tree (one pass over its points).

    Parameters
    ----------
    tree : SMTree
        The kd-tree (scaled points and targets in tree order).
    twice_eps : ndarray, shape (n_eps, n_outputs)
        The grid the search runs on (2ε): its largest value enters the slack.
    region_points : int, default ``SLOPE_REGION_POINTS``
        About the fewest points of a region.

    Returns
    -------
    SlopeBounds
        ``2**depth`` regions with ``depth <= SLOPE_REGION_DEPTH`` and about ``region_points``
        points or more in each. Memory: ``(2 n_outputs + 1) · 8`` bytes per node.
    """
    points, targets = tree.points, tree.targets
    n_points = points.shape[0]
    depth = int(
        max(
            0,
            min(
                SLOPE_REGION_DEPTH, math.floor(math.log2(max(n_points, 1) / max(region_points, 1)))
            ),
        )
    )
    roots = _region_roots(tree, depth)
    gradients = np.empty((len(roots) + 1, targets.shape[1], points.shape[1]))
    gradients[0] = _least_squares_gradient(points, targets) if depth == 0 else 0.0
    region = np.zeros(tree.n_nodes, np.int64)
    for k, root in enumerate(roots, start=1):
        rows = slice(int(tree.start[root]), int(tree.end[root]))
        gradients[k] = _least_squares_gradient(points[rows], targets[rows])
        _mark_subtree(tree.left, tree.right, root, k, region)
    if depth > 0:  # all points, from the regions' fits weighted by their sizes
        sizes = np.array([tree.end[r] - tree.start[r] for r in roots], dtype=np.float64)
        gradients[0] = np.tensordot(sizes / sizes.sum(), gradients[1:], axes=1)
    gradients = np.ascontiguousarray(gradients)
    low, high = _residual_ranges(
        points, targets, gradients, region, tree.start, tree.end, tree.left, tree.right
    )
    reach = float(np.max(np.maximum(np.abs(tree.lo[0]), np.abs(tree.hi[0])))) if n_points else 0.0
    largest = np.maximum(np.abs(targets.min(axis=0)), np.abs(targets.max(axis=0)))
    scale = (
        1.0
        + largest
        + np.max(0.5 * twice_eps, axis=0)
        + np.max(np.sum(np.abs(gradients), axis=2), axis=0) * reach
    )
    return SlopeBounds(
        gradients,
        np.ascontiguousarray(np.sqrt(np.sum(gradients * gradients, axis=2))),
        region,
        low,
        high,
        SLOPE_SLACK * scale,
    )


@njit(cache=True)
def _mark_subtree(left: IntArray, right: IntArray, root: int, value: int, region: IntArray) -> None:
    """``region[node] = value`` for every node under ``root`` (children follow their parent)."""
    stack = np.empty(128, np.int64)
    stack[0] = root
    top = 1
    while top > 0:
        top -= 1
        node = stack[top]
        region[node] = value
        if left[node] >= 0:
            stack[top] = left[node]
            stack[top + 1] = right[node]
            top += 2


@njit(cache=True, inline="always")
def _residual(
    points: FloatArray, targets: FloatArray, gradients: FloatArray, k: int, p: int, c: int
) -> float:
    """``ỹ_p − a_k · w̃_p`` for output c, summed in component order."""
    value = targets[p, c]
    for j in range(points.shape[1]):
        value -= gradients[k, c, j] * points[p, j]
    return value


@njit(cache=True)
def _residual_ranges(
    points: FloatArray,
    targets: FloatArray,
    gradients: FloatArray,
    region: IntArray,
    start: IntArray,
    end: IntArray,
    left: IntArray,
    right: IntArray,
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover - compiled; tested through the search
    """Per node, the range of the residual under its region's gradient (children before parents)."""
    n_nodes = start.shape[0]
    n_out = targets.shape[1]
    low = np.empty((n_nodes, n_out))
    high = np.empty((n_nodes, n_out))
    for node in range(n_nodes - 1, -1, -1):  # children are numbered after their parent
        a, b = left[node], right[node]
        k = region[node]
        merge = a >= 0 and region[a] == k and region[b] == k
        for c in range(n_out):
            if merge:
                low[node, c] = min(low[a, c], low[b, c])
                high[node, c] = max(high[a, c], high[b, c])
                continue
            lo, hi = np.inf, -np.inf
            for p in range(start[node], end[node]):
                r = _residual(points, targets, gradients, k, p, c)
                lo = min(lo, r)
                hi = max(hi, r)
            low[node, c] = lo
            high[node, c] = hi
    return low, high


@njit(cache=True, inline="always")
def _moved(
    low: float,
    high: float,
    gradients: FloatArray,
    source: int,
    target: int,
    c: int,
    box_lo: FloatArray,
    box_hi: FloatArray,
) -> tuple[float, float]:
    """Range of ``ỹ − a_target·w̃`` over a box from that of ``ỹ − a_source·w̃``: plus ``(a_s − a_t)·w̃``."""
    if source == target:
        return low, high
    shift_lo = 0.0
    shift_hi = 0.0
    for j in range(box_lo.shape[0]):
        d = gradients[source, c, j] - gradients[target, c, j]
        p1 = d * box_lo[j]
        p2 = d * box_hi[j]
        shift_lo += min(p1, p2)
        shift_hi += max(p1, p2)
    return low + shift_lo, high + shift_hi


@njit(cache=True, inline="always")
def _bound(excess: float, reach: float, norm: float, distance: float, inverse: float) -> float:
    """U of the module notes for ``excess = R − 2ε`` (``inverse`` = 1 / ``distance``).

    Non-decreasing in ``excess``; ``inf`` where identical points may differ by more than 2ε,
    ``-inf`` where no pair can have a positive slope.
    """
    if excess >= 0.0:
        if distance <= 0.0:
            return np.inf
        return (min(reach, norm * distance) + excess) * inverse
    if reach <= norm * distance:
        if distance <= 0.0:
            return -np.inf  # |Δ| <= R < 2ε for every pair: none can count
        return (reach + excess) * inverse
    return norm + norm * excess / reach


@njit(cache=True, inline="always")
def _bound_exceeds(
    gradients: FloatArray,
    norm: float,
    k: int,
    c: int,
    spread: float,
    a_lo: FloatArray,
    a_hi: FloatArray,
    b_lo: FloatArray,
    b_hi: FloatArray,
    dist2: float,
    twice_eps: FloatArray,
    g: FloatArray,
    monotone: bool,
) -> bool:
    """Whether the slope bound U (module notes) may exceed ``g[e, c]`` at some ε of the grid.

    Boxes ``a`` and ``b``, ``spread`` the largest residual
    difference between them under gradient ``k`` (slack included), ``dist2`` their squared box
    distance. The grid is ascending; with ``monotone`` (``g`` non-increasing along it, as every
    running maximum of pair slopes is) the test stops at the first ε whose ``g`` is at least
    U at the smallest ε: U does not decrease as ε does, so every smaller ε is settled too.
    """
    t_lo = 0.0
    t_hi = 0.0
    for j in range(a_lo.shape[0]):
        grad = gradients[k, c, j]
        p1 = grad * (a_lo[j] - b_hi[j])
        p2 = grad * (a_hi[j] - b_lo[j])
        t_lo += min(p1, p2)
        t_hi += max(p1, p2)
    reach = max(abs(t_lo), abs(t_hi))
    distance = math.sqrt(dist2)
    inverse = 1.0 / distance if distance > 0.0 else 0.0
    margin = 1.0 + 1e-9
    top = _bound(spread - twice_eps[0, c], reach, norm, distance, inverse) * margin
    for e in range(twice_eps.shape[0] - 1, -1, -1):  # large ε first: where bounds are close
        if _bound(spread - twice_eps[e, c], reach, norm, distance, inverse) * margin > g[e, c]:
            return True
        if monotone and top <= g[e, c]:
            return False
    return False


@njit(cache=True, inline="always")
def slope_skips(
    slopes: tuple[FloatArray, FloatArray, IntArray, FloatArray, FloatArray, FloatArray],
    a_region: int,
    a_low: FloatArray,
    a_high: FloatArray,
    a_lo: FloatArray,
    a_hi: FloatArray,
    node: int,
    lo: FloatArray,
    hi: FloatArray,
    dist2: float,
    twice_eps: FloatArray,
    g: FloatArray,
    monotone: bool,
) -> bool:
    """Whether no pair between box ``a`` and ``node`` can raise ``g`` (E, m), by the slope bound.

    ``a_low``, ``a_high`` (m,) hold the residual range of box ``a`` under the gradient of region
    ``a_region``; the node's own range is under its region's gradient. Each output is tested with
    the gradient of either region; the pair is skipped when, for every output, one of the two
    bounds stays at or below ``g`` over the whole grid (ascending). ``monotone``: ``g`` does not
    increase along the grid (see :func:`_bound_exceeds`).
    """
    gradients, norms, region, low, high, slack = slopes
    b_region = region[node]
    b_lo = lo[node]
    b_hi = hi[node]
    for c in range(g.shape[1]):
        # the gradient of box a's region: the node's range moved to it
        nl, nh = _moved(low[node, c], high[node, c], gradients, b_region, a_region, c, b_lo, b_hi)
        spread = max(a_high[c] - nl, nh - a_low[c]) + slack[c]
        if not _bound_exceeds(
            gradients,
            norms[a_region, c],
            a_region,
            c,
            spread,
            a_lo,
            a_hi,
            b_lo,
            b_hi,
            dist2,
            twice_eps,
            g,
            monotone,
        ):
            continue
        if b_region == a_region:
            return False
        # the gradient of the node's region: box a's range moved to it
        ql, qh = _moved(a_low[c], a_high[c], gradients, a_region, b_region, c, a_lo, a_hi)
        spread = max(qh - low[node, c], high[node, c] - ql) + slack[c]
        if _bound_exceeds(
            gradients,
            norms[b_region, c],
            b_region,
            c,
            spread,
            a_lo,
            a_hi,
            b_lo,
            b_hi,
            dist2,
            twice_eps,
            g,
            monotone,
        ):
            return False
    return True
