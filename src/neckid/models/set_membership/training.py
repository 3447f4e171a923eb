r"""The training set of a Set Membership model: one copy of the points, and the checks on it.

:class:`~neckid.SetMembership` keeps its training regressors once, scaled and in the order of its
kd-tree (:class:`~neckid.models.set_membership._kernels.tree.SMTree`), and nothing else of size ``n_samples ×
n_terms``. What needs the raw regressors (the model file, :meth:`partial_fit
<neckid.SetMembership.partial_fit>`, the linear part) recovers them with :func:`unscale`, which
returns rows that the scaling maps back onto the stored points *bit for bit*, so a model written
to a file and read back has the same tree points and the same targets to the last bit.

The prior checks (Milanese & Novara, 2004): the feasible set is non-empty iff
``f_u(w̃_k) >= ỹ_k − ε`` and ``f_l(w̃_k) <= ỹ_k + ε`` for every training k, which is the same as

.. math:: |ỹ_i − ỹ_j| − 2ε \le γ\,\|w̃_i − w̃_j\| \quad \text{for every pair,}

i.e. ``γ >= γ*(ε)``. :func:`prior_holds` checks that with the γ* branch and bound started at γ
(only pairs that could exceed γ are computed); :func:`prior_holds_by_query` is the reference,
which evaluates the bounds at every training point.

References
----------
M. Milanese and C. Novara, "Set membership identification of nonlinear systems",
Automatica 40(6):957-975, 2004.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numba import njit
from numpy.typing import NDArray

from neckid.models.linear.arx import linear_sum
from neckid.models.set_membership._kernels import (
    LEAF_SIZE,
    TREE_MIN_POINTS,
    SMTree,
    gamma_star,
    gamma_star_blocked,
)
from neckid.utils.types import FloatArray, IntArray

__all__ = [
    "PRIOR_TOLERANCE",
    "check_duplicates",
    "duplicate_spread",
    "prior_holds",
    "prior_tolerance",
    "smallest_epsilon",
    "training_tree",
    "unscale",
]


#: Relative tolerance of the prior checks: a pair may exceed ``2ε + γ d`` by
#: ``PRIOR_TOLERANCE · (1 + max |ỹ| + ε)`` (rounding of the bounds), see :func:`prior_tolerance`.
PRIOR_TOLERANCE = 1e-9
#: Rows per block where a computation goes through temporary copies of the rows.
_BLOCK_ROWS = 16_384
#: Steps of one unit in the last place that :func:`unscale` may take (two suffice, see there).
_UNSCALE_STEPS = 8


# ====================================================================================== raw rows
@njit(cache=True)
def _unscale_kernel(
    points: FloatArray, weights: FloatArray, out: FloatArray
) -> None:  # pragma: no cover - compiled; tested through unscale
    for i in range(points.shape[0]):
        for k in range(points.shape[1]):
            p = points[i, k]
            w = weights[k]
            x = p / w
            for _ in range(_UNSCALE_STEPS):
                back = x * w
                if back < p:
                    x = np.nextafter(x, np.inf)
                elif back > p:
                    x = np.nextafter(x, -np.inf)
                else:
                    break
            out[i, k] = x


def unscale(points: FloatArray, weights: FloatArray, out: FloatArray | None = None) -> FloatArray:
    """Raw regressors ``x`` with ``x * weights == points`` exactly, element by element.

    Parameters
    ----------
    points : ndarray, shape (n_rows, n_terms)
        Scaled regressors, ``x_0 * weights`` for some raw ``x_0``.
    weights : ndarray, shape (n_terms,)
        The scaling (> 0).
    out : ndarray, shape (n_rows, n_terms), optional
        Where to write the result (float64, e.g. a block of a larger array).

    Returns
    -------
    ndarray, shape (n_rows, n_terms)
        ``out`` if given: ``points / weights``, moved by a unit in the last place at a time where the product
        does not give the point back. Such a value exists (``x_0``) within two units of the
        quotient, and the rounded product is monotone in x, so the walk towards the point
        stops on one. The only memory used is the result.

    Examples
    --------
    >>> import numpy as np
    >>> x0 = np.random.default_rng(0).normal(size=(1000, 3))
    >>> weights = np.array([1 / 3, 7.1, 0.013])
    >>> points = x0 * weights
    >>> bool(np.array_equal(unscale(points, weights) * weights, points))
    True
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    if out is None:
        out = np.empty(points.shape)
    _unscale_kernel(points, np.ascontiguousarray(weights, dtype=np.float64), out)
    return out


