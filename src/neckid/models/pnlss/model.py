r"""PolynomialStateSpace: the polynomial nonlinear state-space model (PNLSS, ``pnlss``).

.. math::

    x(t+1) = A x(t) + B u(t) + E ζ(x(t), u(t)), \qquad
    y(t) = C x(t) + D u(t) + c + F η(x(t), u(t)),

``ζ`` the monomials of degree 2 … ``degree`` of ``[x; u]`` and ``η`` those of the states alone
(of ``[x; u]`` with ``feedthrough=True``), in internal units: inputs scaled to ``[-1, 1]`` of
their training range, outputs to zero mean and unit standard deviation, each state to ``[-1,
1]`` of its range over the start's training free run. Outside that box widened by
``hold_margin`` the monomials hold their value (the linear terms go on), as in the polynomial
NARX. The start is the linear ``ss`` model (:class:`~neckid.models.linear.SubspaceStateSpace`,
not refined: the free-run fit refines every linear matrix itself; ``E = F = 0``); Levenberg–Marquardt (:mod:`neckid.models.levenberg`) then minimises the
free-run error with the exact Jacobian of the forward sensitivity recursion (:mod:`._kernels`). A trial step whose free
run on the training data leaves the divergence envelope is stopped there with a large error,
so it is rejected; the fitted model never runs away on its training data.

References
----------
J. Paduart, L. Lauwers, J. Swevers, K. Smolders, J. Schoukens, R. Pintelon, "Identification of
nonlinear systems using polynomial nonlinear state space models", Automatica 46(4), 647–656,
2010.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import DIVERGENCE_SPANS, Estimator, ModelResult, check_is_fitted
from neckid.models.facts import StateOrder
from neckid.models.levenberg import fit_least_squares
from neckid.models.linear.subspace import StateSpaceSimulator, SubspaceStateSpace
from neckid.models.linear.subspace_steps import estimate_state
from neckid.models.online import extend_training_ranges, update_experiments
from neckid.models.pnlss._kernels import pnlss_run
from neckid.models.pnlss.fitting import FreeRunProblem, Layout, free_run, linear_start
from neckid.regressors import Lags
from neckid.utils.checks import Interval
from neckid.utils.memory import check_allocation
from neckid.utils.types import FloatArray

__all__ = ["PolynomialStateSpace", "PolynomialStateSpaceSimulator"]

logger = logging.getLogger(__name__)

_ARRAYS = ("A", "B", "C", "D", "intercept", "E", "F")
_START = ("start_A", "start_B", "start_C", "start_D", "start_intercept")
_SCALES = ("u_center", "u_scale", "y_center", "y_scale", "center", "scale", "low", "high")


class PolynomialStateSpace(Estimator):
    r"""Polynomial nonlinear state-space model (Paduart et al. 2010), fitted on the free run.

    Parameters
    ----------
    lags : Lags, optional
        Only its ``conditions`` are used (appended as constant inputs); the state takes the
        place of the lags.
    order : int, optional
        States ``n``; ``None`` takes the ``ss`` model's (the largest gap of its singular
        values).
    degree : int, default 3
        Largest total degree of the monomials (2 … ``degree``) in the state and output
        equations.
    horizon : int, optional
        Block rows of the ``ss`` start (default ``max(10, order + 1)``); also ``max_lag_``.
    feedthrough : bool, default False
        ``D`` and the input monomials of ``η`` are estimated; otherwise the output reads the
        states only.
    hold_margin : float, default 0.5
        Beyond the training box ``[-1, 1]`` of each scaled state and input, widened by this
        fraction of its width on each side, the monomials hold their value.
    max_iter : int, default 100
        Largest number of free runs of the nonlinear fit.

    Attributes
    ----------
    A_, B_, C_, D_, intercept_, E_, F_ : ndarray
        The matrices in internal units (``E_``, ``F_``: one column per monomial of
        ``powers_``; zero columns of ``F_`` for the input monomials without feedthrough).
    powers_ : ndarray of int, shape (n_monomials, n + m)
        Exponents of each nonlinear monomial in ``[x; u]``.
    start_A_, start_B_, start_C_, start_D_, start_intercept_ : ndarray
        The linear start; the initial state of a free run is its estimate from the first
        ``max_lag_`` samples (:meth:`initial_state`).
    u_center_, u_scale_, y_center_, y_scale_ : ndarray
        Internal units: ``ũ = (u − u_center) / u_scale``, ``y = y_center + y_scale ỹ``.
    center_, scale_, low_, high_ : ndarray, shape (n + m,)
        The monomials' box: ``z = ([x; ũ] − center) / scale`` held in ``[low, high]``.
    fit_report_ : dict
        ``rmse_start`` and ``rmse`` (training free run, output units), ``evaluations``,
        ``rejected`` (trial runs stopped by the safeguard), ``message``, ``improved``.
    order_, max_lag_, n_inputs_, n_outputs_, n_samples_ : int
    ts_ : float

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> from neckid.models.pnlss import PolynomialStateSpace
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, 1000)
    >>> y = np.zeros(1000)
    >>> for t in range(1, 1000):
    ...     y[t] = 0.6 * y[t - 1] + 0.3 * u[t - 1] - 0.1 * y[t - 1] ** 2
    >>> data = IOData(u, y, ts=0.01)
    >>> model = PolynomialStateSpace(order=1, degree=2, max_iter=30).fit(data)
    >>> bool(model.fit_percent(data)[0] > 99.0)
    True
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "order": [None, Interval("int", 1, None)],
        "degree": [Interval("int", 2, 5)],
        "horizon": [None, Interval("int", 2, None)],
        "feedthrough": ["boolean"],
        "hold_margin": [Interval("real", 0, None)],
        "max_iter": [Interval("int", 1, None)],
    }

    #: The one-step predictor of an output-error model is its free run (``predict`` says so).
    predicts_by_simulation: ClassVar[bool] = True

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        order: int | None = None,
        degree: int = 3,
        horizon: int | None = None,
        feedthrough: bool = False,
        hold_margin: float = 0.5,
        max_iter: int = 100,
    ) -> None:
        self.lags = lags
        self.order = order
        self.degree = degree
        self.horizon = horizon
        self.feedthrough = feedthrough
        self.hold_margin = hold_margin
        self.max_iter = max_iter

    # ------------------------------------------------------------------ fit
    def fit(self, data: IOData | Sequence[IOData]) -> PolynomialStateSpace:
        """The ``ss`` start, then the free-run fit of all matrices (see the module docstring).

        Raises
        ------
        ValueError
            For a bad hyper-parameter, data too short for the ``ss`` start, or a start whose
            free run leaves the divergence envelope on the training data.
        """
        self._validate_params()
        experiments = as_experiments(self._with_conditions(data, fitting=True))
        self._check_training(experiments)
        if isinstance(self.order, int | np.integer):  # the largest allocation, checked first
            self._check_jacobian(experiments, int(self.order))
        ss = SubspaceStateSpace(
            order=self.order,
            horizon=self.horizon,
            feedthrough=bool(self.feedthrough),
            refine=False,
        ).fit(experiments)
        self._set_units(experiments)
        internal = [self._internal(d) for d in experiments]
        start = linear_start(
            ss, self.u_center_, self.u_scale_, self.y_center_, self.y_scale_, internal
        )
        for name, value in zip(_START, start, strict=True):
            setattr(self, f"{name}_", np.ascontiguousarray(value))
        self.order_, self.max_lag_ = int(ss.order_), int(ss.max_lag_)
        self.singular_values_ = ss.singular_values_
        self._set_box(internal)
        n, m, p = self.order_, experiments[0].n_inputs, experiments[0].n_outputs
        layout = Layout(n, m, p, int(self.degree), bool(self.feedthrough))
        k = layout.n_nonlinear
        a, b, c, d, offset = start
        theta = layout.pack((a, b, c, d, offset, np.zeros((n, k)), np.zeros((p, k))))
        self.powers_ = layout.tables()[0][-k:]
        self.n_samples_ = int(sum(d.n_samples for d in experiments))
        self._check_jacobian(experiments, n)
        self._set_channels(experiments[0])
        self._optimise(layout, theta, experiments, int(self.max_iter))
        return self

    def _check_jacobian(self, experiments: Sequence[IOData], order: int) -> None:
        """Refuse a free-run fit whose Jacobian the machine cannot hold, before allocating it."""
        m, p = experiments[0].n_inputs, experiments[0].n_outputs
        layout = Layout(order, m, p, int(self.degree), bool(self.feedthrough))
        size = sum(rows * columns for rows, columns in layout.shapes())
        n_samples = int(sum(d.n_samples for d in experiments))
        check_allocation(
            8.0 * 3 * n_samples * p * size,  # the Jacobian, its copy, the solver's
            f"the free-run fit's Jacobian ({n_samples:,} samples x {p} outputs x"
            f" {size:,} parameters, order {order}, degree {int(self.degree)})",
            "give a smaller order (order=3), a lower degree, or fewer samples",
        )

    def _set_units(self, experiments: Sequence[IOData]) -> None:
        u = np.vstack([d.u for d in experiments])
        y = np.vstack([d.y for d in experiments])
        low, high = u.min(axis=0), u.max(axis=0)
        half = (high - low) / 2.0
        self.u_center_ = (high + low) / 2.0
        self.u_scale_ = np.where(half > 0, half, 1.0)
        spread = y.std(axis=0)
        self.y_center_ = y.mean(axis=0)
        self.y_scale_ = np.where(spread > 0, spread, 1.0)

    def _internal(self, data: IOData) -> tuple[FloatArray, FloatArray]:
        """``(ũ, ỹ)`` of a record, contiguous."""
        u = np.ascontiguousarray((data.u - self.u_center_) / self.u_scale_)
        y = np.ascontiguousarray((data.y - self.y_center_) / self.y_scale_)
        return u, y

    def _set_box(self, internal: Sequence[tuple[FloatArray, FloatArray]]) -> None:
        """The monomials' box: each state's range over the start's free run, inputs as they are."""
        states = np.vstack([free_run(self._start, u, y, self.max_lag_)[1] for u, y in internal])
        low, high = states.min(axis=0), states.max(axis=0)
        half = (high - low) / 2.0
        m = internal[0][0].shape[1]
        self.center_ = np.concatenate([(high + low) / 2.0, np.zeros(m)])
        self.scale_ = np.concatenate([np.where(half > 0, half, 1.0), np.ones(m)])
        reach = 1.0 + 2.0 * float(self.hold_margin)
        self.low_ = np.full(self.center_.size, -reach)
        self.high_ = np.full(self.center_.size, reach)

    @property
    def _start(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        return (
            self.start_A_,
            self.start_B_,
            self.start_C_,
            self.start_D_,
            self.start_intercept_,
        )

    def _problem(self, layout: Layout, experiments: Sequence[IOData]) -> FreeRunProblem:
        """The free-run problem on ``experiments``, initial states from the linear start."""
        m = self.max_lag_
        runs = []
        for d in experiments:
            u, y = self._internal(d)
            x0 = estimate_state(self._start, y[:m], u[:m])
            runs.append((np.ascontiguousarray(u[m:]), np.ascontiguousarray(y[m:]), x0))
        envelope = self.divergence_envelope()
        low = np.array([envelope[name][0] for name in self.output_names_])
        high = np.array([envelope[name][1] for name in self.output_names_])
        limits = ((low - self.y_center_) / self.y_scale_, (high - self.y_center_) / self.y_scale_)
        box = (self.center_, self.scale_, self.low_, self.high_)
        return FreeRunProblem(layout, runs, box, limits)

    def _optimise(
        self, layout: Layout, theta: FloatArray, experiments: Sequence[IOData], budget: int
    ) -> None:
        """Least squares on the free-run error from ``theta``; refuse a diverging start."""
        problem = self._problem(layout, experiments)
        start = theta[problem.free]
        errors = problem.residuals(start)
        if problem.diverged:
            raise ValueError(
                "the start's free run leaves the divergence envelope (training range widened"
                f" {DIVERGENCE_SPANS:g} times its width) on the training data; the model is"
                " unstable there: fit anew (fit) instead of continuing from it"
            )
        cost = float(np.sum(errors**2))
        solution = fit_least_squares(
            problem.residuals, start, problem.jacobian, max_nfev=budget, f0=errors
        )
        rejected = problem.diverged
        final = problem.run(problem.full(solution.x))
        improved = bool(
            np.all(np.isfinite(final)) and problem.diverged == rejected and 2 * solution.cost < cost
        )
        theta = problem.full(solution.x if improved else start)
        for name, value in zip(_ARRAYS, layout.unpack(theta), strict=True):
            setattr(self, f"{name}_", value)
        scale = self.y_scale_

        def rmse(e: FloatArray) -> list[float]:
            return [float(v) for v in np.sqrt(np.mean(e.reshape(-1, scale.size) ** 2, 0)) * scale]

        self.fit_report_: dict[str, Any] = {
            "rmse_start": rmse(errors),
            "rmse": rmse(final if improved else errors),
            "evaluations": int(solution.nfev),
            "rejected": int(rejected),
            "improved": improved,
            "message": str(solution.message),
        }
        logger.info("PNLSS fit: %s", self.fit_report_)

    def partial_fit(
        self, data: IOData | Sequence[IOData], *, max_iter: int = 20
    ) -> PolynomialStateSpace:
        """Continue the free-run fit from the current matrices on ``data`` (an update, not a refit).

        The internal units, the monomials' box and the initial-state estimator stay those of
        :meth:`fit`; the training ranges (and so the divergence envelope) widen to the new
        data. At most ``max_iter`` free runs. To fit old and new data together from the
        start, call ``fit([old, new])``.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            For data on other channels or another sampling period, too short, or on which the
            current model's free run already leaves the divergence envelope.
        """
        experiments = update_experiments(self, data)
        extend_training_ranges(self, experiments)
        layout = Layout(
            self.order_, self.n_inputs_, self.n_outputs_, int(self.degree), bool(self.feedthrough)
        )
        theta = layout.pack(self.matrices_)
        self._optimise(layout, theta, experiments, int(max_iter))
        self.n_samples_ += int(sum(d.n_samples for d in experiments))
        return self

    # ------------------------------------------------------------------ use
    def state_order(self) -> StateOrder | None:
        """The order and the singular values of the ``ss`` start it came from (fitted)."""
        check_is_fitted(self)
        values = getattr(self, "singular_values_", None)
        return None if values is None else StateOrder(int(self.order_), values)

    @property
    def matrices_(
        self,
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """``(A_, B_, C_, D_, intercept_, E_, F_)`` (internal units)."""
        check_is_fitted(self)
        return self.A_, self.B_, self.C_, self.D_, self.intercept_, self.E_, self.F_

    def initial_state(self, y_rows: ArrayLike, u_rows: ArrayLike) -> FloatArray:
        """The state after ``max_lag_`` samples: the linear start's least-squares estimate.

        Parameters
        ----------
        y_rows : array_like, shape (max_lag_, n_outputs)
        u_rows : array_like, shape (max_lag_, n_inputs)

        Returns
        -------
        ndarray, shape (order_,)
            Estimated with the linear start (``start_*_``), nonlinear terms left out: the fit
            ran every training experiment from this same estimate.
        """
        check_is_fitted(self)
        y = (np.asarray(y_rows, dtype=np.float64) - self.y_center_) / self.y_scale_
        u = (np.asarray(u_rows, dtype=np.float64) - self.u_center_) / self.u_scale_
        return estimate_state(self._start, np.ascontiguousarray(y), np.ascontiguousarray(u))

    def run(self, u: FloatArray, x: FloatArray) -> FloatArray:
        """Free run of inputs ``u`` (output units) from internal state ``x`` (updated in place)."""
        scaled = np.ascontiguousarray((u - self.u_center_) / self.u_scale_)
        out = np.empty((u.shape[0], self.n_outputs_))
        unbounded = np.full(self.n_outputs_, np.inf)
        box = (self.center_, self.scale_, self.low_, self.high_)
        _, parent, var, _ = Layout(
            self.order_, self.n_inputs_, self.n_outputs_, int(self.degree), False
        ).tables()
        with np.errstate(all="ignore"):
            pnlss_run(*self.matrices_, scaled, x, *box, parent, var, -unbounded, unbounded, out)
        return out * self.y_scale_ + self.y_center_

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free run from the state :meth:`initial_state` estimates on the first ``max_lag_`` samples.

        Parameters
        ----------
        data : IOData
            The inputs; its first ``max_lag_`` measured outputs give the initial state unless
            ``initial`` is given (then ``data`` may hold inputs only).
        initial : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
            The first outputs (oldest first; one row is repeated).
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y = self._initial_outputs(data, initial)
        m = self.max_lag_
        x = self.initial_state(y[:m], data.u[:m])
        y[m:] = self.run(np.asarray(data.u[m:], dtype=np.float64), x)
        return self._result("simulation", data, y)

    def predict(self, data: IOData) -> ModelResult:
        """The free run of :meth:`simulate`, with ``kind="simulation"``.

        An output-error model has no measured output in its state equation: its one-step
        predictor is its simulation.
        """
        return self.simulate(data)

    def simulator(self) -> PolynomialStateSpaceSimulator:
        """A stateful simulator: ``reset(y0, u0)`` then ``step(u) -> y`` (same values as simulate)."""
        check_is_fitted(self)
        return PolynomialStateSpaceSimulator(self)

    def state_map(self, bounds: bool = False) -> Any:
        """The model's state functions, for python-control (:func:`neckid.export.control.to_iosystem`).

        Parameters
        ----------
        bounds : bool, default False
            Ignored (the model has no band).

        Returns
        -------
        PolynomialStateMap
            State: the ``order_`` internal states; the same floats as :meth:`simulator`.
        """
        from neckid.models.pnlss.state_map import PolynomialStateMap

        check_is_fitted(self)
        return PolynomialStateMap(self)

    # ------------------------------------------------------------------ files
    def _check_state(self) -> None:
        super()._check_state()
        n, m, p = int(self.order_), self.n_inputs_, self.n_outputs_
        layout = Layout(n, m, p, int(self.degree), bool(self.feedthrough))
        k = layout.n_nonlinear
        shapes = dict(zip("ABECDcF", layout.shapes(), strict=True))
        for name, key in zip(_ARRAYS, "ABCDcEF", strict=True):
            shape = (p,) if key == "c" else shapes[key]
            self._check_shape(name, getattr(self, f"{name}_"), shape)
            if key in "ABCDc":
                self._check_shape(f"start_{name}", getattr(self, f"start_{name}_"), shape)
        for name in _SCALES:
            size = (
                n + m if name in ("center", "scale", "low", "high") else (m if "u_" in name else p)
            )
            self._check_shape(name, getattr(self, f"{name}_"), (size,))
        self._check_shape("powers", self.powers_, (k, n + m))
        expected = layout.tables()[0][-k:] if k else np.zeros((0, n + m), dtype=np.int64)
        if not np.array_equal(self.powers_, expected):
            row = int(np.flatnonzero(np.any(self.powers_ != expected, axis=1))[0])
            raise ValueError(
                f"powers row {row} is {self.powers_[row].tolist()}, but a degree-{self.degree}"
                f" model of order {n} with {m} input(s) has the monomial"
                f" {expected[row].tolist()} there: the powers must be the ones the model computes"
                " (the file is damaged or edited)"
            )
        window = np.flatnonzero(~(np.isfinite(self.low_) & np.isfinite(self.high_)))
        window = window if window.size else np.flatnonzero(~(self.low_ < self.high_))
        if window.size:
            j = int(window[0])
            raise ValueError(
                f"the monomial window [low, high] of variable {j} is [{self.low_[j]:g},"
                f" {self.high_[j]:g}]: it must be two finite numbers with low < high"
            )
        if not (
            np.all(self.u_scale_ > 0) and np.all(self.y_scale_ > 0) and np.all(self.scale_ > 0)
        ):
            raise ValueError("u_scale, y_scale and scale must be > 0")
        if self.max_lag_ < 1:
            raise ValueError(f"max_lag must be >= 1; got {self.max_lag_}")

    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        names = (*_ARRAYS, *_START, *_SCALES, "powers", "singular_values")
        arrays = {name: getattr(self, f"{name}_") for name in names}
        params = self.get_params(deep=False)
        lags = params.pop("lags")
        meta = {
            "params": params,
            "conditions": None if lags is None else list(lags.conditions),
            "ts": self.ts_,
            "n_samples": self.n_samples_,
            "order": self.order_,
            "max_lag": self.max_lag_,
            "fit_report": self.fit_report_,
            **self._channels_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
    ) -> PolynomialStateSpace:
        conditions = meta.get("conditions")
        lags = None if conditions is None else Lags([1], [1], conditions=conditions)
        model = cls(lags, **meta["params"])
        model._restore_channels(meta)
        model.ts_ = float(meta["ts"])
        model.n_samples_ = int(meta["n_samples"])
        model.order_, model.max_lag_ = int(meta["order"]), int(meta["max_lag"])
        model.fit_report_ = dict(meta.get("fit_report", {}))
        for name in (*_ARRAYS, *_START, *_SCALES, "singular_values"):
            setattr(model, f"{name}_", np.ascontiguousarray(arrays[name], dtype=np.float64))
        model.powers_ = np.asarray(arrays["powers"], dtype=np.int64)
        return model


class PolynomialStateSpaceSimulator(StateSpaceSimulator):
    """Step-by-step free run of a :class:`PolynomialStateSpace`, for closed loops.

    ``reset(y0, u0)`` estimates the state from ``max_lag_`` past outputs and inputs
    (:meth:`PolynomialStateSpace.initial_state`); ``reset()`` without outputs starts from the
    internal state ``x = 0`` (the linear start at rest at mid-range inputs). ``step(u)`` returns
    ``y(t)`` and advances the state with the arithmetic of ``simulate``.
    """

    def _advance(self, row: FloatArray) -> FloatArray:
        """``y(t)`` of one input row, the state moved on with the arithmetic of ``simulate``."""
        return np.asarray(self._model.run(row, self.x)[0], dtype=np.float64)
