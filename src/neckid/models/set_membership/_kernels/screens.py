r"""Screens: squared distances summed in any order, for the walks whose result does not depend on it.

The walks whose result does not depend on the order of the visits (a minimum, a maximum, a
k-th smallest value over the points, the largest rounded slope) prune with distances summed in
any order, which vectorise: a sum of n non-negative terms computed in any order (fused
multiply-adds included) is within a relative γ_n = n u / (1 − n u) of the exact sum, as is the
sum in component order that the exact distance takes (Higham, *Accuracy and Stability of
Numerical Algorithms*, 2nd ed., 2002, §4.2). A screen multiplied by :func:`screen_shrink` is
therefore a lower bound of the exact squared distance of every point a box holds, and of the
point's own: a point or node the screen puts beyond a cap is beyond it exactly, and everything
else is decided by the exact sums of :mod:`.tree`.
"""

from __future__ import annotations

import math

from numba import njit

from neckid.utils.types import FloatArray, IntArray

__all__ = ["SLOPE_PRUNE", "box_screen2", "leaf_screen2", "push_screened", "screen_shrink"]

SLOPE_PRUNE = 1.0 - 1e-12


@njit(cache=True)
def screen_shrink(n_dims: int) -> float:
    """The factor that makes a squared distance summed in any order a lower bound of the exact one."""
    return 1.0 - 4.0 * (n_dims + 2) * 2.0**-53


@njit(cache=True, fastmath={"reassoc", "nsz", "contract"})
def box_screen2(w: FloatArray, lo: FloatArray, hi: FloatArray, node: int) -> float:
    """:func:`~.tree.box_distance2` summed in any order (multiply by :func:`screen_shrink`)."""
    acc = 0.0
    for k in range(w.shape[0]):
        gap = max(lo[node, k] - w[k], w[k] - hi[node, k], 0.0)
        acc += gap * gap
    return acc


@njit(cache=True, fastmath={"reassoc", "nsz", "contract"})
def leaf_screen2(
    w: FloatArray, points: FloatArray, first: int, stop: int, out: FloatArray
) -> None:  # pragma: no cover - compiled
    """``out[p − first]``: :func:`~.tree.squared_distance` to ``points[p]``, summed in any order."""
    for p in range(first, stop):
        acc = 0.0
        for k in range(w.shape[0]):
            diff = w[k] - points[p, k]
            acc += diff * diff
        out[p - first] = acc


@njit(cache=True, inline="always")
def _push_pair(
    child: int,
    other: int,
    d_left: float,
    d_right: float,
    node_stack: IntArray,
    dist_stack: FloatArray,
    top: int,
) -> int:
    """Push two sibling nodes with their distances, the nearer one on top (left on a tie)."""
    if d_left <= d_right:
        node_stack[top], dist_stack[top] = other, d_right
        node_stack[top + 1], dist_stack[top + 1] = child, d_left
    else:
        node_stack[top], dist_stack[top] = child, d_left
        node_stack[top + 1], dist_stack[top + 1] = other, d_right
    return top + 2


@njit(cache=True, inline="always")
def push_screened(
    w: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    left: IntArray,
    right: IntArray,
    node: int,
    node_stack: IntArray,
    dist_stack: FloatArray,
    top: int,
    shrink: float,
    squared: bool,
) -> int:
    """:func:`~.tree.push_children` with screened box distances (lower bounds; squared if asked)."""
    child = left[node]
    other = right[node]
    d_left = box_screen2(w, lo, hi, child) * shrink
    d_right = box_screen2(w, lo, hi, other) * shrink
    if not squared:
        d_left = math.sqrt(d_left)
        d_right = math.sqrt(d_right)
    return _push_pair(child, other, d_left, d_right, node_stack, dist_stack, top)