def _residual(
    points: FloatArray, y: FloatArray, weights: FloatArray, coef: FloatArray, intercept: FloatArray
) -> FloatArray:
    """``y − linear_sum(unscale(points))`` block by block (a copy of ``y`` without a linear part)."""
    if not (np.any(coef) or np.any(intercept)):
        return np.array(y, dtype=np.float64, order="C")
    residual = np.empty(y.shape)
    for first in range(0, points.shape[0], _BLOCK_ROWS):
        rows = slice(first, first + _BLOCK_ROWS)
        residual[rows] = y[rows] - linear_sum(unscale(points[rows], weights), coef, intercept)
    return residual


def training_tree(
    x: FloatArray,
    y: FloatArray,
    weights: FloatArray,
    coef: FloatArray,
    intercept: FloatArray,
    keep_outputs: bool,
    *,
    frame: bool = False,
    leaf_size: int = LEAF_SIZE,
) -> tuple[SMTree, FloatArray | None]:
    """Scale ``x`` in place and build the kd-tree on it: the model's one copy of the points.

    Parameters
    ----------
    x : ndarray, shape (n_rows, n_terms), C-contiguous float64
        Raw regressors, **overwritten**: they become the tree's scaled points in tree order.
    y : ndarray, shape (n_rows, n_outputs)
        Measured outputs, rows as in ``x``.
    weights, coef, intercept : ndarray
        Scaling and linear part; the SM targets are ``y − linear_sum(unscale(points))`` (the
        raw rows as :func:`unscale` recovers them, so that a model file gives the same targets).
    keep_outputs : bool
        Also return ``y`` in tree order (needed when the targets are not ``y``: linear part).
    frame : bool, default False
        Split the tree in the points' principal frame (``SMTree(frame=True)``): the same
        results, fewer visits of the screened walks over many lagged terms.
    leaf_size : int, default LEAF_SIZE
        Largest number of points in a leaf of the tree.

    Returns
    -------
    tree : SMTree
    outputs : ndarray or None
        ``y`` in tree order when ``keep_outputs``.
    """
    x *= weights
    residual = _residual(x, y, weights, coef, intercept)  # a new array, reordered in place
    tree = SMTree(
        x, residual, leaf_size, overwrite_points=True, overwrite_targets=True, frame=frame
    )
    return tree, (np.ascontiguousarray(y[tree.perm]) if keep_outputs else None)


# ====================================================================================== duplicates
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX_1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX_2 = np.uint64(0x94D049BB133111EB)
_NEGATIVE_ZERO = np.uint64(1 << 63)


@njit(cache=True, inline="always")
def _row_hash(bits: NDArray[np.uint64], i: int) -> np.uint32:  # pragma: no cover - compiled
    """A 32-bit hash of row ``i`` of float64 bit patterns (−0 hashed as +0, as ``==`` sees them)."""
    h = _GOLDEN
    for k in range(bits.shape[1]):
        v = bits[i, k]
        if v == _NEGATIVE_ZERO:
            v = np.uint64(0)
        h = h * _GOLDEN + v  # then the splitmix64 finaliser
        h = (h ^ (h >> np.uint64(30))) * _MIX_1
        h = (h ^ (h >> np.uint64(27))) * _MIX_2
        h = h ^ (h >> np.uint64(31))
    return np.uint32((h ^ (h >> np.uint64(32))) & np.uint64(0xFFFFFFFF))


@njit(cache=True)
def _row_hashes(bits: NDArray[np.uint64]) -> NDArray[np.uint32]:  # pragma: no cover - compiled
    """:func:`_row_hash` of every row."""
    hashes = np.empty(bits.shape[0], np.uint32)
    for i in range(bits.shape[0]):
        hashes[i] = _row_hash(bits, i)
    return hashes


@njit(cache=True)
def _repeated(ordered: NDArray[np.uint32]) -> NDArray[np.uint32]:  # pragma: no cover - compiled
    """The values that occur more than once in a sorted array, ascending, each once."""
    count = 0
    for p in range(1, ordered.shape[0]):
        if ordered[p] == ordered[p - 1] and (p == 1 or ordered[p - 1] != ordered[p - 2]):
            count += 1
    values = np.empty(count, np.uint32)
    count = 0
    for p in range(1, ordered.shape[0]):
        if ordered[p] == ordered[p - 1] and (p == 1 or ordered[p - 1] != ordered[p - 2]):
            values[count] = ordered[p]
            count += 1
    return values


