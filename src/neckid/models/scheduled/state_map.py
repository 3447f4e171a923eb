"""State functions of the gain-scheduled model, and the names its state-space forms share.

:meth:`GainScheduledModel.state_map <neckid.models.scheduled.model.GainScheduledModel.state_map>`
gives a :class:`ScheduledStateMap`; :func:`neckid.export.control.to_iosystem` turns it into a
python-control system, and :func:`neckid.export.control.to_control` names the states of the model
frozen at one inclination with :func:`scheduled_state_names`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.systems import StateMap
from neckid.utils.checks import check_finite
from neckid.utils.types import FloatArray

__all__ = ["ScheduledStateMap", "command_channel", "scheduled_state_names"]


def command_channel(model: Any) -> int:
    """Index of the scheduled model's command among its inputs (its one lagged input).

    Parameters
    ----------
    model : GainScheduledModel
        Fitted.

    Returns
    -------
    int
    """
    return int(model.lags_.channel[model.lags_.source == 1][0])


def scheduled_state_names(model: Any) -> list[str]:
    """State names of the scheduled model: ``[i(t−1), r(t−1), u(t−d), …, u(t−1)]``.

    Parameters
    ----------
    model : GainScheduledModel
        Fitted.

    Returns
    -------
    list of str
        ``<output>[t-1]`` (the inclination, deg), ``<output>_rate[t-1]`` (its rate, deg/s) and
        ``<command>[t-d]`` … ``<command>[t-1]`` (the last ``d = delay_`` commands).
    """
    output = model.output_names_[0]
    command = model.input_names_[command_channel(model)]
    past = [f"{command}[t-{model.delay_ - k}]" for k in range(model.delay_)]
    return [f"{output}[t-1]", f"{output}_rate[t-1]", *past]


class ScheduledStateMap(StateMap):
    """State functions of a GainScheduledModel: ``x = [i(t−1), r(t−1), u(t−d), …, u(t−1)]``.

    The inclination [deg] and its rate [deg/s] of the previous sample, and the last ``d``
    commands (``d = delay_``, in the command's units); names from
    :func:`scheduled_state_names`. The output is a function of the state alone (no
    feedthrough), computed with the same operations, in the same order, as
    :meth:`~neckid.models.scheduled.simulator.GainScheduledSimulator.step`.

    Parameters
    ----------
    model : GainScheduledModel
        Fitted.
    """

    feedthrough = False

    def __init__(self, model: Any) -> None:
        super().__init__()
        self._model = model
        self._channel = command_channel(model)
        self.delay = int(model.delay_)
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        self.states = scheduled_state_names(model)
        self.ts = float(model.ts_)
        self._position = getattr(model, "form", "rate") == "position"

    def _advance(self, x: FloatArray) -> tuple[float, float]:
        incl, rate = float(x[0]), float(x[1])
        # The same operations, in the same order, as GainScheduledSimulator.step.
        gain = float(self._model.gain(incl))
        pole = float(self._model.pole(incl))
        if self._position:
            following = pole * incl + gain * float(x[2])
            return following, (following - incl) / self.ts
        rate = pole * rate + gain * float(x[2])
        return incl + self.ts * rate, rate

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        return np.array([self._advance(x)[0]])

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        check_finite(u[None, :], "u")
        incl, rate = self._advance(x)
        return np.array([incl, rate, *x[3:], u[self._channel]])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """The state at rest (rate 0) from the last row of each, as the simulator's ``reset``.

        Parameters
        ----------
        y0 : array_like, optional
            Past inclinations [deg]; the last value is used (default 0).
        u0 : array_like, shape (n_inputs,) or (m, n_inputs), optional
            Past inputs; the command of the last row fills the ``d`` past commands (default 0).

        Returns
        -------
        ndarray, shape (2 + delay_,)

        Raises
        ------
        ValueError
            If a value is NaN or inf.
        """
        y_last = 0.0 if y0 is None else float(np.asarray(y0, dtype=np.float64).reshape(-1)[-1])
        u_rows = np.zeros(len(self.inputs)) if u0 is None else np.asarray(u0, dtype=np.float64)
        u_last = float(u_rows.reshape(-1, len(self.inputs))[-1, self._channel])
        state = np.array([y_last, 0.0, *([u_last] * self.delay)])
        check_finite(state[None, :], "initial state")
        return state
