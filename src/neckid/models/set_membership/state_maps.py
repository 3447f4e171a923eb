"""State functions of the Set Membership models whose simulator keeps more than a plain history.

:meth:`ParallelSetMembership.state_map
<neckid.models.set_membership.parallel.ParallelSetMembership.state_map>` gives a
:class:`ParallelStateMap`, :meth:`MultiStepSetMembership.state_map
<neckid.models.set_membership.multistep.MultiStepSetMembership.state_map>` a
:class:`MultiStepStateMap`; :func:`neckid.export.control.to_iosystem` turns them into python-control
systems. The other Set Membership models use the generic :class:`~neckid.systems.HistoryMap`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.systems import (
    HistoryMap,
    StateMap,
    has_lag_zero_input,
    history_names,
    history_rows,
)
from neckid.utils.types import FloatArray

__all__ = ["MultiStepStateMap", "ParallelStateMap", "StatefulParallelStateMap"]


def _parallel_feedthrough(model: Any, base_feedthrough: bool) -> bool:
    """Whether a ParallelSetMembership's output reads ``u(t)``.

    Through its SM regressor directly, or through the parallel model's output at lag 0 when
    that one reads ``u(t)``.
    """
    sm_lags = model.sm_.lags_
    measured = np.isin(sm_lags.channel, np.arange(len(model.input_names_)))
    direct = bool(np.any((sm_lags.source == 1) & (sm_lags.lag == 0) & measured))
    through_parallel = bool(np.any((sm_lags.source == 1) & (sm_lags.lag == 0) & ~measured))
    return direct or (through_parallel and base_feedthrough)


class ParallelStateMap(HistoryMap):
    """State functions of a ParallelSetMembership: a history of its linear part's *simulated* outputs.

    ``x = [ŷ_lin(t−m), …, ŷ_lin(t−1), u(t−m), …, u(t−1)]`` with ``m = max(max_lag_, 1)``:
    the linear part's free-run outputs (``<output>_linear``, output units) and the inputs (input
    units), oldest row first. The output function resets the whole model's simulator on that
    history and steps it; the update steps the linear part alone.

    Parameters
    ----------
    model : ParallelSetMembership
        Fitted.
    bounds : bool
        Add the outputs ``<output>_lower`` and ``<output>_upper`` (the step's band).
    linear_suffix : str
        Appended to each output name for the linear part's outputs (``"_linear"``).
    """

    def __init__(self, model: Any, bounds: bool, linear_suffix: str) -> None:
        self._suffix = linear_suffix
        super().__init__(model, bounds)
        self._linear = model.linear_.simulator()
        self._m_linear = max(int(model.linear_.max_lag_), 1)

    def _feedthrough(self, model: Any) -> bool:
        return _parallel_feedthrough(model, has_lag_zero_input(model.linear_.lags_))

    def _state_names(self, model: Any) -> list[str]:
        linear = [n + self._suffix for n in model.output_names_]
        return history_names(linear, self.m) + history_names(model.input_names_, self.m)

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        y_hist, u_hist = self._split(x)
        self._simulator.reset(y0=y_hist, u0=u_hist)
        y, low, high = self._simulator.step_bounds(u)
        return np.concatenate([y, low, high]) if self._bounds else y

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        y_hist, u_hist = self._split(x)
        self._linear.reset(y_hist[-self._m_linear :], u_hist[-self._m_linear :])
        y_linear = np.asarray(self._linear.step(u), dtype=np.float64)
        return np.concatenate([y_hist[1:].ravel(), y_linear, u_hist[1:].ravel(), u])


class StatefulParallelStateMap(StateMap):
    """State functions of a ParallelSetMembership whose parallel model has a state of its own.

    The base is a state-space model (``ss``, ``pnlss``, ``greybox-neck``): its state is not a
    history of its outputs, so the state is the base's own followed by the SM regressor's
    history, ``m = max(max_lag_, 1)`` rows of ``[u, ŷ_base]`` (the measured inputs, then the
    base's simulated outputs ``<output>_linear``), oldest row first:
    ``x = [x_base, u(t−m), ŷ_base(t−m), …, u(t−1), ŷ_base(t−1)]``. The output function evaluates
    the base's output at ``x_base``, the SM bounds at the regressor that completes, and the
    model's estimate, with the arithmetic of :class:`ParallelSetMembershipSimulator
    <neckid.models.set_membership.parallel.ParallelSetMembershipSimulator>` (the same bits); the
    update advances the base's state and shifts the history.

    Parameters
    ----------
    model : ParallelSetMembership
        Fitted, on a base with a ``state_map``.
    bounds : bool
        Add the outputs ``<output>_lower`` and ``<output>_upper`` (the step's band).
    linear_suffix : str
        Appended to each output name for the base's outputs (``"_linear"``).
    """

    def __init__(self, model: Any, bounds: bool, linear_suffix: str) -> None:
        super().__init__()
        self._model = model
        self._base = model.linear_.state_map()
        self._n_base = len(self._base.states)
        self._m_base = max(int(model.linear_.max_lag_), 1)
        self._bounds = bounds
        self.m = max(int(model.max_lag_), 1)
        self.n_in, self.n_out = len(model.input_names_), len(model.output_names_)
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        if bounds:
            self.outputs += [
                f"{n}_{side}" for side in ("lower", "upper") for n in model.output_names_
            ]
        parallel = [n + linear_suffix for n in model.output_names_]
        self.states = [f"base.{n}" for n in self._base.states] + history_names(
            [*model.input_names_, *parallel], self.m
        )
        self.ts = float(model.ts_)
        self.feedthrough = _parallel_feedthrough(model, bool(self._base.feedthrough))

    def _split(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        return x[: self._n_base], x[self._n_base :].reshape(self.m, self.n_in + self.n_out)

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        x_base, history = self._split(x)
        y_base = self._base.output(x_base, u)
        v = np.vstack([history, np.concatenate([u, y_base])[None, :]])
        t = v.shape[0] - 1
        w = self._model.sm_.lags_.regressor_from_history(np.empty((t + 1, 0)), v, t)
        found = self._model.sm_.core_.bounds(np.ascontiguousarray(w[None, :]))
        low, high = found.lower[0], found.upper[0]
        y = np.asarray(self._model._estimate(found.central[0], y_base, low, high), np.float64)
        return np.concatenate([y, low, high]) if self._bounds else y

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        x_base, history = self._split(x)
        y_base = self._base.output(x_base, u)
        after = self._base.update(x_base, u)
        return np.concatenate([after, history[1:].ravel(), u, y_base])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """The state ``ParallelSetMembershipSimulator.reset(y0, u0)`` starts from.

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (m, n_outputs), optional
            Past outputs, oldest first; one row is repeated; default zeros. The base starts
            from its last rows, and the history takes them as the base's past outputs.
        u0 : array_like, shape (n_inputs,) or (m, n_inputs), optional
            Past inputs, the same way.

        Returns
        -------
        ndarray, shape (n_base_states + m * (n_inputs + n_outputs),)
        """
        y_hist = history_rows(y0, self.m, self.n_out, "y0")
        u_hist = history_rows(u0, self.m, self.n_in, "u0")
        x_base = self._base.initial_state(y_hist[-self._m_base :], u_hist[-self._m_base :])
        return np.concatenate([np.asarray(x_base, np.float64), np.hstack([u_hist, y_hist]).ravel()])


class MultiStepStateMap(StateMap):
    """State functions of a MultiStepSetMembership: its free run's anchor and the inputs since.

    ``x = [k, y anchor (m rows), u anchor (m rows), u since the anchor (horizon − 1 rows)]``
    with ``k`` the steps taken since the anchor (``steps_since_anchor``, a whole number; rows
    past ``k`` are zero), ``m = max(max_lag_, 1)``, outputs and inputs in their units, rows
    oldest first. The simulator is rebuilt by ``reset`` on the anchor and a replay of the ``k``
    inputs (deterministic, so the same bits), then stepped: up to ``horizon`` evaluations per
    sample.

    Parameters
    ----------
    model : MultiStepSetMembership
        Fitted.
    bounds : bool
        Add the outputs ``<output>_lower`` and ``<output>_upper`` (the step's band).
    """

    def __init__(self, model: Any, bounds: bool) -> None:
        super().__init__()
        self._simulator = model.simulator()
        self._bounds = bounds
        self.m = max(int(model.max_lag_), 1)
        self.block = int(model.horizon)
        self.n_out, self.n_in = len(model.output_names_), len(model.input_names_)
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        if bounds:
            self.outputs += [
                f"{n}_{side}" for side in ("lower", "upper") for n in model.output_names_
            ]
        since = [f"{n}[anchor+{j}]" for j in range(1, self.block) for n in model.input_names_]
        self.states = [
            "steps_since_anchor",
            *history_names([f"{n}_anchor" for n in model.output_names_], self.m),
            *history_names([f"{n}_anchor" for n in model.input_names_], self.m),
            *since,
        ]
        self.ts = float(model.ts_)
        self.feedthrough = any(has_lag_zero_input(e.lags_) for e in model.estimators_)

    def _split(self, x: FloatArray) -> tuple[int, FloatArray, FloatArray, FloatArray]:
        n_y, n_u = self.m * self.n_out, self.m * self.n_in
        steps = round(float(x[0]))
        y_anchor = x[1 : 1 + n_y].reshape(self.m, self.n_out)
        u_anchor = x[1 + n_y : 1 + n_y + n_u].reshape(self.m, self.n_in)
        since = x[1 + n_y + n_u :].reshape(self.block - 1, self.n_in)
        return steps, y_anchor, u_anchor, since

    def _replay(self, x: FloatArray, u: FloatArray) -> tuple[list[FloatArray], FloatArray]:
        steps, y_anchor, u_anchor, since = self._split(x)
        self._simulator.reset(y0=y_anchor, u0=u_anchor)
        outputs = [
            np.asarray(self._simulator.step(since[j]), dtype=np.float64) for j in range(steps)
        ]
        y, low, high = self._simulator.step_bounds(u)
        outputs.append(np.asarray(y, dtype=np.float64))
        return outputs, np.concatenate([y, low, high]) if self._bounds else outputs[-1]

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        return self._replay(x, u)[1]

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        steps, y_anchor, u_anchor, since = self._split(x)
        since = since.copy()
        if steps + 1 < self.block:
            since[steps] = u
            return np.concatenate(
                [[steps + 1.0], y_anchor.ravel(), u_anchor.ravel(), since.ravel()]
            )
        outputs, _ = self._replay(x, u)
        y_rows = np.vstack([y_anchor, *outputs])[-self.m :]
        u_rows = np.vstack([u_anchor, since[:steps], u[None, :]])[-self.m :]
        return np.concatenate([[0.0], y_rows.ravel(), u_rows.ravel(), np.zeros(since.size)])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """The state at an anchor: the given history, no step taken since.

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (m, n_outputs), optional
            Past outputs, oldest first; one row is repeated; default zeros.
        u0 : array_like, shape (n_inputs,) or (m, n_inputs), optional
            Past inputs, the same way.

        Returns
        -------
        ndarray, shape (1 + m * (n_outputs + n_inputs) + (horizon − 1) * n_inputs,)
        """
        y_hist = history_rows(y0, self.m, self.n_out, "y0")
        u_hist = history_rows(u0, self.m, self.n_in, "u0")
        return np.concatenate(
            [[0.0], y_hist.ravel(), u_hist.ravel(), np.zeros((self.block - 1) * self.n_in)]
        )
