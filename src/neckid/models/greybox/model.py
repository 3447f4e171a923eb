r"""GreyBoxNeck: tendon slack, Prandtl–Ishlinskii hysteresis and stable low-order dynamics.

.. math::

    s_j(t) &= P_{b_j/2}[x_j](t) \quad\text{(tendon slack: a backlash of width } b_j)\\
    v_o(t) &= \sum_j \sum_k \bigl(w_{ojk} + \textstyle\sum_c w^{c}_{ojk}\,p_c\bigr)
              P_{r_{jk}}[s_j](t) + \sum_c q_{oc}\,p_c + c_o\\
    y_o(t) &= -\sum_{i=1}^{n} a_{oi}\,y_o(t-i) + \Bigl(1 + \sum_i a_{oi}\Bigr)\,v_o(t-d)

``x_j`` the motor inputs, ``p_c`` the experimental conditions (e.g. the payload [kg], from
``Lags(conditions=[...])``), ``P_r`` the play operator (:mod:`.hysteresis`), radii
``r_jk = linspace(0, play_span · range(x_j), n_play)``. The documentation page
``docs/greybox.md`` gives the equations with their references.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import Estimator, ModelResult, check_is_fitted
from neckid.models.excitation import check_excitation
from neckid.models.greybox.fitting import REFLECTION_BOUND, Problem, basis, fit_problem
from neckid.models.greybox.hysteresis import denominator, dynamics_run, play_step
from neckid.models.linear.subspace_steps import STABILITY_MARGIN, slowest_mode_radius
from neckid.models.online import update_experiments
from neckid.models.results import DIVERGENCE_SPANS
from neckid.regressors import Lags
from neckid.systems import history_rows
from neckid.utils.checks import Interval, check_finite
from neckid.utils.types import FloatArray

__all__ = ["GreyBoxNeck", "GreyBoxSimulator"]


class GreyBoxNeck(Estimator):
    r"""Grey-box soft neck: slack → Prandtl–Ishlinskii hysteresis → stable linear dynamics.

    Every input but the conditions goes through its own slack and hysteresis; each output has
    its own all-pole dynamics of ``order`` with unit static gain (stable by construction:
    reflection coefficients in ``(-1, 1)``, every pole within ``mode_radius_``) and its own
    weights. Fitted on the free-run error.

    Parameters
    ----------
    lags : Lags, optional
        Only its ``conditions`` are used (constant inputs that scale the hysteresis and shift
        the offset); the dynamics' order and delay take the place of the lags.
    order : int, default 2
        Poles of the dynamics per output (1 or 2; 2 can ring: the step overshoot).
    delay : int, default 1
        Samples from the operators' output to the dynamics, ``d``.
    n_play : int, default 5
        Play operators of the Prandtl–Ishlinskii operator (1: slack and linear dynamics only).
    play_span : float, default 0.25
        Largest play radius above the slack, as a share of each input's training range.
    slack : bool, default True
        Fit a tendon-slack width per input (otherwise ``b = 0``).
    max_time_constant : float, optional
        Slowest time constant [s] of the dynamics: every pole lies within
        ``exp(−ts / max_time_constant)``. ``None``: a fifth of the longest training experiment
        (:func:`~neckid.models.linear.subspace_steps.slowest_mode_radius`), so every mode
        settles within a record that shows it: a slower pole, with unit static gain, turns
        the operators' output into an integrated one of unbounded scale (see
        ``docs/greybox.md``); a very large value (``1e9``):
        stability alone.
    max_iter : int, default 60
        Function evaluations of ``scipy.optimize.least_squares``.

    Attributes
    ----------
    slack_ : ndarray, shape (n_motor_inputs,)
        Slack widths ``b_j`` in the inputs' units.
    radii_ : ndarray, shape (n_motor_inputs, n_play)
        PI radii ``r_jk`` above the slack.
    reflection_ : ndarray, shape (n_outputs, order)
        Reflection coefficients; ``denominators_`` the polynomials ``[1, a_1, …, a_n]``.
    mode_radius_ : float
        Largest pole magnitude allowed, ``exp(−ts / max_time_constant)``.
    weights_ : ndarray, shape (n_outputs, n_basis)
        ``w``, ``w^c``, ``q`` and ``c`` in the order of
        :func:`~neckid.models.greybox.fitting.basis`.
    n_conditions_ : int
        The last ``n_conditions_`` inputs are conditions.
    train_mse_ : float
        Mean square free-run error on the training data.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> x = np.repeat([0.0, 1.0, 0.6, 1.4, 0.2], 40)
    >>> model = GreyBoxNeck(order=1, n_play=1, max_iter=20).fit(IOData(x, 2 * x + 0.1, ts=0.1))
    >>> model.reflection_.shape, model.max_lag_
    ((1, 1), 1)
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "order": [Interval("int", 1, 2)],
        "delay": [Interval("int", 0, None)],
        "n_play": [Interval("int", 1, None)],
        "play_span": [Interval("real", 0.0, 1.0, closed="right")],
        "slack": ["boolean"],
        "max_time_constant": [None, Interval("real", 0.0, None, closed="neither")],
        "max_iter": [Interval("int", 1, None)],
    }

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        order: int = 2,
        delay: int = 1,
        n_play: int = 5,
        play_span: float = 0.25,
        slack: bool = True,
        max_time_constant: float | None = None,
        max_iter: int = 60,
    ) -> None:
        self.lags = lags
        self.order = order
        self.delay = delay
        self.n_play = n_play
        self.play_span = play_span
        self.slack = slack
        self.max_time_constant = max_time_constant
        self.max_iter = max_iter

    # ------------------------------------------------------------------ fit
    def fit(self, data: IOData | Sequence[IOData]) -> GreyBoxNeck:
        """Identify the model on one experiment or a list (each run starts its own free run).

        Raises
        ------
        ValueError
            For a bad hyper-parameter, no input besides the conditions, or a run too short.
        """
        self._validate_params()
        n_raw = as_experiments(data)[0].n_inputs
        experiments = as_experiments(self._with_conditions(data, fitting=True))
        self._check_training(experiments)
        check_excitation(type(self).__name__, experiments, skip=self._condition_names(True))
        self._fit_experiments(experiments, experiments[0].n_inputs - n_raw)
        return self

    def _fit_experiments(self, experiments: Sequence[IOData], n_conditions: int) -> None:
        n_motor = experiments[0].n_inputs - n_conditions
        if n_motor < 1:
            raise ValueError("GreyBoxNeck needs an input besides the conditions; got none")
        m = max(int(self.order), int(self.delay), 1)
        for i, run in enumerate(experiments):
            if run.n_samples <= m + 1:
                raise ValueError(f"data[{i}] has {run.n_samples} samples; it needs > {m + 1}")
        u = np.vstack([d.u for d in experiments])
        y = np.vstack([d.y for d in experiments])
        spans = np.ptp(u[:, :n_motor], axis=0)
        spans[~(spans > 0)] = 1.0
        width = np.ptp(y, axis=0)
        envelope = np.vstack(
            [y.min(axis=0) - DIVERGENCE_SPANS * width, y.max(axis=0) + DIVERGENCE_SPANS * width]
        )
        radii = np.outer(spans, np.linspace(0.0, float(self.play_span), int(self.n_play)))
        runs = [
            (np.asarray(d.u[:, :n_motor]), np.asarray(d.u[:, n_motor:]), np.asarray(d.y))
            for d in experiments
        ]
        radius = self._mode_radius(experiments)
        problem = Problem(runs, radii, int(self.order), int(self.delay), m, envelope, spans, radius)
        slack, coefficients, weights, cost = fit_problem(
            problem, bool(self.slack), int(self.max_iter)
        )
        fitted = (slack.size if self.slack else 0) + coefficients.size + weights.size
        check_excitation(
            type(self).__name__, experiments, n_parameters=fitted, inputs=False, n_initial=m
        )
        self.slack_, self.radii_, self.mode_radius_ = slack, radii, radius
        self.reflection_, self.weights_ = coefficients, weights
        self.n_conditions_, self.train_mse_ = int(n_conditions), cost
        self.n_samples_ = int(y.shape[0])
        self._set_channels(experiments[0])
        self.max_lag_ = m

    def _mode_radius(self, experiments: Sequence[IOData]) -> float:
        """``exp(−ts / max_time_constant)``, by default from the longest experiment."""
        if self.max_time_constant is None:
            return slowest_mode_radius(max(d.n_samples for d in experiments))
        radius = np.exp(-float(experiments[0].ts) / float(self.max_time_constant))
        return float(min(radius, 1.0 - STABILITY_MARGIN))

    def partial_fit(self, data: IOData | Sequence[IOData]) -> GreyBoxNeck:
        """Refit on ``data`` alone with the same settings (not an update).

        The free-run fit has no statistics that add up over records, so this is a new fit on
        the new experiments; to fit old and new data together call ``fit([old, new])``.

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
        self._fit_experiments(experiments, self.n_conditions_)
        return self

    # ------------------------------------------------------------------ use
    @property
    def denominators_(self) -> FloatArray:
        """``[1, a_1, …, a_n]`` per output, shape ``(n_outputs, order + 1)``."""
        check_is_fitted(self)
        return np.vstack([denominator(k, self.mode_radius_) for k in self.reflection_])

    def operator_output(self, data: IOData) -> FloatArray:
        """``v(t)``: the slack and hysteresis output before the dynamics, ``(n_samples, n_outputs)``."""
        check_is_fitted(self)
        k = self.n_inputs_ - self.n_conditions_
        phi = basis(data.u[:, :k], data.u[:, k:], self.slack_, self.radii_)
        return np.asarray(phi @ self.weights_.T, dtype=np.float64)

    def predict(self, data: IOData) -> ModelResult:
        """One step ahead: ``y(t)`` from the *measured* ``y(t-1) … y(t-n)`` and ``v(t-d)``.

        The operators run on the inputs from the first sample (their memory is the inputs');
        the first ``max_lag_`` samples of the result are the measured outputs.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y = self._initial_outputs(data, None)
        m, d, n = self.max_lag_, int(self.delay), y.shape[0]
        v = self.operator_output(data)
        out = y.copy()
        for o, a in enumerate(self.denominators_):
            step = np.sum(a) * v[m - d : n - d, o]
            for i in range(1, a.size):
                step = step - a[i] * y[m - i : n - i, o]
            out[m:, o] = step
        return self._result("prediction", data, out)

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free run: the dynamics from the first ``max_lag_`` outputs, the operators from ``x(0)``.

        Parameters
        ----------
        data : IOData
            The inputs; its first ``max_lag_`` measured outputs are the initial conditions
            unless ``initial`` is given (then ``data`` may hold inputs only).
        initial : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
            The first outputs (oldest first; one row is repeated).

        Returns
        -------
        ModelResult
            Of kind ``"simulation"``. The plays start relaxed, ``z(-1) = x(0)``.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y = self._initial_outputs(data, initial)
        m = self.max_lag_
        v = self.operator_output(data)
        with np.errstate(over="ignore", invalid="ignore"):
            for o, a in enumerate(self.denominators_):
                y[m:, o] = dynamics_run(a, v[:, o : o + 1], y[:m, o : o + 1], m, self.delay)[:, 0]
        return self._result("simulation", data, y)

    def simulator(self) -> GreyBoxSimulator:
        """A stateful simulator: ``reset(y0, u0)`` then ``step(u) -> y`` (the values of simulate)."""
        check_is_fitted(self)
        return GreyBoxSimulator(self)

    def state_map(self, bounds: bool = False) -> Any:
        """The model's state functions, for python-control (:func:`neckid.export.control.to_iosystem`).

        Parameters
        ----------
        bounds : bool, default False
            Ignored (the model has no band).

        Returns
        -------
        GreyBoxStateMap
            State: the last ``max_lag_`` outputs and operator outputs, and the plays' memory;
            the same floats as :meth:`simulator`.
        """
        from neckid.models.greybox.state_map import GreyBoxStateMap

        check_is_fitted(self)
        return GreyBoxStateMap(self)

    # ------------------------------------------------------------------ files
    def _check_state(self) -> None:
        super()._check_state()
        k, p = self.n_inputs_ - self.n_conditions_, self.n_outputs_
        n_basis = k * int(self.n_play) * (1 + self.n_conditions_) + self.n_conditions_ + 1
        for name, array, shape in (
            ("slack", self.slack_, (k,)),
            ("radii", self.radii_, (k, int(self.n_play))),
            ("reflection", self.reflection_, (p, int(self.order))),
            ("weights", self.weights_, (p, n_basis)),
        ):
            self._check_shape(name, array, shape)
        if np.any(self.slack_ < 0) or np.any(self.radii_ < 0):
            raise ValueError("slack and radii must be >= 0")
        if np.any(np.abs(self.reflection_) > REFLECTION_BOUND):
            raise ValueError(
                f"reflection coefficients must lie in [-{REFLECTION_BOUND}, {REFLECTION_BOUND}]"
                f" (stable poles); got {self.reflection_.tolist()}"
            )
        if not 0.0 < self.mode_radius_ <= 1.0:
            raise ValueError(f"mode_radius must lie in (0, 1]; got {self.mode_radius_}")
        if self.max_lag_ != max(int(self.order), int(self.delay), 1):
            raise ValueError(f"max_lag {self.max_lag_} does not fit order and delay")

    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        arrays = {
            "slack": self.slack_,
            "radii": self.radii_,
            "reflection": self.reflection_,
            "weights": self.weights_,
        }
        params = self.get_params(deep=False)
        lags = params.pop("lags")
        meta = {
            "params": params,
            "conditions": None if lags is None else list(lags.conditions),
            "ts": self.ts_,
            "n_samples": self.n_samples_,
            "n_conditions": self.n_conditions_,
            "train_mse": self.train_mse_,
            "mode_radius": self.mode_radius_,
            **self._channels_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
    ) -> GreyBoxNeck:
        conditions = meta["conditions"]
        lags = None if conditions is None else Lags(1, 1, conditions=conditions)
        model = cls(lags, **meta["params"])
        model._restore_channels(meta)
        model.ts_ = float(meta["ts"])
        model.n_samples_ = int(meta["n_samples"])
        model.n_conditions_ = int(meta["n_conditions"])
        model.train_mse_ = float(meta["train_mse"])
        # Files written before the radius was recorded had none (the unit circle).
        model.mode_radius_ = float(meta.get("mode_radius", 1.0))
        for key in ("slack", "radii", "reflection", "weights"):
            setattr(model, f"{key}_", np.ascontiguousarray(arrays[key], dtype=np.float64))
        model.max_lag_ = max(int(model.order), int(model.delay), 1)
        return model


class GreyBoxSimulator:
    """Step-by-step free run of a :class:`GreyBoxNeck`, for closed loops.

    The state is the plays' outputs, the last ``delay`` operator outputs ``v`` and the last
    ``order`` outputs. ``reset(y0, u0)`` starts the plays relaxed at the oldest row of ``u0``
    and runs them over ``u0``; after ``reset(y0=y[:max_lag_], u0=u[:max_lag_])``, stepping
    ``u[max_lag_:]`` gives what ``simulate`` gives.
    """

    def __init__(self, model: GreyBoxNeck) -> None:
        self._model = model
        self._polynomials = model.denominators_
        self._motors = model.n_inputs_ - model.n_conditions_
        self._radii = model.slack_[:, None] / 2.0 + model.radii_
        self.n_inputs, self.n_outputs = model.n_inputs_, model.n_outputs_
        self.reset()

    def reset(self, y0: ArrayLike | None = None, u0: ArrayLike | None = None) -> None:
        """Start again from past outputs ``y0`` and inputs ``u0`` (oldest first; default zeros).

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
        u0 : array_like, shape (n_inputs,) or (max_lag_, n_inputs), optional
            A single row is repeated.
        """
        m = self._model.max_lag_
        self._y = history_rows(y0, m, self.n_outputs, "y0")
        u_rows = history_rows(u0, m, self.n_inputs, "u0")
        self._plays = np.repeat(u_rows[0, : self._motors, None], self._radii.shape[1], axis=1)
        self._v = np.vstack([self._advance(row) for row in u_rows])

    def _advance(self, u: FloatArray) -> FloatArray:
        """Move the plays with input ``u``; return this sample's ``v`` (``(n_outputs,)``)."""
        k = self._motors
        self._plays = np.vstack(
            [play_step(self._plays[j], float(u[j]), self._radii[j]) for j in range(k)]
        )
        plays = self._plays.reshape(1, -1)
        conditions = u[None, k:]
        scaled = [plays * conditions[:, c : c + 1] for c in range(conditions.shape[1])]
        phi = np.hstack([plays, *scaled, conditions, np.ones((1, 1))])
        return np.asarray((phi @ self._model.weights_.T)[0], dtype=np.float64)

    def step(self, u: ArrayLike) -> FloatArray:
        """Advance one sample with input ``u`` (``(n_inputs,)``); return ``y(t)`` (``(n_outputs,)``)."""
        row = np.asarray(u, dtype=np.float64).reshape(-1)
        if row.shape[0] != self.n_inputs:
            raise ValueError(
                f"u must have {self.n_inputs} values (one per input); got {row.shape[0]}"
            )
        check_finite(row[None, :], "u")
        history = np.vstack([self._v, self._advance(row)])
        drive = history[history.shape[0] - 1 - int(self._model.delay)]
        self._v = history[1:]
        y = np.empty(self.n_outputs)
        for o, a in enumerate(self._polynomials):
            past = self._y[::-1, o][: a.size - 1]
            y[o] = np.sum(a) * drive[o] - float(np.dot(a[1:], past))
        self._y = np.vstack([self._y, y[None, :]])[1:]
        return y.copy()
