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

from neckid._typing import FloatArray
from neckid.models.cache import active_cache, array_digest
from neckid.models.set_membership._kernels import SMTree, gamma_star

__all__ = [
    "DEFAULT_GRID_POINTS",
    "DEFAULT_GRID_SPAN",
    "GammaCurve",
    "choose_epsilon",
    "gamma_from_margin",
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
    x = eps[finite]
    y = g[finite]
    centre = np.arange(k, x.size - k)
    with np.errstate(divide="ignore", invalid="ignore"):
        before = (y[centre - k] - y[centre]) / (x[centre] - x[centre - k])
        after = (y[centre] - y[centre + k]) / (x[centre + k] - x[centre])
        ratio = np.where(after > 0, before / np.where(after > 0, after, 1.0), np.inf)
    ratio = np.where(before > 0, ratio, 0.0)
    if not np.any(ratio > 0):
        return int(finite[0])
    return int(finite[int(centre[int(np.argmax(ratio))])])


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
    progress: ProgressOption, n_samples: int
) -> tuple[Callable[[int, int], None] | None, Callable[[], None]]:
    """Turn the ``progress`` option into a callback and a closer."""
    if callable(progress) and not isinstance(progress, bool):
        return progress, lambda: None
    show = progress if isinstance(progress, bool) else n_samples >= PROGRESS_THRESHOLD
    if not show:
        return None, lambda: None
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    bar = Progress(
        TextColumn("γ*(ε) over pairs"),
        BarColumn(),
        TextColumn("{task.percentage:>5.1f}%"),
        TimeRemainingColumn(),
        transient=True,
    )
    bar.start()
    task = bar.add_task("pairs", total=1.0)

    def update(done: int, total: int) -> None:
        bar.update(task, completed=done / max(total, 1))

    return update, bar.stop


def _gamma_star(
    points: FloatArray,
    targets: FloatArray,
    grid: FloatArray,
    progress: ProgressOption,
    tree: SMTree | None = None,
) -> FloatArray:
    """:func:`~neckid.models.set_membership._kernels.tree.gamma_star` with the progress option (and a tree).

    Values already computed for the same points and targets (a digest of their bytes) are taken
    from the active ``gamma_curves`` cache (:mod:`neckid.models.cache`) and only the missing ε are computed: a selection that fits several
    candidates on one regressor (the default 48-ε curve, each with its own given ε) walks the
    pairs once per new ε. γ*(ε) is exact for each ε whatever else is in the grid, so a cached
    value is the value a new pass would give.
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
                points, targets, np.ascontiguousarray(grid[missing]), callback=callback, tree=tree
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
