"""State functions of the grey-box neck, for python-control (:func:`neckid.export.control.to_iosystem`).

The state is everything :class:`~neckid.models.greybox.model.GreyBoxSimulator` remembers: the
last ``max_lag_`` outputs, the last ``max_lag_`` operator outputs ``v`` and the plays' outputs
(the hysteresis memory, one per motor and radius). The output and the next state are computed by
the simulator's own ``step``, so the system and the simulator give the same floats.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.systems import StateMap, history_names
from neckid.utils.types import FloatArray

__all__ = ["GreyBoxStateMap"]


class GreyBoxStateMap(StateMap):
    """``x = [y(t−m) … y(t−1), v(t−m) … v(t−1), plays]`` of a fitted GreyBoxNeck.

    ``m = max_lag_``; ``v`` is the slack-and-hysteresis output before the dynamics (in the
    output's units), counted from its value at rest (zero inputs, relaxed plays) so that the
    zero state is the simulator's default ``reset()``; the plays are in the motor input's
    units, motor by motor.

    Parameters
    ----------
    model : GreyBoxNeck
        Fitted.
    """

    def __init__(self, model: Any) -> None:
        super().__init__()
        self._simulator = model.simulator()
        self._m = int(model.max_lag_)
        self._n_out = int(model.n_outputs_)
        self._plays_shape = self._simulator._plays.shape
        # v at rest (zero inputs, relaxed plays): the state holds v minus it, so that the zero
        # state is the simulator's default reset, as python-control starts from zero.
        self._simulator.reset()
        self._v_rest = self._simulator._v[0].copy()
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        plays = [
            f"play[{model.input_names_[j]},{r}]"
            for j in range(self._plays_shape[0])
            for r in range(self._plays_shape[1])
        ]
        v_names = [f"v_{name}" for name in model.output_names_]
        self.states = [
            *history_names(self.outputs, self._m),
            *history_names(v_names, self._m),
            *plays,
        ]
        self.ts = float(model.ts_)
        # With a delay of a sample or more the output reads past operator outputs only.
        self.feedthrough = int(model.delay) == 0

    def _load(self, x: FloatArray) -> None:
        """Put the state ``x`` into the simulator."""
        size = self._m * self._n_out
        self._simulator._y = x[:size].reshape(self._m, self._n_out).copy()
        self._simulator._v = x[size : 2 * size].reshape(self._m, self._n_out) + self._v_rest
        self._simulator._plays = x[2 * size :].reshape(self._plays_shape).copy()

    def _state(self) -> FloatArray:
        simulator = self._simulator
        return np.concatenate(
            [
                simulator._y.ravel(),
                (simulator._v - self._v_rest).ravel(),
                simulator._plays.ravel(),
            ]
        )

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        self._load(x)
        return np.asarray(self._simulator.step(u), dtype=np.float64)

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        self._load(x)
        self._simulator.step(u)
        return self._state()

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """The state after the simulator's ``reset(y0, u0)`` (plays relaxed at the oldest input).

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
        u0 : array_like, shape (n_inputs,) or (max_lag_, n_inputs), optional

        Returns
        -------
        ndarray, shape (len(states),)
        """
        self._simulator.reset(y0, u0)
        return self._state()
