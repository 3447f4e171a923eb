r"""The predictive controller's data: the prediction model, its matrices, weights, limits, horizon.

:class:`MPCProblem` holds everything the controller computes with, as plain arrays and numbers
(what a C export writes as const arrays). It is built by :func:`mpc_problem` from a
:class:`~neckid.design.linear_form.LinearForm` (any model with a linear form: ARX, CFF-RLS,
``ss``, the scheduled model or an LPV model frozen at an inclination, a NARX model linearised
there), written as its difference equation from the velocity command :math:`u` [rad/s] to the
inclination :math:`y` [deg],

.. math:: y_t = \sum_{i=1}^{n_a} a_i\, y_{t-i} + \sum_{l=0}^{n_b - 1} b_l\, u_{t-l} + \delta_t,

with :math:`\delta` an integrating disturbance (a random walk, constant over the horizon) that
takes up what the model misses: offset-free tracking (Muske & Badgwell, *J. Process Control*
12, 2002; Pannocchia & Rawlings, *AIChE J.* 49, 2003). The state is the **past values**:
the last :math:`n_a` measured outputs and the last commands, all known in the loop, so the only
estimated state is :math:`\delta`: a steady-state Kalman filter of a random walk seen through
the one-step residual, gain :math:`L = P/(P + 1)`, :math:`P = (\rho + \sqrt{\rho^2 + 4\rho})/2`
for the ratio :math:`\rho = q/r` of the disturbance's step variance to the residual's.

At step :math:`k` the controller has the measurement :math:`y_{k-d}` (``delay`` :math:`d`: 1 in
:func:`neckid.plant.closed_loop`, 0 on the lab's bench) and the commands up to :math:`u_{k-1}`;
it chooses :math:`U = (u_k, \dots, u_{k+N_u-1})`, held at :math:`u_{k+N_u-1}` to the end of the
horizon :math:`N`. The predictions of :math:`y_{k-d+1}, \dots, y_{k+N}` are linear,

.. math:: \hat Y = F h_k + \Phi U + g\,\hat\delta_k, \qquad
          h_k = (y_{k-d}, \dots, y_{k-d-n_a+1}, u_{k-1}, \dots, u_{k-p}),

and the QP, solved at every step (:mod:`neckid.design.mpc.controller`), is

.. math:: \min_{U, s \ge 0}\ w_e \sum_{j=1}^{N} (r_{k+j} - \hat y_{k+j})^2
          + w_u \sum_{j=0}^{N_u-1} (u_{k+j} - u_{k+j-1})^2
          + \sum_{j=1}^{N} (w_s s_j^2 + \lambda_s s_j)

subject to :math:`|u| \le u_{max}`, :math:`|\Delta u| \le \Delta u_{max}` and, when output limits
are given, :math:`y_{min} + w_j - s_j \le \hat y_{k+j} \le y_{max} - w_j + s_j` (:math:`w_j` the
tightening of :mod:`neckid.design.mpc.robust`, 0 for the nominal controller; :math:`s_j` a
slack per horizon step that keeps the QP feasible, penalised so that it is zero whenever the
constraint can be met; the controller counts the steps it is used).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from neckid.design.linear_form import LinearForm
from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = [
    "DEFAULT_COMMAND_LIMIT",
    "DEFAULT_RATE_LIMIT",
    "MPCProblem",
    "disturbance_gain",
    "mpc_problem",
    "prediction_matrices",
]

#: Motor velocity limit [rad/s]: the bench's tendon speed limit 0.03 m/s over the winch radius
#: (``SoftNeckParameters.motor_speed_limit``), the demo PI's saturation.
DEFAULT_COMMAND_LIMIT = 4.0
#: Motor acceleration limit [rad/s²]: the drive's (``SoftNeckParameters.motor_acceleration_limit``;
#: CONTROLLERS.md: the bench's is far above what its logs reach).
DEFAULT_RATE_LIMIT = 200.0


def disturbance_gain(ratio: float) -> float:
    r"""Steady-state Kalman gain of a random walk seen with unit noise, step variance ``ratio``.

    Parameters
    ----------
    ratio : float
        :math:`q/r > 0`.

    Returns
    -------
    float
        :math:`L = P/(P+1)`, :math:`P = (q + \sqrt{q^2 + 4q})/2` (the Riccati equation's root).

    Examples
    --------
    >>> round(disturbance_gain(0.01), 4)
    0.0951
    """
    q = check_number(ratio, "disturbance_ratio", low=0, closed="neither")
    p = (q + math.sqrt(q * q + 4.0 * q)) / 2.0
    return p / (p + 1.0)


@dataclass(frozen=True)
class MPCProblem:
    r"""Everything the predictive controller computes with (see the module docstring).

    Attributes
    ----------
    ts : float
        Period, s.
    a : ndarray, shape (n_a,)
        :math:`a_1 \dots a_{n_a}` of the difference equation.
    b : ndarray, shape (n_b,)
        :math:`b_0 \dots b_{n_b-1}` (coefficient of :math:`u_{t-l}`) [deg/(rad/s)].
    delay : int
        :math:`d`, samples between a measurement and the command computed from it.
    horizon, control_horizon : int
        :math:`N` and :math:`N_u \le N`.
    tracking_weight, move_weight : float
        :math:`w_e` [1/deg²] and :math:`w_u` [1/(rad/s)²].
    command_limit : float
        :math:`u_{max}` [rad/s].
    rate_limit : float
        Largest :math:`|\Delta u|/T` [rad/s²].
    output_min, output_max : float
        Inclination limits [deg] (``-inf`` / ``inf``: none).
    tightening : ndarray, shape (N,)
        :math:`w_j` [deg], subtracted from both limits at horizon step :math:`j`.
    slack_weight, slack_linear_weight : float
        :math:`w_s` and :math:`\lambda_s` of the output constraints' slack.
    disturbance_ratio, disturbance_gain : float
        :math:`q/r` and the Kalman gain :math:`L` of :math:`\delta`.
    preview : bool
        Whether the controller reads the future reference (``set_reference``) or holds the
        current one over the horizon.
    free : ndarray, shape (N + d, n_a + p)
        :math:`F`: the predictions of :math:`y_{k-d+1} \dots y_{k+N}` from :math:`h_k`.
    forced : ndarray, shape (N + d, N_u)
        :math:`\Phi`: their response to :math:`U`.
    disturbance : ndarray, shape (N + d,)
        :math:`g`: their response to :math:`\delta`.
    source : str
        The model, in words.
    info : dict
        What the design recorded (the model file, the band's horizons); not used to compute.
    """

    ts: float
    a: FloatArray
    b: FloatArray
    delay: int
    horizon: int
    control_horizon: int
    tracking_weight: float
    move_weight: float
    command_limit: float
    rate_limit: float
    output_min: float
    output_max: float
    tightening: FloatArray
    slack_weight: float
    slack_linear_weight: float
    disturbance_ratio: float
    disturbance_gain: float
    preview: bool
    free: FloatArray
    forced: FloatArray
    disturbance: FloatArray
    source: str = ""
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def n_history(self) -> int:
        """Length of :math:`h_k`: :math:`n_a` outputs and :math:`p` past commands."""
        return int(self.free.shape[1])

    @property
    def n_past_commands(self) -> int:
        r""":math:`p = \max(d + n_b - 1, 1)`."""
        return self.n_history - self.a.size

    @property
    def constrained(self) -> bool:
        """Whether the QP has output constraints."""
        return bool(math.isfinite(self.output_min) or math.isfinite(self.output_max))

    def predict(self, history: FloatArray, moves: FloatArray, delta: float) -> FloatArray:
        r""":math:`\hat Y = F h + \Phi U + g \delta`, shape ``(N + d,)`` [deg]."""
        return np.asarray(self.free @ history + self.forced @ moves + self.disturbance * delta)


def _simulate(
    a: FloatArray, b: FloatArray, delay: int, n_rows: int, n_moves: int, vector: FloatArray
) -> FloatArray:
    """The difference equation run from ``vector = (h, U, delta)``: rows ``k-d+1 … k+N``."""
    na, nb = a.size, b.size
    p = max(delay + nb - 1, 1)
    history, moves, delta = vector[:na], vector[na : na + p + n_moves], vector[-1]
    past_u, planned = moves[:p], moves[p:]
    y: dict[int, float] = {-delay - i: float(history[i]) for i in range(na)}  # time relative to k

    def u_at(t: int) -> float:
        if t < 0:
            return float(past_u[-t - 1]) if -t - 1 < p else 0.0
        return float(planned[min(t, n_moves - 1)])

    rows = np.empty(n_rows)
    for row in range(n_rows):
        t = -delay + 1 + row
        value = sum(a[i] * y[t - 1 - i] for i in range(na))
        value += sum(b[j] * u_at(t - j) for j in range(nb))
        y[t] = value + delta
        rows[row] = y[t]
    return rows


def prediction_matrices(
    a: FloatArray, b: FloatArray, delay: int, horizon: int, control_horizon: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    r""":math:`F`, :math:`\Phi`, :math:`g` of the difference equation (module docstring).

    Each column is the equation run from one unit entry of :math:`(h, U, \delta)`, in this
    order of arithmetic (a C export that runs the same recursion gets the same floats).

    Parameters
    ----------
    a, b : ndarray
        The difference equation's coefficients.
    delay, horizon, control_horizon : int
        :math:`d`, :math:`N`, :math:`N_u`.

    Returns
    -------
    free : ndarray, shape (N + d, n_a + p)
    forced : ndarray, shape (N + d, N_u)
    disturbance : ndarray, shape (N + d,)
    """
    p = max(delay + b.size - 1, 1)
    size = a.size + p + control_horizon + 1
    columns = np.eye(size)
    rows = horizon + delay
    matrix = np.column_stack(
        [_simulate(a, b, delay, rows, control_horizon, columns[:, c]) for c in range(size)]
    )
    return (
        matrix[:, : a.size + p],
        matrix[:, a.size + p : a.size + p + control_horizon],
        matrix[:, -1],
    )


def _difference_equation(form: LinearForm) -> tuple[FloatArray, FloatArray]:
    """``(a, b)`` of ``form``'s transfer function (see the module docstring)."""
    den = np.trim_zeros(np.asarray(form.den, dtype=np.float64), "f")
    num = np.trim_zeros(np.asarray(form.num, dtype=np.float64), "f")
    if den.size < 2 or num.size == 0 or num.size > den.size:
        raise ValueError(
            f"the model's linear form must be a proper transfer function with a pole; got num"
            f" {num.tolist()}, den {den.tolist()}"
        )
    a = -den[1:] / den[0]
    relative = den.size - num.size
    b = np.concatenate([np.zeros(relative), num / den[0]])
    return a, b


def mpc_problem(
    form: LinearForm,
    *,
    horizon: int = 25,
    control_horizon: int | None = None,
    tracking_weight: float = 1.0,
    move_weight: float = 5.0,
    command_limit: float = DEFAULT_COMMAND_LIMIT,
    rate_limit: float = DEFAULT_RATE_LIMIT,
    output_min: float = -math.inf,
    output_max: float = math.inf,
    tightening: Any = None,
    preview: bool = True,
    disturbance_ratio: float = 0.01,
    slack_weight: float = 1e3,
    slack_linear_weight: float = 1e3,
    info: dict[str, Any] | None = None,
) -> MPCProblem:
    """The predictive controller's data for a linear form.

    Parameters
    ----------
    form : LinearForm
        :func:`~neckid.design.linear_form.linear_form` of the model (its ``computation_delay``
        is the loop's :math:`d`).
    horizon : int, default 25
        :math:`N`, samples (0.5 s at 0.02 s).
    control_horizon : int, optional
        :math:`N_u` (default :math:`N`).
    tracking_weight, move_weight : float, default 1 and 5
        :math:`w_e` [1/deg²], :math:`w_u` [1/(rad/s)²]. The default 5 was chosen on the
        simulated neck on a reference of random levels (not the paper's tests): at 0.05 the
        command chatters between the limits (RMS move 1.6 rad/s per period), from 2 on it does
        not (0.25 at 5).
    command_limit : float, default 4
        :math:`u_{max}` [rad/s] (:data:`DEFAULT_COMMAND_LIMIT`).
    rate_limit : float, default 200
        Largest command change per second [rad/s²] (:data:`DEFAULT_RATE_LIMIT`).
    output_min, output_max : float, optional
        Inclination limits [deg].
    tightening : array_like, shape (N,), optional
        :math:`w_j` [deg] (:func:`~neckid.design.mpc.robust.band_tightening`); default zeros.
    preview : bool, default True
        Read the future reference when the controller is given one.
    disturbance_ratio : float, default 0.01
        :math:`q/r` of the disturbance estimator.
    slack_weight, slack_linear_weight : float
        The slack's quadratic and linear penalties.
    info : dict, optional
        Kept in the controller file.

    Returns
    -------
    MPCProblem

    Examples
    --------
    >>> import control
    >>> from neckid.design import linear_form
    >>> form = linear_form(control.tf([0.1], [1, -1], dt=0.02))   # an integrator, delay 1
    >>> problem = mpc_problem(form, horizon=5)
    >>> problem.free.shape, problem.forced.shape   # y_k ... y_{k+5}; u_k ... u_{k+4}
    ((6, 3), (6, 5))
    >>> [float(v) for v in problem.forced[:, 0]]   # u_k alone: y moves by 0.1 from y_{k+1}
    [0.0, 0.1, 0.1, 0.1, 0.1, 0.1]
    >>> [round(float(v), 6) for v in problem.forced.sum(axis=1)]   # u = 1 from k on: a ramp
    [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]
    """
    if not isinstance(form, LinearForm):
        raise TypeError(f"form must be a LinearForm; got {type(form).__name__}")
    n = int(check_number(horizon, "horizon", low=1, high=1000, integer=True))
    nu = n if control_horizon is None else control_horizon
    nu = int(check_number(nu, "control_horizon", low=1, high=n, integer=True))
    delay = int(form.computation_delay)
    a, b = _difference_equation(form)
    if delay == 0 and b[0] != 0.0:
        raise ValueError(
            "with no computation delay the model must not answer the command within its sample"
            " (its linear form is not strictly proper): use delay 1"
        )
    low, high = float(output_min), float(output_max)
    if math.isnan(low) or math.isnan(high) or not low < high:
        raise ValueError(f"output limits must satisfy min < max; got {low}, {high}")
    tight = np.zeros(n) if tightening is None else np.asarray(tightening, dtype=np.float64)
    if tight.shape != (n,) or not np.all(np.isfinite(tight)) or np.any(tight < 0):
        raise ValueError(f"tightening must be {n} finite values >= 0 [deg], one per horizon step")
    free, forced, disturbance = prediction_matrices(a, b, delay, n, nu)
    return MPCProblem(
        ts=float(form.ts),
        a=a,
        b=b,
        delay=delay,
        horizon=n,
        control_horizon=nu,
        tracking_weight=check_number(tracking_weight, "tracking_weight", low=0, closed="neither"),
        move_weight=check_number(move_weight, "move_weight", low=0),
        command_limit=check_number(command_limit, "command_limit", low=0, closed="neither"),
        rate_limit=check_number(rate_limit, "rate_limit", low=0, closed="neither"),
        output_min=low,
        output_max=high,
        tightening=tight,
        slack_weight=check_number(slack_weight, "slack_weight", low=0, closed="neither"),
        slack_linear_weight=check_number(slack_linear_weight, "slack_linear_weight", low=0),
        disturbance_ratio=float(disturbance_ratio),
        disturbance_gain=disturbance_gain(disturbance_ratio),
        preview=bool(preview),
        free=free,
        forced=forced,
        disturbance=disturbance,
        source=form.source,
        info=dict(info or {}),
    )
