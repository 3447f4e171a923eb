r"""One horizon of a multi-step Set Membership model: its rows, linear part, ε and γ, fitted core.

:class:`~neckid.models.set_membership.multistep.MultiStepSetMembership` fits one Set Membership
predictor per horizon ``k`` on the k-step regressor; the cross-validation that chooses its
settings (:mod:`.multistep_selection`) evaluates the same predictor on each fold. Both go through
the functions here, so that a setting scored in a fold is the model a fit with that setting on
the fold's training experiments would give, bit for bit:

- :func:`horizon_lags`: the k-step regressor that follows from the one-step one;
- :func:`stack_rows`: the training rows of several experiments, as an estimator stacks them;
- :func:`linear_part`: the least-squares direct k-step predictor and its residual's robust scale;
- :func:`epsilon_floor` and :func:`rule_epsilon`: ``ε_k = factor · 1.4826 · MAD(r_k)``, raised
  to half the widest spread of the targets at identical regressors;
- :func:`prior_grid`: ``γ_k = margin · γ*(ε_k)``, or ``margin · γ*(f ε_k)`` at the smallest
  fraction ``f`` of :data:`FALLBACK_FRACTIONS` with a finite positive value where γ*(ε_k) = 0,
  for a whole grid of ε in one walk per training point, with each point's steepest slope
  (:func:`local_constants`);
- :func:`horizon_rows` and :func:`fit_horizon`: the rows and linear part of one horizon (no
  setting needed), then its fitted :class:`~neckid.SetMembership`.

References
----------
M. Milanese and C. Novara, "Set membership identification of nonlinear systems",
Automatica 40(6):957-975, 2004.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from neckid.data.iodata import IOData
from neckid.models.linear.arx import least_squares
from neckid.models.set_membership._kernels import SMTree
from neckid.models.set_membership._kernels.priors import point_gamma_grid
from neckid.models.set_membership.core import FitReport, SMCore, SMSettings, _checked_prior
from neckid.models.set_membership.narx import SetMembership
from neckid.models.set_membership.prior import (
    ProgressOption,
    _progress_callback,
    gamma_from_margin,
)
from neckid.models.set_membership.scaling import term_weights
from neckid.models.set_membership.training import (
    check_duplicates,
    duplicate_spread,
    training_tree,
)
from neckid.regressors import Lags, ResolvedLags
from neckid.utils.types import FloatArray

__all__ = [
    "FALLBACK_FRACTIONS",
    "MAD_TO_STD",
    "HorizonRows",
    "HorizonSetting",
    "LinearPart",
    "PriorGrid",
    "epsilon_floor",
    "fit_horizon",
    "horizon_lags",
    "horizon_rows",
    "linear_part",
    "local_constants",
    "prior_grid",
    "robust_scale",
    "rule_epsilon",
    "stack_rows",
]

#: Fractions of ε_k at which γ* is tried, smallest first, where γ*(ε_k) = 0 (see :func:`gamma_rule`).
FALLBACK_FRACTIONS = (0.5, 0.75, 0.9, 0.99)
#: 1.4826 · MAD estimates the standard deviation of Gaussian data (1 / Φ⁻¹(3/4)).
MAD_TO_STD = 1.482602218505602


@dataclass(frozen=True)
class HorizonSetting:
    """The settings of one horizon's predictor.

    Attributes
    ----------
    epsilon_factor : float or None
        ε_k = ``epsilon_factor`` × the robust scale of the k-step residual; None when ε was given.
    input_weight : float
        Factor on the distance weight of every input term.
    lipschitz : {"global", "local"}
        One Lipschitz constant, or one per training point.
    """

    epsilon_factor: float | None
    input_weight: float
    lipschitz: str

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (``epsilon_factor``, ``input_weight``, ``lipschitz``)."""
        factor = None if self.epsilon_factor is None else float(self.epsilon_factor)
        return {
            "epsilon_factor": factor,
            "input_weight": float(self.input_weight),
            "lipschitz": str(self.lipschitz),
        }

    @classmethod
    def from_json(cls, value: Any) -> HorizonSetting:
        """The setting :meth:`to_json` wrote."""
        factor = value["epsilon_factor"]
        return cls(
            None if factor is None else float(factor),
            float(value["input_weight"]),
            str(value["lipschitz"]),
        )


def _numbers(values: FloatArray) -> str:
    return ", ".join(f"{v:.4g}" for v in np.ravel(values))


