r"""A NARX model's linear form around an operating point: its one-step map differentiated there.

A NARX model :math:`y(t) = f(y(t-1), \dots, y(t-m), u(t), \dots, u(t-m))` at an equilibrium
:math:`(y^*, u^*)`, :math:`f(y^*, \dots, u^*, \dots) = y^*`, behaves for small deviations as the
ARX model

.. math:: \delta y(t) = \sum_{l=1}^{m} a_l\, \delta y(t-l) + \sum_{l=0}^{m} b_l\, \delta u(t-l),
   \qquad a_l = \frac{\partial f}{\partial y(t-l)},\ b_l = \frac{\partial f}{\partial u(t-l)},

i.e. :math:`G(z) = \sum_l b_l z^{m-l} / (z^m - \sum_l a_l z^{m-l})`. The derivatives are central
differences of the model's own one-step map (its ``state_map()``, which rebuilds the simulator
from the history), with a step of ``step`` times each channel's training range: for the Set
Membership models, whose central estimate is piecewise linear in the regressor (a mean of
Lipschitz cones), this is a secant over that step, not a derivative, and it depends on the step.

The equilibrium input is found by Brent's method on the position channel (the model's input
that sets where the neck rests: ``motor_position`` or ``motor_displacement``) over its training
range widened by half; velocity channels rest at 0, conditions at the middle of their range.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = [
    "COMMAND",
    "POSITION_CHANNELS",
    "VELOCITY_CHANNELS",
    "NoLinearFormError",
    "equilibrium",
    "linearise",
]

#: The command channel of the loop.
COMMAND = "velocity_command"
#: Model inputs fed by the motor position (the drive integrates the command).
POSITION_CHANNELS = ("motor_position", "motor_displacement")
#: Model inputs fed by the motor velocity.
VELOCITY_CHANNELS = ("motor_velocity",)


class NoLinearFormError(TypeError):
    """The model has no linear form a controller can be designed on (the message says why)."""


def _span(model: Any, name: str) -> tuple[float, float]:
    ranges: dict[str, tuple[float, float]] = getattr(model, "training_ranges_", {}) or {}
    low, high = ranges.get(name, (-1.0, 1.0))
    return float(low), float(high) if high > low else float(low) + 1.0


def _history_map(model: Any) -> Any:
    from neckid.models.base import check_is_fitted
    from neckid.systems import HistoryMap

    if not callable(getattr(model, "state_map", None)):
        raise NoLinearFormError(
            f"a design takes a fitted neckid model or a python-control system; got"
            f" {type(model).__name__}"
        )
    check_is_fitted(model)
    state_map = model.state_map()
    if not isinstance(state_map, HistoryMap):
        raise NoLinearFormError(
            f"a {type(model).__name__} keeps a state other than its input/output history, so it"
            " cannot be linearised here; design on a linear model (arx, rls, ss) or the"
            " scheduled model instead"
        )
    if len(model.output_names_) != 1:
        raise NoLinearFormError(
            f"a {type(model).__name__} with {len(model.output_names_)} outputs cannot be"
            " linearised here: a design needs one inclination output"
        )
    return state_map


def _resting_inputs(model: Any, inputs: list[str]) -> tuple[FloatArray, int | None]:
    """Inputs at rest (velocities 0, conditions mid-range) and the position channel's index."""
    values = np.zeros(len(inputs))
    level = None
    for j, name in enumerate(inputs):
        if name in POSITION_CHANNELS and level is None:
            level = j
        elif name not in (COMMAND, *VELOCITY_CHANNELS, *POSITION_CHANNELS):
            values[j] = 0.5 * sum(_span(model, name))
    return values, level


