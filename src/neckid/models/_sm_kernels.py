"""Compiled kernels for Set Membership identification, and the plain NumPy references beside them.

Everything here works on *scaled* regressors (the caller multiplies each component by its weight),
so the distance is the plain Euclidean one.

Kernels
-------
- :func:`build_tree`: a kd-tree over the training regressors (median split on the widest
  component, leaves of at most ``LEAF_SIZE`` points); every node keeps its bounding box.
- :class:`SMTree`: the tree plus, per node and per output, the min and max of the targets ỹ, and
  the exact branch-and-bound evaluation of

      f_u(w) = min_k (ỹ_k + γ‖w − w̃_k‖) + ε,      f_l(w) = max_k (ỹ_k − γ‖w − w̃_k‖) − ε.

  A node is skipped when ``min ỹ(node) + γ·dist(w, box)`` cannot lower the best upper value found
  so far *and* ``max ỹ(node) − γ·dist(w, box)`` cannot raise the best lower value. The squared
  box distance is a sum of a subset of the very terms that make up a contained point's squared
  distance, summed in the same order, so (floating-point addition and multiplication being
  monotone) the pruning test never skips a point that would have changed the result: the bounds
  are *bit for bit* those of a linear scan with the same formula.
- :func:`free_run`: the compiled free-run loop (regressor from the simulated history, linear
  part, both bounds, central value fed back).
- :func:`gamma_star`: γ*(ε) = max_{i≠j} (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖ for a whole grid of ε
  in one blocked pass over the pairs, parallel over rows (``numba.prange``), each distance
  computed once; a Python callback reports progress between blocks.

The plain NumPy references (vectorised over training points) are beside this module, in
:mod:`neckid.models._sm_reference`; tests check that the kernels agree with them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

__all__ = [
    "LEAF_SIZE",
    "SMTree",
    "build_tree",
    "free_run",
    "gamma_star",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Largest number of training points in a leaf of the kd-tree.
LEAF_SIZE = 16
#: Depth of the traversal stack; a median-split tree over 2**60 points is shallower.
_STACK_DEPTH = 128


# ---------------------------------------------------------------------------------- tree build
@njit(cache=True)
def _build_tree_kernel(
    points: FloatArray, leaf_size: int
) -> tuple[IntArray, IntArray, IntArray, IntArray, IntArray, FloatArray, FloatArray]:
    n_points, n_dims = points.shape
    max_leaves = n_points // ((leaf_size + 1) // 2) + 1
    max_nodes = 2 * max_leaves + 1
    perm = np.arange(n_points)
    start = np.zeros(max_nodes, np.int64)
    end = np.zeros(max_nodes, np.int64)
    left = np.full(max_nodes, -1, np.int64)
    right = np.full(max_nodes, -1, np.int64)
    lo = np.empty((max_nodes, n_dims))
    hi = np.empty((max_nodes, n_dims))
    stack = np.empty(max_nodes, np.int64)
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
        for k in range(n_dims):
            lo[node, k] = np.inf
            hi[node, k] = -np.inf
        for p in range(s, e):
            i = perm[p]
            for k in range(n_dims):
                v = points[i, k]
                if v < lo[node, k]:
                    lo[node, k] = v
                if v > hi[node, k]:
                    hi[node, k] = v
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
        values = np.empty(e - s)
        for p in range(s, e):
            values[p - s] = points[perm[p], dim]
        order = np.argsort(values, kind="mergesort")
        segment = perm[s:e].copy()
        for q in range(e - s):
            perm[s + q] = segment[order[q]]
        mid = s + (e - s) // 2
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
def _box_distance(w: FloatArray, lo: FloatArray, hi: FloatArray, node: int) -> float:
    acc = 0.0
    for k in range(w.shape[0]):
        v = w[k]
        if v < lo[node, k]:
            diff = lo[node, k] - v
            acc += diff * diff
        elif v > hi[node, k]:
            diff = v - hi[node, k]
            acc += diff * diff
        else:
            acc += 0.0
    return math.sqrt(acc)


@njit(cache=True)
def _query_one(
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
) -> tuple[float, float]:
    """Return ``(max_k ỹ_k − γ d_k, min_k ỹ_k + γ d_k)`` for one query (ε not included)."""
    n_dims = points.shape[1]
    best_upper = np.inf
    best_lower = -np.inf
    node_stack[0] = 0
    dist_stack[0] = _box_distance(w, lo, hi, 0)
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
                acc = 0.0
                for k in range(n_dims):
                    diff = w[k] - points[p, k]
                    acc += diff * diff
                gd = gamma * math.sqrt(acc)
                v = targets[p, col]
                if v + gd < best_upper:
                    best_upper = v + gd
                if v - gd > best_lower:
                    best_lower = v - gd
        else:
            other = right[node]
            d_left = _box_distance(w, lo, hi, child)
            d_right = _box_distance(w, lo, hi, other)
            # Push the farther child first so that the nearer one is explored first.
            if d_left <= d_right:
                node_stack[top] = other
                dist_stack[top] = d_right
                node_stack[top + 1] = child
                dist_stack[top + 1] = d_left
            else:
                node_stack[top] = child
                dist_stack[top] = d_left
                node_stack[top + 1] = other
                dist_stack[top + 1] = d_right
            top += 2
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
    for i in prange(queries.shape[0]):
        node_stack = np.empty(_STACK_DEPTH, np.int64)
        dist_stack = np.empty(_STACK_DEPTH)
        w = queries[i]
        for c in range(n_out):
            low, high = _query_one(
                w, points, targets, c, gamma[c], start, end, left, right, lo, hi, ymin, ymax,
                node_stack, dist_stack,
            )  # fmt: skip
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
    node_stack = np.empty(_STACK_DEPTH, np.int64)
    dist_stack = np.empty(_STACK_DEPTH)
    for i in range(queries.shape[0]):
        for c in range(targets.shape[1]):
            lower[i, c], upper[i, c] = _query_one(
                queries[i], points, targets, c, gamma[c], start, end, left, right, lo, hi, ymin,
                ymax, node_stack, dist_stack,
            )  # fmt: skip


#: Below this many queries the bounds are evaluated without threads.
SERIAL_QUERIES = 64


@njit(cache=True)
def _free_run_kernel(
    u: FloatArray,
    y: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    source: IntArray,
    channel: IntArray,
    lag: IntArray,
    max_lag: int,
    weights: FloatArray,
    coef: FloatArray,
    intercept: FloatArray,
    epsilon: FloatArray,
    gamma: FloatArray,
    points: FloatArray,
    targets: FloatArray,
    start: IntArray,
    end: IntArray,
    left: IntArray,
    right: IntArray,
    lo: FloatArray,
    hi: FloatArray,
    ymin: FloatArray,
    ymax: FloatArray,
) -> None:
    n_terms = source.shape[0]
    n_out = y.shape[1]
    w = np.empty(n_terms)
    ws = np.empty(n_terms)
    node_stack = np.empty(_STACK_DEPTH, np.int64)
    dist_stack = np.empty(_STACK_DEPTH)
    for t in range(max_lag, y.shape[0]):
        for k in range(n_terms):
            if source[k] == 0:
                w[k] = y[t - lag[k], channel[k]]
            else:
                w[k] = u[t - lag[k], channel[k]]
            ws[k] = w[k] * weights[k]
        for c in range(n_out):
            linear = intercept[c]
            for k in range(n_terms):
                linear += w[k] * coef[k, c]
            low, high = _query_one(
                ws, points, targets, c, gamma[c], start, end, left, right, lo, hi, ymin, ymax,
                node_stack, dist_stack,
            )  # fmt: skip
            f_lower = low - epsilon[c]
            f_upper = high + epsilon[c]
            lower[t, c] = linear + f_lower
            upper[t, c] = linear + f_upper
            y[t, c] = linear + 0.5 * (f_lower + f_upper)


class SMTree:
    """Kd-tree over scaled training regressors with per-node target ranges, for exact SM bounds.

    Parameters
    ----------
    points : ndarray, shape (n_points, n_dims)
        Scaled training regressors w̃_k.
    targets : ndarray, shape (n_points, n_outputs)
        Training targets ỹ_k (one column per output).
    leaf_size : int, default LEAF_SIZE
        Largest number of points in a leaf.
    """

    def __init__(self, points: FloatArray, targets: FloatArray, leaf_size: int = LEAF_SIZE) -> None:
        points = np.ascontiguousarray(points, dtype=np.float64)
        targets = np.ascontiguousarray(targets, dtype=np.float64)
        tree = build_tree(points, leaf_size)
        perm = tree["perm"]
        self.perm: IntArray = perm
        self.points: FloatArray = np.ascontiguousarray(points[perm])
        self.targets: FloatArray = np.ascontiguousarray(targets[perm])
        self.start: IntArray = tree["start"]
        self.end: IntArray = tree["end"]
        self.left: IntArray = tree["left"]
        self.right: IntArray = tree["right"]
        self.lo: FloatArray = tree["lo"]
        self.hi: FloatArray = tree["hi"]
        self.ymin, self.ymax = _node_ranges_kernel(self.targets, self.start, self.end)

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
            queries, points, targets, gamma, start, end, left, right, lo, hi, ymin, ymax,
            lower, upper,
        )  # fmt: skip
        return lower - epsilon, upper + epsilon


def free_run(
    tree: SMTree,
    u: FloatArray,
    y_initial: FloatArray,
    source: IntArray,
    channel: IntArray,
    lag: IntArray,
    max_lag: int,
    weights: FloatArray,
    coef: FloatArray,
    intercept: FloatArray,
    epsilon: FloatArray,
    gamma: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Compiled free run; returns ``(y, lower, upper)``, each ``(n_samples, n_outputs)``.

    The first ``max_lag`` rows of ``y`` are ``y_initial``'s (initial conditions); the bounds there
    are NaN.
    """
    y = np.array(y_initial, dtype=np.float64, order="C")
    lower = np.full(y.shape, np.nan)
    upper = np.full(y.shape, np.nan)
    _free_run_kernel(
        np.ascontiguousarray(u, dtype=np.float64), y, lower, upper,
        np.ascontiguousarray(source, dtype=np.int64), np.ascontiguousarray(channel, dtype=np.int64),
        np.ascontiguousarray(lag, dtype=np.int64), int(max_lag),
        np.ascontiguousarray(weights, dtype=np.float64), np.ascontiguousarray(coef, dtype=np.float64),
        np.ascontiguousarray(intercept, dtype=np.float64),
        np.ascontiguousarray(epsilon, dtype=np.float64), np.ascontiguousarray(gamma, dtype=np.float64),
        *tree.kernel_arrays(),
    )  # fmt: skip
    return y, lower, upper


