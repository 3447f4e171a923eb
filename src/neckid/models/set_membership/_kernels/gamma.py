"""γ*(ε) kernels: the blocked all-pairs pass and the exact kd-tree branch and bound.

γ*(ε) = max_{i≠j} (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖ (Milanese & Novara 2004) is the smallest
Lipschitz constant that the data allow for the noise bound ε. Both kernels below compute it
*exactly* for a whole grid of ε at once, by the same arithmetic on each pair; they differ only
in which pairs they can prove useless without computing them.

- :func:`_pairs_rows_kernel` walks every pair ``(i, j > i)`` of a set of rows (the reference,
  quadratic in the number of points);
- the kd-tree branch and bound of :mod:`~neckid.models.set_membership._kernels.gamma_search`
  searches the tree built by :func:`neckid.models.set_membership._kernels.tree.build_tree`
  (Bentley 1975; Friedman, Bentley & Finkel 1977): the points of one leaf search together for
  the partners that could still raise the running maximum, and skip every node whose bound on
  the ratio, (max |ỹ_i − ỹ_j| − 2ε) / min ‖w̃_i − w̃_j‖ over the node, cannot exceed it (or
  whose slope bound, :mod:`~neckid.models.set_membership._kernels.slope`, cannot).

Both test a pair (or a node) against one table, ``reach2[b, c]``: the squared distance below
which a pair whose |ỹ_i − ỹ_j| falls in bin ``b`` can raise γ*(ε) at some ε of the grid, given
the maxima found so far (seeded with the pairs of nearby rows). Only one number is compared per
output, whatever the size of the grid. :func:`gamma_star_blocked` runs the kernels over blocks
of rows (or of leaves), refreshing the table between blocks and reporting progress; with a
tree it can hand the remaining rows to the pair kernel when the tree prunes too little. The
public entry point is :func:`neckid.models.set_membership._kernels.tree.gamma_star`.

The same search answers two neighbouring questions (Milanese & Novara 2004, the prior is valid
iff γ >= γ*(ε)): started at a ``floor`` γ instead of 0 it only opens what could exceed γ, which
checks γ >= γ*(ε) for far less than γ*(ε) costs; with ``margin=True`` it computes
2ε*(γ) = max (|ỹ_i − ỹ_j| − γ‖w̃_i − w̃_j‖)⁺, the smallest ε consistent with γ (a pair counts
only if ``d < (Δ − 2ε̂)/γ``: the same table with the roles of the two swapped).

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

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numba import njit, prange

from neckid.models.set_membership._kernels.gamma_search import (
    _raise,
    _tree_leaves_kernel,
    _tree_leaves_serial,
)
from neckid.models.set_membership._kernels.slope import SlopeBounds, no_slope_bounds, slope_bounds
from neckid.models.set_membership._kernels.tree import SMTree
from neckid.utils.types import FloatArray, IntArray

__all__ = [
    "GAMMA_LEAF_SIZE",
    "REACH_BINS",
    "SLOPE_MIN_SKIPPED",
    "TREE_HANDOVER",
    "TREE_MIN_POINTS",
    "TREE_NODE_COST",
    "TREE_PAIR_COST",
    "TREE_SLOPE_COST",
    "TREE_STRIKES",
    "GammaMethod",
    "SlopeOption",
    "gamma_star",
    "gamma_star_blocked",
]


logger = logging.getLogger(__name__)

#: Bins of the output difference Δ in the table of reachable distances.
REACH_BINS = 4096
#: Consecutive rows (in the order given, and in tree order) paired for the first lower bound.
_SEED_STEPS = 8
_FIRST_STEP = np.array([1], dtype=np.int64)
_LATER_STEPS = np.arange(2, _SEED_STEPS + 1, dtype=np.int64)
#: Cost of a pair whose distance the tree computes, and of a node it tests, in units of one pair
#: of the all-pairs kernel (which streams the distances of a row); see :func:`gamma_star_blocked`.
TREE_PAIR_COST = 2.5
TREE_NODE_COST = 4.5
#: With ``adaptive``, the tree hands over to the pair kernel only when the cost so estimated
#: exceeds the block's pairs by this factor: the estimate is within about 30 % of the measured
#: ratio (1 to 20 dimensions, 1 or 2 threads), so a near tie stays with the tree.
TREE_HANDOVER = 1.25
#: With ``adaptive``, the handover waits for this many such blocks in a row. The first block
#: also finds the large slopes that later blocks prune with, so its cost alone overstates the
#: search's: on a payload split's residuals (4 terms, 14,811 rows) the first of 64 blocks cost
#: more than its pairs, and the whole search took 0.15 s on the tree against 0.50 s handed over.
TREE_STRIKES = 2
#: A tree block runs without threads when the previous one cost less than this (in pairs).
SERIAL_WORK = 200_000
#: Cost of one slope bound (:mod:`.slope`), in the same units.
TREE_SLOPE_COST = 6.0
#: With ``slopes="auto"``, the slope bounds are dropped after a block in which they skipped less
#: than this share of the nodes they were tested on (a skipped node saves its whole subtree, so a
#: few per cent pay for the test).
SLOPE_MIN_SKIPPED = 0.01
#: Whether the tree search also bounds slopes with regional linear models (see
#: :func:`gamma_star_blocked`).
SlopeOption = Literal["never", "auto", "always"] | SlopeBounds


# ------------------------------------------------------------------------- all pairs
@njit(cache=True, parallel=True)
def _pairs_rows_kernel(
    points_t: FloatArray,
    targets: FloatArray,
    twice_eps: FloatArray,
    rows: IntArray,
    out: FloatArray,
    reach2: FloatArray,
    bins_per_unit: FloatArray,
    margin: bool,
) -> None:
    """For each row ``i`` in ``rows``, raise ``out[r]`` (E, m) with every pair ``(i, j > i)``.

    ``out[r]`` comes in holding the running maximum from earlier blocks. The squared distances of
    a row are computed component by component over the contiguous rows of ``points_t``.
    """
    n_dims, n_points = points_t.shape
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
            _raise(margin, g, d2[q], targets, i, i + 1 + q, twice_eps, reach2, bins_per_unit)


# ------------------------------------------------------------------------- driver
@njit(cache=True)
def _seed_kernel(
    points: FloatArray,
    targets: FloatArray,
    twice_eps: FloatArray,
    g: FloatArray,
    margin: bool,
    steps: IntArray,
    reach2: FloatArray,
    bins_per_unit: FloatArray,
) -> None:
    """Raise ``g`` with the pairs of rows ``step`` apart, for each step of ``steps``.

    ``reach2`` and ``bins_per_unit`` are the table of :func:`_reach_table` (a pair it rules out
    cannot raise ``g``), or ``(1, m)`` infinities and zeros to test every pair.
    """
    n_points, n_dims = points.shape
    for step in steps:
        for i in range(n_points - step):
            dd = 0.0
            for k in range(n_dims):
                diff = points[i + step, k] - points[i, k]
                dd += diff * diff
            _raise(margin, g, dd, targets, i, i + step, twice_eps, reach2, bins_per_unit)


def _reach_table(best: FloatArray, twice_eps: FloatArray, bins_per_unit: FloatArray) -> FloatArray:
    """``reach2[b, c]``: squared distance below which a pair with Δ up to bin ``b`` may count.

    A pair (Δ, d) raises γ*(ε_e) only if ``d < (Δ − 2ε_e) / γ*(ε_e)`` for some e; the right side
    grows with Δ, so its value at the bin's upper edge bounds the whole bin. Slightly inflated
    so that rounding never skips a pair that counts. An output that never changes (no bins)
    gets 0: no pair of it can exceed 2ε >= 0.
    """
    n_out = best.shape[1]
    # A Δ in bin b - 1 has Δ * bins_per_unit < b; the relative 1e-12 covers the rounding of both.
    edges = (
        np.arange(REACH_BINS)[:, None]
        * (1.0 + 1e-12)
        / np.where(bins_per_unit > 0, bins_per_unit, 1.0)
    )
    reach = np.zeros((REACH_BINS, n_out))
    for e in range(best.shape[0]):
        num = edges - twice_eps[e]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(num > 0, num / best[e], 0.0)
        reach = np.maximum(reach, ratio)
    reach2 = reach * reach * (1.0 + 1e-9)
    reach2[:, bins_per_unit == 0] = 0.0
    return np.ascontiguousarray(reach2)


def _interleaved(items: IntArray) -> IntArray:
    """``items[0], items[-1], items[1], items[-2], ...``.

    Over rows 0..N-1, consecutive pairs of this order hold N-1 pairs ``(i, j > i)`` together, so
    equal slices hold equal numbers of pairs (and over leaves in tree order, nearly equal).
    """
    half = (items.size + 1) // 2
    order = np.empty(items.size, dtype=np.int64)
    order[0::2] = items[:half]
    order[1::2] = items[::-1][: items.size // 2]
    return order


def _rows_of(first: IntArray, last: IntArray) -> IntArray:
    """The rows of the ranges ``[first[k], last[k])``, one range after the other."""
    lengths = last - first
    return np.repeat(first - np.cumsum(lengths) + lengths, lengths) + np.arange(lengths.sum())


def gamma_star_blocked(
    points: FloatArray,
    targets: FloatArray,
    twice_eps: FloatArray,
    n_blocks: int,
    callback: Callable[[int, int], None] | None,
    tree: SMTree | None,
    adaptive: bool = False,
    floor: FloatArray | None = None,
    margin: bool = False,
    slopes: SlopeOption = "never",
) -> tuple[FloatArray, dict[str, int]]:
    """γ*(ε) on a sorted grid ``twice_eps`` (2ε, shape (E, m)), block after block of rows.

    Parameters
    ----------
    points : ndarray, shape (n_points, n_dims)
        Scaled regressors (C-contiguous float64).
    targets : ndarray, shape (n_points, n_outputs)
        Targets ỹ (C-contiguous float64).
    twice_eps : ndarray, shape (n_eps, n_outputs)
        2ε, each column sorted ascending.
    n_blocks : int
        Number of blocks: of rows without a tree, of leaves with one (at most the number of
        rows or leaves). Each holds about the same number of pairs ``(i, j > i)``; the pruning
        table is refreshed and ``callback`` called after each.
    callback : callable or None
        ``callback(pairs_done, pairs_total)``.
    tree : SMTree or None
        The kd-tree over ``points`` and ``targets`` (leaf size 4 to 16 works best); None runs
        the all-pairs kernel only.
    adaptive : bool, default False
        With a tree: once the counted work of ``TREE_STRIKES`` blocks in a row
        (``TREE_PAIR_COST`` per pair distance plus ``TREE_NODE_COST`` per box distance) exceeds
        ``TREE_HANDOVER`` times the number of pairs the all-pairs kernel would have walked, the
        remaining blocks go to the all-pairs kernel (over the points in tree order). The first
        block alone can be costly while the search finds the large slopes, so it does not
        decide. The result is the same, bit for bit; only the time differs. The costs are in
        units of one pair of the all-pairs kernel, measured on 1 to 20 dimensions.
    floor : ndarray, shape (n_outputs,) or (n_eps, n_outputs), optional
        Start the running maxima at this value instead of 0: the result is
        ``max(γ*(ε), floor)``, and only pairs that could exceed the floor are computed. With a
        floor at or above γ*(ε) the table of reachable distances is small from the start and
        nearly every node is skipped: the check that γ >= γ*(ε) (result equal to the floor)
        costs far less than γ*(ε) itself.
    margin : bool, default False
        Compute ``max_{i≠j} (|ỹ_i − ỹ_j| − γ‖w̃_i − w̃_j‖)⁺ = 2ε*(γ)`` instead, the same way:
        ``twice_eps`` then holds γ, shape (1, m), and so does the result (``floor`` starts it).
        A pair can raise it only if ``d < (Δ − 2ε̂)/γ``, the table of γ*(ε) with the roles of
        the running maximum and the grid swapped.
    slopes : {"never", "auto", "always"} or SlopeBounds, default "never"
        With a tree (never with ``margin``), also test every node that passes the box test with
        the bound of the regional linear models of
        :mod:`~neckid.models.set_membership._kernels.slope`, built before the first block (one
        pass over the points, about what the first lower bound over neighbouring rows costs):
        ``"auto"`` drops them after a block in which they skipped less than
        ``SLOPE_MIN_SKIPPED`` of what they were tested on, ``"always"`` keeps them; given bounds
        (of this tree) are kept too. Either way the result is the same, bit for bit.

    Returns
    -------
    gamma : ndarray, shape (n_eps, n_outputs)
        γ*(ε), in the order of ``twice_eps``.
    stats : dict
        ``pairs`` (all pairs), ``computed`` and ``tested`` (pair and box distances the tree
        computed), ``sloped`` and ``skipped`` (slope bounds evaluated, and the nodes they
        skipped), ``slope_blocks`` (tree blocks run with slope bounds), ``tree_rows`` and
        ``pair_rows`` (rows done by each kernel).
    """
    n_points = points.shape[0]
    span = np.ptp(targets, axis=0) if n_points else np.zeros(targets.shape[1])
    bins_per_unit = np.where(span > 0, (REACH_BINS - 2) / np.where(span > 0, span, 1.0), 0.0)
    best = _first_maxima(points, targets, twice_eps, floor, margin, tree, bins_per_unit)
    search: _TreeBlocks | None = None
    if tree is not None:
        points, targets = tree.points, tree.targets
        search = _TreeBlocks.start(tree, twice_eps, best, margin, slopes)
        leaves = np.flatnonzero(tree.left < 0)
        units = _interleaved(leaves[np.argsort(tree.start[leaves], kind="stable")])
    else:
        units = _interleaved(np.arange(n_points))
    total = n_points * (n_points - 1) // 2
    stats = dict.fromkeys(
        ("computed", "tested", "sloped", "skipped", "slope_blocks", "tree_rows", "pair_rows"), 0
    )
    stats["pairs"] = total
    points_t: FloatArray | None = None
    reach2: FloatArray | None = None
    reach_of = best  # the maxima reach2 was computed from
    done = 0
    for block in np.array_split(units, max(1, min(int(n_blocks), units.size))):
        if block.size == 0:
            continue
        first, last = (
            (tree.start[block], tree.end[block]) if tree is not None else (block, block + 1)
        )
        count = last - first
        pairs = int(np.sum(count * (n_points - 1) - (first + last - 1) * count // 2))
        if reach2 is None or not np.array_equal(best, reach_of):
            reach2 = (
                _reach_table(twice_eps, best, bins_per_unit)
                if margin
                else _reach_table(best, twice_eps, bins_per_unit)
            )
            reach_of = best
        if search is not None and search.searching:
            out = search.run(block, best, reach2, bins_per_unit, stats)
            stats["tree_rows"] += int(count.sum())
            over = adaptive and search.cost > TREE_HANDOVER * pairs
            search.strikes = search.strikes + 1 if over else 0
            search.searching = search.strikes < TREE_STRIKES
        else:
            rows = np.ascontiguousarray(_rows_of(first, last) if tree is not None else block)
            if points_t is None:
                points_t = np.ascontiguousarray(points.T)
            out = np.broadcast_to(best, (rows.size, *best.shape)).copy()
            _pairs_rows_kernel(
                points_t, targets, twice_eps, rows, out, reach2, bins_per_unit, margin
            )
            stats["pair_rows"] += rows.size
        best = np.maximum(best, out.max(axis=0))
        done += pairs
        if callback is not None:
            callback(done, total)
    return best, stats


def _first_maxima(
    points: FloatArray,
    targets: FloatArray,
    twice_eps: FloatArray,
    floor: FloatArray | None,
    margin: bool,
    tree: SMTree | None,
    bins_per_unit: FloatArray,
) -> FloatArray:
    """The running maxima before the first block: the floor raised by the seed pairs.

    The pairs of rows up to ``_SEED_STEPS`` apart, in the order given and (with a tree) in tree
    order: the neighbours one row apart with every pair tested, the others through the table of
    the maxima these gave (a pair it rules out cannot raise them, so the maxima are the same).
    """
    best = np.zeros(twice_eps.shape)
    if floor is not None:
        best = np.array(np.broadcast_to(floor, twice_eps.shape), dtype=np.float64)
    orders = [] if tree is not None and points is tree.points else [(points, targets)]
    if tree is not None:
        orders.append((tree.points, tree.targets))
    every = (np.full((1, targets.shape[1]), np.inf), np.zeros(targets.shape[1]))
    for order_points, order_targets in orders:
        _seed_kernel(order_points, order_targets, twice_eps, best, margin, _FIRST_STEP, *every)
    table = (
        _reach_table(twice_eps, best, bins_per_unit)
        if margin
        else _reach_table(best, twice_eps, bins_per_unit)
    )
    for order_points, order_targets in orders:
        _seed_kernel(
            order_points, order_targets, twice_eps, best, margin, _LATER_STEPS, table, bins_per_unit
        )
    return best


@dataclass
class _TreeBlocks:
    """The kd-tree side of :func:`gamma_star_blocked`: its arrays, slope bounds and last cost.

    ``slope_state`` is ``"off"``, ``"on"`` (dropped after a block where the bounds skipped less
    than ``SLOPE_MIN_SKIPPED`` of what they tested) or ``"kept"``; ``monotone`` says that the
    running maxima do not increase along the grid (true of every maximum of pair slopes; a
    floor per ε might break it), which lets the slope test stop early.
    """

    tree: SMTree
    twice_eps: FloatArray
    margin: bool
    bounds: SlopeBounds
    slope_state: str
    monotone: bool
    cost: float = np.inf  # of the last block, in pairs of the all-pairs kernel
    strikes: int = 0  # consecutive blocks that cost more than the pairs would have
    searching: bool = True

    @classmethod
    def start(
        cls,
        tree: SMTree,
        twice_eps: FloatArray,
        best: FloatArray,
        margin: bool,
        slopes: SlopeOption,
    ) -> _TreeBlocks:
        """The search's state before the first block (slope bounds built if asked for)."""
        bounds = no_slope_bounds(tree.targets.shape[1], tree.points.shape[1])
        state = "off"
        if not margin and isinstance(slopes, SlopeBounds):
            bounds, state = slopes, "kept"
        elif not margin and slopes in ("always", "auto"):
            bounds = slope_bounds(tree, twice_eps)
            state = "kept" if slopes == "always" else "on"
        monotone = bool(np.all(best[1:] <= best[:-1]))
        return cls(tree, twice_eps, margin, bounds, state, monotone)

    def run(
        self,
        block: IntArray,
        best: FloatArray,
        reach2: FloatArray,
        bins_per_unit: FloatArray,
        stats: dict[str, int],
    ) -> FloatArray:
        """Search the leaves of ``block``; return their running maxima and add to ``stats``."""
        tree = self.tree
        out = np.broadcast_to(best, (block.size, *best.shape)).copy()
        work = np.zeros((block.size, 4), dtype=np.int64)
        kernel = _tree_leaves_serial if self.cost < SERIAL_WORK else _tree_leaves_kernel
        arrays = (
            tree.start,
            tree.end,
            tree.left,
            tree.right,
            tree.lo,
            tree.hi,
            tree.ymin,
            tree.ymax,
        )
        kernel(
            tree.points,
            tree.targets,
            self.twice_eps,
            block,
            out,
            reach2,
            bins_per_unit,
            arrays,
            work,
            self.margin,
            tuple(self.bounds),
            self.monotone,
        )
        computed, tested, sloped, skipped = (int(v) for v in work.sum(axis=0))
        for name, value in (
            ("computed", computed),
            ("tested", tested),
            ("sloped", sloped),
            ("skipped", skipped),
            ("slope_blocks", int(self.slope_state != "off")),
        ):
            stats[name] += value
        self.cost = TREE_PAIR_COST * computed + TREE_NODE_COST * tested + TREE_SLOPE_COST * sloped
        if self.slope_state == "on" and skipped < SLOPE_MIN_SKIPPED * sloped:
            self.bounds = no_slope_bounds(tree.targets.shape[1], tree.points.shape[1])
            self.slope_state = "off"
        return out


