"""The fitted Set Membership core that the NARX, multi-step and parallel estimators share.

An SM model is, once fitted, a kd-tree over the scaled training regressors with their targets,
the prior (noise bound ε, Lipschitz constant γ, optionally one constant per training point), the
distance's weights and the linear part. :class:`SMCore` holds exactly that, and everything the
estimators do with it lives here once: the bounds at given regressors (:meth:`SMCore.bounds`),
the compiled free run (:meth:`SMCore.free_run`) and the online update that adds rows and revises
γ (:meth:`SMCore.extended`). :func:`fit_core` builds one from a regressor matrix and the
estimator's settings (:class:`SMSettings`), choosing ε and γ by the rules of
:class:`~neckid.models.set_membership.SetMembership`.

References
----------
M. Milanese and C. Novara, "Set Membership identification of nonlinear systems", Automatica
40(6), 957-975, 2004.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import Any, NamedTuple

import numpy as np

from neckid.models.linear.arx import least_squares, linear_sum
from neckid.models.set_membership import prior
from neckid.models.set_membership._kernels import (
    SMTree,
    free_run,
    learn_constants,
    local_bounds,
)
from neckid.models.set_membership._kernels.priors import prior_bounds
from neckid.models.set_membership._kernels.tree import SERIAL_QUERIES
from neckid.models.set_membership.metric import learnt_weights
from neckid.models.set_membership.prior import (
    GammaCurve,
    _epsilon_grid,
    _gamma_star,
    gamma_from_margin,
)
from neckid.models.set_membership.scaling import term_weights
from neckid.models.set_membership.training import (
    check_duplicates,
    prior_holds,
    smallest_epsilon,
    training_tree,
    unscale,
)
from neckid.models.set_membership.update import PriorRule, revise_prior
from neckid.regressors import ResolvedLags
from neckid.utils.checks import per_output
from neckid.utils.types import BoolArray, FloatArray

__all__ = ["FitReport", "SMBounds", "SMCore", "SMSettings", "fit_core"]

logger = logging.getLogger(__name__)


class SMBounds(NamedTuple):
    """Optimal bounds and central estimate, each of shape ``(n_rows, n_outputs)``."""

    lower: FloatArray
    central: FloatArray
    upper: FloatArray


@dataclass(frozen=True)
class SMSettings:
    """The settings of an SM fit: the hyper-parameters of :class:`SetMembership` but ``lags``.

    See :class:`~neckid.models.set_membership.SetMembership` for each one's meaning.
    """

    epsilon: Any = None
    gamma: Any = None
    gamma_margin: float = 1.1
    scaling: Any = "std"
    linear_part: bool = False
    epsilons: Any = None
    progress: Any = None
    input_weight: float = 1.0
    lipschitz: str = "global"
    local_neighbours: int = 10

    @classmethod
    def of(cls, estimator: Any) -> SMSettings:
        """The settings of an estimator that has these hyper-parameters (by name)."""
        return cls(**{f.name: getattr(estimator, f.name) for f in fields(cls)})


@dataclass(frozen=True)
class FitReport:
    """What the choice of the prior found: γ*(ε) at the chosen ε, the curve, the check."""

    gamma_star: FloatArray
    curve: GammaCurve | None
    prior_valid: BoolArray


@dataclass(eq=False)
class SMCore:
    """A fitted SM map: tree, prior, distance and linear part; the bounds and free run on them.

    Attributes
    ----------
    tree : SMTree
        The scaled training regressors (reordered) with the targets ỹ (measured outputs minus
        the linear part).
    weights : ndarray, shape (n_terms,)
        Scaled regressor = regressor · weights.
    coef, intercept : ndarray, shapes (n_terms, n_outputs) and (n_outputs,)
        The linear part (zeros without one).
    epsilon, gamma : ndarray, shape (n_outputs,)
        Noise bound ε (output units) and Lipschitz constant γ (in the weighted distance).
    outputs : ndarray or None
        The measured training outputs in tree order when there is a linear part (else they are
        the tree's targets).
    point_gamma : ndarray or None
        One constant per training point and output (local Lipschitz constants), tree order.
    local_neighbours : int
        Training points the local bounds combine.
    """

    tree: SMTree
    weights: FloatArray
    coef: FloatArray
    intercept: FloatArray
    epsilon: FloatArray
    gamma: FloatArray
    outputs: FloatArray | None = None
    point_gamma: FloatArray | None = None
    local_neighbours: int = field(default=10)

    @property
    def n_samples(self) -> int:
        """Number of training regressors."""
        return int(self.tree.points.shape[0])

    @property
    def x_train(self) -> FloatArray:
        """The training regressors (unscaled) in tree order, recovered from the tree's points."""
        return unscale(self.tree.points, self.weights)

    @property
    def y_train(self) -> FloatArray:
        """The measured training outputs in tree order (the targets without a linear part)."""
        return self.tree.targets if self.outputs is None else self.outputs

    def bounds(self, x: FloatArray) -> SMBounds:
        """Lower bound, central estimate and upper bound of ``f_o`` at raw regressors ``x``.

        ``x`` is ``(n_rows, n_terms)``, contiguous float64, already checked. The linear part is
        summed as the compiled free run does (intercept first, then term by term), so that a
        simulator stepping these bounds and :meth:`free_run` agree to the last bit.
        """
        linear = linear_sum(x, self.coef, self.intercept)
        scaled = x * self.weights
        if scaled.shape[0] >= SERIAL_QUERIES:
            # The screened walk of the cross-validation, bit for bit the two below and faster
            # (most of all on a tree split in its principal frame: docs/benchmarks/sm_speed.md).
            constants = (
                self.point_gamma[None]
                if self.point_gamma is not None
                else np.empty((0, *self.tree.targets.shape))
            )
            low, high = prior_bounds(
                self.tree,
                scaled,
                self.epsilon[None, :],
                self.gamma[None, :],
                constants,
                np.array([0 if constants.shape[0] else -1]),
                self.local_neighbours,
            )
            lower, upper = low[:, 0], high[:, 0]
        elif self.point_gamma is not None:
            lower, upper, _ = local_bounds(
                self.tree,
                self.point_gamma,
                scaled,
                self.epsilon,
                self.gamma,
                self.local_neighbours,
            )
        else:
            lower, upper = self.tree.bounds(scaled, self.epsilon, self.gamma)
        return SMBounds(linear + lower, linear + 0.5 * (lower + upper), linear + upper)

    def free_run(
        self, u: FloatArray, y0: FloatArray, lags: ResolvedLags
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The compiled free run with global constants: ``(y, lower, upper)``, time down the rows.

        ``y0`` holds the first ``lags.max_lag`` outputs (the initial conditions).
        """
        return free_run(
            self.tree,
            u,
            y0,
            lags.source,
            lags.channel,
            lags.lag,
            lags.max_lag,
            self.weights,
            self.coef,
            self.intercept,
            self.epsilon,
            self.gamma,
        )

    def extended(
        self,
        x_new: FloatArray,
        y_new: FloatArray,
        *,
        settings: SMSettings,
        gamma_star: FloatArray,
        prior: PriorRule,
        output_names: Sequence[str],
    ) -> tuple[SMCore, FitReport]:
        """A new core with rows added: same ε and weights, γ revised by the ``prior`` rule.

        The linear part, if any, is refitted on all rows; local constants (when this core has
        them) are learned again. Nothing here changes ``self``.
        """
        n_old = self.n_samples
        x = np.empty((n_old + x_new.shape[0], x_new.shape[1]))
        unscale(self.tree.points, self.weights, out=x[:n_old])
        x[n_old:] = x_new
        y = np.ascontiguousarray(np.vstack([self.y_train, y_new]))
        coef, intercept = self.coef, self.intercept
        linear_part = bool(settings.linear_part)
        if linear_part:
            coef, intercept = least_squares(x, y, fit_intercept=True)
        tree, outputs = training_tree(x, y, self.weights, coef, intercept, linear_part)
        gamma, star, valid = revise_prior(
            tree,
            np.flatnonzero(tree.perm >= n_old),
            self.epsilon,
            self.gamma,
            prior_holds(tree, self.epsilon, self.gamma)[0],
            gamma_star,
            linear_part,
            prior,
            float(settings.gamma_margin),
            output_names,
        )
        constants = None
        if self.point_gamma is not None:
            constants = learn_constants(tree, self.epsilon, gamma, float(settings.gamma_margin))
        core = SMCore(
            tree,
            self.weights,
            np.ascontiguousarray(coef),
            intercept,
            self.epsilon,
            gamma,
            outputs,
            constants,
            self.local_neighbours,
        )
        return core, FitReport(star, None, valid)


def _checked_prior(
    settings: SMSettings, y: FloatArray, names: Sequence[str]
) -> tuple[FloatArray | None, FloatArray | None]:
    """The given ε and γ as one value per output (None where not given), after the checks."""
    n_out = y.shape[1]
    epsilon = None if settings.epsilon is None else per_output(settings.epsilon, n_out, "epsilon")
    if epsilon is not None and np.any(epsilon < 0):
        raise ValueError(f"epsilon must be >= 0 (a noise bound); got {epsilon.tolist()}")
    gamma = None if settings.gamma is None else per_output(settings.gamma, n_out, "gamma")
    if gamma is not None and np.any(gamma <= 0):
        raise ValueError(f"gamma must be > 0 (a Lipschitz constant); got {gamma.tolist()}")
    constant = np.flatnonzero(np.ptp(y, axis=0) == 0)
    if constant.size:
        raise ValueError(
            f"output {names[int(constant[0])]!r} is constant over the training data; there is"
            " nothing to identify"
        )
    return epsilon, gamma


def _gamma_star_at(curve: GammaCurve | None, epsilon: FloatArray) -> FloatArray:
    """γ*(ε) read off the curve at the chosen ε (NaN where the curve has no such point)."""
    found = np.full(epsilon.shape[0], np.nan)
    if curve is not None:
        for c in range(epsilon.shape[0]):
            hit = np.flatnonzero(curve.epsilons[:, c] == epsilon[c])
            if hit.size:
                found[c] = curve.gamma[hit[0], c]
    return found


def _choose_prior(
    tree: SMTree,
    epsilon: FloatArray | None,
    gamma: FloatArray | None,
    settings: SMSettings,
    names: Sequence[str],
) -> tuple[FloatArray, FloatArray, FitReport]:
    """ε and γ by the estimator's rules, with γ*(ε), the curve and the prior's check."""
    n_rows = tree.points.shape[0]
    curve: GammaCurve | None = None
    if epsilon is not None:
        check_duplicates(tree, epsilon, names)
    if gamma is None or settings.epsilons is not None:
        grid = _epsilon_grid(settings.epsilons, tree.targets)
        if epsilon is not None:
            grid = np.sort(np.vstack([grid, epsilon[None, :]]), axis=0)
        logger.debug(
            "gamma*(eps) over %d pairs, %d eps values", n_rows * (n_rows - 1) // 2, grid.shape[0]
        )
        if epsilon is None and settings.epsilons is None and n_rows >= prior.KNEE_SEARCH_MIN_ROWS:
            # The default rule: the curve exact only as far as its knee needs (knee_search).
            curve = prior.knee_search(tree, grid, settings.progress, output_names=tuple(names))
        else:
            values = _gamma_star(tree.points, tree.targets, grid, settings.progress, tree)
            curve = GammaCurve(grid, values, tuple(names), n_rows)
    # The prior holds by construction when γ or ε is derived from the other; only a (ε, γ)
    # given together is checked (γ >= γ*(ε), by branch and bound from γ).
    valid = np.ones(len(names), dtype=bool)
    check = epsilon is not None and gamma is not None
    if epsilon is None:
        if gamma is not None:
            epsilon = smallest_epsilon(tree, gamma)
        elif curve is not None:
            epsilon = curve.knee()
            check_duplicates(tree, epsilon, names)
        else:  # pragma: no cover - the curve is computed whenever gamma is None
            raise RuntimeError("internal error: no way to choose epsilon")
    gamma_star_at = _gamma_star_at(curve, epsilon)
    if gamma is None:
        gamma = gamma_from_margin(gamma_star_at, float(settings.gamma_margin))
        flat = np.flatnonzero(~(gamma > 0))
        if flat.size:
            c = int(flat[0])
            raise ValueError(
                f"γ*(ε) is {gamma_star_at[c]!r} for output {names[c]!r} at epsilon ="
                f" {epsilon[c]:.6g}: every pair of outputs differs by at most 2ε, so any"
                " constant fits; use a smaller epsilon or give gamma"
            )
    if check:
        valid, star = prior_holds(tree, epsilon, gamma)
        if not valid.all():
            c = int(np.flatnonzero(~valid)[0])
            raise ValueError(
                f"gamma = {gamma[c]:.6g} is below gamma*(epsilon) = {star[c]:.6g} for output"
                f" {names[c]!r} at epsilon = {epsilon[c]:.6g}: no Lipschitz function with"
                " that constant fits the data to within ±epsilon (the prior is invalid); use"
                f" gamma >= {star[c]:.6g} or a larger epsilon"
            )
    return epsilon, gamma, FitReport(gamma_star_at, curve, valid)


def fit_core(
    x: FloatArray,
    y: FloatArray,
    lags: ResolvedLags,
    settings: SMSettings,
    *,
    linear: tuple[FloatArray, FloatArray] | None = None,
    base_weights: FloatArray | None = None,
) -> tuple[SMCore, FitReport]:
    """Fit the SM core on regressor rows ``x`` (which it takes over) and targets ``y``.

    Parameters
    ----------
    x : ndarray, shape (n_rows, n_terms)
        Raw regressors; they become the kd-tree's points, scaled and reordered in place (the
        one copy of the training regressors the core keeps): the caller must not use ``x`` after.
    y : ndarray, shape (n_rows, n_outputs)
        Measured outputs.
    lags : ResolvedLags
        The regressor's terms (names, input or output, lag).
    settings : SMSettings
        The estimator's settings.
    linear : (coef, intercept), optional
        The least-squares linear ARX on ``(x, y)``, when the caller has computed it already
        (used only with ``settings.linear_part``).
    base_weights : ndarray, shape (n_terms,), optional
        The distance's weights before any learning (``scaling`` and ``input_weight``), when the
        caller has computed them already.

    Returns
    -------
    (SMCore, FitReport)

    Raises
    ------
    ValueError
        Fewer than 2 rows, a constant output, a bad ε or γ, or a given (ε, γ) that the data
        falsify; the message names the output and says what to do.
    """
    n_rows, n_terms = x.shape
    n_out = y.shape[1]
    names = lags.output_names
    if n_rows < 2:
        raise ValueError(
            f"SetMembership needs at least 2 training regressors; the data give {n_rows}"
            f" (lags up to {lags.max_lag}); use a longer record"
        )
    epsilon, gamma = _checked_prior(settings, y, names)
    if base_weights is None:
        base_weights = term_weights(settings.scaling, settings.input_weight, x, lags)
    if not settings.linear_part:
        coef, intercept = np.zeros((n_terms, n_out)), np.zeros(n_out)
    elif linear is not None:
        coef, intercept = linear
    else:
        coef, intercept = least_squares(x, y, fit_intercept=True)
    weights = learnt_weights(settings.scaling, base_weights, x, y - (x @ coef + intercept))
    # From here on x is the tree's points: scaled and reordered in place (one copy).
    tree, outputs = training_tree(x, y, weights, coef, intercept, bool(settings.linear_part))
    del x
    epsilon, gamma, report = _choose_prior(tree, epsilon, gamma, settings, names)
    local = settings.lipschitz == "local"
    core = SMCore(
        tree,
        weights,
        np.ascontiguousarray(coef),
        np.asarray(intercept, dtype=np.float64),
        np.asarray(epsilon, dtype=np.float64),
        np.asarray(gamma, dtype=np.float64),
        outputs,
        None,
        int(settings.local_neighbours),
    )
    if local:
        core.point_gamma = learn_constants(
            tree, core.epsilon, core.gamma, float(settings.gamma_margin)
        )
    logger.info(
        "SetMembership fitted on %d regressors: epsilon=%s gamma=%s",
        n_rows,
        core.epsilon.tolist(),
        core.gamma.tolist(),
    )
    return core, report