# ---------------------------------------------------------------------------------- gamma*(eps)
@njit(cache=True, parallel=True)
def _gamma_star_rows_kernel(
    points_t: FloatArray,
    targets: FloatArray,
    twice_eps: FloatArray,
    rows: IntArray,
    out: FloatArray,
    reach2: FloatArray,
    bins_per_unit: FloatArray,
) -> None:
    """For each row ``i`` in ``rows``, update ``out[r]`` (E, m) with the pairs ``(i, j > i)``.

    ``out[r]`` comes in holding the running maximum from earlier blocks. ``reach2[b, c]`` bounds
    from above the squared distance below which a pair whose output difference falls in bin
    ``b - 1`` (``Δ * bins_per_unit[c]``) can still raise that maximum at some ε; other pairs are
    skipped without a square root or a division. For a pair, the ratio
    ℓ_e = (Δ − 2ε_e)/d is affine in ε and the running maximum G_e is convex in ε (a maximum of
    such lines, sampled on the grid), so ℓ_e − G_e is concave along the grid: once it is <= 0 and
    not increasing it stays <= 0, and the loop over the grid stops. ``twice_eps`` is sorted.
    """
    n_dims, n_points = points_t.shape
    n_out = targets.shape[1]
    n_eps = twice_eps.shape[0]
    n_bins = reach2.shape[0]
    for r in prange(rows.shape[0]):
        i = rows[r]
        count = n_points - i - 1
        if count <= 0:
            continue
        g = out[r]
        d2 = np.zeros(count)
        for k in range(n_dims):
            xi = points_t[k, i]
            row = points_t[k, i + 1 :]
            for q in range(count):
                diff = row[q] - xi
                d2[q] += diff * diff
        for q in range(count):
            j = i + 1 + q
            dd = d2[q]
            if dd == 0.0:
                for c in range(n_out):
                    delta = abs(targets[i, c] - targets[j, c])
                    for e in range(n_eps):
                        if delta - twice_eps[e, c] <= 0.0:
                            break
                        g[e, c] = np.inf
                continue
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
                    elif (
                        gap <= previous
                        and previous > -np.inf
                        and twice_eps[e, c] > twice_eps[e - 1, c]
                    ):
                        # (a repeated ε of the grid has its own entry: never stop on it)
                        break
                    previous = gap


