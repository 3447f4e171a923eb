"""The Set Membership prior from data: the γ*(ε) curve, its ε grid and the knee rule for ε.

``γ*(ε)`` is the smallest Lipschitz constant consistent with the data for a noise bound ``ε``
(Milanese & Novara, 2004); :class:`GammaCurve` holds it on a grid of ε and :func:`choose_epsilon`
picks ε where the curve flattens. :class:`~neckid.SetMembership` uses these when ε or γ is not
given; :func:`neckid.gamma_curve` computes the curve alone.

References
----------
M. Milanese and C. Novara, "Set membership identification of nonlinear systems",
Automatica 40(6):957-975, 2004.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from neckid.models.cache import active_cache, array_digest
from neckid.models.set_membership._kernels import SMTree, gamma_star
from neckid.models.set_membership.training import duplicate_spread
from neckid.utils.types import FloatArray, IntArray

__all__ = [
    "DEFAULT_GRID_POINTS",
    "DEFAULT_GRID_SPAN",
    "GammaCurve",
    "choose_epsilon",
    "gamma_from_margin",
    "knee_search",
]

ProgressOption = bool | Callable[[int, int], None] | None

#: Grid steps on each side of a point over which :func:`choose_epsilon` measures the slope.
SLOPE_WINDOW = 2
#: Number of points of the default ε grid (ε = 0 and a geometric sequence).
DEFAULT_GRID_POINTS = 48
#: The default ε grid spans ``[1e-4, 0.25] * ptp(ỹ)`` (plus ε = 0), per output.
DEFAULT_GRID_SPAN = (1e-4, 0.25)
#: Above this many training regressors the γ*(ε) pass shows a progress bar (``progress=None``).
PROGRESS_THRESHOLD = 20_000


@dataclass(frozen=True)
class GammaCurve:
    """The curve γ*(ε): the smallest Lipschitz constant consistent with the data, per ε.

    Attributes
    ----------
    epsilons : ndarray, shape (n_eps, n_outputs)
        The grid of noise bounds ε, ascending, per output (same unit as the output).
    gamma : ndarray, shape (n_eps, n_outputs)
        γ*(ε) = max_{i≠j} (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖ (``inf`` where two identical
        regressors have outputs more than 2ε apart).
    output_names : tuple of str
    n_samples : int
        Number of training regressors (the pass is over ``n_samples * (n_samples - 1) / 2`` pairs).

    Notes
    -----
    The curve of a default fit (``SetMembership().fit`` with neither ε nor γ, the default grid,
    at least ``KNEE_SEARCH_MIN_ROWS`` rows) may be partial: :func:`knee_search` computes γ*(ε)
    exactly on the grid's first values only, up to two or more grid steps past the chosen knee,
    and ``epsilons`` and ``gamma`` hold those rows (each value exact, the same as on the whole
    grid); :meth:`knee` gives the chosen ε. :func:`neckid.gamma_curve` computes the whole curve.
    """

    epsilons: FloatArray
    gamma: FloatArray
    output_names: tuple[str, ...]
    n_samples: int

    def knee(self) -> FloatArray:
        """The ε chosen by :func:`choose_epsilon` for each output, shape ``(n_outputs,)``."""
        return np.array(
            [
                self.epsilons[choose_epsilon(self.epsilons[:, c], self.gamma[:, c]), c]
                for c in range(self.gamma.shape[1])
            ]
        )


def choose_epsilon(epsilons: ArrayLike, gamma: ArrayLike) -> int:
    r"""Index of the ε where the curve γ*(ε) stops falling steeply (its knee).

    Parameters
    ----------
    epsilons : array_like, shape (n_eps,)
        Ascending grid of ε.
    gamma : array_like, shape (n_eps,)
        γ*(ε) on that grid.

    Returns
    -------
    int
        The index of the chosen ε.

    Notes
    -----
    The rule: keep the grid points where γ*(ε) is finite; at each inner point ``e`` compare the
    mean slope of the curve over the ``SLOPE_WINDOW`` grid steps before it with the mean slope
    over the ``SLOPE_WINDOW`` steps after it,

    .. math:: r_e = \frac{(γ^*_{e-k} − γ^*_e) / (ε_e − ε_{e-k})}{(γ^*_e − γ^*_{e+k}) / (ε_{e+k} − ε_e)},

    and take the ε where ``r_e`` is largest: where the slope flattens the most. Below the noise
    bound, pairs of close regressors whose outputs differ by noise alone make γ*(ε) fall with a
    slope ``2 / ‖w̃_i − w̃_j‖`` that is steep; above it, γ* falls slowly, driven by the function
    itself (Milanese & Novara, 2004, Section 5, choose ε where the curve stops rising sharply as
    ε decreases). With fewer than ``2 * SLOPE_WINDOW + 1`` finite points the smallest finite ε is
    returned. It is a heuristic: it tends to err towards small ε when the regressor has more
    terms than the system needs (the knee then blurs). If the sensor's noise bound is known,
    give it as ``epsilon``.

    Examples
    --------
    >>> eps = [0.0, 0.01, 0.02, 0.03, 0.05, 0.1, 0.2]
    >>> choose_epsilon(eps, [80.0, 55.0, 30.0, 5.0, 4.8, 4.3, 3.3])
    3
    """
    eps = np.asarray(epsilons, dtype=np.float64)
    g = np.asarray(gamma, dtype=np.float64)
    finite = np.flatnonzero(np.isfinite(g))
    if finite.size == 0:
        raise ValueError(
            "γ*(ε) is infinite over the whole ε grid: identical regressors have outputs more than"
            " 2ε apart for every ε tried; use a larger ε grid or add regressor terms"
        )
    k = SLOPE_WINDOW
    if finite.size < 2 * k + 1:
        return int(finite[0])
    centre, ratio = _slope_ratios(eps[finite], g[finite])
    if not np.any(ratio > 0):
        return int(finite[0])
    return int(finite[int(centre[int(np.argmax(ratio))])])


def _slope_ratios(x: FloatArray, y: FloatArray) -> tuple[IntArray, FloatArray]:
    """The ratios ``r_e`` of :func:`choose_epsilon` at the inner points of a finite curve.

    Element by element, so the ratio at a point is the same float whatever the rest of the
    curve: :func:`knee_search` relies on it to compare a partial curve with the whole one.
    """
    k = SLOPE_WINDOW
    centre = np.arange(k, x.size - k)
    with np.errstate(divide="ignore", invalid="ignore"):
        before = (y[centre - k] - y[centre]) / (x[centre] - x[centre - k])
        after = (y[centre] - y[centre + k]) / (x[centre + k] - x[centre])
        ratio = np.where(after > 0, before / np.where(after > 0, after, 1.0), np.inf)
    ratio = np.where(before > 0, ratio, 0.0)
    return centre, ratio


def _default_epsilons(targets: FloatArray) -> FloatArray:
    """Default ε grid per output: 0 and ``geomspace(1e-4, 0.25, 47) * ptp(ỹ)``."""
    span = np.ptp(targets, axis=0)
    steps = np.geomspace(*DEFAULT_GRID_SPAN, DEFAULT_GRID_POINTS - 1)
    return np.vstack([np.zeros((1, targets.shape[1])), steps[:, None] * span[None, :]])


def _epsilon_grid(epsilons: ArrayLike | None, targets: FloatArray) -> FloatArray:
    n_out = targets.shape[1]
    if epsilons is None:
        return _default_epsilons(targets)
    grid = np.asarray(epsilons, dtype=np.float64)
    if grid.ndim == 1:
        grid = np.repeat(grid[:, None], n_out, axis=1)
    if grid.ndim != 2 or grid.shape[1] != n_out or grid.shape[0] == 0:
        raise ValueError(
            f"epsilons must be a 1-D grid or one column per output ({n_out}); got shape"
            f" {np.shape(epsilons)}"
        )
    if not np.all(np.isfinite(grid)) or np.any(grid < 0):
        raise ValueError(f"epsilons must be finite and >= 0; got {grid.tolist()}")
    return np.sort(grid, axis=0)


def _progress_callback(
    progress: ProgressOption, n_samples: int, label: str = "γ*(ε) over pairs"
) -> tuple[Callable[[int, int], None] | None, Callable[[], None]]:
    """Turn the ``progress`` option into a callback and a closer.

    Shown through :mod:`neckid.utils.progress`: the reporter of the context (the command line's bar or
    lines), else a bar when standard error is a terminal.
    """
    if callable(progress) and not isinstance(progress, bool):
        return progress, lambda: None
    show = progress if isinstance(progress, bool) else n_samples >= PROGRESS_THRESHOLD
    if not show:
        return None, lambda: None
    from contextlib import ExitStack

    from neckid.utils.progress import shown_task

    stack = ExitStack()
    advance = stack.enter_context(shown_task(label, 1.0, terminal_only=True))
    shown = [0.0]

    def update(done: int, total: int) -> None:
        share = done / max(total, 1)
        advance(share - shown[0])
        shown[0] = share

    return update, stack.close


def _gamma_star(
    points: FloatArray,
    targets: FloatArray,
    grid: FloatArray,
    progress: ProgressOption,
    tree: SMTree | None = None,
    lower: FloatArray | None = None,
) -> FloatArray:
    """:func:`~neckid.models.set_membership._kernels.tree.gamma_star` with the progress option (and a tree).

    Values already computed for the same points and targets (a digest of their bytes) are taken
    from the active ``gamma_curves`` cache (:mod:`neckid.models.cache`) and only the missing ε
    are computed: a selection that fits several candidates on one regressor (the default 48-ε
    curve, each with its own given ε) walks the pairs once per new ε. γ*(ε) is exact for each ε
    whatever else is in the grid, so a cached value is the value a new pass would give.

    ``lower`` (shape of ``grid``) holds values known to be at most γ*(ε), each the slope of a
    pair of these very rows (γ*(ε) of a subset of them, :func:`knee_search`): the search starts
    its running maximum there (``floor``) and skips what cannot exceed it. The result is
    ``max(γ*(ε), lower) = γ*(ε)``, the same floats.
    """
    grid = np.asarray(grid, dtype=np.float64)
    cache = active_cache("gamma_curves")
    key = array_digest(points, targets)
    known = dict(cache.get(key) or {}) if cache is not None else {}
    out = np.empty(grid.shape)
    missing = []
    for e in range(grid.shape[0]):
        values = [known.get((c, float(grid[e, c]))) for c in range(grid.shape[1])]
        if any(v is None for v in values):
            missing.append(e)
        else:
            out[e] = values
    if missing:
        callback, close = _progress_callback(progress, points.shape[0])
        try:
            computed = gamma_star(
                points,
                targets,
                np.ascontiguousarray(grid[missing]),
                callback=callback,
                tree=tree,
                floor=None if lower is None else np.ascontiguousarray(lower[missing]),
            )
        finally:
            close()
        out[missing] = computed
        for row, e in enumerate(missing):
            for c in range(grid.shape[1]):
                known[(c, float(grid[e, c]))] = float(computed[row, c])
    if cache is not None:
        cache.put(key, known)
    return out


#: Rows of the subsample on which :func:`knee_search` locates the knee (every k-th row in time).
KNEE_SUBSAMPLE = 5_000
#: Below this many training rows the default rule walks the whole curve (it takes < 1 s there).
KNEE_SEARCH_MIN_ROWS = 20_000
#: Exact inner points that :func:`knee_search` wants after the chosen knee before it stops.
KNEE_MARGIN = 1
#: Grid values added to the exact part of the curve per step of :func:`knee_search`.
KNEE_STEP = 3
#: An inner point beyond the exact part is ruled out when its ratio on the subsample's curve,
#: times this, is below the knee's exact ratio (see :func:`knee_search`).
KNEE_SAFETY = 4.0


#: Rows of the permutation scanned at a time by :func:`_subsample_rows` (its only temporaries).
_SCAN_ROWS = 1 << 14


def _subsample_rows(tree: SMTree, size: int) -> IntArray:
    """Tree positions of every ``ceil(N / size)``-th training row, in the order of time."""
    n_rows = tree.points.shape[0]
    stride = max(1, -(-n_rows // max(int(size), 1)))
    positions = np.concatenate(
        [
            first + np.flatnonzero(tree.perm[first : first + _SCAN_ROWS] % stride == 0)
            for first in range(0, n_rows, _SCAN_ROWS)
        ]
        or [np.zeros(0, np.int64)]
    )
    return positions[np.argsort(tree.perm[positions], kind="stable")]


def knee_search(
    tree: SMTree,
    grid: FloatArray,
    progress: ProgressOption = None,
    *,
    subsample: int = KNEE_SUBSAMPLE,
    output_names: tuple[str, ...] = (),
) -> GammaCurve:
    r"""The γ*(ε) curve exact on the grid's first values, far enough to hold its knee.

    The knee rule (:func:`choose_epsilon`) takes the inner point of largest slope ratio
    ``r_e`` over the whole curve; γ*(ε) costs little at small ε (close pairs decide it, the
    kd-tree prunes the rest) and much at large ε, where many distant pairs have nearly the
    largest slope. This search:

    1. computes the whole curve on a subsample (every k-th row in time, ``subsample`` rows; its
       γ*(ε) is a lower bound of the full one, close to it where distant pairs decide), and the
       first finite ε ``f`` of the full curve (from the identical rows, all of them);
    2. computes γ*(ε) exactly, on all rows, at the grid's values ``0 .. b`` with
       ``b = f + 4 + KNEE_MARGIN``, or ``k_s + 2 + KNEE_MARGIN + 1`` if larger when the
       subsample's knee ``k_s`` stands out (its ratio ``KNEE_SAFETY`` times those past it): each
       value exact whatever else is in the grid, and so the ratios ``r_e`` at the inner points
       whose five values are all exact, the same floats as over the whole curve. Each pass
       starts its running maxima at the subsample's values (the slopes of pairs of these very
       rows, so lower bounds: the result is the same, and the search skips what cannot exceed
       them) and bounds slopes with regional linear models where that prunes
       (:mod:`~neckid.models.set_membership._kernels.slope`): past a knee, where millions of
       distant pairs have nearly the largest slope, this is what makes the exact values cheap;
    3. stops when the largest of those, ``r*`` at ``e*``, has ``KNEE_MARGIN`` exact inner
       points after it and every inner point beyond the exact part has a subsample ratio below
       ``r* / KNEE_SAFETY``; otherwise extends the exact part (one pass over the pairs) as far
       as those inner points need, by ``KNEE_STEP`` grid values at least, and goes back to 3.
       At the end of the grid the curve is whole and the choice is that of the walk.

    The inner points before ``e*`` are all exact, so ``e*`` is the walk's choice unless an
    inner point beyond the exact part has a full-data ratio above ``r*`` though its subsample
    ratio is below ``r* / KNEE_SAFETY``: a heuristic, checked against the walk on the soft-neck
    and public data sets in ``tests/test_default_epsilon.py``.

    Parameters
    ----------
    tree : SMTree
        The training tree (scaled regressors and targets ỹ).
    grid : ndarray, shape (n_eps, n_outputs)
        Ascending grid of ε per output.
    progress : bool, callable or None
        As for :class:`~neckid.models.set_membership.SetMembership`: a bar over each exact pass.
    subsample : int, default ``KNEE_SUBSAMPLE``
        Rows of the subsample (all rows when the data have fewer than twice as many).
    output_names : tuple of str

    Returns
    -------
    GammaCurve
        γ*(ε) exact at the grid's first ``b + 1`` values (``n_samples`` all rows); its
        :meth:`GammaCurve.knee` is the chosen ε.
    """
    grid = np.ascontiguousarray(grid, dtype=np.float64)
    n_eps, n_out = grid.shape
    n_rows = tree.points.shape[0]
    names = tuple(output_names) or tuple(f"y{c + 1}" for c in range(n_out))
    k = SLOPE_WINDOW
    rows = _subsample_rows(tree, subsample)
    if rows.size < 2 * k + 1 or 2 * rows.size > n_rows:
        values = _gamma_star(tree.points, tree.targets, grid, progress, tree)
        return GammaCurve(grid, values, names, n_rows)
    subtree = SMTree(
        tree.points[rows], tree.targets[rows], overwrite_points=True, overwrite_targets=True
    )
    sub = gamma_star(subtree.points, subtree.targets, grid, method="tree", tree=subtree)
    del subtree
    # γ*(ε) is infinite exactly where identical rows differ by more than 2ε (every row, not the
    # subsample's): the knee lies at least two grid steps past the last such ε.
    spread = duplicate_spread(tree.points, tree.targets)
    infinite = spread[None, :] - 2.0 * grid > 0.0
    sub = np.where(infinite, np.inf, sub)
    sub_ratio = np.full((n_eps, n_out), np.nan)  # the subsample's r_e, by grid index
    first = np.argmin(infinite, axis=0)  # the first finite ε (all rows)
    last = 0
    for c in range(n_out):
        last = max(last, int(first[c]) + 2 * k + KNEE_MARGIN)
        finite = np.flatnonzero(np.isfinite(sub[:, c]))
        if finite.size < 2 * k + 1:
            continue
        centre, ratio = _slope_ratios(grid[finite, c], sub[finite, c])
        sub_ratio[finite[centre], c] = ratio
        # Start at the subsample's knee when it stands out as the knee of the whole curve must
        # (its ratio KNEE_SAFETY times those past it); from the first finite ε otherwise, as
        # when the steep part of the curve comes from close pairs the subsample lacks.
        knee = int(np.argmax(sub_ratio[:, c] == np.nanmax(sub_ratio[:, c])))
        past = sub_ratio[knee + k + 1 :, c]
        if np.all(KNEE_SAFETY * past[np.isfinite(past)] < sub_ratio[knee, c]):
            last = max(last, knee + k + KNEE_MARGIN + 1)
    last = min(n_eps - 1, last)
    # The subsample's γ*(ε) are slopes of pairs of these rows: lower bounds that start the search.
    exact = _gamma_star(
        tree.points, tree.targets, grid[: last + 1], progress, tree, sub[: last + 1]
    )
    while last < n_eps - 1:
        needed = max(
            _knee_needs(grid[: last + 1, c], exact[:, c], sub_ratio[:, c], n_eps)
            for c in range(n_out)
        )
        if needed <= last:
            break
        more = min(n_eps - 1, max(needed, last + KNEE_STEP))
        added = _gamma_star(
            tree.points,
            tree.targets,
            grid[last + 1 : more + 1],
            progress,
            tree,
            sub[last + 1 : more + 1],
        )
        exact = np.vstack([exact, added])
        last = more
    return GammaCurve(np.array(grid[: last + 1]), exact, names, n_rows)


def _knee_needs(eps: FloatArray, exact: FloatArray, sub_ratio: FloatArray, n_eps: int) -> int:
    """How far the exact part of a curve must reach for its knee to be the whole curve's.

    See :func:`knee_search` (step 3): ``eps.size - 1`` (the last exact index) or less when the
    exact part settles the knee; otherwise the last index that the knee's exact neighbours and
    the inner points the subsample cannot rule out need (at least one more). ``sub_ratio``
    holds the subsample's ratios by grid index (NaN where it has none); ``n_eps`` is the size
    of the whole grid.
    """
    k = SLOPE_WINDOW
    last = eps.size - 1
    finite = np.flatnonzero(np.isfinite(exact))
    # γ*(ε) does not increase with ε: the infinite values come first, then the finite ones.
    if finite.size < 2 * k + 1 or finite[-1] != last or finite.size != last - finite[0] + 1:
        return last + 1
    centre, ratio = _slope_ratios(eps[finite], exact[finite])
    best = int(np.argmax(ratio))
    top = float(ratio[best])
    if not top > 0:
        return last + 1
    needed = int(finite[centre[best]]) + k + KNEE_MARGIN
    beyond = sub_ratio[last - k + 1 : n_eps - k]  # inner points with a value past the exact part
    doubtful = np.flatnonzero(~(KNEE_SAFETY * beyond < top))
    if doubtful.size:
        needed = max(needed, last - k + 1 + int(doubtful[-1]) + k)
    return min(needed, n_eps - 1)


def gamma_from_margin(gamma_star: ArrayLike, margin: float) -> FloatArray:
    """The rule γ = margin · γ*(ε), the one place it is written.

    γ*(ε) is the smallest Lipschitz constant the *training* data allow at noise bound ε, a lower
    bound of the true one; the margin (``gamma_margin``, default 1.1) leaves room for what the
    data did not explore. Used by the fit, the multi-step fit and the online update.

    Examples
    --------
    >>> gamma_from_margin([2.0, 0.5], 1.1).tolist()
    [2.2, 0.55]
    """
    return float(margin) * np.asarray(gamma_star, dtype=np.float64)