def robust_scale(residual: Any) -> FloatArray:
    r"""Robust scale of each column: ``1.4826 · median(|r − median(r)|)`` (the normalised MAD).

    Parameters
    ----------
    residual : array_like, shape (n_samples, n_outputs)

    Returns
    -------
    ndarray, shape (n_outputs,)
        Equal to the standard deviation for Gaussian data; a few large errors barely move it.

    Examples
    --------
    >>> robust_scale([[1.0], [2.0], [3.0], [4.0], [100.0]])
    array([1.482602...])
    """
    r = np.asarray(residual, dtype=np.float64)
    centre = np.median(r, axis=0)
    return np.asarray(MAD_TO_STD * np.median(np.abs(r - centre), axis=0), dtype=np.float64)


def horizon_lags(lags: ResolvedLags, steps: int) -> Lags:
    r"""The regressor of the direct ``steps``-ahead predictor built from a one-step regressor.

    With the one-step regressor holding ``y(s − l)`` for the output lags ``l`` and ``u(s − l)``
    for the input lags ``l``, the ``k``-step predictor of ``y(s)`` made at time ``t = s − k``
    holds

    - the outputs the one-step regressor of ``y(t + 1)`` holds: lags ``l + k − 1`` (so lag ``k``
      is ``y(t)``, the last measured output), and
    - every input that the ``k`` one-step regressors of ``y(t + 1) … y(t + k)`` hold: lags
      ``l + j`` for ``j = 0 … k − 1`` (the past inputs and the future ones up to ``t + k − min l``).

    Its largest lag is ``max_lag + k − 1``. For ``k = 1`` it is the one-step regressor.

    Parameters
    ----------
    lags : ResolvedLags
        The one-step regressor, bound to channels.
    steps : int
        The horizon ``k >= 1``, in samples.

    Returns
    -------
    Lags
        Per channel, by name.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> data = IOData(np.zeros(20), np.arange(20.0), ts=0.02)
    >>> horizon_lags(Lags.arx(2, 2).resolve(data), 3)
    Lags(outputs={'y': [3, 4]}, inputs={'u': [1, 2, 3, 4]})
    """
    outputs: dict[str, list[int]] = {n: [] for n in lags.output_names}
    inputs: dict[str, set[int]] = {n: set() for n in lags.input_names}
    for source, channel, lag in zip(lags.source, lags.channel, lags.lag, strict=True):
        if source == 0:
            outputs[lags.output_names[channel]].append(int(lag) + steps - 1)
        elif lags.input_names[channel] in lags.conditions:  # constant: lag 0 says it all
            inputs[lags.input_names[channel]].add(0)
        else:
            inputs[lags.input_names[channel]].update(range(int(lag), int(lag) + steps))
    return Lags(
        outputs=outputs,
        inputs={n: sorted(v) for n, v in inputs.items()},
        conditions=lags.conditions,
    )


def stack_rows(parts: Sequence[tuple[FloatArray, FloatArray]]) -> tuple[FloatArray, FloatArray]:
    """The regressor rows and targets of several experiments, one below the other.

    As :meth:`~neckid.models.base.NarxModel.fit` stacks them: one experiment's rows are taken as
    they are (the targets copied), several are stacked in order.
    """
    if len(parts) == 1:
        return parts[0][0], parts[0][1].copy()
    return np.vstack([p[0] for p in parts]), np.vstack([p[1] for p in parts])


class LinearPart(NamedTuple):
    """The least-squares direct predictor on the k-step regressor and what it leaves."""

    coef: FloatArray
    intercept: FloatArray
    residual: FloatArray
    scale: FloatArray


def linear_part(x: FloatArray, y: FloatArray) -> LinearPart:
    """Least squares with intercept on ``(x, y)``, its residual and the residual's robust scale."""
    coef, intercept = least_squares(x, y, fit_intercept=True)
    residual = y - (x @ coef + intercept)
    return LinearPart(coef, intercept, residual, robust_scale(residual))


def epsilon_floor(points: FloatArray, target: FloatArray) -> FloatArray:
    """Half the widest spread of ``target`` at identical rows of ``points``, a relative 1e-9 above.

    No Lipschitz function fits a smaller ε. The margin covers the estimator recomputing the
    targets from the scaled points, which can move them by an ulp.
    """
    return 0.5 * duplicate_spread(points, target) * (1.0 + 1e-9)


def rule_epsilon(factor: float, scale: FloatArray, floor: FloatArray) -> FloatArray:
    """``max(factor · scale, floor)`` per output."""
    return np.maximum(float(factor) * scale, floor)