#: Bins of the output difference Δ in the table of reachable distances of the γ*(ε) pass.
_REACH_BINS = 4096


def _neighbour_seed(points: FloatArray, targets: FloatArray, twice_eps: FloatArray) -> FloatArray:
    """γ*(ε) over the pairs of samples up to 8 rows apart: a cheap first lower bound.

    Consecutive regressors of a time series are close, so these pairs give most of γ*(ε) and
    let the blocked pass skip most other pairs from its first block on.
    """
    best = np.zeros(twice_eps.shape)
    for step in range(1, min(9, points.shape[0])):
        dist = np.sqrt(np.sum((points[step:] - points[:-step]) ** 2, axis=1))
        delta = np.abs(targets[step:] - targets[:-step])
        moving = dist > 0
        if not moving.any():
            continue
        for e in range(twice_eps.shape[0]):
            num = delta[moving] - twice_eps[e]
            ratio = np.where(num > 0, num, 0.0) / dist[moving, None]
            best[e] = np.maximum(best[e], ratio.max(axis=0))
    return best


def _reach_table(best: FloatArray, twice_eps: FloatArray, bins_per_unit: FloatArray) -> FloatArray:
    """``reach2[b, c]``: squared distance below which a pair with Δ up to bin ``b`` may count.

    A pair (Δ, d) raises γ*(ε_e) only if ``d < (Δ − 2ε_e) / γ*(ε_e)`` for some e; the right side
    grows with Δ, so its value at the bin's upper edge bounds the whole bin. Slightly inflated
    so that rounding never skips a pair that counts.
    """
    n_out = best.shape[1]
    edges = np.arange(_REACH_BINS)[:, None] / np.where(bins_per_unit > 0, bins_per_unit, 1.0)
    reach = np.zeros((_REACH_BINS, n_out))
    for e in range(best.shape[0]):
        num = edges - twice_eps[e]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(num > 0, num / best[e], 0.0)
        reach = np.maximum(reach, ratio)
    reach2 = reach * reach * (1.0 + 1e-9)
    reach2[:, bins_per_unit == 0] = np.inf
    return np.ascontiguousarray(reach2)


