"""The step-by-step free run of a :class:`~neckid.models.scheduled.model.GainScheduledModel`.

:class:`GainScheduledSimulator` holds the state of the scheduled first-order model (inclination,
rate, the last ``d`` commands) and advances it one sample at a time, so the model can sit in a
closed loop beside a controller; :func:`clipped_polyval` is the schedule it evaluates, shared with
the model's ``gain`` and ``pole``.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from neckid.utils.checks import check_finite
from neckid.utils.types import FloatArray

__all__ = ["GainScheduledSimulator", "clipped_polyval"]


class _FittedSchedule(Protocol):
    """The fitted attributes of a :class:`~neckid.models.scheduled.model.GainScheduledModel` used here."""

    gain_coefficients_: FloatArray
    pole_coefficients_: FloatArray
    schedule_range_: FloatArray
    pole_bound: float
    form: str
    ts_: float
    delay_: int
    n_inputs_: int
    lags_: Any


def clipped_polyval(
    coefficients: FloatArray, inclination: ArrayLike, schedule_range: FloatArray
) -> FloatArray:
    """A polynomial (highest power first) at the inclination clipped to ``[low, high]`` [deg]."""
    scheduling = np.clip(np.asarray(inclination, dtype=np.float64), *schedule_range)
    return np.asarray(np.polyval(coefficients, scheduling))


class GainScheduledSimulator:
    """Step-by-step free run of a :class:`GainScheduledModel`, for a closed loop beside a controller.

    ``step(u)`` takes the inputs at the current time ``t`` (the command among them; a scalar when
    the model has one input) and returns the inclination ``i(t)`` [deg], which depends on the
    commands up to ``t − d`` (``d = delay_``). Rate form:
    ``r(t) = P(s) r(t−1) + N(s) u(t−d)``, ``i(t) = i(t−1) + ts r(t)``; position form:
    ``i(t) = P(s) i(t−1) + N(s) u(t−d)`` and ``r(t) = (i(t) − i(t−1)) / ts``. ``s`` is
    ``i(t−1)`` clipped to the model's ``schedule_range_``, ``P`` is held in ``±pole_bound``
    (the values of :meth:`GainScheduledModel.gain` and :meth:`GainScheduledModel.pole`).
    """

    def __init__(self, model: _FittedSchedule) -> None:
        self._gain = np.asarray(model.gain_coefficients_, dtype=np.float64)
        self._pole = np.asarray(model.pole_coefficients_, dtype=np.float64)
        self._range = np.asarray(model.schedule_range_, dtype=np.float64)
        self._bound = float(model.pole_bound)
        self._position = model.form == "position"
        self.ts = float(model.ts_)
        self.delay = int(model.delay_)
        self.n_inputs = model.n_inputs_
        self.n_outputs = 1
        self._channel = int(model.lags_.channel[model.lags_.source == 1][0])
        self.reset()

    def reset(
        self, y0: ArrayLike | None = None, u0: ArrayLike | None = None, rate0: float = 0.0
    ) -> None:
        """Start again at inclination ``y0`` [deg] (default 0), rate ``rate0`` [deg/s], past inputs ``u0``.

        ``y0`` and ``u0`` may be one row or a history of rows (oldest first): the last row is
        used, and the past commands ``u(t−d) … u(t−1)`` are all taken equal to it. In the
        position form the state is the inclination alone: ``rate0`` is only reported as
        :attr:`rate` until the first step.
        """
        y_array = np.zeros(1) if y0 is None else np.asarray(y0, dtype=np.float64).reshape(-1)
        if y_array.size == 0:
            raise ValueError("y0 must hold the initial inclination; got an empty array")
        y_row = y_array[-1:]
        u_array = np.zeros(self.n_inputs) if u0 is None else np.asarray(u0, dtype=np.float64)
        u_row = u_array.reshape(-1, self.n_inputs)[-1] if u_array.size else np.zeros(self.n_inputs)
        values = np.array([float(y_row[0]), float(rate0), float(u_row[self._channel])])
        check_finite(values[None, :], "initial state", ["y0", "rate0", "u0"])
        self.inclination = float(values[0])
        self.rate = float(values[1])
        self._past_u = [float(values[2])] * self.delay  # u(t-d), ..., u(t-1)

    @property
    def current_gain(self) -> float:
        """``N`` at the current inclination (used by the next step)."""
        return float(clipped_polyval(self._gain, self.inclination, self._range))

    @property
    def current_pole(self) -> float:
        """``P`` at the current inclination (used by the next step)."""
        pole = clipped_polyval(self._pole, self.inclination, self._range)
        return float(np.clip(pole, -self._bound, self._bound))

    def step(self, u: float | ArrayLike) -> FloatArray:
        """Advance one sample with inputs ``u``; return the inclination, shape ``(1,)``."""
        u_now = np.asarray(u, dtype=np.float64).reshape(-1)
        if u_now.size != self.n_inputs:
            raise ValueError(f"u must have {self.n_inputs} value(s) (one per input); got {u!r}")
        check_finite(u_now[None, :], "u")
        gain = self.current_gain
        pole = self.current_pole
        if self._position:
            previous = self.inclination
            self.inclination = pole * previous + gain * self._past_u[0]
            self.rate = (self.inclination - previous) / self.ts
        else:
            self.rate = pole * self.rate + gain * self._past_u[0]
            self.inclination = self.inclination + self.ts * self.rate
        self._past_u = [*self._past_u[1:], float(u_now[self._channel])]
        return np.array([self.inclination])