class PriorGrid(NamedTuple):
    """γ_k at every ε of a grid, with γ*(ε) and each training point's steepest slope."""

    gamma: FloatArray  # (n_eps, n_outputs), NaN where no constant can be learned
    star: FloatArray  # (n_eps, n_outputs)
    steepest: FloatArray  # (n_eps, n_points, n_outputs), tree order


def _steepest(
    tree: SMTree, epsilons: FloatArray, progress: ProgressOption
) -> tuple[FloatArray, FloatArray]:
    """Every point's steepest slope at every ε (any order) and γ*(ε), their maximum."""
    order = np.argsort(epsilons, axis=0, kind="stable")
    ascending = np.take_along_axis(epsilons, order, axis=0)
    callback, close = _progress_callback(progress, tree.points.shape[0])
    try:
        slopes = point_gamma_grid(tree, ascending, callback)
    finally:
        close()
    steepest = np.empty_like(slopes)
    for c in range(epsilons.shape[1]):
        steepest[order[:, c], :, c] = slopes[:, :, c]
    return steepest, steepest.max(axis=1, initial=0.0)


def prior_grid(
    tree: SMTree, epsilons: FloatArray, margin: float, progress: ProgressOption = False
) -> PriorGrid:
    """γ_k for every ε of a grid: ``margin · γ*(ε)``, or at a fraction of ε where γ*(ε) = 0.

    Parameters
    ----------
    tree : SMTree
        The training tree (scaled k-step regressors and the targets of the Set Membership map).
    epsilons : ndarray, shape (n_eps, n_outputs)
    margin : float
        ``gamma_margin`` (>= 1).
    progress : bool or callable
        Progress of the pass over the points.

    Returns
    -------
    PriorGrid

    Notes
    -----
    One walk per training point gives its steepest slope ``γ_i(ε)`` at every ε
    (:func:`~neckid.models.set_membership._kernels.priors.point_gamma_grid`): the local
    constants, and γ*(ε) = max_i γ_i(ε), since both ends of every pair carry its slope. Where
    γ*(ε) = 0 the fallback is γ*(f ε) at the smallest f of :data:`FALLBACK_FRACTIONS` for which
    it is finite and positive (identical regressors can make it infinite below ε).
    """
    steepest, star = _steepest(tree, epsilons, progress)
    chosen = np.where(star > 0, star, np.nan)
    flat = np.flatnonzero(np.any(~(star > 0), axis=1))
    if flat.size:
        fractions = np.asarray(FALLBACK_FRACTIONS)
        trial = (fractions[None, :, None] * epsilons[flat][:, None, :]).reshape(-1, star.shape[1])
        tried = _steepest(tree, trial, False)[1].reshape(flat.size, fractions.size, -1)
        usable = np.where(np.isfinite(tried) & (tried > 0), tried, np.nan)
        first = np.argmax(~np.isnan(usable), axis=1)
        fallback = np.take_along_axis(usable, first[:, None, :], axis=1)[:, 0, :]
        chosen[flat] = np.where(star[flat] > 0, star[flat], fallback)
    gamma = gamma_from_margin(chosen, margin)
    return PriorGrid(np.where(gamma > 0, gamma, np.nan), star, steepest)


def local_constants(steepest: FloatArray, gamma: FloatArray, margin: float) -> FloatArray:
    """Each point's constant ``min(margin · γ_i, γ)``, as :func:`learn_constants` makes them.

    Where every ``γ_i`` is 0 (γ*(ε) = 0) every point gets ``γ``.
    """
    constants = np.minimum(margin * steepest, gamma)
    flat = steepest.max(axis=0, initial=0.0) == 0
    constants[:, flat] = np.asarray(gamma, dtype=np.float64)[flat]
    return np.ascontiguousarray(constants)


class HorizonRows(NamedTuple):
    """One horizon's training rows and linear part, before any setting is applied."""

    model: SetMembership  # channels, lags and ranges set (``_prepare_fit``), not fitted
    x: FloatArray
    y: FloatArray
    linear: LinearPart


