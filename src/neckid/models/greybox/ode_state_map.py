"""State functions of a GreyBoxODE, for python-control (:func:`neckid.export.control.to_iosystem`).

The state is the structure's own state at the current sample (the simulator's): the output is
``y(t) = g(x(t), u(t), θ)`` and the update integrates ``x`` over one period with ``u(t)`` held,
by the same kernel as the free run, so the system and the simulator give the same floats.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.models.greybox.ode_kernels import advance, evaluate
from neckid.systems import StateMap
from neckid.utils.types import FloatArray

__all__ = ["GreyBoxODEStateMap"]


class GreyBoxODEStateMap(StateMap):
    """``x``: the structure's states (named and in the units of the structure) of a fitted GreyBoxODE.

    Parameters
    ----------
    model : GreyBoxODE
        Fitted.
    """

    def __init__(self, model: Any) -> None:
        super().__init__()
        self._model = model
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        self.states = list(model.structure_.state_names)
        self.ts = float(model.ts_)

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        model = self._model
        return evaluate(model.structure_.output_equation, x, u, model.parameters_)

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        model = self._model
        return advance(model.structure_, x, u, model.parameters_, model.ts_, model.substeps_)

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """The state after the simulator's ``reset(y0, u0)``: the rule's state, one period on.

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (rows, n_outputs), optional
        u0 : array_like, shape (n_inputs,) or (rows, n_inputs), optional

        Returns
        -------
        ndarray, shape (n_states,)
        """
        simulator = self._model.simulator()
        simulator.reset(y0, u0)
        return np.array(simulator.state, dtype=np.float64)