@njit(cache=True)
def _candidate_groups(
    bits: NDArray[np.uint64], repeated: NDArray[np.uint32]
) -> tuple[IntArray, IntArray]:  # pragma: no cover - compiled; tested through check_duplicates
    """The rows whose hash is in ``repeated``, grouped by hash: ``order`` and group ``offsets``.

    Group g is ``order[offsets[g]:offsets[g + 1]]`` (rows ascending); the hashes are computed
    again instead of kept, so only the candidate rows take memory.
    """
    offsets = np.zeros(repeated.shape[0] + 1, np.int64)
    for i in range(bits.shape[0]):
        h = _row_hash(bits, i)
        g = np.searchsorted(repeated, h)
        if g < repeated.shape[0] and repeated[g] == h:
            offsets[g + 1] += 1
    for group in range(repeated.shape[0]):
        offsets[group + 1] += offsets[group]
    fill = offsets[:-1].copy()
    order = np.empty(offsets[-1], np.int64)
    for i in range(bits.shape[0]):
        h = _row_hash(bits, i)
        g = np.searchsorted(repeated, h)
        if g < repeated.shape[0] and repeated[g] == h:
            order[fill[g]] = i
            fill[g] += 1
    return order, offsets


@njit(cache=True)
def _widest_duplicates(
    points: FloatArray, targets: FloatArray, order: IntArray, offsets: IntArray
) -> tuple[FloatArray, IntArray]:  # pragma: no cover - compiled; tested through check_duplicates
    """Per output, the widest target spread over a group of identical rows, and its two rows.

    Each group of rows with equal hashes (``order``, ``offsets`` of :func:`_candidate_groups`)
    is split into its sets of identical rows (compared exactly), one set after the other.
    """
    n_terms = points.shape[1]
    n_out = targets.shape[1]
    spread = np.zeros(n_out)
    pair = np.zeros((n_out, 2), np.int64)
    high = np.empty(n_out, np.int64)
    low = np.empty(n_out, np.int64)
    grouped = np.zeros(order.shape[0], np.bool_)  # by position in ``order``
    for g in range(offsets.shape[0] - 1):
        first, stop = offsets[g], offsets[g + 1]
        for lead in range(first, stop - 1):
            if grouped[lead]:
                continue
            a = order[lead]
            high[:] = a
            low[:] = a
            for p in range(lead + 1, stop):
                b = order[p]
                if grouped[p]:
                    continue
                same = True
                for k in range(n_terms):
                    if points[a, k] != points[b, k]:
                        same = False
                        break
                if not same:
                    continue
                grouped[p] = True
                for c in range(n_out):
                    if targets[b, c] > targets[high[c], c]:
                        high[c] = b
                    if targets[b, c] < targets[low[c], c]:
                        low[c] = b
            for c in range(n_out):
                width = targets[high[c], c] - targets[low[c], c]
                if width > spread[c]:
                    spread[c] = width
                    pair[c, 0] = high[c]
                    pair[c, 1] = low[c]
    return spread, pair


def check_duplicates(tree: SMTree, epsilon: FloatArray, output_names: Sequence[str]) -> None:
    """Refuse identical regressors whose outputs differ by more than 2ε (no γ can fit them).

    Rows are grouped by a hash of their values and compared exactly within a group, so the
    check allocates 4 bytes per row (and 8 per row whose hash repeats), not a copy of the rows. The message names the two
    rows in the order of the training data (``tree.perm``) with the widest spread.

    Raises
    ------
    ValueError
        For the first output whose widest spread exceeds ``2 ε``.
    """
    if tree.points.shape[0] < 2:
        return
    spread, pair = _duplicates(tree.points, tree.targets)
    for c, name in enumerate(output_names):
        if spread[c] > 2.0 * epsilon[c]:
            i, j = sorted(int(tree.perm[p]) for p in pair[c])
            raise ValueError(
                f"training regressor rows {i} and {j} are identical but output"
                f" {name!r} differs by {spread[c]:.6g} > 2*epsilon = {2 * epsilon[c]:.6g}: no"
                " Lipschitz function fits them, for any gamma (the prior is invalid); use"
                f" epsilon >= {spread[c] / 2:.6g} for that output or add regressor terms that"
                " tell the two samples apart"
            )


