"""The principal frame of a Set Membership kd-tree (``SMTree(frame=True)``).

A k-step regressor holds lagged copies of a few smooth signals, so most of its spread lies along
a few directions; a kd-tree split along the raw components cuts along axes the cloud barely
spreads over and its boxes are loose. :func:`principal_frame` gives the leading principal axes
and the rounding room of a rotation onto them; :class:`~.tree.SMTree` splits in that frame and
keeps the boxes in it for the screened walks (:func:`~.screens.frame_query`,
:func:`~.screens.frame_lower2`), and :func:`node_boxes` gives the boxes in the points' own
coordinates for the other walks.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from neckid.utils.types import FloatArray, IntArray

__all__ = [
    "FRAME_AXES",
    "FRAME_MIN_TERMS",
    "empty_box",
    "node_boxes",
    "principal_frame",
    "widen_box",
]

#: Fewest terms for which ``SMTree(frame=True)`` splits in a principal frame: with few terms a
#: kd-tree over the raw components prunes about as well.
FRAME_MIN_TERMS = 8
#: Principal axes a frame keeps (all of them with fewer terms). A screen over the leading axes
#: is a lower bound of the one over all (fewer non-negative terms) and costs proportionally
#: less; at horizon 40 of the soft-neck payload split (84 terms) one fold's slopes and bounds
#: took 3.4 CPU s keeping 84 axes, 2.7 keeping 32, 2.5 keeping 16 and 2.4 keeping 8 (7.3
#: without a frame; ``docs/benchmarks/sm_speed.md``). 16 leaves room for signals spread over
#: more directions than the neck's.
FRAME_AXES = 16


def principal_frame(points: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """``(μ, R, error)``: the centre, the principal axes (rows) and the rounding room of a frame.

    ``R`` holds the leading :data:`FRAME_AXES` eigenvectors of the points' scatter matrix,
    largest spread first, so a kd-tree over ``R (w − μ)`` splits along the directions the
    points spread in; distances in the frame are at most those in the points' coordinates. ``error`` is
    ``(e, c)``: ``c = 2 (n + 2) u √n`` bounds the rounding of a rotated point relative to
    ``‖w − μ‖`` (``γ_{n+1} ‖R‖_F``, Higham 2002, §3.5, with room) and ``e`` that of the stored
    points (``c`` times their largest ``‖w − μ‖``, with room). None (no frame) below
    :data:`FRAME_MIN_TERMS` terms, for fewer than two points, non-finite points, or an ``R``
    farther than 1e-10 from orthogonal (Frobenius norm of ``R Rᵀ − I``).
    """
    n_points, n_dims = points.shape
    if n_dims < FRAME_MIN_TERMS or n_points < 2 or not np.all(np.isfinite(points)):
        return None
    centre = points.mean(axis=0)
    centred = points - centre
    _, vectors = np.linalg.eigh(centred.T @ centred)
    rotation = np.ascontiguousarray(vectors[:, ::-1].T)
    if not np.linalg.norm(rotation @ rotation.T - np.eye(n_dims)) <= 1e-10:
        return None
    rotation = np.ascontiguousarray(rotation[:FRAME_AXES])
    factor = 2.0 * (n_dims + 2) * 2.0**-53 * math.sqrt(n_dims)
    largest = float(np.sqrt(np.max(np.einsum("ij,ij->i", centred, centred))))
    return centre, rotation, np.array([factor * largest * 1.01, factor])


@njit(cache=True, inline="always")
def empty_box(lo: FloatArray, hi: FloatArray, node: int) -> None:
    """Set the box of ``node`` to the empty one (``lo = inf``, ``hi = -inf``)."""
    for k in range(lo.shape[1]):
        lo[node, k] = np.inf
        hi[node, k] = -np.inf


@njit(cache=True, inline="always")
def widen_box(lo: FloatArray, hi: FloatArray, node: int, points: FloatArray, i: int) -> None:
    """Widen the box of ``node`` to hold ``points[i]``."""
    for k in range(lo.shape[1]):
        v = points[i, k]
        if v < lo[node, k]:
            lo[node, k] = v
        if v > hi[node, k]:
            hi[node, k] = v


@njit(cache=True)
def node_boxes(
    points: FloatArray, start: IntArray, end: IntArray, left: IntArray, right: IntArray
) -> tuple[FloatArray, FloatArray]:
    """Every node's bounding box of ``points`` (tree order), bottom up.

    Leaves from their points, the other nodes from their children's boxes (a node's children
    come after it): the min and max over the node's points, exactly, in one pass.
    """
    n_nodes = start.shape[0]
    n_dims = points.shape[1]
    lo = np.empty((n_nodes, n_dims))
    hi = np.empty((n_nodes, n_dims))
    for node in range(n_nodes - 1, -1, -1):
        a = left[node]
        if a >= 0:
            b = right[node]
            for k in range(n_dims):
                lo[node, k] = min(lo[a, k], lo[b, k])
                hi[node, k] = max(hi[a, k], hi[b, k])
            continue
        empty_box(lo, hi, node)
        for p in range(start[node], end[node]):
            widen_box(lo, hi, node, points, p)
    return lo, hi
