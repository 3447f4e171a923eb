r"""The lab's fixed controllers of the soft-neck logs: the integer PI and the fractional controller.

Both run at :math:`T = 0.025` s on the error :math:`e_k = r_k + d_k - i_k` (reference plus
dither minus the **raw** inclination, deg) and give the motor velocity command :math:`c_k`
[rad/s]. Both follow :class:`neckid.systems.Controller` (``reset()``,
``step(reference, measurement) -> command``, the reference there already holding the dither), so
they run in :func:`neckid.plant.closed_loop`, and both give ``state_map()`` for
:func:`neckid.export.control.to_iosystem`.

A failed sensor read is a NaN measurement: nothing is updated and the last command is held
(the bench's behaviour; see :func:`neckid.loops.controllers.reconstruct.failed_reads`).

References
----------
- ``shared/data/softneck/CONTROLLERS.md`` (sections "int: PI" and "fra: fixed fractional
  controller"), from github.com/munozyanez/phd_Archived @ a9198c8 and the fractional-control
  library github.com/munozyanez/fcontrol @ 5e47a79 (``PIDBlock``, ``FPDBlock``,
  ``FractionalDerivative``).
- I. Podlubny, *Fractional Differential Equations*, Academic Press, 1999, sec. 2.2 and 7.3 (the
  Grünwald–Letnikov definition and its truncated, "short-memory" sum).
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

from neckid.loops.controllers.references import LAB_TS
from neckid.systems import StateMap
from neckid.utils.checks import check_number, check_ts
from neckid.utils.types import FloatArray

__all__ = [
    "FRA_ID_GAINS",
    "FRA_STAIR_GAINS",
    "PI_GAINS",
    "LabController",
    "LabControllerStateMap",
    "LabFractionalController",
    "LabPI",
    "grunwald_letnikov_weights",
]

#: The PI of the int stairs and steps: (kp, ki).
PI_GAINS = (0.2084, 0.8237)
#: The fractional controller of the fra stairs and steps: (kp, kd, fex).
FRA_STAIR_GAINS = (0.2084, 0.8237, -0.55)
#: The fractional controller of the identification run: (kp, kd, fex).
FRA_ID_GAINS = (0.2342, 0.7370, -0.59)

#: Smallest tap magnitude kept by the lab's truncation (the first tap below it is kept too).
GL_THRESHOLD = 0.01
_MAX_TAPS = 100_000


def grunwald_letnikov_weights(order: float, threshold: float = GL_THRESHOLD) -> FloatArray:
    r"""Taps :math:`w_i = (-1)^i \binom{a}{i}` of the Grünwald–Letnikov sum, truncated as the lab does.

    :math:`w_0 = 1`, :math:`w_i = w_{i-1}\,(i - 1 - a)/i`; the sum stops after the first tap with
    :math:`|w_i| <` ``threshold`` (that tap included).

    Parameters
    ----------
    order : float
        The derivative order :math:`a` (for the lab's controller :math:`a = 1 + f_{ex}`).
    threshold : float, default 0.01
        The truncation threshold.

    Returns
    -------
    ndarray, shape (N,)
        The taps, :math:`N \ge 2`.

    Raises
    ------
    ValueError
        If the taps do not fall below ``threshold`` within 100000 taps (orders at or below
        about 0, whose taps decay too slowly or grow).

    References
    ----------
    CONTROLLERS.md ("fra"); Podlubny (1999), sec. 2.2.

    Examples
    --------
    >>> w = grunwald_letnikov_weights(0.45)
    >>> len(w), w[:3].round(5).tolist()
    (12, [1.0, -0.45, -0.12375])
    """
    a = check_number(order, "order")
    limit = check_number(threshold, "threshold", low=0, closed="neither")
    taps = [1.0]
    while abs(taps[-1]) >= limit:
        i = len(taps)
        if i >= _MAX_TAPS:
            raise ValueError(
                f"the Grünwald–Letnikov taps of order {a} do not fall below {limit} within"
                f" {_MAX_TAPS} taps; use a larger threshold"
            )
        taps.append(taps[-1] * (i - 1 - a) / i)
    return np.array(taps)


class LabController:
    """Base of the lab's controllers: the failed-read hold, ``step``, ``reset`` and the state map.

    A subclass sets :attr:`law_states` (names of its law's state) and implements
    :meth:`initial_law_state` and :meth:`law` (one period from the error). The full state adds
    the last command: ``[law state..., velocity_command[t-1]]``.

    Attributes
    ----------
    ts : float
        Period, s.
    n_references, n_motors : int
        1 and 1: one inclination, one motor.
    """

    ts: float = LAB_TS
    n_references = 1
    n_motors = 1
    law_states: list[str]

    def initial_law_state(self) -> FloatArray:
        """The law's state after :meth:`reset`."""
        raise NotImplementedError  # pragma: no cover - abstract

    def law(self, state: FloatArray, error: float) -> tuple[float, FloatArray]:
        """One period after a good read: ``(command [rad/s], next law state)``."""
        raise NotImplementedError  # pragma: no cover - abstract

    def hold(self, state: FloatArray) -> FloatArray:
        """The law's state after a failed read (unchanged; a replay advances its row)."""
        return state

    @property
    def states(self) -> list[str]:
        """Names of the full state: the law's, then ``velocity_command[t-1]``."""
        return [*self.law_states, "velocity_command[t-1]"]

    def initial_state(self) -> FloatArray:
        """The full state after :meth:`reset` (last command 0)."""
        return np.append(self.initial_law_state(), 0.0)

    def control_law(
        self, state: ArrayLike, reference: ArrayLike, measurement: ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """The controller as a pure function: command and next state from a given state.

        Parameters
        ----------
        state : array_like, shape (len(states),)
            As :meth:`initial_state` packs it.
        reference : float
            Reference plus dither [deg].
        measurement : float
            Raw inclination [deg]; NaN for a failed read (the last command is held and nothing
            but a replay's row counter changes).

        Returns
        -------
        command : ndarray, shape (1,)
            Velocity command [rad/s].
        state : ndarray
            The next state.
        """
        full = np.asarray(state, dtype=np.float64).reshape(-1)
        if full.shape[0] != len(self.states):
            raise ValueError(f"state must have {len(self.states)} values; got {full.shape[0]}")
        y = float(np.asarray(measurement, dtype=np.float64).reshape(-1)[0])
        if math.isnan(y):
            return full[-1:].copy(), np.append(self.hold(full[:-1].copy()), full[-1])
        r = float(np.asarray(reference, dtype=np.float64).reshape(-1)[0])
        if not (math.isfinite(r) and math.isfinite(y)):
            raise ValueError(f"reference and measurement must be finite; got {r}, {y}")
        command, following = self.law(full[:-1].copy(), r - y)
        return np.array([command]), np.append(following, command)

    def reset(self) -> None:
        """Back to the initial state (zero integrals, no command yet)."""
        self._state = self.initial_state()

    def step(self, reference: ArrayLike, measurement: ArrayLike) -> FloatArray:
        """One control period.

        Parameters
        ----------
        reference : float
            Reference plus dither [deg] (a :class:`~.references.LabReference`'s ``values``).
        measurement : float
            Raw inclination [deg]; NaN for a failed sensor read (the command is held).

        Returns
        -------
        ndarray, shape (1,)
            Velocity command [rad/s].
        """
        if not hasattr(self, "_state"):
            self.reset()
        command, self._state = self.control_law(self._state, reference, measurement)
        return command

    def state_map(self, bounds: bool = False) -> LabControllerStateMap:
        """The controller's state functions, for :func:`neckid.export.control.to_iosystem`.

        Parameters
        ----------
        bounds : bool, default False
            Ignored (a controller has no band).

        Returns
        -------
        LabControllerStateMap
        """
        return LabControllerStateMap(self)


class ControlLaw(Protocol):
    """A controller written as a pure function of a packed state (what the map below needs)."""

    ts: float

    @property
    def states(self) -> list[str]:
        """Names of the packed state."""

    def initial_state(self) -> FloatArray:
        """The packed state after ``reset``."""

    def control_law(
        self, state: ArrayLike, reference: ArrayLike, measurement: ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """Command and next state from a given state."""


class LabControllerStateMap(StateMap):
    """State functions of a :class:`LabController`, as :class:`~neckid.plant.ControllerStateMap`.

    Inputs ``reference`` (with the dither) and ``inclination`` [deg]; output
    ``velocity_command`` [rad/s]; state ``[law state..., velocity_command[t-1],
    inclination[t-1]]``. The command of sample ``k`` reads the inclination of sample ``k − 1``
    from the state (as :func:`neckid.plant.closed_loop` does), so the map has no feedthrough
    from the measurement.

    Parameters
    ----------
    controller : LabController
        Its :meth:`~LabController.control_law` is the map (its own state is not touched).
    """

    def __init__(self, controller: ControlLaw) -> None:
        super().__init__()
        self._controller = controller
        self.inputs = ["reference", "inclination"]
        self.outputs = ["velocity_command"]
        self.states = [*controller.states, "inclination[t-1]"]
        self.ts = controller.ts

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        return self._controller.control_law(x[:-1], u[0], x[-1])[0]

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        return np.append(self._controller.control_law(x[:-1], u[0], x[-1])[1], u[1])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """The controller's :meth:`~LabController.initial_state` and a zero first inclination.

        Parameters
        ----------
        y0, u0 : array_like, optional
            Ignored.

        Returns
        -------
        ndarray, shape (len(states),)
        """
        return np.append(self._controller.initial_state(), 0.0)


class LabPI(LabController):
    r"""The lab's integer PI (the ``int`` logs), with a Tustin integrator.

    .. math::

        I_k = I_{k-1} + \tfrac{T}{2}(e_k + e_{k-1}), \qquad c_k = k_p e_k + k_i I_k,

    from :math:`I_{-1} = e_{-1} = 0`; no saturation, no anti-windup.

    Parameters
    ----------
    kp : float, default 0.2084
        Proportional gain, (rad/s)/deg.
    ki : float, default 0.8237
        Integral gain, (rad/s)/(deg s).
    ts : float, default 0.025
        Period :math:`T`, s.

    References
    ----------
    CONTROLLERS.md ("int: PI"); fcontrol ``PIDBlock``.

    Examples
    --------
    >>> pi = LabPI(kp=1.0, ki=2.0, ts=0.5)
    >>> [float(pi.step(1.0, 0.0)[0]) for _ in range(3)]   # I = 0.25, 0.75, 1.25
    [1.5, 2.5, 3.5]
    """

    def __init__(self, kp: float = PI_GAINS[0], ki: float = PI_GAINS[1], ts: float = LAB_TS):
        self.law_states = ["integral", "error[t-1]"]
        self.kp = check_number(kp, "kp")
        self.ki = check_number(ki, "ki")
        self.ts = check_ts(ts)
        self.reset()

    def initial_law_state(self) -> FloatArray:
        """``[I, e_prev] = [0, 0]``."""
        return np.zeros(2)

    def law(self, state: FloatArray, error: float) -> tuple[float, FloatArray]:
        """One period: ``(c_k, [I_k, e_k])``."""
        integral = state[0] + 0.5 * self.ts * (error + state[1])
        return self.kp * error + self.ki * integral, np.array([integral, error])


class LabFractionalController(LabController):
    r"""The lab's fixed fractional controller (the ``fra`` logs and the identification run).

    .. math::

        x_k = x_{k-1} + T e_k, \qquad v_k = \sum_{i=0}^{N-1} w_i\, x_{k-i}, \qquad
        c_k = k_p e_k + k_d v_k,

    with :math:`w_i = (-1)^i \binom{a}{i}`, :math:`a = 1 + f_{ex}`
    (:func:`grunwald_letnikov_weights`, truncated after the first :math:`|w_i| < 0.01`) and
    :math:`x_{k} = 0` for :math:`k < 0`: a Grünwald–Letnikov derivative of order :math:`a` of the
    integral of :math:`e`, i.e. a fractional integral of order :math:`-f_{ex}`. The sum's step is
    1, not :math:`T`, so the realised fractional gain is :math:`k_d T^{a}`.

    Parameters
    ----------
    kp : float, default 0.2084
        Proportional gain, (rad/s)/deg.
    kd : float, default 0.8237
        Gain of the fractional term (on the step-1 sum).
    fex : float, default -0.55
        The lab's exponent (:math:`-1 < f_{ex} < 0`: a fractional integral of order
        :math:`-f_{ex}`).
    ts : float, default 0.025
        Period :math:`T`, s.

    Attributes
    ----------
    weights : ndarray, shape (N,)
        The taps (:math:`N = 12` for :math:`a = 0.45`).

    References
    ----------
    CONTROLLERS.md ("fra: fixed fractional controller"); fcontrol ``FPDBlock``,
    ``FractionalDerivative``; Podlubny (1999), sec. 7.3.

    Examples
    --------
    >>> ctrl = LabFractionalController(kp=0.0, kd=1.0, fex=-0.5, ts=1.0)
    >>> [round(float(ctrl.step(1.0, 0.0)[0]), 6) for _ in range(3)]   # x = 1, 2, 3
    [1.0, 1.5, 1.875]
    """

    def __init__(
        self,
        kp: float = FRA_STAIR_GAINS[0],
        kd: float = FRA_STAIR_GAINS[1],
        fex: float = FRA_STAIR_GAINS[2],
        ts: float = LAB_TS,
    ) -> None:
        self.kp = check_number(kp, "kp")
        self.kd = check_number(kd, "kd")
        self.fex = check_number(fex, "fex")
        self.ts = check_ts(ts)
        self.weights = grunwald_letnikov_weights(1.0 + self.fex)
        n = self.weights.shape[0]
        self.law_states = [f"x[t-{i}]" for i in range(1, n)]
        self.reset()

    def initial_law_state(self) -> FloatArray:
        """``[x_{k-1}, …, x_{k-N+1}]``, zeros."""
        return np.zeros(self.weights.shape[0] - 1)

    def law(self, state: FloatArray, error: float) -> tuple[float, FloatArray]:
        """One period: ``(c_k, [x_k, …, x_{k-N+2}])``."""
        return fractional_period(self.weights, state, error, self.ts, self.kp, self.kd)


def fractional_period(
    weights: FloatArray, history: FloatArray, error: float, ts: float, kp: float, kd: float
) -> tuple[float, FloatArray]:
    r"""One period of the lab's fractional law on a history of the integral.

    Parameters
    ----------
    weights : ndarray, shape (N,)
        The Grünwald–Letnikov taps.
    history : ndarray, shape (M,), M >= N - 1
        :math:`x_{k-1}, x_{k-2}, …` (newest first); only the first ``N - 1`` are read.
    error : float
        :math:`e_k` [deg].
    ts : float
        Period, s.
    kp, kd : float
        The gains of this period.

    Returns
    -------
    command : float
        :math:`c_k = k_p e_k + k_d v_k` [rad/s].
    history : ndarray, shape (M,)
        :math:`x_k, x_{k-1}, …`, shifted by one.
    """
    x = history[0] + ts * error
    n = weights.shape[0]
    v = weights[0] * x + float(weights[1:] @ history[: n - 1])
    following = np.empty_like(history)
    following[0] = x
    following[1:] = history[:-1]
    return kp * error + kd * v, following