def duplicate_spread(points: FloatArray, targets: FloatArray) -> FloatArray:
    """The widest spread of the targets among identical rows of ``points``, per output.

    Half of it is the smallest ε for which any Lipschitz function fits the data (0 when no two
    rows are identical).
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    targets = np.ascontiguousarray(targets, dtype=np.float64)
    if points.shape[0] < 2:
        return np.zeros(targets.shape[1])
    return np.asarray(_duplicates(points, targets)[0], dtype=np.float64)


def _duplicates(points: FloatArray, targets: FloatArray) -> tuple[FloatArray, IntArray]:
    """Per output, the widest target spread among identical rows and the pair of rows holding it.

    A 32-bit hash per row (4 bytes per row, sorted in place) finds the hashes that repeat; only
    the rows with such a hash are then grouped and compared exactly (their hash computed again),
    so the check takes 4 bytes per row plus 8 per candidate row, not a copy of the rows.
    """
    bits = points.view(np.uint64)
    hashes = _row_hashes(bits)
    hashes.sort()
    repeated = _repeated(hashes)
    del hashes
    order, offsets = _candidate_groups(bits, repeated)
    return _widest_duplicates(points, targets, order, offsets)


# ====================================================================================== prior
def prior_tolerance(targets: FloatArray, epsilon: FloatArray) -> FloatArray:
    """``PRIOR_TOLERANCE · (1 + max |ỹ| + ε)`` per output: the slack the prior checks allow."""
    largest = np.maximum(np.abs(targets.min(axis=0)), np.abs(targets.max(axis=0)))
    return PRIOR_TOLERANCE * (1.0 + largest + epsilon)


def prior_holds(
    tree: SMTree, epsilon: FloatArray, gamma: FloatArray
) -> tuple[NDArray[np.bool_], FloatArray]:
    r"""Per output, whether the data are consistent with (ε, γ): γ >= γ*(ε), up to the tolerance.

    Parameters
    ----------
    tree : SMTree
        The training points and targets.
    epsilon, gamma : ndarray, shape (n_outputs,)

    Returns
    -------
    valid : ndarray of bool, shape (n_outputs,)
        True where no pair has ``|ỹ_i − ỹ_j| − 2ε − τ > γ‖w̃_i − w̃_j‖``, with τ of
        :func:`prior_tolerance`.
    gamma_star : ndarray, shape (n_outputs,)
        γ*(ε) where the prior fails (exact, for the message); NaN where it holds.

    Notes
    -----
    One branch-and-bound pass of :func:`~neckid.models.set_membership._kernels.tree.gamma_star` over the grid
    ``(ε, ε + τ/2)`` with the running maximum started at γ (``floor``): a pair or node is only
    opened if it could have a ratio ``(Δ − 2ε)/d`` above γ, so when γ is above γ*(ε) almost
    everything is skipped. The result is ``max(γ, γ*(ε + τ/2))``, equal to γ iff the prior holds.

    :func:`prior_holds_by_query` (the reference) tests the same pairs through the bounds,
    ``f_u(w̃_k) + τ >= ỹ_k − ε``: both accept a pair iff ``Δ − 2ε − γ d <= τ``, each with its own
    rounding (a few units in the last place of Δ), so they differ only for a pair within
    rounding of the tolerance itself.
    """
    tolerance = prior_tolerance(tree.targets, epsilon)
    grid = np.vstack([epsilon, epsilon + 0.5 * tolerance])
    best = gamma_star(tree.points, tree.targets, grid, tree=tree, floor=gamma)
    valid = np.asarray(best[1] <= gamma, dtype=bool)
    return valid, np.where(valid, np.nan, best[0])


def smallest_epsilon(tree: SMTree, gamma: FloatArray) -> FloatArray:
    r"""ε*(γ) = ½ max_{i≠j} (|ỹ_i − ỹ_j| − γ‖w̃_i − w̃_j‖)⁺: the smallest ε consistent with γ.

    Parameters
    ----------
    tree : SMTree
        The training points and targets.
    gamma : ndarray, shape (n_outputs,)

    Returns
    -------
    ndarray, shape (n_outputs,)

    Notes
    -----
    By branch and bound over the tree (:func:`~neckid.models.set_membership._kernels.gamma.gamma_star_blocked`
    with ``margin=True``): a pair can raise the running maximum 2ε̂ only if ``‖w̃_i − w̃_j‖ <
    (|ỹ_i − ỹ_j| − 2ε̂)/γ``, the same test as the check that γ >= γ*(ε̂), so it costs about
    what :func:`prior_holds` does. The data are consistent with (ε*(γ), γ) by construction (the
    tightest pair meets it with equality), so no prior check follows. Below
    ``TREE_MIN_POINTS`` points every pair is walked. :func:`smallest_epsilon_by_query` is the
    reference (the bounds at every training point).
    """
    gamma = np.ascontiguousarray(gamma, dtype=np.float64)[None, :]
    search = tree if tree.points.shape[0] >= TREE_MIN_POINTS else None
    twice, _ = gamma_star_blocked(
        tree.points, tree.targets, gamma, 64, None, search, adaptive=True, margin=True
    )
    return np.asarray(0.5 * twice[0], dtype=np.float64)
