"""State functions of the Koopman model, for python-control: the lifted linear system itself.

The state ``x`` is the lifted state without its constant entry, counted from the lift of a
zero history ``z₀`` (where the simulator's ``reset()`` starts, and python-control's default
``X0 = 0``): ``z = [x; 0] + z₀``, ``output(x, u) = C z + D u`` and ``update(x, u)`` the first
entries of ``A z + B u − z₀``, with the matrices of
:meth:`~neckid.models.koopman.model.KoopmanEDMD.lifted_system`; the I/O system, the simulator
and ``simulate`` agree to rounding.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.systems import StateMap, history_rows
from neckid.utils.types import FloatArray

__all__ = ["KoopmanStateMap"]


class KoopmanStateMap(StateMap):
    """``x``: a fitted KoopmanEDMD's lifted state (delays, observables) from the rest lift ``z₀``.

    Parameters
    ----------
    model : KoopmanEDMD
        Fitted.
    """

    def __init__(self, model: Any) -> None:
        super().__init__()
        self._model = model
        self._system = model.lifted_system()
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        self.states = model.state_names()[:-1]
        self.ts = float(model.ts_)
        self.feedthrough = bool(np.any(self._system.D))
        self._rest = model.simulator().x.copy()  # z₀: the lift of a zero history

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        z = np.append(x, 0.0) + self._rest
        return np.asarray(self._system.C @ z + self._system.D @ u, dtype=np.float64)

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        z = np.append(x, 0.0) + self._rest
        ahead = self._system.A @ z + self._system.B @ u - self._rest
        return np.asarray(ahead[:-1], dtype=np.float64)

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """The state the simulator's ``reset(y0, u0)`` starts from (0 without ``y0``).

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
        u0 : array_like, shape (n_inputs,) or (max_lag_, n_inputs), optional

        Returns
        -------
        ndarray, shape (order_ - 1,)
        """
        if y0 is None:
            return np.zeros(len(self.states))
        m = max(int(self._model.max_lag_), 1)
        y_rows = history_rows(y0, m, len(self.outputs), "y0")
        u_rows = history_rows(u0, m, len(self.inputs), "u0")
        lifted = self._model.initial_state(y_rows, u_rows) - self._rest
        return np.asarray(lifted[:-1], dtype=np.float64)