def equilibrium(model: Any, inclination: float) -> FloatArray:
    """The inputs that hold a NARX model at rest at an inclination (see the module docstring).

    Parameters
    ----------
    model : fitted NARX model
        As for :func:`linearise`.
    inclination : float
        deg.

    Returns
    -------
    ndarray, shape (n_inputs,)
        In the model's input order: the position channel solved for, velocities 0, conditions
        mid-range.

    Raises
    ------
    ValueError
        If no position in its training range widened by half holds the model there.
    """
    from scipy.optimize import brentq

    state_map = _history_map(model)
    y_star = check_number(inclination, "inclination")
    inputs = list(model.input_names_)
    m = state_map.m
    rest, level = _resting_inputs(model, inputs)
    if level is None:
        return rest

    def at_rest(value: float) -> float:
        u = rest.copy()
        u[level] = value
        x = np.concatenate([np.full(m, y_star), np.tile(u, m)])
        return float(state_map.output(x, u)[0]) - y_star

    low, high = _span(model, inputs[level])
    width = high - low
    grid = np.linspace(low - 0.5 * width, high + 0.5 * width, 61)
    residual = np.array([at_rest(v) for v in grid])
    change = np.flatnonzero(np.sign(residual[:-1]) * np.sign(residual[1:]) <= 0)
    if not change.size:
        raise ValueError(
            f"no {inputs[level]} in [{grid[0]:.3g}, {grid[-1]:.3g}] holds the"
            f" {type(model).__name__} at {y_star:g} deg; choose an inclination inside its"
            f" training range {_span(model, model.output_names_[0])}"
        )
    i = int(change[0])
    rest[level] = brentq(at_rest, grid[i], grid[i + 1], xtol=1e-12)
    return rest


def linearise(
    model: Any, inclination: float, *, output: str | None = None, step: float = 0.01
) -> Any:
    """The linear form of a NARX model at an inclination, as a ``control.TransferFunction``.

    Parameters
    ----------
    model : fitted NARX model
        Any model whose ``state_map()`` is its input/output history
        (:class:`~neckid.systems.HistoryMap`): Set Membership, neural, polynomial, ARX.
    inclination : float
        The operating point :math:`y^*` [deg].
    output : str, optional
        Ignored unless it names another output than the model's only one (refused).
    step : float, default 0.01
        Central-difference step, as a share of each channel's training range.

    Returns
    -------
    control.TransferFunction
        From each model input (the model's names) to its output, ``dt = ts_``.

    Raises
    ------
    NoLinearFormError
        If the model's state is not its history, or it has several outputs.
    ValueError
        If no input in the training range holds the model at ``inclination``.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> u = np.random.default_rng(0).normal(size=300)
    >>> y = np.zeros(300)
    >>> for t in range(1, 300):
    ...     y[t] = 0.5 * y[t - 1] + 2.0 * u[t - 1]
    >>> data = IOData(u, y, ts=0.02, input_names=["motor_position"], output_names=["inclination"])
    >>> g = linearise(LinearARX(Lags.arx(1, 1)).fit(data), 1.0)
    >>> np.round(g.num[0][0], 3), np.round(g.den[0][0], 3)
    (array([2.]), array([ 1. , -0.5]))
    """
    import control

    state_map = _history_map(model)
    y_star = check_number(inclination, "inclination")
    relative = check_number(step, "step", low=0, closed="neither")
    inputs = list(model.input_names_)
    name_out = model.output_names_[0]
    if output is not None and output != name_out:
        raise ValueError(f"output {output!r} is not the model's output {name_out!r}")
    m, n_in = state_map.m, len(inputs)
    rest = equilibrium(model, y_star)

    def one_step(y_rows: FloatArray, u_rows: FloatArray, u_now: FloatArray) -> float:
        x = np.concatenate([y_rows, u_rows.ravel()])
        return float(state_map.output(x, u_now)[0])

    y_rows, u_rows = np.full(m, y_star), np.tile(rest, (m, 1))
    h_y = relative * np.diff(_span(model, name_out))[0]
    a = np.zeros(m + 1)
    for r in range(m):
        up, down = y_rows.copy(), y_rows.copy()
        up[r] += h_y
        down[r] -= h_y
        a[m - r] = (one_step(up, u_rows, rest) - one_step(down, u_rows, rest)) / (2 * h_y)
    nums = []
    for j, name in enumerate(inputs):
        h_u = relative * np.diff(_span(model, name))[0]
        b = np.zeros(m + 1)
        for r in range(m + 1):  # r < m: history row (lag m - r); r = m: the input now (lag 0)
            up, down = u_rows.copy(), u_rows.copy()
            now_up, now_down = rest.copy(), rest.copy()
            if r < m:
                up[r, j] += h_u
                down[r, j] -= h_u
            else:
                now_up[j] += h_u
                now_down[j] -= h_u
            b[m - r] = (one_step(y_rows, up, now_up) - one_step(y_rows, down, now_down)) / (2 * h_u)
        nums.append([b])
    den = np.concatenate([[1.0], -a[1:]])
    return control.tf(
        [[n[0] for n in nums]],
        [[den] * n_in],
        dt=float(model.ts_),
        inputs=inputs,
        outputs=[name_out],
    )
