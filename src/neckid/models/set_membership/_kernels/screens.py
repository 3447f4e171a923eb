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

A tree may also be split in a **principal frame** (``SMTree(frame=True)``): the points rotated
onto the principal axes of their cloud, ``ẑ = R (w − μ)``, where a kd-tree over lagged signals
(a few directions hold almost all the spread) prunes far better than over the raw components.
Its boxes and screens are then in that frame, and :func:`frame_lower2` turns a screen into a
lower bound of the exact squared distance in the tree's own coordinates, with room for the
rounding of the rotation (:func:`frame_query`, which rotates the query and returns that room)
and for ``R`` being orthogonal only to rounding. The exact sums stay in the tree's coordinates,
so every result is unchanged; only the visits are fewer.
"""

from __future__ import annotations

import math

from numba import njit
from numpy.typing import NDArray

from neckid.utils.types import FloatArray, IntArray

__all__ = [
    "FRAME_RELATIVE",
    "SLOPE_PRUNE",
    "box_screen2",
    "frame_lower2",
    "frame_query",
    "leaf_screen2",
    "push_framed",
    "push_screened",
    "screen_shrink",
]

SLOPE_PRUNE = 1.0 - 1e-12
#: Relative room of a principal-frame screen: more than the departure of ``R`` from an
#: orthogonal matrix (checked below 1e-10 when the frame is made), the rounding of a screen and
#: of the exact sum it stands for (a relative γ_{n+2}, below 1e-12 for n < 4,000 terms).
FRAME_RELATIVE = 1e-9


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


@njit(cache=True, inline="always")
def frame_query(w: FloatArray, frame: tuple[NDArray, ...], qz: FloatArray) -> float:
    """Write the query ``w`` in the tree's screening frame into ``qz``; return its slack.

    ``frame`` is :meth:`~.tree.SMTree.frame_arrays`. Without a principal frame ``qz`` is ``w``
    and the slack is -1 (screens are used as they are). With one, ``qz = R (w − μ)`` summed in
    any order, and the slack is an absolute bound of the rounding of ``qz`` and of every stored
    rotated point together (``γ_{n+1} ‖R‖_F ‖w − μ‖``, with room; Higham 2002, §3.5).
    """
    _, _, _, rot, mu, error = frame
    n = w.shape[0]
    if rot.shape[0] == 0:
        for k in range(n):
            qz[k] = w[k]
        return -1.0
    norm2 = 0.0
    for j in range(n):
        diff = w[j] - mu[j]
        norm2 += diff * diff
    for i in range(rot.shape[0]):
        acc = 0.0
        for j in range(n):
            acc += rot[i, j] * (w[j] - mu[j])
        qz[i] = acc
    return error[0] + error[1] * math.sqrt(norm2) * 1.01


@njit(cache=True, inline="always")
def frame_lower2(screen2: float, shrink: float, slack: float) -> float:
    """A lower bound of the exact squared distance from a screen summed in the frame.

    ``slack`` < 0 (no principal frame): ``screen2 · shrink``, the plain screen. Else the
    distance in the frame less its relative and absolute room, squared, less its relative room
    again (0 when the room exceeds it, and for NaN: such a node or point is never skipped).
    """
    lower = screen2 * shrink
    if slack < 0.0:
        return lower
    reach = math.sqrt(lower) * (1.0 - FRAME_RELATIVE) - slack
    if not reach > 0.0:
        return 0.0
    return reach * reach * (1.0 - FRAME_RELATIVE)


@njit(cache=True, inline="always")
def push_framed(
    qz: FloatArray,
    frame: tuple[NDArray, ...],
    left: IntArray,
    right: IntArray,
    node: int,
    node_stack: IntArray,
    dist_stack: FloatArray,
    top: int,
    shrink: float,
    slack: float,
    squared: bool,
) -> int:
    """:func:`push_screened` in the screening frame (lower bounds; squared if asked)."""
    _, zlo, zhi, _, _, _ = frame
    child = left[node]
    other = right[node]
    d_left = frame_lower2(box_screen2(qz, zlo, zhi, child), shrink, slack)
    d_right = frame_lower2(box_screen2(qz, zlo, zhi, other), shrink, slack)
    if not squared:
        d_left = math.sqrt(d_left)
        d_right = math.sqrt(d_right)
    return _push_pair(child, other, d_left, d_right, node_stack, dist_stack, top)
