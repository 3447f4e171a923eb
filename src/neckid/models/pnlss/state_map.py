"""State functions of the polynomial nonlinear state-space model, for python-control.

The state is the model's own internal state ``x`` (scaled units); the output and the next state
are computed by :meth:`~neckid.models.pnlss.model.PolynomialStateSpace.run` on one sample, so the
system and the simulator give the same floats.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.systems import StateMap, history_rows
from neckid.utils.types import FloatArray

__all__ = ["PolynomialStateMap"]


class PolynomialStateMap(StateMap):
    """``x``: the ``order_`` internal states of a fitted PolynomialStateSpace.

    Without ``feedthrough`` the output reads the state alone.

    Parameters
    ----------
    model : PolynomialStateSpace
        Fitted.
    """

    def __init__(self, model: Any) -> None:
        super().__init__()
        self._model = model
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        self.states = [f"x{i + 1}" for i in range(int(model.order_))]
        self.ts = float(model.ts_)
        self.feedthrough = bool(model.feedthrough)

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        state = x.copy()
        return np.asarray(self._model.run(u[None, :], state)[0], dtype=np.float64)

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        state = x.copy()
        self._model.run(u[None, :], state)
        return state

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """The state the simulator's ``reset(y0, u0)`` starts from (zero without ``y0``).

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
        u0 : array_like, shape (n_inputs,) or (max_lag_, n_inputs), optional

        Returns
        -------
        ndarray, shape (order_,)
        """
        model = self._model
        if y0 is None:
            return np.zeros(int(model.order_))
        m = int(model.max_lag_)
        y_rows = history_rows(y0, m, len(self.outputs), "y0")
        u_rows = history_rows(u0, m, len(self.inputs), "u0")
        return np.asarray(model.initial_state(y_rows, u_rows), dtype=np.float64)
