r"""Multi-step Set Membership: a direct k-step predictor per horizon, with guaranteed bands.

A one-step NARX model run in a loop compounds its own errors, and the bounds a one-step Set
Membership model carries along a free run bound ``f_o`` at the *simulated* regressor, not the
trajectory. A *direct* k-step model predicts ``y(t + k)`` from what is known at time ``t`` (the
measured outputs up to ``t`` and the inputs up to ``t + k``): its Set Membership bounds are then
guaranteed bounds of the k-step-ahead output, whenever the prior holds (Lauricella & Fagiano;
Terzi, Fagiano, Farina & Scattolini). :class:`MultiStepSetMembership` fits one such model per
horizon, each a :class:`~neckid.SetMembership` (exact kd-tree bounds) on the k-step regressor
of :func:`horizon_lags`. By default each horizon's ε factor, input weight and Lipschitz form are
chosen by cross-validation over the training runs
(:mod:`~neckid.models.set_membership.multistep_selection`); what one horizon's fit does is in
:mod:`~neckid.models.set_membership.horizon_fit`.

References
----------
M. Lauricella and L. Fagiano, "Set membership identification of linear systems with guaranteed
simulation accuracy", IEEE Transactions on Automatic Control 65(12):5189-5204, 2020.

E. Terzi, L. Fagiano, M. Farina and R. Scattolini, "Learning-based predictive control for linear
systems: a unitary approach", Automatica 108:108473, 2019 (multi-step predictors identified by
Set Membership for predictive control).

M. Milanese and C. Novara, "Set membership identification of nonlinear systems",
Automatica 40(6):957-975, 2004.
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
from neckid.models.online import extend_training_ranges, update_experiments
from neckid.models.set_membership.core import SMSettings
from neckid.models.set_membership.horizon_fit import (
    MAD_TO_STD,
    HorizonSetting,
    fit_horizon,
    horizon_lags,
    horizon_rows,
    robust_scale,
)
from neckid.models.set_membership.multistep_selection import (
    MultiStepSelection,
    candidate_grid,
    json_candidates,
    select_settings,
)
from neckid.models.set_membership.narx import (
    DEFAULT_GAMMA_MARGIN,
    Invalidation,
    SetMembership,
)
from neckid.models.set_membership.prior import ProgressOption
from neckid.models.set_membership.state_maps import MultiStepStateMap
from neckid.models.set_membership.update import PriorRule
from neckid.regressors import Lags
from neckid.utils.checks import Interval, Options
from neckid.utils.types import FloatArray

__all__ = [
    "MAD_TO_STD",
    "MAX_HORIZON",
    "MultiStepSetMembership",
    "MultiStepSimulator",
    "horizon_lags",
    "robust_scale",
]

logger = logging.getLogger(__name__)

#: Largest horizon accepted, in samples.
MAX_HORIZON = 1000


class MultiStepSetMembership(NarxModel):
    r"""Direct multi-step Set Membership predictors, one per horizon, with guaranteed bands.

    For each horizon ``k`` a Set Membership model (Milanese & Novara, 2004) of

    .. math:: y(t + k) = f_k\bigl(y(t), y(t − 1), …, u(t + k − d), …, u(t − n_b + 1)\bigr)
              + d_k(t), \qquad |d_k(t)| \le ε_k,

    on the regressor of :func:`horizon_lags` (measured outputs up to ``t``, inputs up to
    ``t + k``), as in the multi-step Set Membership predictors of Terzi, Fagiano, Farina &
    Scattolini. :meth:`predict_ahead` gives the central estimate of ``y(t + k)`` and a band that
    contains the measurement ``y(t + k)`` whenever the prior (ε_k, γ_k) holds. The ε factor,
    the input weight and the form of the Lipschitz prior of each horizon are, by default, chosen
    by cross-validation over the training runs (see Notes, *Settings*).

    Parameters
    ----------
    lags : Lags
        The one-step regressor, e.g. ``Lags.arx(2, 2)``; the k-step regressors are derived from
        it (:func:`horizon_lags`).
    horizon : int, default 10
        Fit the predictors of every horizon ``1 … horizon`` (samples). It is also the block length
        of :meth:`simulate` and :meth:`predict_receding` (re-anchoring period).
    horizons : sequence of int, optional
        Further horizons (>= 1) to fit, for :meth:`predict_ahead` only (e.g. ``[40]``).
    epsilon_factor : float or sequence of float, optional
        ε_k = ``epsilon_factor`` × the robust scale (1.4826 · MAD) of the k-step residual of the
        linear least-squares predictor on the training data (see Notes). A number fixes it; a
        sequence lists the candidates of the cross-validation; None (default) tries
        :data:`~neckid.models.set_membership.multistep_selection.EPSILON_FACTORS`
        (1, 1.5, 2, 2.5, 3, 4, 5). Unused when ``epsilon`` is given.
    epsilon : float or array_like, optional
        A known bound of the k-step error instead of the rule: one number (every horizon and
        output), shape ``(n_horizons,)`` or ``(n_horizons, n_outputs)``, in the order of
        ``horizons_`` (ascending), output units.
    gamma_margin : float, default 1.1
        γ_k = ``gamma_margin`` · γ*(ε_k) (>= 1).
    scaling : {"std", "none"}, default "std"
        Weights of the k-step regressor components in the distance (1 / std over the training
        regressors, or ones).
    input_weight : float or sequence of float, optional
        Factor (> 0) on the weight of every input term (as in :class:`~neckid.SetMembership`);
        the k-step regressor holds about ``k`` input terms per input channel, so values below 1
        keep the distance from being dominated by them. A number fixes it; a sequence lists the
        candidates; None (default) tries 1 and 0.3 (1 when ``epsilon`` is given).
    linear_part : bool, default True
        Each ``f_k`` is a least-squares linear predictor on the k-step regressor plus a Set
        Membership model of its residual.
    progress : bool or callable, optional
        Progress of the cross-validation (``callback(done, total)`` over horizons × folds) and
        of the final fit's γ*(ε) passes (see :class:`~neckid.SetMembership`); a bar when True,
        or when None above 20,000 training rows.
    lipschitz : {"global", "local"}, optional
        One Lipschitz constant per horizon, or one per training point and horizon (see Notes,
        *Local constants*). None (default) tries both (``"global"`` when ``epsilon`` is given).
    local_neighbours : int, default 10
        With ``lipschitz="local"``, the number of nearest training points whose largest
        constant is the constant at a query.
    target_coverage : float, default 0.95
        The mean held-out coverage of the guaranteed band a setting must reach in the
        cross-validation to be chosen, in (0, 1].

    Attributes
    ----------
    horizons_ : ndarray of int, shape (n_horizons,)
        The fitted horizons, ascending: ``1 … horizon`` and ``horizons``.
    estimators_ : tuple of SetMembership
        One fitted model per horizon, on the regressor ``horizon_lags(lags_, k)``.
    epsilon_, gamma_, gamma_star_ : ndarray, shape (n_horizons, n_outputs)
        ε_k, γ_k and γ*(ε_k) per horizon and output.
    residual_scale_ : ndarray, shape (n_horizons, n_outputs)
        Robust scale (1.4826 · MAD) of the k-step least-squares residual on the training data.
    settings_ : tuple of HorizonSetting
        Per horizon, the ε factor (None when ``epsilon`` was given), input weight and Lipschitz
        form the predictor was fitted with: the chosen ones, or the given ones.
    selection_ : MultiStepSelection or None
        The cross-validation (:mod:`~neckid.models.set_membership.multistep_selection`): the
        folds, the chosen settings and every setting's held-out coverage and width per fold
        (``selection_.table()``); None when nothing was chosen (every setting given, or
        ``epsilon`` given).
    lags_ : ResolvedLags
        The one-step regressor; ``max_lag_`` is its largest lag.
    n_inputs_, n_outputs_, n_samples_ : int
    ts_ : float

    Raises
    ------
    ValueError
        In ``fit``: a horizon < 1 or above :data:`MAX_HORIZON`, an ``epsilon`` of the wrong shape
        or negative, a list of candidates with ``epsilon`` given, a training experiment shorter
        than the longest k-step regressor, and
        everything :meth:`SetMembership.fit <neckid.SetMembership.fit>` refuses.

    Notes
    -----
    *Bounds.* For horizon ``k``, with ``f_{k,l}`` and ``f_{k,u}`` the Set Membership bounds
    (Milanese & Novara, 2004, Theorem 1) of ``f_k`` at the regressor ``φ_k(t)``,

    .. math:: f_{k,l}(φ) \le f_k(φ) \le f_{k,u}(φ), \qquad
              y(t + k) \in \bigl[f_{k,l}(φ) − ε_k,\; f_{k,u}(φ) + ε_k\bigr],

    the second being the *guaranteed band* of :meth:`predict_ahead` (``lower``, ``upper``): it
    holds for every ``t`` whenever ``|d_k| <= ε_k`` and ``f_k`` is Lipschitz with constant ``γ_k``
    (the prior). The first, the bounds of the noise-free ``f_k``, are in the result's extras.

    *ε_k (the rule).* ``ε_k = epsilon_factor · 1.4826 · MAD(r_k)``, with ``r_k`` the residual
    of the least-squares linear k-step predictor (standardised regressors, with intercept) on
    the training data only, MAD the median absolute deviation from the median. With the default
    factor 3 it is the 3σ level of a Gaussian residual, robust to the few large errors that make
    a plain maximum useless. It is a rule, not a guarantee: with a known noise bound, give
    ``epsilon``. The rule measures what the *linear* predictor misses: where a strong
    nonlinearity dominates that residual, ε_k overstates the noise and the bands are as wide as
    the linear model's errors (the Set Membership part then refines the centre, not the band).
    A smaller ε makes γ*(ε), a maximum over pairs of samples, grow fast when the residual has
    heavy tails: too small an ε widens the band instead of narrowing it.

    *γ_k.* ``γ_k = gamma_margin · γ*(ε_k)``, with γ*(ε) the smallest Lipschitz constant
    consistent with the training data (:func:`~neckid.gamma_curve`), computed exactly on the
    residual of the linear part. Where γ*(ε_k) = 0 (every training residual lies within ±ε_k
    of one value: a constant fits), ``γ_k = gamma_margin · γ*(ε_k / 2)`` instead, any γ >= 0
    being consistent: the band then still widens away from the data (if identical regressors
    make γ*(ε_k / 2) infinite, the first finite one of γ*(0.75 ε_k), γ*(0.9 ε_k), γ*(0.99 ε_k)).

    *ε_k floor.* No Lipschitz function fits two identical regressors whose targets differ by more
    than 2ε (a quantised sensor at rest gives many); the rule's ε_k is raised, with a warning,
    to half the widest such spread.

    *Local constants.* With ``lipschitz="local"`` each ``f_k`` has one constant per training
    point, the steepest slope that point takes part in (times ``gamma_margin``), and the
    constant at a query is the largest of its ``local_neighbours`` nearest points' (ties
    included; the prior of :class:`~neckid.SetMembership` with ``lipschitz="local"``). A few
    steep pairs (controller switches, hysteresis) then widen the band only near themselves, so a
    smaller ε_k no longer blows the band up everywhere; ``gamma_`` stays the global constant (the
    largest one; every point's constant where γ*(ε_k) = 0).

    *Settings.* ``epsilon_factor``, ``input_weight`` and ``lipschitz`` left at None (or given
    as lists) are chosen per horizon by
    :func:`~neckid.models.set_membership.multistep_selection.select_settings`: folds over the
    training experiments (leave one out; with one experiment, three contiguous time blocks),
    every setting of the grid fitted on each fold's training part by the rules above and scored
    on the held-out part; the narrowest mean guaranteed band among the settings whose mean
    held-out coverage reaches ``target_coverage``, else the highest coverage (with a warning).
    The model is then fitted on all the training data with each horizon's chosen setting
    (``settings_``; the fold table is ``selection_``). The grid's regressor, kd-tree, γ*(ε) pass
    and distances are shared by its settings, so choosing costs a few fits, not one per setting.
    With ``epsilon`` given (a known bound) nothing is chosen: None means 1 and ``"global"``. To
    fit fixed settings give all three, e.g. ``epsilon_factor=3, input_weight=1,
    lipschitz="global"`` (the defaults before the selection).

    *Free run.* :meth:`simulate` cannot re-anchor on measurements (a free run does not look at
    measured outputs after the initial ones): it chains the predictors in blocks of ``horizon``
    samples, each block anchored on the model's own last outputs. The bands of the first block
    are guaranteed; later ones are those of ``f_k`` at a simulated regressor
    (``extras["band"] == "chained"``). :meth:`predict_receding` is the receding-horizon run
    that re-anchors on the *measured* outputs every ``horizon`` samples, with guaranteed bands.

    References
    ----------
    E. Terzi, L. Fagiano, M. Farina and R. Scattolini, "Learning-based predictive control for
    linear systems: a unitary approach", Automatica 108:108473, 2019.

    M. Lauricella and L. Fagiano, "Set membership identification of linear systems with
    guaranteed simulation accuracy", IEEE TAC 65(12):5189-5204, 2020.

    M. Milanese and C. Novara, "Set membership identification of nonlinear systems",
    Automatica 40(6):957-975, 2004.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> from neckid.models.set_membership.multistep import MultiStepSetMembership
    >>> rng = np.random.default_rng(0)
    >>> u = np.repeat(rng.uniform(-1, 1, 60), 10)
    >>> y = np.zeros(600)
    >>> for t in range(1, 600):
    ...     y[t] = 0.8 * y[t - 1] + np.tanh(u[t - 1]) + rng.uniform(-0.01, 0.01)
    >>> data = IOData(u, y, ts=0.02)
    >>> model = MultiStepSetMembership(Lags.arx(1, 1), horizon=3).fit(data[:400])
    >>> model.horizons_
    array([1, 2, 3])
    >>> model.selection_.folds, len(model.settings_)  # one record: three time blocks
    ('time blocks', 3)
    >>> ahead = model.predict_ahead(data[400:], steps=3)
    >>> ahead.n_initial, ahead.extras["band"]
    (3, 'guaranteed')
    >>> bool(np.all(ahead.lower[3:] <= ahead.y[3:]) and np.all(ahead.y[3:] <= ahead.upper[3:]))
    True
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "horizon": [Interval("int", 1, MAX_HORIZON)],
        "horizons": [None, "lag-list"],
        "epsilon_factor": [None, Interval("real", 0, None, closed="neither"), "array-like"],
        "epsilon": [None, Interval("real", 0, None), "array-like"],
        "gamma_margin": [Interval("real", 1, None)],
        "scaling": [Options(("std", "none"))],
        "input_weight": [None, Interval("real", 0, None, closed="neither"), "array-like"],
        "linear_part": ["boolean"],
        "progress": [None, "boolean", "callable"],
        "lipschitz": [None, Options(("global", "local"))],
        "local_neighbours": [Interval("int", 1, None)],
        "target_coverage": [Interval("real", 0, 1, closed="right")],
    }

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        horizon: int = 10,
        horizons: Sequence[int] | None = None,
        epsilon_factor: float | Sequence[float] | None = None,
        epsilon: float | ArrayLike | None = None,
        gamma_margin: float = DEFAULT_GAMMA_MARGIN,
        scaling: Literal["std", "none"] = "std",
        input_weight: float | Sequence[float] | None = None,
        linear_part: bool = True,
        progress: ProgressOption = None,
        lipschitz: Literal["global", "local"] | None = None,
        local_neighbours: int = 10,
        target_coverage: float = 0.95,
    ) -> None:
        self.lags = lags
        self.horizon = horizon
        self.horizons = horizons
        self.epsilon_factor = epsilon_factor
        self.epsilon = epsilon
        self.gamma_margin = gamma_margin
        self.scaling = scaling
        self.input_weight = input_weight
        self.linear_part = linear_part
        self.progress = progress
        self.lipschitz = lipschitz
        self.local_neighbours = local_neighbours
        self.target_coverage = target_coverage

    # ------------------------------------------------------------------ fit
    def _horizon_set(self) -> NDArray[np.int64]:
        extra = [] if self.horizons is None else [int(k) for k in self.horizons]
        bad = [k for k in extra if not 1 <= k <= MAX_HORIZON]
        if bad:
            raise ValueError(
                f"horizons must hold horizons in [1, {MAX_HORIZON}] samples; got {bad[0]} in"
                f" {extra}"
            )
        return np.array(sorted(set(range(1, int(self.horizon) + 1)) | set(extra)), dtype=np.int64)

    def _given_epsilon(self, n_horizons: int, n_outputs: int) -> FloatArray | None:
        if self.epsilon is None:
            return None
        value = np.asarray(self.epsilon, dtype=np.float64)
        if value.ndim == 0:
            value = np.full((n_horizons, n_outputs), float(value))
        elif value.ndim == 1 and value.shape[0] == n_horizons:
            value = np.repeat(value[:, None], n_outputs, axis=1)
        if value.shape != (n_horizons, n_outputs):
            raise ValueError(
                f"epsilon must be a number, {n_horizons} numbers (one per horizon) or shape"
                f" ({n_horizons}, {n_outputs}) (horizon, output); got shape {np.shape(self.epsilon)}"
            )
        if not np.all(np.isfinite(value)) or np.any(value < 0):
            raise ValueError(f"epsilon must be finite and >= 0 (a bound); got {value.tolist()}")
        return value

    def fit(self, data: IOData | Sequence[IOData]) -> MultiStepSetMembership:
        """Fit one Set Membership predictor per horizon on one experiment or a list of them.

        Settings left to choose (None or lists) are chosen first, per horizon, by
        cross-validation over the experiments (see Notes, *Settings*). Regressors never
        straddle two experiments; every experiment must be longer than the longest k-step
        regressor (``max_lag + max(horizons_) − 1`` samples).
        """
        data = self._with_conditions(data, fitting=True)
        self._prepare_fit(data)
        experiments = as_experiments(data)
        horizons = self._horizon_set()
        given = self._given_epsilon(horizons.size, self.n_outputs_)
        shortest = min(d.n_samples for d in experiments)
        longest_lag = self.lags_.max_lag + int(horizons[-1]) - 1
        if shortest <= longest_lag + 1:
            raise ValueError(
                f"the shortest training experiment has {shortest} samples, too few for horizon"
                f" {int(horizons[-1])}: its regressor reaches {longest_lag} samples back; use"
                " longer experiments or a shorter horizon"
            )
        grid = candidate_grid(
            self.epsilon_factor, self.input_weight, self.lipschitz, given=given is not None
        )
        options = SMSettings(
            gamma_margin=float(self.gamma_margin),
            scaling=self.scaling,
            linear_part=bool(self.linear_part),
            progress=self.progress,
            local_neighbours=int(self.local_neighbours),
        )
        # Rows and linear parts first, before any compiled kernel (see horizon_rows).
        rows = [
            horizon_rows(experiments, horizon_lags(self.lags_, int(k)), options) for k in horizons
        ]
        selection = None
        if len(grid.settings()) > 1:
            selection = select_settings(
                experiments,
                self.lags_,
                horizons.tolist(),
                grid,
                options,
                target_coverage=float(self.target_coverage),
                progress=self.progress,
            )
            settings = selection.chosen
        else:
            (setting,) = grid.settings()
            if given is not None:
                setting = HorizonSetting(None, setting.input_weight, setting.lipschitz)
            settings = (setting,) * horizons.size
        estimators = []
        scale = np.empty((horizons.size, self.n_outputs_))
        gamma_star_at = np.empty((horizons.size, self.n_outputs_))
        for i, k in enumerate(horizons):
            model, scale[i], gamma_star_at[i] = fit_horizon(
                rows[i],
                settings[i],
                epsilon=None if given is None else given[i],
                options=options,
                steps=int(k),
            )
            estimators.append(model)
            logger.info(
                "horizon %d: %s epsilon=%s gamma=%s",
                k,
                settings[i].to_json(),
                model.epsilon_.tolist(),
                model.gamma_.tolist(),
            )
        self.horizons_ = horizons
        self.estimators_ = tuple(estimators)
        self.residual_scale_ = scale
        self.gamma_star_ = gamma_star_at
        self.settings_ = tuple(settings)
        self.selection_ = selection
        self._set_horizon_arrays()
        self._mark_fitted()
        return self

    def invalidation(
        self, data: IOData | Sequence[IOData]
    ) -> dict[int, Invalidation | list[Invalidation]]:
        """Per horizon, which samples of new data fall outside their guaranteed k-step band.

        Parameters
        ----------
        data : IOData or list of IOData
            New measurements with the training channels.

        Returns
        -------
        dict
            ``{k: Invalidation}`` for every fitted horizon (a list per horizon when a list was
            given): ``.fraction`` is the share of samples outside the band of
            :meth:`predict_ahead`, ``.smallest_epsilon`` the smallest ε_k that would hold them
            all (γ_k kept). A horizon whose regressor is longer than one of the experiments is
            left out (so a list's positions always match ``data``).
        """
        check_is_fitted(self)
        experiments = as_experiments(self._with_conditions(data))
        report: dict[int, Invalidation | list[Invalidation]] = {}
        for k, model in zip(self.horizons_.tolist(), self.estimators_, strict=True):
            if all(d.n_samples > model.lags_.max_lag for d in experiments):
                found = model.invalidation(experiments)
                if isinstance(data, IOData) and isinstance(found, list):
                    report[int(k)] = found[0]
                else:
                    report[int(k)] = found
        return report

    def partial_fit(
        self, data: IOData | Sequence[IOData], *, prior: PriorRule = "adapt"
    ) -> MultiStepSetMembership:
        """Add new experiments to the data set of every horizon's predictor.

        Each k-step predictor takes the new k-step regressors
        (:meth:`SetMembership.partial_fit <neckid.SetMembership.partial_fit>`: its linear part
        refitted on all its points, ε_k kept, γ_k re-checked with ``prior`` and raised, under
        ``"adapt"``, to this model's ``gamma_margin`` · γ*(ε_k)). An experiment too short for
        the regressor of a horizon is left out of that horizon's data.

        Parameters
        ----------
        data : IOData or list of IOData
            New measurements on the model's channels.
        prior : {"adapt", "keep", "raise"}, default "adapt"
            As for :meth:`SetMembership.partial_fit <neckid.SetMembership.partial_fit>`.

        Returns
        -------
        MultiStepSetMembership
            ``self``; each predictor's ``last_invalidation_`` reports on its horizon.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            Data on other channels, or too short for any horizon's regressor.
        """
        experiments = update_experiments(self, data)
        updated = 0
        for i, model in enumerate(self.estimators_):
            usable = [d for d in experiments if d.n_samples > model.lags_.max_lag]
            if not usable:
                continue
            model.set_params(gamma_margin=float(self.gamma_margin))
            model.partial_fit(usable, prior=prior)
            self.gamma_star_[i] = np.where(
                np.isfinite(model.gamma_star_), model.gamma_star_, self.gamma_star_[i]
            )
            updated += 1
        if updated == 0:
            raise ValueError(
                f"every experiment is too short for the shortest k-step regressor (lags up to"
                f" {self.estimators_[0].lags_.max_lag}); give longer data"
            )
        self.n_samples_ += int(sum(d.n_samples - self.lags_.max_lag for d in experiments))
        self._set_horizon_arrays()
        extend_training_ranges(self, experiments)
        return self

    def set_membership_prior(self) -> SetMembershipPrior:
        """ε and γ per horizon (rows) and output, with the horizons (fitted)."""
        check_is_fitted(self)
        horizons = tuple(int(k) for k in self.horizons_)
        distance = SetMembershipPrior.distance_of(self.scaling)
        return SetMembershipPrior(
            self.epsilon_, self.gamma_, horizons, str(self.lipschitz), distance
        )

    def _set_horizon_arrays(self) -> None:
        self.epsilon_ = np.vstack([m.epsilon_ for m in self.estimators_])
        self.gamma_ = np.vstack([m.gamma_ for m in self.estimators_])

    # ------------------------------------------------------------------ evaluation
    def _estimator(self, steps: Any) -> SetMembership:
        if isinstance(steps, bool) or not isinstance(steps, int | np.integer):
            raise TypeError(f"steps must be a whole number of samples; got {steps!r}")
        hit = np.flatnonzero(self.horizons_ == int(steps))
        if not hit.size:
            raise ValueError(
                f"steps must be one of the fitted horizons {self.horizons_.tolist()}; got {steps}"
                " (fit with horizons=[...] to add it)"
            )
        return self.estimators_[int(hit[0])]

    def predict_ahead(self, data: IOData, steps: int = 1) -> ModelResult:
        """Direct ``steps``-ahead prediction with its guaranteed band.

        Row ``s`` of the result is the prediction of ``y(s)`` made at time ``t = s − steps``,
        from the measured outputs up to ``t`` and the inputs up to ``s``.

        Parameters
        ----------
        data : IOData
            Measured inputs and outputs, the training channels.
        steps : int, default 1
            The horizon ``k``, one of ``horizons_``.

        Returns
        -------
        ModelResult
            ``kind="prediction"``; ``n_initial = max_lag_ + steps − 1`` rows are the measured
            outputs (bands NaN there). ``lower``, ``upper``: the guaranteed band of the
            measurement, ``[f_l − ε_k, f_u + ε_k]``. ``extras``: ``"band"`` (``"guaranteed"``),
            ``"steps"``, ``"epsilon"`` and ``"gamma"`` (per output), ``"function_lower"`` and
            ``"function_upper"`` (``f_l``, ``f_u``: the bounds of the noise-free ``f_k``).

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            If ``steps`` is not a fitted horizon, ``data`` holds no outputs or other channels,
            or is too short for the k-step regressor.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        self._check_inputs(data)
        model = self._estimator(steps)
        if data.n_outputs == 0:
            raise ValueError(
                "predict_ahead needs the measured outputs up to each anchor time; data holds"
                " inputs only (use simulate(data, initial=...) for a free run)"
            )
        x, _ = model.lags_.build_one(data)
        bounds = model.core_.bounds(x)
        start = model.lags_.max_lag
        i = int(np.flatnonzero(self.horizons_ == int(steps))[0])
        epsilon = self.epsilon_[i]
        y = np.array(data.y, dtype=np.float64)
        lower, upper = np.full(y.shape, np.nan), np.full(y.shape, np.nan)
        f_lower, f_upper = np.full(y.shape, np.nan), np.full(y.shape, np.nan)
        y[start:] = bounds.central
        f_lower[start:], f_upper[start:] = bounds.lower, bounds.upper
        lower[start:], upper[start:] = bounds.lower - epsilon, bounds.upper + epsilon
        extras = {
            "band": "guaranteed",
            "steps": int(steps),
            "epsilon": epsilon.copy(),
            "gamma": self.gamma_[i].copy(),
            "function_lower": f_lower,
            "function_upper": f_upper,
        }
        return ModelResult.from_data(
            "prediction",
            data,
            y,
            start,
            self.output_names_,
            self.output_units_,
            lower,
            upper,
            extras,
        )

    def predict(self, data: IOData) -> ModelResult:
        """One-step-ahead prediction with the guaranteed band: ``predict_ahead(data, steps=1)``."""
        return self.predict_ahead(data, steps=1)

    def predict_receding(self, data: IOData) -> ModelResult:
        """Receding-horizon prediction: re-anchored on the *measured* outputs every ``horizon``.

        Not a free run. The anchors are ``t_j = max_lag_ − 1 + j · horizon``; the samples
        ``t_j + 1 … t_j + horizon`` are predicted by the direct predictors of horizons
        ``1 … horizon`` from the measurements up to ``t_j`` (and the inputs), so every band is a
        guaranteed k-step band. This is what a predictive controller that receives a
        measurement every ``horizon`` samples sees.

        Returns
        -------
        ModelResult
            ``kind="prediction"``, ``n_initial = max_lag_``; ``extras["steps"]`` holds the
            horizon of each row (0 for the initial ones), ``extras["band"] == "guaranteed"``.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            If ``data`` holds no outputs or other channels.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        self._check_inputs(data)
        if data.n_outputs == 0:
            raise ValueError("predict_receding needs the measured outputs; data holds inputs only")
        block = int(self.horizon)
        m = self.max_lag_
        n = data.n_samples
        if n <= m:
            raise ValueError(
                f"data has {n} samples, too few for lags up to {m}: it needs at least {m + 1}"
            )
        y = np.array(data.y, dtype=np.float64)
        lower, upper = np.full(y.shape, np.nan), np.full(y.shape, np.nan)
        steps = np.zeros(n, dtype=np.int64)
        steps[m:] = (np.arange(m, n) - m) % block + 1
        for k in range(1, min(block, n - m) + 1):
            model = self._estimator(k)
            rows = np.flatnonzero(steps == k)
            start = model.lags_.max_lag
            x, _ = model.lags_.build_one(data)
            bounds = model.core_.bounds(np.ascontiguousarray(x[rows - start]))
            epsilon = self.epsilon_[k - 1]
            y[rows], lower[rows], upper[rows] = (
                bounds.central,
                bounds.lower - epsilon,
                bounds.upper + epsilon,
            )
        extras = {"band": "guaranteed", "steps": steps}
        return ModelResult.from_data(
            "prediction", data, y, m, self.output_names_, self.output_units_, lower, upper, extras
        )

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free run: the direct predictors chained in blocks of ``horizon`` samples.

        From the initial outputs (the first ``max_lag_`` of ``data``, or ``initial``), the
        predictors of horizons ``1 … horizon`` give the next ``horizon`` samples; the last
        ``max_lag_`` of those (the model's own outputs) anchor the next block, and so on. Only
        ``data.u`` is used after the initial outputs, so ``data`` may hold inputs only when
        ``initial`` is given. To re-anchor on measured outputs use :meth:`predict_receding`.

        Returns
        -------
        ModelResult
            ``kind="simulation"``; ``lower``/``upper`` are ``[f_l − ε_k, f_u + ε_k]`` at the
            chained regressor (``extras["band"] == "chained"``: guaranteed in the first block
            only); ``extras["steps"]`` the horizon used for each row.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y = self._initial_outputs(data, initial)
        m = self.max_lag_
        y, lower, upper = stepped_run(self.simulator(), data.u, y, m)
        steps = np.zeros(data.n_samples, dtype=np.int64)
        steps[m:] = (np.arange(m, data.n_samples) - m) % int(self.horizon) + 1
        return self._result(
            "simulation", data, y, lower, upper, {"band": "chained", "steps": steps}
        )

    def simulator(self) -> MultiStepSimulator:
        """A stateful simulator with ``reset(y0=..., u0=...)`` and ``step(u) -> y``.

        It runs the same chained free run as :meth:`simulate`: after
        ``reset(y0=y[:max_lag_], u0=u[:max_lag_])``, stepping ``u[max_lag_:]`` gives what
        ``simulate`` gives.
        """
        check_is_fitted(self)
        return MultiStepSimulator(self)

    def state_map(self, bounds: bool = False) -> MultiStepStateMap:
        """The model's state functions, for python-control (:func:`neckid.export.control.to_iosystem`).

        Parameters
        ----------
        bounds : bool, default False
            Add the outputs ``<output>_lower`` and ``<output>_upper`` (the step's band).

        Returns
        -------
        MultiStepStateMap
            State: the anchor of the chained free run (``max(max_lag_, 1)`` rows of outputs and
            inputs), the inputs since and the number of steps since.
        """
        check_is_fitted(self)
        return MultiStepStateMap(self, bounds)

    # ------------------------------------------------------------------ files
    def _check_state(self) -> None:
        super()._check_state()
        horizons = np.asarray(self.horizons_)
        expected = self._horizon_set()
        if horizons.shape != expected.shape or not np.array_equal(horizons, expected):
            raise ValueError(
                f"horizons {horizons.tolist()} must be 1..horizon={self.horizon} and the extra"
                f" horizons {list(self.horizons or [])}"
            )
        if len(self.estimators_) != horizons.size:
            raise ValueError(
                f"there must be one predictor per horizon ({horizons.size}); got"
                f" {len(self.estimators_)}"
            )
        for k, model in zip(horizons, self.estimators_, strict=True):
            expected_lags = horizon_lags(self.lags_, int(k))
            if model.lags_.to_lags() != expected_lags or (
                model.input_names_,
                model.output_names_,
            ) != (self.input_names_, self.output_names_):
                raise ValueError(
                    f"the predictor of horizon {int(k)} has the regressor"
                    f" {model.lags_.to_lags()!r}; the one-step regressor {self.lags_.to_lags()!r}"
                    f" gives {expected_lags!r}"
                )
        shape = (horizons.size, self.n_outputs_)
        self._check_shape("residual_scale", self.residual_scale_, shape)
        self._check_shape("gamma_star", self.gamma_star_, shape)
        fitted = [(float(m.input_weight), str(m.lipschitz)) for m in self.estimators_]
        if [(float(s.input_weight), s.lipschitz) for s in self.settings_] != fitted:
            raise ValueError(
                f"settings {[s.to_json() for s in self.settings_]} must hold each horizon's"
                f" input_weight and lipschitz; its predictors have {fitted}"
            )

    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        arrays: dict[str, NDArray[Any]] = {
            "horizons": self.horizons_,
            "residual_scale": self.residual_scale_,
            "gamma_star": self.gamma_star_,
        }
        submodels: dict[str, Any] = {}
        for k, model in zip(self.horizons_, self.estimators_, strict=True):
            sub_arrays, sub_meta = model._get_state()
            for name, value in sub_arrays.items():
                arrays[f"h{int(k)}_{name}"] = value
            submodels[str(int(k))] = sub_meta
        epsilon = self.epsilon
        meta = {
            "params": {
                "horizon": int(self.horizon),
                "horizons": None if self.horizons is None else [int(k) for k in self.horizons],
                "epsilon_factor": json_candidates(self.epsilon_factor),
                "epsilon": None if epsilon is None else np.asarray(epsilon, float).tolist(),
                "gamma_margin": float(self.gamma_margin),
                "scaling": str(self.scaling),
                "input_weight": json_candidates(self.input_weight),
                "linear_part": bool(self.linear_part),
                "lipschitz": None if self.lipschitz is None else str(self.lipschitz),
                "local_neighbours": int(self.local_neighbours),
                "target_coverage": float(self.target_coverage),
            },
            "submodels": submodels,
            "settings": [s.to_json() for s in self.settings_],
            "selection": None if self.selection_ is None else self.selection_.to_json(),
            **self._narx_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
    ) -> MultiStepSetMembership:
        model = cls(None, **meta["params"])
        model._restore_narx_meta(meta)
        horizons = np.asarray(arrays["horizons"])
        if horizons.ndim != 1 or horizons.dtype.kind not in "iu":
            raise ValueError(f"horizons must be a 1-D array of whole numbers; got {horizons!r}")
        estimators = []
        for k in horizons.tolist():
            prefix = f"h{k}_"
            sub_arrays = {n[len(prefix) :]: v for n, v in arrays.items() if n.startswith(prefix)}
            if not sub_arrays:
                raise KeyError(f"{prefix}x_train")
            estimators.append(SetMembership._from_state(sub_arrays, meta["submodels"][str(k)]))
        model.horizons_ = horizons.astype(np.int64)
        model.estimators_ = tuple(estimators)
        model.residual_scale_ = np.asarray(arrays["residual_scale"], dtype=np.float64)
        model.gamma_star_ = np.asarray(arrays["gamma_star"], dtype=np.float64)
        if "settings" in meta:
            model.settings_ = tuple(HorizonSetting.from_json(s) for s in meta["settings"])
        else:  # a file of the release before the selection: one fixed setting
            factor = meta["params"].get("epsilon_factor")
            model.settings_ = tuple(
                HorizonSetting(
                    None if model.epsilon is not None or factor is None else float(factor),
                    float(m.input_weight),
                    str(m.lipschitz),
                )
                for m in estimators
            )
        selection = meta.get("selection")
        model.selection_ = None if selection is None else MultiStepSelection.from_json(selection)
        model._set_horizon_arrays()
        return model


class MultiStepSimulator(NarxSimulator):
    """Step-by-step chained free run of a fitted :class:`MultiStepSetMembership`.

    The history is anchored at its last row; the ``k``-th step after the anchor applies the
    predictor of horizon ``k`` to the anchored outputs and the inputs since; after ``horizon``
    steps the model's own last outputs become the new anchor. ``step(u)`` returns the central
    estimate; after it, :attr:`lower` and :attr:`upper` hold that step's band
    ``[f_l − ε_k, f_u + ε_k]`` (guaranteed in the first block only).
    """

    def __init__(self, model: MultiStepSetMembership) -> None:
        self._model = model
        self._block = int(model.horizon)
        self._history = max(model.max_lag_, 1)
        super().__init__(model.lags_, model.estimators_[0]._predict_rows)

    @property
    def steps_since_anchor(self) -> int:
        """Steps taken since the last anchor (0 right after a reset or a re-anchoring)."""
        return self._steps

    def reset(self, y0: ArrayLike | None = None, u0: ArrayLike | None = None) -> None:
        """Start again from a constant history, anchored at its last row.

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (max_lag, n_outputs), optional
            Past outputs (oldest first); a single row is repeated. Default zeros.
        u0 : array_like, shape (n_inputs,) or (max_lag, n_inputs), optional
            Past inputs (oldest first); a single row is repeated. Default zeros.
        """
        super().reset(y0, u0)
        self._steps = 0
        self.lower = np.full(self.n_outputs, np.nan)
        self.upper = np.full(self.n_outputs, np.nan)

    def step_bounds(self, u: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Advance one sample with input ``u``; return ``(y, lower, upper)``, each ``(n_outputs,)``."""
        u_now = self._input_row(u)
        self._u = np.vstack([self._u, u_now[None, :]])
        k = self._steps + 1
        model = self._model.estimators_[k - 1]
        t = self._u.shape[0] - 1
        w = model.lags_.regressor_from_history(self._y, self._u, t)
        bounds = model.core_.bounds(w[None, :])
        epsilon = self._model.epsilon_[k - 1]
        y_now = np.asarray(bounds.central[0], dtype=np.float64)
        self.lower = bounds.lower[0] - epsilon
        self.upper = bounds.upper[0] + epsilon
        self._y = np.vstack([self._y, y_now[None, :]])
        if k == self._block:
            self._y = self._y[-self._history :]
            self._u = self._u[-self._history :]
            self._steps = 0
        else:
            self._steps = k
        return y_now.copy(), self.lower.copy(), self.upper.copy()

    def step(self, u: ArrayLike) -> FloatArray:
        """Advance one sample with input ``u`` (shape ``(n_inputs,)``); return ``y`` (``(n_outputs,)``)."""
        return self.step_bounds(u)[0]
