"""Set Membership (SM) identification of NARX models (Milanese & Novara, 2004), exact and fast.

The data are ``ỹ_k = f_o(w̃_k) + e_k`` with ``|e_k| <= ε`` and ``f_o`` Lipschitz with constant
``γ`` on the (scaled) regressor space. Every function consistent with these assumptions and the
data lies between the optimal bounds ``f_l <= f <= f_u``; their mean ``f_c`` is the optimal
estimate. See :class:`SetMembership` for the equations, the choice of ε and γ and the references.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import (
    ModelResult,
    NarxModel,
    NarxSimulator,
    check_is_fitted,
    stepped_run,
)
from neckid.models.facts import SetMembershipPrior
from neckid.models.linear.arx import least_squares
from neckid.models.online import extend_training_ranges, update_experiments, update_rows
from neckid.models.set_membership._kernels import (
    SMTree,
    check_constants,
)
from neckid.models.set_membership.core import FitReport, SMBounds, SMCore, SMSettings, fit_core
from neckid.models.set_membership.metric import learnt_weights
from neckid.models.set_membership.prior import (
    GammaCurve,
    ProgressOption,
    _epsilon_grid,
    _gamma_star,
    choose_epsilon,
)
from neckid.models.set_membership.scaling import term_weights
from neckid.models.set_membership.training import (
    training_tree,
)
from neckid.models.set_membership.update import Invalidation, PriorRule
from neckid.regressors import Lags
from neckid.utils.checks import Interval, Options, check_finite
from neckid.utils.types import FloatArray

__all__ = [
    "DEFAULT_GAMMA_MARGIN",
    "GammaCurve",
    "Invalidation",
    "SMBounds",
    "SetMembership",
    "SetMembershipSimulator",
    "choose_epsilon",
    "gamma_curve",
]

logger = logging.getLogger(__name__)


#: Default ratio γ / γ*(ε). γ*(ε) is the smallest constant consistent with the *training* data,
#: a lower bound of the true one; 10 % above it leaves room for what the data did not explore.
DEFAULT_GAMMA_MARGIN = 1.1


# ====================================================================================== results
# ====================================================================================== helpers
# ====================================================================================== estimator
class SetMembership(NarxModel):
    r"""Nonlinear Set Membership identification of a NARX model (Milanese & Novara, 2004).

    For each output, ``y(t) = f_o(w(t)) + e(t)`` with ``w(t)`` the regressor of ``lags``,
    ``|e(t)| <= ε`` and ``f_o`` Lipschitz with constant γ in the scaled Euclidean norm. From the
    training pairs ``(w̃_k, ỹ_k)`` the model gives, at any regressor ``w``, the tightest bounds
    on ``f_o(w)`` and the optimal (central) estimate between them.

    Parameters
    ----------
    lags : Lags
        The regressor, e.g. ``Lags(outputs=3, inputs=[8, 9, 10])`` (the seed paper's).
    epsilon : float or array_like of shape (n_outputs,), optional
        Noise bound ε >= 0 per output, in output units (e.g. the sensor's known accuracy). Default:
        chosen from the γ*(ε) curve (see Notes), or, if ``gamma`` is given, the smallest ε
        consistent with it.
    gamma : float or array_like of shape (n_outputs,), optional
        Lipschitz constant γ > 0 per output (output units per unit of scaled regressor). Default:
        ``gamma_margin * γ*(ε)``. A γ below γ*(ε) is refused (the prior would be invalid).
    gamma_margin : float, default 1.1
        Ratio γ / γ*(ε) >= 1 when γ is not given (see :data:`DEFAULT_GAMMA_MARGIN`).
    scaling : {"std", "gradient", "none"} or array_like of shape (n_terms,), default "std"
        Weights of the regressor components in the distance: ``1 / std`` of each component over
        the training regressors; that times each component's relative slope of what SM
        interpolates (``"gradient"``, a metric learnt from the training data, see
        :mod:`neckid.models.set_membership.metric`); all ones; or user weights (> 0).
    input_weight : float, default 1.0
        Factor (> 0) on the weight of every *input* term, on top of ``scaling``. Below 1 the
        distance, and so the SM part, depends mostly on the past outputs: with a linear part, a
        residual nonlinearity of the outputs alone (a cubic stiffness) is then interpolated in
        the output directions, where it varies, instead of being diluted over the input lags.
    linear_part : bool, default False
        Fit a linear ARX on the same regressor by least squares first and identify its residual
        with SM; predictions and bounds are the linear part plus the residual's (what makes SM
        extrapolate outside the data).
    epsilons : array_like, shape (n_eps,) or (n_eps, n_outputs), optional
        Grid of ε for :attr:`gamma_curve_`. Default: 0 and 47 geometrically spaced values in
        ``[1e-4, 0.25] * ptp(ỹ)`` per output. A given ``epsilon`` is added to the grid. The
        curve is an O(N²) pass: when ``gamma`` is given it is only computed if ``epsilons`` is.
    progress : bool or callable, optional
        Progress bar (rich) for the γ*(ε) pass: None shows it from 20,000 training regressors;
        a callable gets ``(pairs_done, pairs_total)`` between blocks.
    lipschitz : {"global", "local"}, default "global"
        One Lipschitz constant for the whole regressor space (Milanese & Novara), or one per
        training point (see Notes, *Local constants*): the bounds then widen slowly where the
        data are smooth and fast only near the steep pairs.
    local_neighbours : int, default 10
        With ``lipschitz="local"``: the constant at a query is the largest of its
        ``local_neighbours`` nearest training points' constants.

    Attributes
    ----------
    epsilon_ : ndarray, shape (n_outputs,)
        The noise bound used, per output.
    gamma_ : ndarray, shape (n_outputs,)
        The Lipschitz constant used, per output.
    gamma_star_ : ndarray, shape (n_outputs,)
        γ*(ε_) where it was computed (from the curve), NaN otherwise.
    gamma_curve_ : GammaCurve or None
        The ε grid and γ*(ε) (None when γ was given and ``epsilons`` was not).
    prior_valid_ : ndarray of bool, shape (n_outputs,)
        Whether the data are consistent with (ε, γ): ``f_u(w̃_k) >= ỹ_k − ε`` for every
        training k, i.e. γ >= γ*(ε) (checked by branch and bound when both are given, true by
        construction when one is derived from the other); fit raises when it fails, so after
        fit it holds True (``partial_fit`` with ``prior="keep"`` may leave it False).
    point_gamma_ : ndarray, shape (n_samples, n_outputs) or None
        With ``lipschitz="local"``, each training point's constant
        ``min(gamma_margin · γ_i, γ)`` in the tree's order (the order of a model file's
        ``x_train``); None with one global constant. ``local_neighbours_`` is the number of
        neighbours fitted with (``set_params`` after ``fit`` changes neither).
    weights_ : ndarray, shape (n_terms,)
        Scaling of the regressor components.
    coef_, intercept_ : ndarray
        The linear part, ``(n_terms, n_outputs)`` and ``(n_outputs,)`` (zeros without one).
    n_samples_ : int
        Number of training regressors.
    lags_ : ResolvedLags
    n_inputs_, n_outputs_ : int
    ts_ : float

    Raises
    ------
    ValueError
        In ``fit``: ε < 0, γ <= 0, ``gamma_margin`` < 1, γ below γ*(ε) (the message gives γ*(ε)),
        identical regressors whose outputs differ by more than 2ε, fewer than 2 regressors (or,
        with a linear part, fewer than the linear unknowns), a constant output.

    Notes
    -----
    With the feasible set FFS = {f Lipschitz(γ) : |ỹ_k − f(w̃_k)| <= ε for all k}, the optimal
    bounds and central estimate are (Milanese & Novara, 2004, Theorem 1 and eq. 10-12)

    .. math::

        f_u(w) = \min_k \left(ỹ_k + ε + γ\,\|w − w̃_k\|\right), \qquad
        f_l(w) = \max_k \left(ỹ_k − ε − γ\,\|w − w̃_k\|\right), \qquad
        f_c(w) = \tfrac12 \left(f_u(w) + f_l(w)\right),

    where ``‖·‖`` is the Euclidean norm of the weighted regressor. The seed paper ("Model
    Identification of a Soft Robotic Neck", eq. 6-7) writes the bounds without ε; the central
    estimate is the same, the bounds are not: here they are the ε form, the tightest bounds on
    the noise-free ``f_o``. A new measurement must then lie in ``[f_l − ε, f_u + ε]``
    (:meth:`invalidation`).

    *Prior validation.* FFS is non-empty iff ``f_u(w̃_k) >= ỹ_k − ε`` for all k, i.e.
    ``|ỹ_i − ỹ_j| <= 2ε + γ‖w̃_i − w̃_j‖`` for every pair, so the smallest consistent γ is

    .. math:: γ^*(ε) = \max_{i \ne j} \frac{\left(|ỹ_i − ỹ_j| − 2ε\right)^+}{\|w̃_i − w̃_j\|}.

    Identical regressors with outputs more than 2ε apart make γ*(ε) infinite: no γ fits them.

    *Choice of ε and γ.* With neither given, γ*(ε) is computed on the ε grid and ε is taken at
    the knee of the curve (:func:`choose_epsilon`), where its slope flattens the most; then
    ``γ = gamma_margin · γ*(ε)``. With ε given, ``γ = gamma_margin · γ*(ε)``. With γ given,
    ε is the smallest value consistent with it, ``ε = ½ max_{i,j} (|ỹ_i − ỹ_j| − γ‖w̃_i − w̃_j‖)⁺``
    (computed exactly, by branch and bound over the pairs). With both given, γ >= γ*(ε) is
    checked by the γ* branch and bound started at γ, which skips every pair that cannot exceed
    it (:func:`~neckid.models.set_membership.training.prior_holds`; a relative 1e-9 of slack), and a γ
    below γ*(ε) is refused. If the sensor's noise bound is known, pass it as ``epsilon``: the
    knee is a heuristic.

    *Linear part.* Following Milanese & Novara's later work (Novara, Milanese et al. on SM with a
    linear part), ``f = θᵀw + c + f_r``: ``θ, c`` by least squares, and ``f_r`` identified by SM
    on the residual ``ỹ_k − θᵀw̃_k − c``; the bounds are ``θᵀw + c + f_{r,l}`` and
    ``θᵀw + c + f_{r,u}``.

    *Local constants* (``lipschitz="local"``). The prior becomes
    ``|f(w) − f(w̃_j)| <= max(γ(w), γ_j) ‖w − w̃_j‖``, with ``γ_j`` the constant of training point
    ``j`` and ``γ(w)`` the largest ``γ_j`` of the training points within the
    ``local_neighbours``-th smallest distance to ``w`` (ties included). Each point's constant is
    the steepest slope it takes part in,
    ``γ_i = gamma_margin · max_{j≠i} (|ỹ_i − ỹ_j| − 2ε)⁺ / ‖w̃_i − w̃_j‖`` (capped at the global
    ``γ``; ``γ`` itself where γ*(ε) = 0), so both ends of every training pair carry its slope, the
    bounds never cross, and the largest constant is the global ``γ*(ε)``. ε is chosen as above;
    the global ``γ_`` is kept (the largest constant). See
    :mod:`neckid.models.set_membership._kernels.local`. :meth:`simulate` then steps the simulator (no compiled
    free run), and :meth:`partial_fit` re-learns every point's constant on all the data.

    *Evaluation.* The bounds are evaluated exactly by branch and bound over a kd-tree of the
    training regressors whose nodes keep their bounding box and the min/max of ỹ; they equal a
    brute-force scan to the last bit in the distance sum's order (see
    :mod:`neckid.models.set_membership._kernels.tree`). The tree holds the one copy of the training regressors,
    scaled and in tree order (the matrix built for ``fit`` is reordered in place;
    :mod:`neckid.models.set_membership.training`). In :meth:`simulate` the bounds at each step are the bounds
    of ``f_o`` at the *simulated* regressor (as in the seed paper's figures), not a guaranteed
    enclosure of the true free-run trajectory.

    References
    ----------
    M. Milanese and C. Novara, "Set membership identification of nonlinear systems",
    Automatica 40(6):957-975, 2004.

    C. Novara, L. Fagiano and M. Milanese, "Direct feedback control design for nonlinear systems",
    Automatica 49(4):849-860, 2013 (SM with a linear part, and the choice of ε and γ).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> from neckid.models.set_membership.narx import SetMembership
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, 600)
    >>> y = np.zeros(600)
    >>> for t in range(1, 600):
    ...     y[t] = 0.6 * y[t - 1] + np.tanh(2 * u[t - 1]) + rng.uniform(-0.01, 0.01)
    >>> data = IOData(u, y, ts=0.02)
    >>> model = SetMembership(Lags(outputs=1, inputs=1), epsilon=0.01).fit(data[:400])
    >>> model.epsilon_, bool(model.gamma_[0] > 0)
    (array([0.01]), True)
    >>> sim = model.simulate(data[400:])
    >>> sim.kind, bool(np.all(sim.lower[1:] <= sim.y[1:])), bool(np.all(sim.y[1:] <= sim.upper[1:]))
    ('simulation', True, True)
    >>> bool(sim.fit_percent(data[400:])[0] > 80)
    True
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "epsilon": [None, Interval("real", 0, None), "array-like"],
        "gamma": [None, Interval("real", 0, None, closed="neither"), "array-like"],
        "gamma_margin": [Interval("real", 1, None)],
        "scaling": [Options(("std", "gradient", "none")), "array-like"],
        "linear_part": ["boolean"],
        "epsilons": [None, "array-like"],
        "progress": [None, "boolean", "callable"],
        "input_weight": [Interval("real", 0, None, closed="neither")],
        "lipschitz": [Options(("global", "local"))],
        "local_neighbours": [Interval("int", 1, None)],
    }

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        epsilon: float | ArrayLike | None = None,
        gamma: float | ArrayLike | None = None,
        gamma_margin: float = DEFAULT_GAMMA_MARGIN,
        scaling: Literal["std", "gradient", "none"] | ArrayLike = "std",
        linear_part: bool = False,
        epsilons: ArrayLike | None = None,
        progress: ProgressOption = None,
        input_weight: float = 1.0,
        lipschitz: Literal["global", "local"] = "global",
        local_neighbours: int = 10,
    ) -> None:
        self.lags = lags
        self.epsilon = epsilon
        self.gamma = gamma
        self.gamma_margin = gamma_margin
        self.scaling = scaling
        self.linear_part = linear_part
        self.epsilons = epsilons
        self.progress = progress
        self.input_weight = input_weight
        self.lipschitz = lipschitz
        self.local_neighbours = local_neighbours

    # ------------------------------------------------------------------ fit
    def _fit_regression(self, x: FloatArray, y: FloatArray) -> None:
        """Fit on the regressor matrix ``x`` built by ``_prepare_fit``, which it takes over.

        ``x`` becomes the kd-tree's points, scaled and reordered in place (the one copy of the
        training regressors the model keeps); ``NarxModel.fit`` does not use it afterwards.
        A regressor of as many terms as training rows or more is refused: its Lipschitz bound
        would rest on fewer points than dimensions.
        """
        if 2 <= x.shape[0] <= x.shape[1]:  # (fewer than 2 rows: fit_core says so)
            raise ValueError(
                f"Set Membership needs more training rows than regressor terms: {x.shape[0]} rows"
                f" for {x.shape[1]} terms; use a longer record or fewer lags"
            )
        self._set_core(*fit_core(x, y, self.lags_, SMSettings.of(self)))

    def _set_core(self, core: SMCore, report: FitReport, *, new_curve: bool = True) -> None:
        """Take a fitted core and what its fit found (``gamma_curve_`` kept unless ``new_curve``)."""
        self.core_ = core
        self.gamma_star_ = report.gamma_star
        self.prior_valid_ = report.prior_valid
        if new_curve:
            self.gamma_curve_ = report.curve

    # The fitted state lives in ``core_``; these read it under the names users know.
    weights_ = property(lambda self: self.core_.weights, doc="Distance weights, (n_terms,).")
    coef_ = property(lambda self: self.core_.coef, doc="Linear part, (n_terms, n_outputs).")
    intercept_ = property(lambda self: self.core_.intercept, doc="Linear part's intercept.")
    epsilon_ = property(lambda self: self.core_.epsilon, doc="Noise bound ε per output.")
    gamma_ = property(lambda self: self.core_.gamma, doc="Lipschitz constant γ per output.")
    point_gamma_ = property(
        lambda self: self.core_.point_gamma, doc="Local constants (tree order), or None."
    )
    local_neighbours_ = property(
        lambda self: self.core_.local_neighbours, doc="Points the local bounds combine."
    )

    def set_membership_prior(self) -> SetMembershipPrior:
        """ε and γ per output, the Lipschitz constants' kind and the distance (fitted)."""
        check_is_fitted(self)
        distance = SetMembershipPrior.distance_of(self.scaling)
        return SetMembershipPrior(self.epsilon_, self.gamma_, None, str(self.lipschitz), distance)

    @property
    def _tree(self) -> SMTree:
        return self.core_.tree

    @property
    def _x_train(self) -> FloatArray:
        """The training regressors (unscaled) in tree order, recovered from the tree's points."""
        return self.core_.x_train

    @property
    def _y_train(self) -> FloatArray:
        """The measured training outputs in tree order (the SM targets without a linear part)."""
        return self.core_.y_train

    # ------------------------------------------------------------------ evaluation
    def _bounds_rows(self, x: FloatArray) -> SMBounds:
        return self.core_.bounds(x)

    def _predict_rows(self, x: FloatArray) -> FloatArray:
        return self._bounds_rows(x).central

    def bounds(self, regressors: ArrayLike) -> SMBounds:
        """Bounds and central estimate of ``f_o`` at raw regressors.

        Parameters
        ----------
        regressors : array_like, shape (n_rows, n_terms) or (n_terms,)
            Unscaled regressors, columns in the order of ``lags_.names``.

        Returns
        -------
        SMBounds
            ``(lower, central, upper)``, each ``(n_rows, n_outputs)``: ``f_l``, ``f_c``, ``f_u``
            (plus the linear part, if any).

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            If the shape is wrong or a value is NaN or inf.
        """
        check_is_fitted(self)
        x = np.asarray(regressors, dtype=np.float64)
        if x.ndim == 1:
            x = x[None, :]
        n_terms = self.lags_.n_terms
        if x.ndim != 2 or x.shape[1] != n_terms:
            raise ValueError(
                f"regressors must have {n_terms} columns ({list(self.lags_.names)}); got shape"
                f" {np.shape(regressors)}"
            )
        check_finite(x, "regressors", self.lags_.names)
        return self._bounds_rows(np.ascontiguousarray(x))

    def predict(self, data: IOData) -> ModelResult:
        """One-step-ahead prediction with bounds: the regressor holds the measured past outputs.

        The first ``max_lag`` samples are the measured outputs (initial conditions) and their
        bounds are NaN.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        self._check_inputs(data)
        x, _ = self.lags_.build_one(data)
        m = self.lags_.max_lag
        result = self._bounds_rows(x)
        y = np.array(data.y, dtype=np.float64)
        lower = np.full(y.shape, np.nan)
        upper = np.full(y.shape, np.nan)
        y[m:], lower[m:], upper[m:] = result.central, result.lower, result.upper
        return self._result("prediction", data, y, lower, upper, {"band": "sm-one-step"})

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free-run simulation (compiled loop): the regressor holds the model's own past outputs.

        The first ``max_lag`` outputs of ``data`` (or ``initial``, shape ``(n_outputs,)`` or
        ``(max_lag, n_outputs)``, when ``data`` holds inputs only) are the initial conditions
        (bounds NaN there); from then on only ``data.u`` is used. The bounds at each step are
        those of ``f_o`` at the simulated regressor.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y0 = self._initial_outputs(data, initial)
        if self.point_gamma_ is not None:
            # Local constants: no compiled loop; the simulator steps the same bounds.
            y, lower, upper = stepped_run(self.simulator(), data.u, y0, self.lags_.max_lag)
            return self._result("simulation", data, y, lower, upper, {"band": "sm-free-run"})
        y, lower, upper = self.core_.free_run(data.u, y0, self.lags_)
        return self._result("simulation", data, y, lower, upper, {"band": "sm-free-run"})

    def simulator(self) -> SetMembershipSimulator:
        """A stateful simulator with ``reset(y0=..., u0=...)`` and ``step(u) -> y``.

        After each step, ``lower`` and ``upper`` hold that step's bounds; ``step_bounds(u)``
        returns ``(y, lower, upper)`` at once.
        """
        check_is_fitted(self)
        return SetMembershipSimulator(self)

    def invalidation(self, data: IOData | Sequence[IOData]) -> Invalidation | list[Invalidation]:
        """Which samples of new data falsify the prior: outside ``[f_l − ε, f_u + ε]``.

        Parameters
        ----------
        data : IOData or list of IOData
            New measurements with the training channels.

        Returns
        -------
        Invalidation or list of Invalidation
            One per experiment (a list when a list was given).
        """
        check_is_fitted(self)
        experiments = as_experiments(self._with_conditions(data))
        results = []
        for d in experiments:
            x, y_meas = self.lags_.build_one(d)
            b = self._bounds_rows(x)
            low = b.lower - self.epsilon_
            high = b.upper + self.epsilon_
            excess_rows = np.maximum(np.maximum(low - y_meas, y_meas - high), 0.0)
            m = self.lags_.max_lag
            excess = np.zeros(d.y.shape)
            excess[m:] = excess_rows
            results.append(Invalidation(excess > 0, excess, m, d.output_names, self.epsilon_))
        return results[0] if isinstance(data, IOData) else results

    def partial_fit(
        self, data: IOData | Sequence[IOData], *, prior: PriorRule = "adapt"
    ) -> SetMembership:
        """Add new experiments to the data set; keep ε, re-check γ.

        Parameters
        ----------
        data : IOData or list of IOData
            New measurements on the model's channels.
        prior : {"adapt", "keep", "raise"}, default "adapt"
            What to do when the old and new data together falsify the prior (ε, γ):
            ``"adapt"`` raises γ to ``gamma_margin · γ*(ε)`` of all the data (the rule of
            ``fit``), ``"keep"`` keeps γ and warns, ``"raise"`` refuses the update.

        Returns
        -------
        SetMembership
            ``self``, with the new regressors in its data set (``n_samples_`` grows) and the
            kd-tree rebuilt over all of them; the linear part, if any, refitted by least
            squares on all of them (the refit's); ``last_invalidation_`` holds
            :meth:`invalidation` of the new data *before* the update (the share of samples
            outside ``[f_l − ε, f_u + ε]`` of the prior as it stood).

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            Data on other channels or too short; ``prior="raise"`` and the prior fails.

        Notes
        -----
        Not a refit: ε and the regressor ``weights_`` are kept (γ is measured in the weighted
        distance, so changing the weights would change its meaning), and γ only grows. See
        :mod:`neckid.models.set_membership.update` for the rule and its cost.
        """
        experiments = update_experiments(self, data)
        invalidation = self.invalidation(experiments)
        x_new, y_new = update_rows(self, experiments)
        # Everything that can fail runs before the model changes.
        core, report = self.core_.extended(
            x_new,
            y_new,
            settings=SMSettings.of(self),
            gamma_star=self.gamma_star_,
            prior=prior,
            output_names=self.output_names_,
        )
        self._set_core(core, report, new_curve=False)
        self.n_samples_ = core.n_samples
        self.last_invalidation_ = invalidation
        extend_training_ranges(self, experiments)
        return self

    # ------------------------------------------------------------------ files
    def _check_state(self) -> None:
        core = self.core_
        self._check_learned(
            core.tree.points,
            core.tree.targets,
            {
                "weights": core.weights,
                "coef": core.coef,
                "intercept": core.intercept,
                "epsilon": core.epsilon,
                "gamma": core.gamma,
            },
        )
        check_constants(core.point_gamma, self._fitted_lipschitz, self.n_samples_, core.gamma)

    @property
    def _fitted_lipschitz(self) -> str:
        """The form fitted (``set_params`` after ``fit`` changes the setting, not the model)."""
        return "global" if self.point_gamma_ is None else "local"

    def _check_learned(
        self, x: FloatArray, y: FloatArray, learned: Mapping[str, FloatArray]
    ) -> None:
        """The shapes and signs of the training rows and of the ``learned`` arrays (by name)."""
        super()._check_state()
        n_terms, n_out, n_rows = self.lags_.n_terms, self.n_outputs_, self.n_samples_
        shapes = {
            "weights": (n_terms,),
            "coef": (n_terms, n_out),
            "intercept": (n_out,),
            "epsilon": (n_out,),
            "gamma": (n_out,),
        }
        self._check_shape("x_train", x, (n_rows, n_terms))
        self._check_shape("y_train", y, (n_rows, n_out))
        for name, shape in shapes.items():
            self._check_shape(name, learned[name], shape)
        for name, rule in (
            ("gamma", learned["gamma"] > 0),
            ("epsilon", learned["epsilon"] >= 0),
            ("weights", learned["weights"] > 0),
        ):
            if not np.all(rule):
                raise ValueError(f"{name} must be > 0 (epsilon >= 0); got {learned[name].tolist()}")

    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        arrays: dict[str, NDArray[Any]] = {
            "x_train": self._x_train,
            "y_train": self._y_train,
            "weights": self.weights_,
            "coef": self.coef_,
            "intercept": self.intercept_,
            "epsilon": self.epsilon_,
            "gamma": self.gamma_,
            "gamma_star": self.gamma_star_,
            "prior_valid": self.prior_valid_,
        }
        if self.point_gamma_ is not None:
            arrays["point_gamma"] = self.point_gamma_
        if self.gamma_curve_ is not None:
            arrays["curve_epsilons"] = self.gamma_curve_.epsilons
            arrays["curve_gamma"] = self.gamma_curve_.gamma

        def plain(value: Any) -> Any:
            if value is None or isinstance(value, str):
                return value
            return np.asarray(value, dtype=np.float64).tolist()

        meta = {
            "params": {
                "epsilon": plain(self.epsilon),
                "gamma": plain(self.gamma),
                "gamma_margin": float(self.gamma_margin),
                "scaling": plain(self.scaling),
                "linear_part": bool(self.linear_part),
                "epsilons": plain(self.epsilons),
                "input_weight": float(self.input_weight),
                "lipschitz": self._fitted_lipschitz,
                "local_neighbours": self.local_neighbours_,
            },
            **self._narx_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
    ) -> SetMembership:
        model = cls(None, **meta["params"])
        model._restore_narx_meta(meta)
        # Own copies: the tree scales and reorders the rows in place.
        x = np.array(arrays["x_train"], dtype=np.float64, order="C")
        y = np.array(arrays["y_train"], dtype=np.float64, order="C")
        learned = {
            "weights": np.asarray(arrays["weights"], dtype=np.float64),
            "coef": np.ascontiguousarray(arrays["coef"], dtype=np.float64),
            "intercept": np.asarray(arrays["intercept"], dtype=np.float64),
            "epsilon": np.asarray(arrays["epsilon"], dtype=np.float64),
            "gamma": np.asarray(arrays["gamma"], dtype=np.float64),
        }
        curve = (
            GammaCurve(
                np.asarray(arrays["curve_epsilons"], dtype=np.float64),
                np.asarray(arrays["curve_gamma"], dtype=np.float64),
                model.lags_.output_names,
                int(x.shape[0]),
            )
            if "curve_epsilons" in arrays
            else None
        )
        model._check_learned(x, y, learned)  # before the tree is built on the arrays
        saved = arrays.get("point_gamma")
        saved = None if saved is None else np.asarray(saved, dtype=np.float64)
        check_constants(saved, model.lipschitz, model.n_samples_, learned["gamma"])
        tree, outputs = training_tree(
            x,
            y,
            learned["weights"],
            learned["coef"],
            learned["intercept"],
            bool(model.linear_part),
        )
        core = SMCore(
            tree,
            learned["weights"],
            learned["coef"],
            learned["intercept"],
            learned["epsilon"],
            learned["gamma"],
            outputs,
            # The rows were saved in the old tree's order; the new tree reorders them.
            None if saved is None else np.ascontiguousarray(saved[tree.perm]),
            int(model.local_neighbours),
        )
        report = FitReport(
            np.asarray(arrays["gamma_star"], dtype=np.float64),
            curve,
            np.asarray(arrays["prior_valid"], dtype=bool),
        )
        model._set_core(core, report)
        return model


class SetMembershipSimulator(NarxSimulator):
    """Step-by-step free run of a fitted :class:`SetMembership`, with the bounds of each step.

    ``step(u)`` returns the central estimate; after it, :attr:`lower` and :attr:`upper` hold that
    step's bounds (NaN before the first step). ``step_bounds(u)`` returns all three.
    """

    def __init__(self, model: SetMembership) -> None:
        self._model = model
        n_out = model.n_outputs_
        self.lower: FloatArray = np.full(n_out, np.nan)
        self.upper: FloatArray = np.full(n_out, np.nan)
        super().__init__(model.lags_, self._central_and_keep)

    def _central_and_keep(self, x: FloatArray) -> FloatArray:
        b = self._model._bounds_rows(np.ascontiguousarray(x))
        self.lower = b.lower[0].copy()
        self.upper = b.upper[0].copy()
        return b.central

    def reset(self, y0: ArrayLike | None = None, u0: ArrayLike | None = None) -> None:
        """Start again from a constant history (see :meth:`NarxSimulator.reset`)."""
        super().reset(y0, u0)
        if hasattr(self, "lower"):
            self.lower = np.full(self.n_outputs, np.nan)
            self.upper = np.full(self.n_outputs, np.nan)

    def step_bounds(self, u: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Advance one sample; return ``(y, lower, upper)``, each ``(n_outputs,)``."""
        y = self.step(u)
        return y, self.lower.copy(), self.upper.copy()


# ====================================================================================== function
def gamma_curve(
    data: IOData | Sequence[IOData],
    lags: Lags,
    epsilons: ArrayLike | None = None,
    scaling: Literal["std", "gradient", "none"] | ArrayLike = "std",
    linear_part: bool = False,
    progress: ProgressOption = None,
    input_weight: float = 1.0,
) -> GammaCurve:
    r"""The curve γ*(ε) of the data: the smallest Lipschitz constant consistent with each ε.

    Parameters
    ----------
    data : IOData or list of IOData
        Training experiments (regressors never straddle two).
    lags : Lags
        The regressor.
    epsilons : array_like, shape (n_eps,) or (n_eps, n_outputs), optional
        The ε grid (>= 0). Default: 0 and 47 geometrically spaced values in
        ``[1e-4, 0.25] * ptp(ỹ)`` per output.
    scaling : {"std", "gradient", "none"} or array_like, default "std"
        As in :class:`SetMembership`.
    linear_part : bool, default False
        Compute the curve of the residual of a least-squares linear ARX (as the estimator does).
    progress : bool or callable, optional
        Progress bar for large data (default: from 20,000 regressors), or a callback
        ``(pairs_done, pairs_total)``.
    input_weight : float, default 1.0
        As in :class:`SetMembership`.

    Returns
    -------
    GammaCurve

    Raises
    ------
    ValueError
        As :meth:`SetMembership.fit` for bad data; for a negative or NaN ε in the grid.

    Notes
    -----
    .. math:: γ^*(ε) = \max_{i \ne j} \frac{\left(|ỹ_i − ỹ_j| − 2ε\right)^+}{\|w̃_i − w̃_j\|}

    (Milanese & Novara, 2004). All ε of the grid are done in one compiled pass over the
    ``N(N − 1)/2`` pairs, parallel over rows, each distance computed once.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> from neckid.models.set_membership.narx import gamma_curve
    >>> rng = np.random.default_rng(1)
    >>> u = rng.uniform(-1, 1, 300)
    >>> y = np.zeros(300)
    >>> for t in range(1, 300):
    ...     y[t] = 0.5 * y[t - 1] + u[t - 1] + rng.uniform(-0.05, 0.05)
    >>> curve = gamma_curve(IOData(u, y, ts=0.1), Lags(outputs=1, inputs=1), [0.0, 0.05, 0.2])
    >>> bool(np.all(np.diff(curve.gamma[:, 0]) <= 0))
    True
    """
    model = SetMembership(lags, scaling=scaling, linear_part=linear_part, input_weight=input_weight)
    x, y = model._prepare_fit(data)
    if x.shape[0] < 2:
        raise ValueError(f"gamma_curve needs at least 2 regressors; the data give {x.shape[0]}")
    weights = term_weights(scaling, input_weight, x, model.lags_)
    if linear_part:
        coef, intercept = least_squares(x, y, fit_intercept=True)
        y = y - (x @ coef + intercept)
    weights = learnt_weights(scaling, weights, x, y)
    grid = _epsilon_grid(epsilons, y)
    points = np.ascontiguousarray(x * weights)
    values = _gamma_star(points, np.ascontiguousarray(y), grid, progress)
    return GammaCurve(grid, values, model.lags_.output_names, int(x.shape[0]))
