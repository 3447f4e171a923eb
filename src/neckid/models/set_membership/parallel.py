r"""ParallelSetMembership: Set Membership on a linear model run in parallel (output-error form).

A NARX model (:class:`~neckid.SetMembership`) feeds its own outputs back in free run, so a small
one-step error at a level the training data cover sparsely is integrated by the slow dynamics; on
a short record (the cascaded tanks) that is where SM loses to a linear ARX. Here the feedback stays
linear: a linear ARX identified by least squares is *simulated* from the inputs, and SM identifies
the static map from that simulated output (and, optionally, a few input samples) to the measured
output:

.. math::

    \hat y_L = \text{free run of the ARX on } u, \qquad
    y(t) = f_o(v(t)) + e(t), \quad
    v(t) = [\hat y_L(t - j)]_{j \in J} \cup [u(t - k)]_{k \in K}, \quad |e(t)| \le ε.

The regressor ``v`` holds no measured output, so free-run simulation *is* one-step evaluation of
the SM bounds: the SM guarantees (``y(t) ∈ [f_l(v(t)) − ε, f_u(v(t)) + ε]`` whenever the prior
holds) are bounds on the simulation error, and errors of the nonlinear part are never fed back.
In Narendra & Parthasarathy's terms the NARX SM models are series-parallel; this one is parallel.
The structure is a Wiener model with a dynamic, nonparametric SM output map.

The estimate at each step is SM's central one, ``(f_u + f_l) / 2`` (optimal in the worst case
over the feasible functions), or, with ``estimate="projection"``, the parallel model's own output
moved into ``[f_l, f_u]`` when it leaves them: the feasible function closest to the parametric
model, which it leaves unchanged wherever the data and the prior do not contradict it. That is
the form for a good parametric model (a polynomial fitted for simulation): the central estimate
would replace its output by an interpolation of noisy data, the projection only corrects it where
it is shown wrong.

References
----------
M. Milanese, C. Novara, "Set Membership identification of nonlinear systems", Automatica 40(6),
957-975, 2004 (the bounds, the central estimate, γ*(ε)).
K. S. Narendra, K. Parthasarathy, "Identification and control of dynamical systems using neural
networks", IEEE Trans. Neural Networks 1(1), 4-27, 1990 (series-parallel and parallel models).
M. Lauricella, L. Fagiano, "Set membership identification of linear systems with guaranteed
simulation accuracy", IEEE Trans. Automatic Control 65(12), 5189-5204, 2020 (why simulation,
not one-step, bounds matter).
M. Milanese, C. Novara, "Unified Set Membership theory for identification, prediction and
filtering of nonlinear systems", Automatica 47(10), 2141-2151, 2011 (every function of the
feasible set is a valid estimate; the central one is worst-case optimal).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.base import clone

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import (
    DivergenceError,
    Estimator,
    ExtrapolationWarning,
    ModelResult,
    check_is_fitted,
    history_rows,
)
from neckid.models.facts import SetMembershipPrior
from neckid.models.linear.arx import LinearARX
from neckid.models.online import extend_training_ranges, update_experiments
from neckid.models.polynomial.narx import PolynomialNARX
from neckid.models.set_membership.narx import (
    DEFAULT_GAMMA_MARGIN,
    GammaCurve,
    Invalidation,
    SetMembership,
)
from neckid.models.set_membership.state_maps import (
    ParallelStateMap,
    StatefulParallelStateMap,
)
from neckid.models.set_membership.update import PriorRule
from neckid.regressors import Lags, ResolvedLags
from neckid.utils.checks import Options, check_lag_list
from neckid.utils.types import FloatArray

__all__ = ["ParallelSetMembership", "ParallelSetMembershipSimulator"]


#: Suffix of the channel that carries the linear model's simulated output in the SM regressor.
LINEAR_SUFFIX = "_linear"


class ParallelSetMembership(Estimator):
    r"""Set Membership identification of the map from a linear model's simulation to the output.

    Fitting (1) identifies a linear ARX on ``lags`` by least squares, (2) simulates it in free
    run on every training experiment, giving ``ŷ_L``, and (3) identifies with
    :class:`~neckid.SetMembership` the map ``v(t) -> y(t)`` with ``v(t)`` the samples
    ``ŷ_L(t − j)``, ``j`` in ``linear_lags``, and ``u(t − k)``, ``k`` in ``input_lags``.
    Simulation runs the linear model and evaluates the SM bounds at each ``v(t)``; nothing of the
    nonlinear part is fed back (see the module docstring).

    Parameters
    ----------
    lags : Lags
        Regressor of the linear ARX, e.g. ``Lags.arx(3, 3, 1)``.
    linear_lags : sequence of int, default (0, 1)
        Lags (>= 0) of the linear model's simulated output(s) in the SM regressor.
    input_lags : sequence of int, default ()
        Lags (>= 0) of every measured input in the SM regressor.
    parallel_degree : int, default 1
        Degree of the model run in parallel: 1 is the linear ARX; higher degrees make it a
        :class:`~neckid.PolynomialNARX` on ``lags`` (the SM map then corrects what that
        polynomial misses).
    parallel_fit : {"prediction", "simulation"}, default "prediction"
        How the parallel model is fitted: least squares on the one-step error, or then for its
        free run (output error; see :class:`~neckid.PolynomialNARX`). ``"simulation"`` with
        degree 1 gives an output-error linear model.
    epsilon, gamma, gamma_margin, scaling, input_weight, linear_part, epsilons, progress
        As for :class:`~neckid.SetMembership` (same defaults and rules), applied to the SM map
        (``linear_part`` adds a least-squares linear map of ``v`` under the SM residual; by
        default the SM map is the whole correction; ``input_weight`` weighs the measured-input
        terms of ``v`` against the linear model's outputs).
    lipschitz, local_neighbours
        One Lipschitz constant for the SM map, or one per training point (as for
        :class:`~neckid.SetMembership`).
    estimate : {"central", "projection"}, default "central"
        The output at each step: SM's central estimate ``(f_u + f_l) / 2``, or the parallel
        model's output clipped into ``[f_l, f_u]`` (see the module docstring). The bounds are
        the same either way.
    base : str or estimator, optional
        The model run in parallel, so that the SM bounds come with the best simulator: a
        registry name (:func:`neckid.methods`: ``"arx"``, ``"poly"``, ``"ss"``, ``"pnlss"``,
        ``"greybox-neck"``, ...) made with ``lags`` and its defaults, or an unfitted estimator
        with its own settings (cloned; given ``lags`` when its own are None; a model file then
        keeps the fitted part, not these settings). ``None``: the linear ARX
        (or the polynomial of ``parallel_degree`` / ``parallel_fit``). A base with a state of
        its own (``ss``, ``pnlss``, ``greybox-neck``) runs with its own state (its state map then
        holds that state and the SM regressor's history).

    Attributes
    ----------
    linear_ : estimator
        The model run in parallel (a linear ARX unless ``base``, ``parallel_degree`` or
        ``parallel_fit`` say otherwise).
    sm_ : SetMembership
        The SM map; its inputs are the model's inputs followed by one ``<output>_linear``
        channel per output.
    epsilon_, gamma_ : ndarray, shape (n_outputs,)
        The SM noise bound and Lipschitz constant used (those of ``sm_``).
    max_lag_ : int
        Initial samples a simulation takes from the measured outputs (the larger of the linear
        model's and the SM regressor's maximum lag).
    lags_ : ResolvedLags
        The linear model's resolved regressor.
    n_inputs_, n_outputs_, n_samples_ : int
    ts_ : float

    Raises
    ------
    ValueError
        In ``fit``: the linear model's free run on a training experiment is not finite (an
        unstable ARX; try other ``lags``), a channel is named ``<output>_linear`` already, and
        every error :class:`~neckid.SetMembership` raises.

    Notes
    -----
    ``predict`` and ``simulate`` give the same values: the model is of output-error type, so its
    one-step predictor is its simulation (the measured outputs only set the initial conditions);
    the result of ``predict`` says so with ``kind="simulation"``.

    Examples
    --------
    A first-order system followed by a saturation (tanh): the linear ARX misses the saturation,
    the parallel model maps the ARX's simulation through it:

    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX, ParallelSetMembership
    >>> rng = np.random.default_rng(0)
    >>> u = np.repeat(rng.uniform(0, 2, 200), 10)
    >>> x = np.zeros(u.size)
    >>> for t in range(1, u.size):
    ...     x[t] = 0.9 * x[t - 1] + 0.1 * u[t - 1]
    >>> data = IOData(u, np.tanh(x) + 0.01 * rng.normal(size=u.size), ts=0.1)
    >>> train, test = data[:1500], data[1500:]
    >>> arx = LinearARX(Lags.arx(1, 1, 1)).fit(train)
    >>> model = ParallelSetMembership(Lags.arx(1, 1, 1)).fit(train)
    >>> [round(float(m.simulate(test).fit_percent(test)[0])) for m in (arx, model)]
    [73, 89]
    """

    #: The SM map's hyper-parameters: SetMembership's, with the same rules and defaults.
    _SM_PARAMETERS = (
        "epsilon",
        "gamma",
        "gamma_margin",
        "scaling",
        "input_weight",
        "lipschitz",
        "local_neighbours",
        "linear_part",
        "epsilons",
        "progress",
    )
    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "linear_lags": ["lag-list"],
        "input_lags": ["lag-list"],
        "parallel_degree": PolynomialNARX._parameter_constraints["degree"],
        "parallel_fit": PolynomialNARX._parameter_constraints["fit_for"],
        "estimate": [Options({"central", "projection"})],
        "base": [None, str, Estimator],
        **{k: SetMembership._parameter_constraints[k] for k in _SM_PARAMETERS},
    }
    predicts_by_simulation = True

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        linear_lags: Sequence[int] = (0, 1),
        input_lags: Sequence[int] = (),
        parallel_degree: int = 1,
        parallel_fit: str = "prediction",
        epsilon: float | ArrayLike | None = None,
        gamma: float | ArrayLike | None = None,
        gamma_margin: float = DEFAULT_GAMMA_MARGIN,
        scaling: str | ArrayLike = "std",
        input_weight: float = 1.0,
        linear_part: bool = False,
        epsilons: ArrayLike | None = None,
        progress: Any = None,
        lipschitz: str = "global",
        local_neighbours: int = 10,
        estimate: str = "central",
        base: str | Estimator | None = None,
    ) -> None:
        self.lags = lags
        self.linear_lags = linear_lags
        self.input_lags = input_lags
        self.parallel_degree = parallel_degree
        self.parallel_fit = parallel_fit
        self.epsilon = epsilon
        self.gamma = gamma
        self.gamma_margin = gamma_margin
        self.scaling = scaling
        self.input_weight = input_weight
        self.linear_part = linear_part
        self.epsilons = epsilons
        self.progress = progress
        self.lipschitz = lipschitz
        self.local_neighbours = local_neighbours
        self.estimate = estimate
        self.base = base

    # ------------------------------------------------------------------ fit
    def _sm_lags(self, input_names: Sequence[str], output_names: Sequence[str]) -> Lags:
        linear = check_lag_list(self.linear_lags, "linear_lags")
        inputs = check_lag_list(self.input_lags, "input_lags")
        conditions = self.lags.conditions if isinstance(self.lags, Lags) else ()
        spec: dict[str, list[int]] = {
            name: [0] if name in conditions else list(inputs) for name in input_names
        }
        for name in output_names:
            spec[name + LINEAR_SUFFIX] = list(linear)
        if not linear and not inputs:
            raise ValueError(
                "linear_lags and input_lags are both empty: the SM map would have no regressor;"
                " give linear_lags (e.g. [0, 1]) or input_lags"
            )
        return Lags(outputs=0, inputs=spec, conditions=conditions)

    def _augment(self, data: IOData, simulated: FloatArray) -> IOData:
        out = data
        for j, name in enumerate(data.output_names):
            out = out.with_channel(
                name + LINEAR_SUFFIX, simulated[:, j], unit=data.output_units[j], kind="input"
            )
        return out

    def _linear_run(self, data: IOData, argument: str) -> IOData:
        """``data`` with the linear model's free run appended as ``<output>_linear`` inputs."""
        try:
            with warnings.catch_warnings():
                # The parallel model reports the log's extrapolation itself, once.
                warnings.simplefilter("ignore", ExtrapolationWarning)
                simulated = self.linear_.simulate(data).y
        except DivergenceError as exc:  # said below, naming the record
            simulated = exc.result.y
        bad = np.flatnonzero(~np.isfinite(simulated).all(axis=1))
        if bad.size:
            raise ValueError(
                f"the model run in parallel ({type(self.linear_).__name__}) diverges in free run on"
                f" {argument} ({data.name or 'unnamed record'}) at sample {int(bad[0])}: it is"
                " unstable; try other lags or another base"
            )
        return self._augment(data, simulated)

    def fit(self, data: IOData | Sequence[IOData]) -> ParallelSetMembership:
        """Fit the linear model, simulate it on each experiment, then fit the SM map.

        Parameters
        ----------
        data : IOData or list of IOData
            One experiment or several (regressors never straddle two).

        Returns
        -------
        ParallelSetMembership
            ``self``.
        """
        self._validate_params()
        experiments = as_experiments(self._with_conditions(data, fitting=True))
        self._check_training(experiments)
        first = experiments[0]
        taken = set(first.input_names) | set(first.output_names)
        clash = [n + LINEAR_SUFFIX for n in first.output_names if n + LINEAR_SUFFIX in taken]
        if clash:
            raise ValueError(
                f"channel {clash[0]!r} exists already; ParallelSetMembership names the linear"
                " model's simulated outputs '<output>_linear': rename that channel"
            )
        sm_lags = self._sm_lags(first.input_names, first.output_names)
        if self.lags is None:
            raise ValueError("ParallelSetMembership needs lags=Lags(...) for its linear model")
        self.linear_ = self._parallel_model().fit(experiments)
        augmented = [
            self._linear_run(d, f"training experiment {i}") for i, d in enumerate(experiments)
        ]
        self.sm_ = SetMembership(sm_lags, **{k: getattr(self, k) for k in self._SM_PARAMETERS}).fit(
            augmented
        )
        self._set_channels(first)
        self._set_fitted_attributes(self.lags.resolve(experiments))
        return self

    def _parallel_model(self) -> Any:
        """The model run in parallel: ``base`` by its registry name, else the linear ARX.

        Without ``base``, a polynomial NARX when ``parallel_degree`` or ``parallel_fit`` ask for one.
        """
        if isinstance(self.base, Estimator):  # an unfitted model with its own settings
            model = clone(self.base)
            if "lags" in model.get_params() and model.get_params()["lags"] is None:
                model.set_params(lags=self.lags)
        elif self.base is not None:
            from neckid.registry import get_method, methods

            if self.base not in methods():
                raise ValueError(
                    f"base must be the name of a method ({', '.join(methods())}) or an unfitted"
                    f" estimator; got base={self.base!r}"
                )
            model = get_method(self.base).make(self.lags)
        else:
            model = None
        if model is not None:
            if "SetMembership" in type(model).__name__:
                raise ValueError(
                    f"base={self.base!r}: the model run in parallel must not be a Set Membership"
                    " model itself; give arx, poly, ss, pnlss, greybox-neck, ..."
                )
            return model
        if int(self.parallel_degree) == 1 and self.parallel_fit == "prediction":
            return LinearARX(self.lags)
        return PolynomialNARX(
            self.lags, degree=int(self.parallel_degree), fit_for=self.parallel_fit
        )

    def _set_fitted_attributes(self, resolved: ResolvedLags | None = None) -> None:
        # A base with a state of its own (ss, pnlss) has no regressor: ``lags`` on the data.
        found = getattr(self.linear_, "lags_", None)
        if found is None:
            found = resolved if resolved is not None else self.lags_
        self.lags_: ResolvedLags = found
        self.max_lag_ = max(int(self.linear_.max_lag_), self.sm_.lags_.max_lag)
        self.n_samples_ = self.sm_.n_samples_
        self.epsilon_ = self.sm_.epsilon_
        self.gamma_ = self.sm_.gamma_

    def set_membership_prior(self) -> SetMembershipPrior:
        """The SM map's prior (:meth:`SetMembership.set_membership_prior`) and the estimate."""
        check_is_fitted(self)
        sm, distance = self.sm_, SetMembershipPrior.distance_of(self.sm_.scaling)
        lipschitz, estimate = str(sm.lipschitz), str(self.estimate)
        return SetMembershipPrior(sm.epsilon_, sm.gamma_, None, lipschitz, distance, estimate)

    @property
    def gamma_curve_(self) -> GammaCurve | None:
        """The SM map's γ*(ε) curve (see :attr:`SetMembership.gamma_curve_`)."""
        check_is_fitted(self)
        return self.sm_.gamma_curve_

    # ------------------------------------------------------------------ evaluation
    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free-run simulation with the SM bounds of each step.

        The first ``max_lag_`` outputs of ``data`` (or ``initial``, shape ``(n_outputs,)`` or
        ``(max_lag_, n_outputs)``, when ``data`` holds inputs only) are the initial conditions
        (bounds NaN there); from then on only ``data.u`` is used. ``lower``/``upper`` bound the
        noise-free output ``f_o(v(t))``; a measurement consistent with the prior lies within ε of
        them.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y = self._initial_outputs(data, initial)
        with_initial = IOData(
            data.u,
            y,
            ts=data.ts,
            input_names=data.input_names,
            output_names=self.output_names_,
            input_units=data.input_units,
            output_units=self.output_units_,
            t0=data.t0,
            name=data.name,
        )
        augmented = self._linear_run(with_initial, "data")
        result = self.sm_.predict(augmented)
        m = self.max_lag_
        lower = np.full(y.shape, np.nan)
        upper = np.full(y.shape, np.nan)
        assert result.lower is not None and result.upper is not None
        lower[m:], upper[m:] = result.lower[m:], result.upper[m:]
        # The simulated outputs of the parallel model are the last inputs of the SM map.
        y[m:] = self._estimate(
            result.y[m:], augmented.u[m:, -self.n_outputs_ :], lower[m:], upper[m:]
        )
        return self._result("simulation", data, y, lower, upper, {"band": "sm-free-run"})

    def _estimate(
        self, central: FloatArray, parallel: FloatArray, lower: FloatArray, upper: FloatArray
    ) -> FloatArray:
        """The output: the central estimate, or the parallel model's output clipped to the bounds."""
        if self.estimate == "projection":
            return np.minimum(np.maximum(parallel, lower), upper)
        return central

    def predict(self, data: IOData) -> ModelResult:
        """The free run of :meth:`simulate`, with ``kind="simulation"``.

        An output-error model's one-step predictor is its simulation: no measured output enters
        its regressor.
        """
        return self.simulate(data)

    def invalidation(self, data: IOData | Sequence[IOData]) -> Invalidation | list[Invalidation]:
        """Which samples of new data fall outside ``[f_l − ε, f_u + ε]`` of the *simulation*.

        See :meth:`SetMembership.invalidation`; here the regressor is the linear model's free
        run, so a sample outside the band falsifies the prior along the whole simulated record.
        """
        check_is_fitted(self)
        experiments = as_experiments(self._with_conditions(data))
        augmented = [self._linear_run(d, f"experiment {i}") for i, d in enumerate(experiments)]
        result = self.sm_.invalidation(augmented)
        assert isinstance(result, list)
        return result[0] if isinstance(data, IOData) else result

    def partial_fit(
        self,
        data: IOData | Sequence[IOData],
        *,
        prior: PriorRule = "adapt",
        update_linear: bool = True,
    ) -> ParallelSetMembership:
        """Update the linear model exactly, then add the new data to the SM map.

        Parameters
        ----------
        data : IOData or list of IOData
            New measurements on the model's channels.
        prior : {"adapt", "keep", "raise"}, default "adapt"
            The SM map's rule when the new data falsify its prior
            (:meth:`SetMembership.partial_fit <neckid.SetMembership.partial_fit>`).
        update_linear : bool, default True
            Update the linear ARX by exact recursive least squares
            (:meth:`LinearARX.partial_fit <neckid.LinearARX.partial_fit>`) before its free run on
            the new data feeds the SM map; ``False`` keeps it.

        Returns
        -------
        ParallelSetMembership
            ``self``; ``sm_.last_invalidation_`` holds the invalidation of the new data by the
            SM prior as it stood (with the linear model as it stood, the regressor of the data
            set).

        Notes
        -----
        Not a refit: the SM data set keeps the old points as they were, computed from the free
        run of the *old* linear model (the training inputs are not stored, so they cannot be
        recomputed); only the new points come from the updated one. With ``update_linear`` the
        linear part equals its refit on all the data, and the SM map is then slightly
        inconsistent with it on the old points; with ``update_linear=False`` every point of the
        map refers to the same linear model.
        """
        experiments = update_experiments(self, data)
        invalidation = self.invalidation(experiments)
        if update_linear:
            self.linear_.partial_fit(experiments)
        augmented = [self._linear_run(d, f"data[{i}]") for i, d in enumerate(experiments)]
        self.sm_.partial_fit(augmented, prior=prior)
        self.sm_.last_invalidation_ = invalidation
        self._set_fitted_attributes()
        extend_training_ranges(self, experiments)
        return self

    def simulator(self) -> ParallelSetMembershipSimulator:
        """A stateful simulator with ``reset(y0=..., u0=...)`` and ``step(u) -> y``."""
        check_is_fitted(self)
        return ParallelSetMembershipSimulator(self)

    def state_map(self, bounds: bool = False) -> ParallelStateMap | StatefulParallelStateMap:
        """The model's state functions, for python-control (:func:`neckid.export.control.to_iosystem`).

        Parameters
        ----------
        bounds : bool, default False
            Add the outputs ``<output>_lower`` and ``<output>_upper`` (the step's band).

        Returns
        -------
        ParallelStateMap or StatefulParallelStateMap
            On a NARX base (ARX, polynomial): the base's simulated outputs
            (``<output>_linear``) and the inputs, ``max(max_lag_, 1)`` rows each, oldest first.
            On a base with a state of its own (``ss``, ``pnlss``, ``greybox-neck``): the base's
            state (``base.<name>``), then the SM regressor's history of inputs and base outputs.
        """
        check_is_fitted(self)
        if isinstance(self.linear_, LinearARX | PolynomialNARX):
            return ParallelStateMap(self, bounds, LINEAR_SUFFIX)
        if not callable(getattr(self.linear_, "state_map", None)):
            raise TypeError(
                f"the base {type(self.linear_).__name__} (base={self.base!r}) has no state"
                " functions: simulate this model with model.simulator() instead"
            )
        return StatefulParallelStateMap(self, bounds, LINEAR_SUFFIX)

    def _check_state(self) -> None:
        super()._check_state()
        self.linear_._check_state()
        self.sm_._check_state()
        if self.max_lag_ != max(self.linear_.max_lag_, self.sm_.max_lag_):
            raise ValueError(f"max_lag {self.max_lag_!r} does not fit the linear and SM parts")

    # ------------------------------------------------------------------ files
    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        linear_arrays, linear_meta = self.linear_._get_state()
        sm_arrays, sm_meta = self.sm_._get_state()
        arrays = {f"linear__{k}": v for k, v in linear_arrays.items()}
        arrays.update({f"sm__{k}": v for k, v in sm_arrays.items()})
        meta = {
            "params": {
                "linear_lags": list(check_lag_list(self.linear_lags, "linear_lags")),
                "input_lags": list(check_lag_list(self.input_lags, "input_lags")),
                "parallel_degree": int(self.parallel_degree),
                "parallel_fit": str(self.parallel_fit),
                "estimate": str(self.estimate),
                "base": self.base if isinstance(self.base, str) else None,
            },
            "parallel_class": type(self.linear_).__name__,
            "lags": self.lags_.to_dict(),
            **self._channels_meta(),
            "linear": linear_meta,
            "sm": sm_meta,
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
    ) -> ParallelSetMembership:
        def part(prefix: str) -> dict[str, NDArray[Any]]:
            return {k[len(prefix) :]: v for k, v in arrays.items() if k.startswith(prefix)}

        import importlib

        from neckid.registry import model_classes

        model = cls(None, **meta["params"])
        parallel = {k: v for k, v in model_classes().items() if not k.endswith("SetMembership")}
        kind = meta.get("parallel_class", "LinearARX")
        if kind not in parallel:
            raise ValueError(f"parallel_class must be one of {sorted(parallel)}; got {kind!r}")
        found = getattr(importlib.import_module(parallel[kind]), kind)
        model.linear_ = found._from_state(part("linear__"), meta["linear"])
        model.sm_ = SetMembership._from_state(part("sm__"), meta["sm"])
        resolved = ResolvedLags.from_dict(meta["lags"]) if "lags" in meta else None
        model.lags = resolved.to_lags() if resolved is not None else model.linear_.lags
        sm_params = model.sm_.get_params()
        for name in model._SM_PARAMETERS:
            setattr(model, name, sm_params[name])
        model.ts_ = model.linear_.ts_
        model._restore_channels(meta, getattr(model.linear_, "lags_", resolved))
        model._set_fitted_attributes(resolved)
        return model


class ParallelSetMembershipSimulator:
    """Step-by-step run of a fitted :class:`ParallelSetMembership`, with each step's bounds.

    ``step(u)`` advances the linear model and returns the model's estimate; after it,
    :attr:`lower` and :attr:`upper` hold that step's bounds. ``reset(y0, u0)`` sets the initial
    conditions: a single row (repeated) or ``max_lag_`` rows, oldest first, of past outputs and
    inputs; the linear model's simulated output starts equal to the past outputs.
    """

    def __init__(self, model: ParallelSetMembership) -> None:
        self._model = model
        self.n_inputs = model.n_inputs_
        self.n_outputs = model.n_outputs_
        self._linear = model.linear_.simulator()
        self._sm_lags = model.sm_.lags_
        self.lower: FloatArray = np.full(self.n_outputs, np.nan)
        self.upper: FloatArray = np.full(self.n_outputs, np.nan)
        self.reset()

    def reset(self, y0: ArrayLike | None = None, u0: ArrayLike | None = None) -> None:
        """Start again from the given (or zero) past outputs and inputs."""
        m = max(self._model.max_lag_, 1)
        y_hist = history_rows(y0, m, self.n_outputs, "y0")
        u_hist = history_rows(u0, m, self.n_inputs, "u0")
        m_linear = max(int(self._model.linear_.max_lag_), 1)
        self._linear.reset(y_hist[-m_linear:], u_hist[-m_linear:])
        # SM regressor history: the measured inputs, then the simulated outputs.
        self._v = np.hstack([u_hist, y_hist])
        self.lower = np.full(self.n_outputs, np.nan)
        self.upper = np.full(self.n_outputs, np.nan)

    def step_bounds(self, u: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Advance one sample with input ``u``; return ``(y, lower, upper)``, each ``(n_outputs,)``."""
        u_now = np.asarray(u, dtype=np.float64).reshape(-1)
        y_linear = self._linear.step(u_now)  # checks the shape and finiteness of u
        self._v = np.vstack([self._v, np.concatenate([u_now, y_linear])[None, :]])
        t = self._v.shape[0] - 1
        w = self._sm_lags.regressor_from_history(np.empty((t + 1, 0)), self._v, t)
        bounds = self._model.sm_.core_.bounds(np.ascontiguousarray(w[None, :]))
        self._v = self._v[1:]
        self.lower = bounds.lower[0].copy()
        self.upper = bounds.upper[0].copy()
        y = self._model._estimate(bounds.central[0], y_linear, self.lower, self.upper)
        return np.array(y, dtype=np.float64), self.lower.copy(), self.upper.copy()

    def step(self, u: ArrayLike) -> FloatArray:
        """Advance one sample with input ``u`` (shape ``(n_inputs,)``); return ``y``."""
        return self.step_bounds(u)[0]
