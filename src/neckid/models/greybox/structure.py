r"""What a user-defined grey-box state-space model is made of: equations, parameters, initial state.

A :class:`GreyBoxStructure` is MATLAB's ``idnlgrey`` model file in Python: a state equation with
unknown physical parameters, an output equation, and the rule that gives the state at the first
sample. :class:`~neckid.models.greybox.ode.GreyBoxODE` fits its parameters on the free-run
error. A structure is a small frozen dataclass, so a user writes one in a few lines:

.. code-block:: python

    import numpy as np
    from neckid.models.greybox import GreyBoxStructure, StructureParameter

    def one_tank(x, u, p):  # dx/dt = b u - a sqrt(x): Torricelli's outflow
        return np.array([p[1] * u[0] - p[0] * np.sqrt(max(x[0], 0.0))])

    def level(x, u, p):
        return np.array([x[0]])

    def from_output(y0, u0, p):
        return np.array([max(y0[0], 0.0)])

    TANK = GreyBoxStructure(
        name="one-tank", state_equation=one_tank, output_equation=level,
        initial_state=from_output, state_names=("level",), state_units=("cm",),
        parameters=(StructureParameter("outflow", 0.1, 1e-3, 10.0, "cm^0.5/s", log_scale=True),
                    StructureParameter("pump_gain", 0.1, 1e-3, 10.0, "cm/(V s)", log_scale=True)),
        n_inputs=1, n_outputs=1)

The functions take and return flat ``float64`` NumPy arrays: ``state_equation(x, u, p)`` gives
``dx/dt`` (``time="continuous"``, in the states' units per second) or ``x(t+1)``
(``time="discrete"``); ``output_equation(x, u, p)`` gives ``y``; ``initial_state(y0, u0, p)``
gives ``x(0)`` from the first measured output and input; the optional ``saturation(x, u, p)``
holds the state in limits that depend on the parameters (an overflow). ``p`` holds the
parameters in the order of :attr:`GreyBoxStructure.parameters`. Decorate them with
``numba.njit`` and the free run is compiled; plain Python functions run step by step in Python,
about 50 times slower (``docs/greybox_ode.md`` gives the measured costs).

A model file keeps only the structure's *name* and its fingerprint (parameter, state and channel
counts and names): :func:`~neckid.models.greybox.catalog.resolve_structure` finds the shipped
structures by name and a user's among those passed explicitly.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from neckid.utils.types import FloatArray

__all__ = ["GreyBoxStructure", "StructureParameter", "UnknownStructureError"]

#: ``f(x, u, p) -> array``: the signature of a structure's three functions.
StructureFunction = Callable[[FloatArray, FloatArray, FloatArray], FloatArray]


class UnknownStructureError(ValueError):
    """A model file names a grey-box structure that is neither shipped nor given."""


@dataclass(frozen=True)
class StructureParameter:
    """One physical parameter of a grey-box structure.

    Attributes
    ----------
    name : str
        A Python identifier (``"pump_gain"``).
    initial : float
        The initial guess, in ``unit``; the first start of every fit.
    lower, upper : float, default -inf, inf
        Bounds of the fit (``lower < upper``; ``lower <= initial <= upper``).
    unit : str, default ""
        The unit, for tables and the documentation (``"V^0.5/s"``).
    description : str, default ""
        One line saying what the parameter is.
    log_scale : bool, default False
        Search the parameter on a logarithmic scale (a rate constant spanning decades); needs
        ``lower > 0``.
    fixed : bool, default False
        Keep the parameter at ``initial`` (MATLAB's ``Fixed``): not fitted.
    """

    name: str
    initial: float
    lower: float = -math.inf
    upper: float = math.inf
    unit: str = ""
    description: str = ""
    log_scale: bool = False
    fixed: bool = False

    def check(self, structure: str) -> None:
        """Raise ``ValueError`` naming the structure and parameter when a value breaks a rule."""
        where = f"structure {structure!r}, parameter {self.name!r}"
        if not self.name.isidentifier():
            raise ValueError(f"{where}: the name must be a Python identifier")
        values = (self.initial, self.lower, self.upper)
        if any(not isinstance(v, int | float) or isinstance(v, bool) for v in values):
            raise TypeError(f"{where}: initial, lower and upper must be numbers; got {values}")
        if math.isnan(self.lower) or math.isnan(self.upper) or not self.lower < self.upper:
            raise ValueError(
                f"{where}: lower < upper is required; got [{self.lower}, {self.upper}]"
            )
        if not (math.isfinite(self.initial) and self.lower <= self.initial <= self.upper):
            raise ValueError(
                f"{where}: initial must be a finite number in [{self.lower}, {self.upper}];"
                f" got {self.initial}"
            )
        if self.log_scale and not (self.lower > 0 and math.isfinite(self.upper)):
            raise ValueError(
                f"{where}: log_scale needs finite bounds with lower > 0; got"
                f" [{self.lower}, {self.upper}]"
            )


@dataclass(frozen=True)
class GreyBoxStructure:
    r"""A grey-box state-space model: equations, parameters and the initial state's rule.

    Continuous time (``time="continuous"``):

    .. math::

        \dot x = f(x, u, \theta), \qquad y = g(x, u, \theta), \qquad x(0) = x_0(y(0), u(0), \theta),

    integrated over each sampling period with the input held (zero-order hold) by
    :mod:`~neckid.models.greybox.ode_kernels`. Discrete time: :math:`x(t+1) = f(x(t), u(t), \theta)`.

    Attributes
    ----------
    name : str
        The name a model file keeps (``"cascaded-tanks"``); loading finds the structure by it.
    state_equation : callable
        ``f(x, u, p) -> ndarray (n_states,)``: ``dx/dt`` per second, or ``x(t+1)``.
    output_equation : callable
        ``g(x, u, p) -> ndarray (n_outputs,)``.
    initial_state : callable
        ``x0(y0, u0, p) -> ndarray (n_states,)``: the state at the first sample from its
        measured output ``y0`` and input ``u0`` (the fit may refine it per experiment, see
        ``GreyBoxODE(initial_state=...)``).
    parameters : tuple of StructureParameter
        The parameters, in the order ``p`` holds them.
    state_names : tuple of str
    n_inputs, n_outputs : int
        The channels the equations take and give (conditions of ``Lags(conditions=...)``
        count as inputs, after the log's own).
    state_units : tuple of str, optional
        Default ``""`` per state.
    time : {"continuous", "discrete"}, default "continuous"
    saturation : callable, optional
        ``s(x, u, p) -> ndarray (n_states,)``, applied to the state after every integration
        step (continuous time) or sample (discrete time): a hard limit that depends on the
        parameters, such as a tank that overflows at its capacity (the water above it goes
        elsewhere). Continuous in the parameters, unlike a switch inside the state equation
        that a fixed-step integrator crosses at different stages, so the free-run cost stays
        continuous for the fit. Default: none.
    state_lower, state_upper : tuple of float, optional
        Constant bounds the state is held in after every integration step (a level is never
        negative), after ``saturation``; also the bounds of an estimated initial state.
        Default unbounded.
    description : str, default ""
        One paragraph for tables and the documentation.
    references : tuple of str, default ()
        Where the equations come from.
    """

    name: str
    state_equation: StructureFunction
    output_equation: StructureFunction
    initial_state: StructureFunction
    parameters: tuple[StructureParameter, ...]
    state_names: tuple[str, ...]
    n_inputs: int
    n_outputs: int
    state_units: tuple[str, ...] = ()
    time: Literal["continuous", "discrete"] = "continuous"
    saturation: StructureFunction | None = None
    state_lower: tuple[float, ...] | None = None
    state_upper: tuple[float, ...] | None = None
    description: str = ""
    references: tuple[str, ...] = field(default=())

    # ------------------------------------------------------------------ derived
    @property
    def n_states(self) -> int:
        """Number of states."""
        return len(self.state_names)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """The parameters' names, in the order ``p`` holds them."""
        return tuple(p.name for p in self.parameters)

    @property
    def functions(self) -> tuple[StructureFunction, ...]:
        """The structure's functions: state, output, initial state (and saturation if any)."""
        found = (self.state_equation, self.output_equation, self.initial_state)
        return found if self.saturation is None else (*found, self.saturation)

    @property
    def compiled(self) -> bool:
        """Whether every function is a numba ``njit`` function (then the free run is compiled)."""
        return all(hasattr(f, "py_func") for f in self.functions)

    def initial_values(self) -> FloatArray:
        """The initial guesses of every parameter, ``(n_parameters,)``."""
        return np.array([p.initial for p in self.parameters], dtype=np.float64)

    def state_bounds(self) -> tuple[FloatArray, FloatArray]:
        """``(lower, upper)`` state bounds, ``(n_states,)`` each (``±inf`` where none)."""
        n = self.n_states
        low = np.full(n, -np.inf) if self.state_lower is None else np.array(self.state_lower, float)
        high = np.full(n, np.inf) if self.state_upper is None else np.array(self.state_upper, float)
        return low, high

    def fingerprint(self) -> dict[str, Any]:
        """What a model file records about the structure besides its name (checked on load)."""
        return {
            "name": self.name,
            "time": self.time,
            "parameters": list(self.parameter_names),
            "states": list(self.state_names),
            "n_inputs": int(self.n_inputs),
            "n_outputs": int(self.n_outputs),
            "saturation": self.saturation is not None,
        }

    # ------------------------------------------------------------------ checks
    def check(self) -> None:
        """Refuse a structure whose declarations do not fit together (one line naming the rule).

        Raises
        ------
        TypeError
            A function is not callable, a parameter is not a :class:`StructureParameter`.
        ValueError
            Empty name, duplicate parameter names, counts below 1, units or state bounds whose
            length is not the number of states, a parameter breaking its own rules.
        """
        where = f"structure {self.name!r}"
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"a grey-box structure needs a non-empty name; got {self.name!r}")
        for role in ("state_equation", "output_equation", "initial_state", "saturation"):
            function = getattr(self, role)
            if not callable(function) and not (role == "saturation" and function is None):
                raise TypeError(f"{where}: {role} must be a function f(x, u, p) -> array")
        if self.time not in ("continuous", "discrete"):
            raise ValueError(f"{where}: time must be 'continuous' or 'discrete'; got {self.time!r}")
        for name in ("n_inputs", "n_outputs"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{where}: {name} must be a whole number >= 1; got {value!r}")
        if self.n_states < 1:
            raise ValueError(f"{where}: state_names must name at least one state")
        for attribute in ("state_units", "state_lower", "state_upper"):
            value = getattr(self, attribute)
            if value and len(value) != self.n_states:
                raise ValueError(
                    f"{where}: {attribute} must have one entry per state ({self.n_states});"
                    f" got {len(value)}"
                )
        low, high = self.state_bounds()
        if np.any(np.isnan(low)) or np.any(np.isnan(high)) or np.any(low >= high):
            raise ValueError(f"{where}: state_lower < state_upper is required for every state")
        if not self.parameters:
            raise ValueError(f"{where}: a grey-box structure needs at least one parameter")
        for parameter in self.parameters:
            if not isinstance(parameter, StructureParameter):
                raise TypeError(
                    f"{where}: parameters must be StructureParameter; got"
                    f" {type(parameter).__name__}"
                )
            parameter.check(self.name)
        names = self.parameter_names
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"{where}: parameter names repeat: {repeated}")

    def check_fingerprint(self, recorded: Mapping[str, Any]) -> None:
        """Refuse a structure that is not the one a model file was fitted with."""
        ours = self.fingerprint()
        differing = [key for key, value in ours.items() if recorded.get(key) != value]
        if differing:
            key = differing[0]
            raise ValueError(
                f"the model file's structure {recorded.get('name')!r} has {key}"
                f" {recorded.get(key)!r}, but the structure given has {ours[key]!r}: pass the"
                " structure the model was fitted with"
            )