# ---------------------------------------------------------------------------------- gamma*(eps)
#: The ways :func:`gamma_star` can walk the pairs.
GammaMethod = Literal["auto", "tree", "pairs"]
#: Below this many points ``method="auto"`` walks all pairs. Both ways take under 0.15 s there
#: for the default 48-ε grid (measured on neck-like regressors, n = 12: pairs 0.13 s, tree
#: 0.07 s at 10,000 points; the tree wins from a few hundred points on time series, from about
#: 4,000 on i.i.d. uniform 12-D points), while compiling the tree's kernels costs a fresh
#: install about 3 s: small problems, such as the demo's, keep to the one kernel.
TREE_MIN_POINTS = 10_000
#: Leaf size of the kd-tree that :func:`gamma_star` builds.
GAMMA_LEAF_SIZE = 8


def gamma_star(
    points: FloatArray,
    targets: FloatArray,
    epsilons: FloatArray,
    n_blocks: int = 64,
    callback: Callable[[int, int], None] | None = None,
    method: GammaMethod = "auto",
    *,
    tree: SMTree | None = None,
    floor: FloatArray | None = None,
    slopes: SlopeOption = "auto",
) -> FloatArray:
    """γ*(ε) = max_{i≠j} (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖ for each ε of a grid and each output.

    Parameters
    ----------
    points : ndarray, shape (n_points, n_dims)
        Scaled regressors.
    targets : ndarray, shape (n_points, n_outputs)
        Targets ỹ.
    epsilons : ndarray, shape (n_eps, n_outputs)
        The grid of ε per output (any order, >= 0).
    n_blocks : int, default 64
        How many blocks of rows (of kd-tree leaves with the tree; at most one per row or leaf),
        each holding about the same number of pairs ``(i, j > i)``; ``callback`` is called
        after each.
    callback : callable, optional
        ``callback(pairs_done, pairs_total)`` called from Python between blocks.
    method : {"auto", "tree", "pairs"}, default "auto"
        ``"pairs"`` walks every pair (the quadratic reference); ``"tree"`` finds, for each
        point, the partners that can still raise γ*(ε) by branch and bound over a kd-tree;
        ``"auto"`` walks the pairs below ``TREE_MIN_POINTS`` points and otherwise runs the
        tree, handing the remaining rows to the pair kernel if the tree prunes too little (a
        cost estimate from the work it counted, see
        :func:`neckid.models.set_membership._kernels.gamma.gamma_star_blocked`). All give the same result.
    tree : SMTree, optional
        A kd-tree already built over ``points`` and ``targets`` (any leaf size; the estimator
        passes its own, with ``points=tree.points`` and ``targets=tree.targets``): searched
        instead of building a new one (which would copy the points).
    floor : ndarray, shape (n_outputs,) or (n_eps, n_outputs), optional
        Return ``max(γ*(ε), floor)``: pairs that cannot exceed the floor are never computed
        (see :func:`~neckid.models.set_membership._kernels.gamma.gamma_star_blocked`). The result equals the floor
        exactly when no pair exceeds it, which is how :func:`~neckid.models.set_membership.training.prior_holds`
        checks γ >= γ*(ε) without computing γ*(ε).
    slopes : {"auto", "never", "always"} or SlopeBounds, default "auto"
        Whether the tree search also bounds slopes with regional linear models of the targets:
        by default once it finds itself opening many nodes (see ``slopes`` of
        :func:`~neckid.models.set_membership._kernels.gamma.gamma_star_blocked`). The result is
        the same either way.

    Returns
    -------
    ndarray, shape (n_eps, n_outputs)
        γ*(ε); ``inf`` where two identical regressors have targets more than 2ε apart, 0 where
        no two targets are more than 2ε apart.

    Raises
    ------
    ValueError
        If ``method`` is not one of the three.

    Notes
    -----
    γ*(ε) is the smallest Lipschitz constant for which the prior assumptions of Set Membership
    identification (Milanese & Novara 2004) are not falsified by the data at noise bound ε.
    Both kernels evaluate each pair they cannot skip with the same floating-point operations
    and skip only pairs that provably cannot raise the maximum, so ``"tree"`` and ``"pairs"``
    agree to the last bit (see :mod:`neckid.models.set_membership._kernels.gamma`).

    The tree's cost depends on the data. On time-series regressors and a small ε each point
    meets a few hundred candidates and the cost grows like N log N; at large ε, where many
    distant pairs have nearly the largest slope, the candidates within reach grow with N and
    so does the cost per point (quadratic, with a small constant). Where it prunes almost
    nothing (every pair with the same slope) a pair costs it several times what it costs the
    pair kernel, which is why ``"auto"`` watches the work it counts.

    References
    ----------
    M. Milanese and C. Novara, "Set Membership identification of nonlinear systems",
    Automatica 40(6), 957-975, 2004.

    Examples
    --------
    >>> import numpy as np
    >>> points = np.array([[0.0], [1.0], [3.0]])
    >>> targets = np.array([[0.0], [1.0], [5.0]])
    >>> gamma_star(points, targets, np.array([[0.0], [0.5], [3.0]]), method="tree")[:, 0]
    array([2. , 1.5, 0. ])
    """
    if method not in ("auto", "tree", "pairs"):
        raise ValueError(f"method must be 'auto', 'tree' or 'pairs'; got {method!r}")
    points = np.ascontiguousarray(points, dtype=np.float64)
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    epsilons = np.asarray(epsilons, dtype=np.float64)
    order = np.argsort(epsilons, axis=0, kind="stable")
    twice_eps = np.ascontiguousarray(2.0 * np.take_along_axis(epsilons, order, axis=0))
    n_points = points.shape[0]
    use_tree = method == "tree" or (method == "auto" and n_points >= TREE_MIN_POINTS)
    if not use_tree or n_points < 2:
        tree = None
    elif tree is None:
        tree = SMTree(points, targets, GAMMA_LEAF_SIZE)
    if floor is not None:
        floor = np.asarray(floor, dtype=np.float64)
        if floor.ndim == 2:  # one value per ε and output: in the order of the sorted grid
            floor = np.take_along_axis(floor, order, axis=0)
        floor = np.ascontiguousarray(floor)
    best, stats = gamma_star_blocked(
        points,
        targets,
        twice_eps,
        n_blocks,
        callback,
        tree,
        method == "auto",
        floor,
        slopes=slopes,
    )
    logger.debug("gamma*(eps) over %d points: %s", n_points, stats)
    result = np.empty_like(best)
    np.put_along_axis(result, order, best, axis=0)
    return result
