r"""Designed controllers as objects: :math:`c_k = k_p e_k + k_f v_k`, :math:`v = D(z) e`.

:class:`DesignedController` follows :class:`neckid.systems.Controller` (``reset()``,
``step(reference, measurement) -> command``) like the simulated neck's PI and the lab's
controllers, so it runs in :func:`neckid.plant.closed_loop`,
:func:`neckid.loops.model_in_loop.model_in_the_loop` and, through ``state_map()``, in
:func:`neckid.export.control.to_iosystem` (python-control's ``NonlinearIOSystem``, saturation and
schedule included). :meth:`DesignedController.to_control` gives the linear controller from the
error to the command as a ``control.StateSpace``, exactly (no saturation; a scheduled
controller at one inclination): the operator's state space (:mod:`neckid.design.operators`)
scaled by :math:`k_f`, plus :math:`k_p`. The lab's Grünwald–Letnikov sum is an FIR filter on the
error's integral; its state space is the integrator and the shift register of the last
:math:`N - 1` integrals, exact, not an approximation.

One period, from the error :math:`e_k = r_k - y_{k-1}` [deg]:

.. math:: v_k = C_D s_k + D_D e_k, \quad u_k = k_p e_k + k_f v_k, \quad
          c_k = \mathrm{clip}(u_k, \pm c_{max}), \quad s_{k+1} = A_D s_k + B_D e_k

unless the command saturates and the error pushes it further (:math:`e_k u_k > 0`): then
:math:`s_{k+1} = s_k` (conditional integration, the anti-windup of
:class:`~neckid.plant.InclinationController`). Without ``command_limit`` there is no clipping
(the lab's controllers have none). A NaN measurement is a failed sensor read: the last command is
held and nothing else changes (the lab's behaviour). A scheduled controller takes
:math:`(k_p, k_f)` interpolated linearly in the measured inclination (held at the ends of its
table), keeping the operator's state when they change, as the lab's adaptive controller does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.design.operators import DiscreteOperator
from neckid.loops.controllers.lab import LabControllerStateMap
from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = ["DesignedController", "DesignedStateMap", "GainSchedule"]


@dataclass(frozen=True)
class GainSchedule:
    """Gains against the inclination: linear interpolation, held beyond the table's ends.

    Attributes
    ----------
    inclinations : ndarray, shape (n,)
        Increasing, deg.
    kp, kf : ndarray, shape (n,)
        The gains there.
    """

    inclinations: FloatArray
    kp: FloatArray
    kf: FloatArray

    def __post_init__(self) -> None:
        points = np.asarray(self.inclinations, dtype=np.float64)
        if points.ndim != 1 or points.size < 2 or np.any(np.diff(points) <= 0):
            raise ValueError(
                "a gain schedule needs two or more increasing inclinations; got"
                f" {np.asarray(self.inclinations).tolist()}"
            )
        for name in ("kp", "kf"):
            values = np.asarray(getattr(self, name), dtype=np.float64)
            if values.shape != points.shape or not np.all(np.isfinite(values)):
                raise ValueError(
                    f"schedule {name} must be {points.size} finite gains, one per inclination;"
                    f" got {values.tolist()}"
                )

    def at(self, inclination: float) -> tuple[float, float]:
        """``(kp, kf)`` at an inclination [deg]."""
        return (
            float(np.interp(inclination, self.inclinations, self.kp)),
            float(np.interp(inclination, self.inclinations, self.kf)),
        )


class DesignedController:
    r"""A designed PI or fractional controller, :math:`k_p + k_f D(z)`, optionally scheduled.

    Parameters
    ----------
    kp : float
        Proportional gain, (rad/s)/deg (ignored when ``schedule`` is given).
    kf : float
        Gain of the operator (:math:`k_i` for the Tustin integrator; of :math:`s^\alpha`
        otherwise).
    operator : DiscreteOperator
        :mod:`neckid.design.operators`.
    command_limit : float, optional
        Saturation of the command, rad/s, with conditional integration (None: none).
    schedule : GainSchedule, optional
        Gains against the measured inclination.
    info : dict, optional
        What the design was (spec, achieved margins, the model): kept in the controller file.

    Attributes
    ----------
    ts : float
        The operator's period, s.
    n_references, n_motors : int
        1 and 1.

    Examples
    --------
    >>> from neckid.design.operators import tustin_integrator
    >>> pi = DesignedController(1.0, 2.0, tustin_integrator(0.5))
    >>> [float(pi.step(1.0, 0.0)[0]) for _ in range(3)]   # as the lab's PI: I = 0.25, 0.75, 1.25
    [1.5, 2.5, 3.5]
    """

    n_references = 1
    n_motors = 1

    def __init__(
        self,
        kp: float,
        kf: float,
        operator: DiscreteOperator,
        *,
        command_limit: float | None = None,
        schedule: GainSchedule | None = None,
        info: dict[str, Any] | None = None,
    ) -> None:
        if not isinstance(operator, DiscreteOperator):
            raise TypeError(f"operator must be a DiscreteOperator; got {type(operator).__name__}")
        if schedule is not None and not isinstance(schedule, GainSchedule):
            raise TypeError(f"schedule must be a GainSchedule; got {type(schedule).__name__}")
        self.kp = check_number(kp, "kp")
        self.kf = check_number(kf, "kf")
        self.operator = operator
        self.command_limit = (
            None
            if command_limit is None
            else check_number(command_limit, "command_limit", low=0, closed="neither")
        )
        self.schedule = schedule
        self.info = dict(info or {})
        self.ts = operator.ts
        self.reset()

    @property
    def kind(self) -> str:
        """``"pi"`` (the Tustin integrator) or ``"fractional"``, ``"scheduled-"`` before when scheduled."""
        base = "pi" if self.operator.method == "tustin" else "fractional"
        return f"scheduled-{base}" if self.schedule is not None else base

    @property
    def order(self) -> float:
        r"""The operator's order :math:`\alpha` (−1 for the integrator)."""
        return self.operator.order

    @property
    def states(self) -> list[str]:
        """Names of the state: the operator's, then ``velocity_command[t-1]``."""
        return [f"operator[{i}]" for i in range(self.operator.n_states)] + ["velocity_command[t-1]"]

    def gains(self, inclination: float) -> tuple[float, float]:
        """``(kp, kf)`` at a measured inclination [deg] (the fixed gains when not scheduled)."""
        if self.schedule is None:
            return self.kp, self.kf
        return self.schedule.at(inclination)

    def initial_state(self) -> FloatArray:
        """Zeros: the operator at rest and no command yet."""
        return np.zeros(self.operator.n_states + 1)

    def control_law(
        self, state: ArrayLike, reference: ArrayLike, measurement: ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """The controller as a pure function: command and next state from a given state.

        Parameters
        ----------
        state : array_like, shape (len(states),)
            As :meth:`initial_state` packs it.
        reference : float
            Inclination reference [deg].
        measurement : float
            Inclination [deg]; NaN for a failed read (the last command is held).

        Returns
        -------
        command : ndarray, shape (1,)
            Velocity command [rad/s].
        state : ndarray
            The next state.

        Raises
        ------
        ValueError
            If the state has the wrong size or the reference is not finite.
        """
        full = np.asarray(state, dtype=np.float64).reshape(-1)
        if full.shape[0] != self.operator.n_states + 1:
            raise ValueError(
                f"state must have {self.operator.n_states + 1} values; got {full.shape[0]}"
            )
        y = float(np.asarray(measurement, dtype=np.float64).reshape(-1)[0])
        if math.isnan(y):
            return full[-1:].copy(), full.copy()
        r = float(np.asarray(reference, dtype=np.float64).reshape(-1)[0])
        if not (math.isfinite(r) and math.isfinite(y)):
            raise ValueError(f"reference and measurement must be finite; got {r}, {y}")
        error = r - y
        inner = full[:-1]
        v, following = self.operator.step(inner, error)
        kp, kf = self.gains(y)
        wanted = kp * error + kf * v
        command = wanted
        if self.command_limit is not None and abs(wanted) > self.command_limit:
            command = math.copysign(self.command_limit, wanted)
            if error * wanted > 0.0:
                following = inner.copy()
        return np.array([command]), np.append(following, command)

    def reset(self) -> None:
        """Back to the initial state."""
        self._state = self.initial_state()

    def step(self, reference: ArrayLike, measurement: ArrayLike) -> FloatArray:
        """One control period.

        Parameters
        ----------
        reference : float
            Inclination reference [deg].
        measurement : float
            The last measured inclination [deg]; NaN for a failed read.

        Returns
        -------
        ndarray, shape (1,)
            Velocity command [rad/s].
        """
        command, self._state = self.control_law(self._state, reference, measurement)
        return command

    def response(self, omega: ArrayLike, inclination: float | None = None) -> np.ndarray:
        r"""Frequency response :math:`k_p + k_f D(e^{j\omega T})` of the linear controller.

        Parameters
        ----------
        omega : array_like
            rad/s.
        inclination : float, optional
            For a scheduled controller, where to take the gains [deg] (required then).

        Returns
        -------
        ndarray of complex
        """
        kp, kf = self._linear_gains(inclination)
        return kp + kf * self.operator.response(omega)

    def _linear_gains(self, inclination: float | None) -> tuple[float, float]:
        if self.schedule is not None and inclination is None:
            raise ValueError("a scheduled controller needs inclination= (deg) for its gains")
        return self.gains(0.0 if inclination is None else float(inclination))

    def to_control(self, inclination: float | None = None) -> Any:
        """The linear controller as a ``control.StateSpace``: input ``error`` [deg], output ``velocity_command``.

        Exact for the realised operator (the GL sum's FIR as its shift register); no
        saturation. A scheduled controller is taken at ``inclination`` [deg].

        Parameters
        ----------
        inclination : float, optional
            Required for a scheduled controller.

        Returns
        -------
        control.StateSpace
        """
        import control

        kp, kf = self._linear_gains(inclination)
        op = self.operator
        return control.ss(
            op.a,
            op.b[:, None],
            kf * op.c[None, :],
            [[kp + kf * op.d]],
            dt=self.ts,
            inputs=["error"],
            outputs=["velocity_command"],
            name=f"{self.kind} controller",
        )

    def state_map(self, bounds: bool = False) -> DesignedStateMap:
        """The controller's state functions, for :func:`neckid.export.control.to_iosystem`.

        Parameters
        ----------
        bounds : bool, default False
            Ignored (a controller has no band).

        Returns
        -------
        DesignedStateMap
        """
        return DesignedStateMap(self)

    def __repr__(self) -> str:
        return (
            f"DesignedController(kind={self.kind!r}, kp={self.kp:.6g}, kf={self.kf:.6g},"
            f" order={self.order:.6g}, method={self.operator.method!r}, ts={self.ts!r},"
            f" command_limit={self.command_limit!r})"
        )


class DesignedStateMap(LabControllerStateMap):
    """State functions of a :class:`DesignedController`: the lab's controllers' map.

    Inputs ``reference`` and ``inclination`` [deg]; output ``velocity_command`` [rad/s]; state
    ``[operator..., velocity_command[t-1], inclination[t-1]]``. The command of sample ``k`` reads
    the inclination of sample ``k − 1`` from the state, as :func:`neckid.plant.closed_loop`
    does, so there is no feedthrough from the measurement.

    Parameters
    ----------
    controller : DesignedController
        Its :meth:`~DesignedController.control_law` is the map (its own state is not touched).
    """

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """Zeros, as after :meth:`DesignedController.reset`, and a zero first inclination.

        Parameters
        ----------
        y0, u0 : array_like, optional
            Ignored.

        Returns
        -------
        ndarray, shape (len(states),)
        """
        return np.zeros(len(self.states))
