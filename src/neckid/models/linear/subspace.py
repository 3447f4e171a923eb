r"""SubspaceStateSpace: a linear state-space model identified by subspace methods (``ss``).

.. math::

    x(t+1) = A\,x(t) + B\,u(t) + K\,e(t), \qquad y(t) = C\,x(t) + D\,u(t) + c + e(t)

(MATLAB's ``n4sid`` model). The identification is PO-MOESP with least squares for ``B``, ``D``
and ``c`` on the free run from the initial state of each run's first samples, a refinement of
that free-run error and a Kalman gain by Hannan–Rissanen regression: each step is a function of
:mod:`.subspace_steps`, whose docstring gives the equations; the order from the singular
values or, with ``order="folds"``, on held-out runs (:mod:`.subspace_order`); the documentation page
``docs/subspace.md`` gives the whole method.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from threadpoolctl import threadpool_limits

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import Estimator, ModelResult, check_is_fitted
from neckid.models.excitation import check_excitation
from neckid.models.facts import StateOrder
from neckid.models.linear.subspace_order import order_by_folds
from neckid.models.linear.subspace_refine import refine_free_run
from neckid.models.linear.subspace_sizes import check_subspace_sizes
from neckid.models.linear.subspace_steps import (
    STABILITY_MARGIN,
    bound_modes,
    choose_order,
    estimate_state,
    initial_states,
    innovations,
    kalman_gain,
    observability_basis,
    output_error_regression,
    past_future_factor,
    predictor_run,
    shift_invariance,
    spectral_radius,
    state_space_run,
)
from neckid.models.online import update_experiments
from neckid.regressors import Lags
from neckid.systems import StateMap, history_rows, input_row
from neckid.utils.checks import Interval, Options
from neckid.utils.progress import task
from neckid.utils.types import FloatArray

__all__ = ["StateSpaceMap", "StateSpaceSimulator", "SubspaceStateSpace"]

#: Block rows of the past and of the future when ``horizon`` is not given (at least order + 1).
DEFAULT_HORIZON = 10

Matrices = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]


class SubspaceStateSpace(Estimator):
    r"""Linear state-space model by subspace identification (PO-MOESP), MIMO, stable.

    ``x(t+1) = A x(t) + B u(t)``, ``y(t) = C x(t) + D u(t) + c`` for the free run, plus the
    Kalman gain ``K`` of the innovation form for the one-step prediction.

    Parameters
    ----------
    lags : Lags, optional
        Only its ``conditions`` are used (experimental conditions appended as constant inputs,
        as for every model); the state takes the place of the regressor's lags.
    order : int or "folds", optional
        State dimension ``n``. ``None`` chooses it at the largest gap of the singular values
        (``singular_values_``), from 1 to ``(horizon − 1) × n_outputs``; ``"folds"``, with two
        or more experiments, on held-out runs: each held out in turn, the smallest order within
        one standard error of the best mean free-run fit
        (:func:`~neckid.models.linear.subspace_order.order_by_folds`).
    horizon : int, optional
        Block rows ``i`` of the past and of the future in the Hankel matrices (default
        ``max(10, order + 1)``). It is also ``max_lag_``: the free run starts from the state
        estimated on the first ``i`` samples.
    feedthrough : bool, default False
        Estimate ``D`` (the output reads ``u(t)``); otherwise ``D = 0``, as for a plant with
        at least one sample of delay.
    fit_intercept : bool, default True
        Estimate the output offset ``c`` (and centre the Hankel matrices).
    max_time_constant : float, optional
        Slowest time constant [s] a mode may have: every eigenvalue of ``A`` is kept within
        ``exp(−ts / max_time_constant)`` (the subspace estimate's slower modes moved onto that
        circle, the refinement held inside it). ``None``: stability alone. A mode slower than
        the records is an integrator over them and drifts on any input bias of a new run; a
        fifth of the longest record
        (:func:`~neckid.models.linear.subspace_steps.slowest_mode_radius`) bounds it, at a
        cost on the soft-neck logs (``docs/subspace.md``).
    refine : bool, default True
        Refine all matrices and ``c`` on the free-run error, every run from the state of its
        first ``horizon`` samples as in :meth:`simulate` (Levenberg–Marquardt on compiled
        sensitivities, :mod:`~neckid.models.linear.subspace_refine`);
        kept only if stable and better.
    max_iter : int, default 100
        Function evaluations of the refinement.

    Attributes
    ----------
    A_, B_, C_, D_ : ndarray
        ``(n, n)``, ``(n, n_inputs)``, ``(n_outputs, n)``, ``(n_outputs, n_inputs)``; every
        eigenvalue of ``A_`` lies within ``mode_radius_`` (inside the unit circle).
    mode_radius_ : float
        ``exp(−ts / max_time_constant)`` (see ``max_time_constant``).
    intercept_ : ndarray, shape (n_outputs,)
        ``c``.
    kalman_gain_ : ndarray, shape (n, n_outputs)
        ``K`` (zeros when it did not lower the one-step error on the training data).
    singular_values_ : ndarray
        Of the PO-MOESP matrix, on signals scaled to unit standard deviation: the order's
        evidence (``order_`` of them stand out).
    order_, horizon_ : int
    order_rule_ : str
        How ``order_`` was set: ``"given"``, ``"folds"`` or
        ``"singular values"`` (one).
    order_fold_fits_ : ndarray, shape (n_candidates, n_experiments)
        With ``order_rule_ == "folds"``: row ``k`` the free-run fit [%] of order ``k + 1`` on
        each held-out experiment (unrefined); otherwise empty.
    stabilised_ : bool
        The least-squares ``A`` was unstable and Maciejowski's stable estimate replaced it.
    bounded_ : bool
        The subspace ``A`` had a mode beyond ``mode_radius_``; it was moved onto that circle
        (:func:`~neckid.models.linear.subspace_steps.bound_modes`).
    refined_ : bool
        The refinement was run and kept.
    max_lag_ : int
        ``horizon_``: samples a free run takes its initial state from.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> from neckid.models.linear import SubspaceStateSpace
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=400)
    >>> y = np.zeros(400)
    >>> for t in range(2, 400):
    ...     y[t] = 1.5 * y[t - 1] - 0.7 * y[t - 2] + u[t - 1]
    >>> model = SubspaceStateSpace(refine=False).fit(IOData(u, y, ts=0.1))
    >>> model.order_, np.round(np.sort(np.abs(np.linalg.eigvals(model.A_))), 4)
    (2, array([0.8367, 0.8367]))
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "order": [None, Interval("int", 1, None), Options({"folds"})],
        "horizon": [None, Interval("int", 2, None)],
        "max_time_constant": [None, Interval("real", 0.0, None, closed="neither")],
        "feedthrough": ["boolean"],
        "fit_intercept": ["boolean"],
        "refine": ["boolean"],
        "max_iter": [Interval("int", 1, None)],
    }

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        order: int | Literal["folds"] | None = None,
        horizon: int | None = None,
        max_time_constant: float | None = None,
        feedthrough: bool = False,
        fit_intercept: bool = True,
        refine: bool = True,
        max_iter: int = 100,
    ) -> None:
        self.lags = lags
        self.order = order
        self.horizon = horizon
        self.max_time_constant = max_time_constant
        self.feedthrough = feedthrough
        self.fit_intercept = fit_intercept
        self.refine = refine
        self.max_iter = max_iter

    # ------------------------------------------------------------------ fit
    def fit(self, data: IOData | Sequence[IOData]) -> SubspaceStateSpace:
        """Identify the model on one experiment or a list (no Hankel window straddles two).

        Raises
        ------
        ValueError
            For a bad hyper-parameter, data too short for the horizon, or an ``order`` the
            horizon cannot hold (``order <= (horizon − 1) × n_outputs``), or ``order="folds"``
            with a single experiment.
        """
        self._validate_params()
        experiments = as_experiments(self._with_conditions(data, fitting=True))
        self._check_training(experiments)
        check_excitation(type(self).__name__, experiments, skip=self._condition_names(True))
        self._fit_experiments(experiments, self.order)
        return self

    def _horizon(self, order: int | str | None) -> int:
        if self.horizon is not None:
            return int(self.horizon)
        return max(DEFAULT_HORIZON, (int(order) if isinstance(order, numbers.Integral) else 0) + 1)

    def _check_order_fits(self, experiments: Sequence[IOData], order: int, horizon: int) -> None:
        """Refuse, in terms of ``order``, an order whose horizon (order + 1) the logs cannot hold.

        The past-future regression needs more windows of ``2 * horizon`` samples than it has
        columns (``2 * horizon * (m + p)``, plus the intercept's).
        """
        m, p = experiments[0].n_inputs, experiments[0].n_outputs
        lengths = [d.n_samples for d in experiments]

        def fits(i: int) -> bool:
            windows = sum(max(0, n - 2 * i + 1) for n in lengths)
            return windows >= 2 * i * (m + p) + bool(self.fit_intercept)

        if fits(horizon):
            return

        def refinable(i: int) -> bool:  # the free-run refinement's unknowns, order i - 1
            k, values = i - 1, sum(max(0, n - i) for n in lengths) * p
            return k * k + k * m + p * k + p * m + p <= values

        candidates = range(DEFAULT_HORIZON, max(lengths) // 2 + 1)
        largest = max((i for i in candidates if fits(i) and refinable(i)), default=0)
        hint = (
            f"give an order of at most {(largest - 1) * p}" if largest > 1 else "no order fits them"
        )
        raise ValueError(
            f"order={order} is too high for these logs ({', '.join(map(str, lengths))} samples):"
            f" an order-{order} model regresses on windows of {2 * horizon} samples (horizon"
            f" {horizon} = order + 1, past and future) and they do not hold enough of them; {hint},"
            " or give longer logs"
        )

    def _scales(self, experiments: Sequence[IOData]) -> tuple[FloatArray, FloatArray]:
        """Standard deviation of every input and output channel (1 for a constant one)."""
        u = np.vstack([d.u for d in experiments])
        y = np.vstack([d.y for d in experiments])
        su, sy = u.std(axis=0), y.std(axis=0)
        su[~(su > 0)] = 1.0
        sy[~(sy > 0)] = 1.0
        return su, sy

    def _fit_experiments(self, experiments: Sequence[IOData], order: int | str | None) -> None:
        """:meth:`_identify` with one BLAS thread.

        Its matrices are tall and narrow (windows or samples by at most a few hundred
        columns), where a second BLAS thread gains little on a quiet machine and, on a busy
        one, loses many times over to threads waiting for a core (``docs/performance.md``).
        """
        with threadpool_limits(limits=1, user_api="blas"):
            self._identify(experiments, order)

    def _identify(self, experiments: Sequence[IOData], order: int | str | None) -> None:
        su, sy = self._scales(experiments)
        scaled = [(d.u / su, d.y / sy) for d in experiments]
        i = self._horizon(order)
        m, p = experiments[0].n_inputs, experiments[0].n_outputs
        if self.horizon is None and isinstance(order, numbers.Integral):
            self._check_order_fits(experiments, int(order), i)
        intercept, feedthrough = bool(self.fit_intercept), bool(self.feedthrough)
        factor = past_future_factor(scaled, i, intercept)
        left, values = observability_basis(factor, i, m, p)
        largest = max(1, min((i - 1) * p, int(np.sum(values > 0))))
        radius = self._mode_radius(experiments)
        self.order_rule_, self.order_fold_fits_ = "given", np.zeros((0, len(experiments)))
        if isinstance(order, numbers.Integral):
            n = int(order)
        elif order == "folds":
            too_short = [k for k, (u, _) in enumerate(scaled) if u.shape[0] <= 2 * i]
            if len(experiments) < 2 or too_short:
                raise ValueError(
                    "order='folds' holds each experiment out in turn: it needs two or more,"
                    f" each longer than 2 * horizon = {2 * i} samples; got {len(experiments)}"
                    f" (too short: {too_short}); give order=None or an order"
                )
            self.order_rule_ = "folds"
            options = (feedthrough, intercept)
            n, self.order_fold_fits_ = order_by_folds(scaled, i, largest, options, radius, sy)
        else:
            self.order_rule_ = "singular values"
            n = choose_order(values, largest)
        if n > (i - 1) * p:
            raise ValueError(
                f"order {n} needs horizon > order / n_outputs + 1 = {n // p + 1}: the"
                f" observability matrix of horizon={i} block rows holds at most order"
                f" {(i - 1) * p}; raise horizon"
            )
        lengths = [d.n_samples for d in experiments]
        check_subspace_sizes(
            lengths, m, p, n, i, refine=bool(self.refine), feedthrough=feedthrough,
            intercept=intercept,
        )  # fmt: skip
        a, c, self.stabilised_ = shift_invariance(left, values, n, p)
        a, self.bounded_ = bound_modes(a, radius)
        b, d, offset, _ = output_error_regression(a, c, scaled, feedthrough, intercept, i, sy)
        matrices: Matrices = (a, b, c, d, offset)
        self.refined_ = False
        if self.refine:
            with task(f"state-space free-run refinement (order {n})"):  # a line every 10 s
                refined = refine_free_run(
                    matrices, scaled, feedthrough, intercept, int(self.max_iter), i, radius, sy
                )
            self.refined_ = refined is not matrices
            matrices = refined
        x0s = initial_states(matrices, scaled, i, sy)
        gain = kalman_gain(matrices, x0s, scaled, innovations(scaled, i, feedthrough, intercept))
        a, b, c, d, offset = matrices
        self.A_ = np.ascontiguousarray(a)
        self.B_ = np.ascontiguousarray(b / su[None, :])
        self.C_ = np.ascontiguousarray(c * sy[:, None])
        self.D_ = np.ascontiguousarray(d * sy[:, None] / su[None, :])
        self.intercept_ = np.asarray(offset * sy, dtype=np.float64)
        self.kalman_gain_ = np.ascontiguousarray(gain / sy[None, :])
        self.singular_values_ = np.asarray(values, dtype=np.float64)
        self.mode_radius_ = radius
        self.order_, self.horizon_ = n, i
        self.n_samples_ = int(sum(d.n_samples for d in experiments))
        self._set_channels(experiments[0])
        self.max_lag_ = i

    def _mode_radius(self, experiments: Sequence[IOData]) -> float:
        """``exp(−ts / max_time_constant)``; just inside the unit circle without it."""
        if self.max_time_constant is None:
            return 1.0 - STABILITY_MARGIN
        radius = np.exp(-float(experiments[0].ts) / float(self.max_time_constant))
        return float(min(radius, 1.0 - STABILITY_MARGIN))

    def partial_fit(self, data: IOData | Sequence[IOData]) -> SubspaceStateSpace:
        """Refit on ``data`` alone, keeping the order found by :meth:`fit` (not an update).

        A subspace estimate has no statistics that add up over records (the LQ factor does,
        but ``B``, ``D``, the refinement and the gain are computed on the data themselves), so
        this is a new identification on the new experiments, of the same order, and the
        training ranges become theirs. To identify on old and new data together, call
        ``fit([old, new])``.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            For data on other channels or another sampling period, or too short.
        """
        experiments = update_experiments(self, data)
        self._validate_params()
        self._check_training(experiments)
        self._fit_experiments(experiments, self.order_)
        return self

    # ------------------------------------------------------------------ use
    def state_order(self) -> StateOrder:
        """The order and the singular values it was read from (fitted)."""
        check_is_fitted(self)
        return StateOrder(int(self.order_), self.singular_values_)

    @property
    def matrices_(self) -> Matrices:
        """``(A_, B_, C_, D_, intercept_)``."""
        check_is_fitted(self)
        return self.A_, self.B_, self.C_, self.D_, self.intercept_

    def initial_state(self, y_rows: ArrayLike, u_rows: ArrayLike) -> FloatArray:
        """The state after ``max_lag_`` samples, from those outputs and inputs (least squares).

        Parameters
        ----------
        y_rows : array_like, shape (max_lag_, n_outputs)
        u_rows : array_like, shape (max_lag_, n_inputs)

        Returns
        -------
        ndarray, shape (order_,)
            ``x(max_lag_)``: the state that best explains the given samples, run over them.
        """
        check_is_fitted(self)
        y = np.ascontiguousarray(y_rows, dtype=np.float64)
        u = np.ascontiguousarray(u_rows, dtype=np.float64)
        return estimate_state(self.matrices_, y, u)

    def predict(self, data: IOData) -> ModelResult:
        """One step ahead by the steady-state Kalman predictor ``A − K C`` (``K = kalman_gain_``).

        The predictor starts at sample ``max_lag_`` from the state :meth:`initial_state` fits
        to the first ``max_lag_`` samples (those are the measured outputs in the result).
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y0 = self._initial_outputs(data, None)
        m = self.max_lag_
        x = self.initial_state(y0[:m], data.u[:m])
        a, b, c, d, offset = self.matrices_
        y = y0.copy()
        with np.errstate(over="ignore", invalid="ignore"):
            y[m:] = predictor_run(
                a, b, c, d, offset, self.kalman_gain_,
                np.ascontiguousarray(data.u[m:]), np.ascontiguousarray(y0[m:]), x,
            )  # fmt: skip
        return self._result("prediction", data, y)

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free run from the state fitted to the first ``max_lag_`` samples.

        Parameters
        ----------
        data : IOData
            The inputs; its first ``max_lag_`` measured outputs give the initial state unless
            ``initial`` is given (then ``data`` may hold inputs only).
        initial : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
            The first outputs (oldest first; one row is repeated).

        Returns
        -------
        ModelResult
            Of kind ``"simulation"``; its first ``max_lag_`` samples are the initial outputs.
            From sample ``max_lag_`` on, ``x`` starts at :meth:`initial_state` of the first
            ``max_lag_`` outputs and inputs and runs on the inputs alone.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y = self._initial_outputs(data, initial)
        m = self.max_lag_
        x = self.initial_state(y[:m], data.u[:m])
        with np.errstate(over="ignore", invalid="ignore"):
            y[m:] = state_space_run(*self.matrices_, np.ascontiguousarray(data.u[m:]), x)[0]
        return self._result("simulation", data, y)

    def transfer_matrix(self) -> tuple[list[list[FloatArray]], FloatArray]:
        r"""``G(z) = C (zI − A)^{-1} B + D`` as numerators over the common denominator ``det(zI − A)``.

        Returns
        -------
        (numerators, denominator)
            ``numerators[o][j]`` (from input ``j`` to output ``o``) and the denominator:
            polynomial coefficients in ``z``, highest power first, ``order_ + 1`` of each. The
            offset ``intercept_`` is not part of ``G``.

        Notes
        -----
        For one input and one output, ``c (zI − A)^{-1} b = (det(zI − A + b c) − det(zI − A))
        / det(zI − A)`` (the matrix determinant lemma), so each element is a difference of two
        characteristic polynomials (``numpy.poly``), without any matrix inversion.
        """
        a, b, c, d, _ = self.matrices_
        denominator = np.poly(a) if a.size else np.ones(1)
        numerators = [
            [
                np.poly(a - b[:, j : j + 1] @ c[o : o + 1, :]) - denominator + d[o, j] * denominator
                for j in range(b.shape[1])
            ]
            for o in range(c.shape[0])
        ]
        return numerators, np.asarray(denominator, dtype=np.float64)

    def simulator(self) -> StateSpaceSimulator:
        """A stateful simulator: ``reset(y0, u0)`` then ``step(u) -> y`` (same values as simulate)."""
        check_is_fitted(self)
        return StateSpaceSimulator(self)

    def state_map(self, bounds: bool = False) -> StateSpaceMap:
        """State functions on the model's own state ``x`` (``order_`` values), for python-control.

        Parameters
        ----------
        bounds : bool, default False
            Ignored (a state-space model has no bounds).
        """
        check_is_fitted(self)
        return StateSpaceMap(self)

    # ------------------------------------------------------------------ files
    def _check_state(self) -> None:
        super()._check_state()
        n, m, p = int(self.order_), self.n_inputs_, self.n_outputs_
        for name, array, shape in (
            ("A", self.A_, (n, n)),
            ("B", self.B_, (n, m)),
            ("C", self.C_, (p, n)),
            ("D", self.D_, (p, m)),
            ("intercept", self.intercept_, (p,)),
            ("kalman_gain", self.kalman_gain_, (n, p)),
        ):
            self._check_shape(name, array, shape)
        if not (n >= 1 and self.max_lag_ == self.horizon_ >= 2):
            raise ValueError(f"order {n} and horizon {self.horizon_} must be >= 1 and >= 2")
        radius = spectral_radius(self.A_)
        if radius >= 1.0 - STABILITY_MARGIN:
            raise ValueError(f"A has an eigenvalue of magnitude {radius:.6g}: not stable")

    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        arrays = {
            "A": self.A_,
            "B": self.B_,
            "C": self.C_,
            "D": self.D_,
            "intercept": self.intercept_,
            "kalman_gain": self.kalman_gain_,
            "singular_values": self.singular_values_,
            "order_fold_fits": self.order_fold_fits_,
        }
        params = self.get_params(deep=False)
        lags = params.pop("lags")
        meta = {
            "params": params,
            "lags": _lags_to_dict(lags),
            "ts": self.ts_,
            "n_samples": self.n_samples_,
            "order": self.order_,
            "horizon": self.horizon_,
            "order_rule": self.order_rule_,
            "mode_radius": self.mode_radius_,
            "bounded": bool(self.bounded_),
            "stabilised": bool(self.stabilised_),
            "refined": bool(self.refined_),
            **self._channels_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
    ) -> SubspaceStateSpace:
        model = cls(_lags_from_dict(meta["lags"]), **meta["params"])
        model._restore_channels(meta)
        model.ts_ = float(meta["ts"])
        model.n_samples_ = int(meta["n_samples"])
        model.order_, model.horizon_ = int(meta["order"]), int(meta["horizon"])
        model.stabilised_, model.refined_ = bool(meta["stabilised"]), bool(meta["refined"])
        # Files written before the order rule was recorded: the rule is not known.
        model.order_rule_ = str(meta.get("order_rule", "unknown"))
        model.mode_radius_ = float(meta.get("mode_radius", 1.0 - STABILITY_MARGIN))
        model.bounded_ = bool(meta.get("bounded", False))
        fold_fits = arrays.get("order_fold_fits", np.zeros((0, 0)))
        model.order_fold_fits_ = np.asarray(fold_fits, dtype=np.float64)
        for key in ("A", "B", "C", "D", "intercept", "kalman_gain", "singular_values"):
            value = np.ascontiguousarray(arrays[key], dtype=np.float64)
            setattr(model, f"{key}_", value)
        model.max_lag_ = model.horizon_
        return model


def _lags_to_dict(lags: Lags | None) -> dict[str, Any] | None:
    """A :class:`Lags` as JSON (per-channel lags kept as a mapping)."""
    if lags is None:
        return None

    def plain(spec: Any) -> Any:
        return {k: list(v) for k, v in spec.items()} if isinstance(spec, dict) else list(spec)

    return {
        "outputs": plain(lags.outputs),
        "inputs": plain(lags.inputs),
        "conditions": list(lags.conditions),
    }


def _lags_from_dict(value: Mapping[str, Any] | None) -> Lags | None:
    if value is None:
        return None
    return Lags(value["outputs"], value["inputs"], conditions=value["conditions"])


class StateSpaceSimulator:
    """Step-by-step free run of a :class:`SubspaceStateSpace`, for closed loops.

    ``reset(y0, u0)`` estimates the state from ``max_lag_`` past outputs and inputs
    (:meth:`SubspaceStateSpace.initial_state`); ``reset()`` without outputs starts from
    ``x = 0`` (the model at rest, its output the offset ``c``). ``step(u)`` returns ``y(t)`` and
    advances the state, with the arithmetic of ``simulate``: the same values, to the bit.
    """

    def __init__(self, model: SubspaceStateSpace) -> None:
        self._model = model
        self._matrices = model.matrices_
        self.n_inputs, self.n_outputs = model.n_inputs_, model.n_outputs_
        self.reset()

    def reset(self, y0: ArrayLike | None = None, u0: ArrayLike | None = None) -> None:
        """Start again: from the state fitted to ``y0`` and ``u0``, or from zero without ``y0``.

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
            Past outputs (oldest first); a single row is repeated.
        u0 : array_like, shape (n_inputs,) or (max_lag_, n_inputs), optional
            Past inputs, the same way (default zeros).
        """
        m = self._model.max_lag_
        if y0 is None:
            self.x = np.zeros(self._model.order_)
            return
        y_rows = history_rows(y0, m, self.n_outputs, "y0")
        u_rows = history_rows(u0, m, self.n_inputs, "u0")
        self.x = self._model.initial_state(y_rows, u_rows)

    def step(self, u: ArrayLike) -> FloatArray:
        """Advance one sample with input ``u`` (``(n_inputs,)``); return ``y(t)`` (``(n_outputs,)``)."""
        return np.asarray(self._advance(input_row(u, self.n_inputs)), dtype=np.float64)

    def _advance(self, row: FloatArray) -> FloatArray:
        """``y(t)`` of one input row ``(1, n_inputs)``; the state moves on (subclasses: the model)."""
        y, self.x = state_space_run(*self._matrices, row, self.x)
        return np.asarray(y[0], dtype=np.float64)


class StateSpaceMap(StateMap):
    """State functions of a :class:`SubspaceStateSpace`: ``x`` is the model's state.

    ``output(x, u) = C x + D u + c`` and ``update(x, u) = A x + B u``, with the arithmetic of
    the simulator; states named ``x1 … xn``; feedthrough only with ``feedthrough=True``.
    """

    def __init__(self, model: SubspaceStateSpace) -> None:
        super().__init__()
        self._model = model
        self._matrices = model.matrices_
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        self.states = [f"x{k + 1}" for k in range(model.order_)]
        self.ts = float(model.ts_)
        self.feedthrough = bool(model.feedthrough)

    def _run(self, x: FloatArray, u: FloatArray) -> tuple[FloatArray, FloatArray]:
        row = np.ascontiguousarray(u, dtype=np.float64).reshape(1, -1)
        return state_space_run(*self._matrices, row, np.ascontiguousarray(x))

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        return np.asarray(self._run(x, u)[0][0], dtype=np.float64)

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        return np.asarray(self._run(x, u)[1], dtype=np.float64)

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """The state the simulator's ``reset(y0, u0)`` starts from (zeros without ``y0``).

        Parameters
        ----------
        y0, u0 : array_like, optional
            Past outputs and inputs, as ``reset`` takes them.

        Returns
        -------
        ndarray, shape (order_,)
        """
        simulator = StateSpaceSimulator(self._model)
        simulator.reset(y0, u0)
        return np.asarray(simulator.x, dtype=np.float64)