def horizon_rows(experiments: Sequence[IOData], lags: Lags, options: SMSettings) -> HorizonRows:
    """The k-step rows of the training experiments and their least-squares linear part.

    Nothing here depends on the setting, and nothing runs a compiled parallel kernel: a caller
    can compute every horizon's rows before the kernels (NumPy's threaded BLAS is slow while
    numba's OpenMP threads are still spinning after a kernel).
    """
    model = SetMembership(
        lags,
        scaling=options.scaling,
        linear_part=bool(options.linear_part),
        local_neighbours=int(options.local_neighbours),
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # reported once, by fit_horizon
        x, y = model._prepare_fit(experiments)
    return HorizonRows(model, x, y, linear_part(x, y))


def fit_horizon(
    rows: HorizonRows,
    setting: HorizonSetting,
    *,
    epsilon: FloatArray | None,
    options: SMSettings,
    steps: int,
) -> tuple[SetMembership, FloatArray, FloatArray]:
    """The fitted Set Membership predictor of one horizon, its residual scale and γ*(ε_k).

    Parameters
    ----------
    rows : HorizonRows
        The horizon's training rows (:func:`horizon_rows`); its ``x`` becomes the tree's points.
    setting : HorizonSetting
        ε factor (unused when ``epsilon`` is given), input weight and Lipschitz form.
    epsilon : ndarray, shape (n_outputs,), optional
        A given ε_k.
    options : SMSettings
        ``scaling``, ``linear_part``, ``gamma_margin``, ``local_neighbours`` and ``progress``
        of the multi-step estimator (its ε, γ and the setting's fields are ignored).
    steps : int
        The horizon ``k`` (for messages).

    Raises
    ------
    ValueError
        Where γ*(ε_k) = 0 and no fraction of ε_k gives a finite positive γ*, a constant output,
        identical regressors whose outputs differ by more than twice a given ε.
    """
    model, x, y, linear = rows
    model.set_params(input_weight=float(setting.input_weight), lipschitz=setting.lipschitz)
    target = np.ascontiguousarray(linear.residual if options.linear_part else y)
    # The estimator's own distance (it warns about constant terms here, once).
    weights = term_weights(options.scaling, setting.input_weight, x, model.lags_)
    points = np.ascontiguousarray(x * weights)
    if epsilon is None:
        factor = float(setting.epsilon_factor)  # type: ignore[arg-type]
        floor = epsilon_floor(points, target)
        epsilon = rule_epsilon(factor, linear.scale, floor)
        if np.any(floor > factor * linear.scale):
            warnings.warn(
                f"horizon {steps}: epsilon_factor x the residual scale ="
                f" {_numbers(factor * linear.scale)} is below half the spread of the outputs at"
                f" identical regressors, {_numbers(floor)}; epsilon is raised to it (no Lipschitz"
                " function fits a smaller one)",
                UserWarning,
                stacklevel=3,
            )
    names = model.output_names_
    _checked_prior(SMSettings(epsilon=epsilon.tolist()), y, names)  # a constant output
    # From here on x is the tree's points: scaled and reordered in place (one copy).
    # Split in the principal frame: its steepest slopes and predict_ahead's bounds are screened
    # walks, the same floats on fewer points.
    tree, outputs = training_tree(
        x, y, weights, linear.coef, linear.intercept, bool(options.linear_part), frame=True
    )
    check_duplicates(tree, epsilon, names)
    priors = prior_grid(tree, epsilon[None, :], float(options.gamma_margin), options.progress)
    gamma = priors.gamma[0]
    if np.any(np.isnan(gamma)):
        c = int(np.flatnonzero(np.isnan(gamma))[0])
        raise ValueError(
            f"output {names[c]!r}, horizon {steps}: γ*(ε) = 0 at epsilon ="
            f" {epsilon[c]:.6g} (a constant fits every training target to within ±ε) and no"
            " ε between ε/2 and ε gives a finite positive γ*, so no Lipschitz constant can"
            " be learned; give a smaller epsilon"
        )
    constants = None
    if setting.lipschitz == "local":
        constants = local_constants(priors.steepest[0], gamma, float(options.gamma_margin))
    core = SMCore(
        tree,
        weights,
        np.ascontiguousarray(linear.coef),
        np.asarray(linear.intercept, dtype=np.float64),
        np.asarray(epsilon, dtype=np.float64),
        gamma,
        outputs,
        constants,
        int(options.local_neighbours),
    )
    # The prior holds by construction (γ >= γ*(ε) on these very targets): nothing to check.
    model.set_params(epsilon=epsilon.tolist(), gamma=gamma.tolist())
    model._set_core(core, FitReport(np.full(len(names), np.nan), None, np.ones(len(names), bool)))
    model._mark_fitted()
    return model, linear.scale, priors.star[0]