def gamma_star(
    points: FloatArray,
    targets: FloatArray,
    epsilons: FloatArray,
    n_blocks: int = 64,
    callback: Callable[[int, int], None] | None = None,
) -> FloatArray:
    """γ*(ε) for each ε of a grid and each output, over all pairs, in one blocked compiled pass.

    Parameters
    ----------
    points : ndarray, shape (n_points, n_dims)
        Scaled regressors.
    targets : ndarray, shape (n_points, n_outputs)
        Targets ỹ.
    epsilons : ndarray, shape (n_eps, n_outputs)
        The grid of ε per output (any order, >= 0).
    n_blocks : int, default 64
        How many blocks of rows (each block holds the same number of pairs); ``callback`` is
        called after each.
    callback : callable, optional
        ``callback(pairs_done, pairs_total)`` called from Python between blocks.

    Returns
    -------
    ndarray, shape (n_eps, n_outputs)
        γ*(ε); ``inf`` where two identical regressors have targets more than 2ε apart.
    """
    points = np.asarray(points, dtype=np.float64)
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    epsilons = np.asarray(epsilons, dtype=np.float64)
    n_points = points.shape[0]
    order = np.argsort(epsilons, axis=0, kind="stable")
    twice_eps = np.ascontiguousarray(2.0 * np.take_along_axis(epsilons, order, axis=0))
    points_t = np.ascontiguousarray(points.T)
    # Rows 0, N-1, 1, N-2, ...: consecutive pairs of rows hold N-1 pairs together, so equal slices
    # of this order hold equal work (for the blocks and for the threads inside a block).
    half = np.arange((n_points + 1) // 2)
    interleaved = np.empty(n_points, dtype=np.int64)
    interleaved[0::2] = half
    interleaved[1::2] = (n_points - 1 - half)[: n_points // 2]
    total = n_points * (n_points - 1) // 2
    best = _neighbour_seed(points, targets, twice_eps)
    span = np.ptp(targets, axis=0) if n_points else np.zeros(targets.shape[1])
    bins_per_unit = np.where(span > 0, (_REACH_BINS - 2) / np.where(span > 0, span, 1.0), 0.0)
    blocks = np.array_split(interleaved, max(1, min(int(n_blocks), n_points)))
    done = 0
    for rows in blocks:
        if rows.size == 0:
            continue
        out = np.broadcast_to(best, (rows.size, *best.shape)).copy()
        reach2 = _reach_table(best, twice_eps, bins_per_unit)
        _gamma_star_rows_kernel(
            points_t, targets, twice_eps, np.ascontiguousarray(rows), out, reach2, bins_per_unit
        )
        best = np.maximum(best, out.max(axis=0))
        done += int(np.sum(n_points - 1 - rows))
        if callback is not None:
            callback(done, total)
    result = np.empty_like(best)
    np.put_along_axis(result, order, best, axis=0)
    return result
