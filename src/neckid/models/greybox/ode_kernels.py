r"""The free run of a grey-box structure: fixed-step Runge–Kutta with a held input, compiled.

Over one sampling period :math:`T_s` the input is held (zero-order hold) and the continuous-time
state equation :math:`\dot x = f(x, u, \theta)` is integrated by ``substeps`` steps of the
classical fourth-order Runge–Kutta method, :math:`h = T_s / \text{substeps}`
(Hairer, Nørsett & Wanner 1993, §II.1):

.. math::

    k_1 &= f(x, u, \theta), \quad k_2 = f(x + \tfrac h2 k_1, u, \theta), \quad
    k_3 = f(x + \tfrac h2 k_2, u, \theta), \quad k_4 = f(x + h k_3, u, \theta),\\
    x &\leftarrow \operatorname{clip}\bigl(s(x + \tfrac h6 (k_1 + 2k_2 + 2k_3 + k_4), u, \theta),
    \ x_{low},\ x_{high}\bigr),

:math:`s` the structure's saturation (the identity when it has none) and the clip holding the
state in its constant bounds after every step. A discrete-time structure takes
:math:`x(t+1) = \operatorname{clip}(s(f(x(t), u(t), \theta), u(t), \theta))`. The output is
:math:`y(t) = g(x(t), u(t), \theta)`.

:func:`advance` and :func:`free_run` are the public wrappers: they check shapes, cast to
contiguous ``float64`` and pick the kernel. The kernels are compiled once with explicit
signatures whose function arguments are numba first-class function types, so one compiled kernel
(cached on disk) serves every structure whose functions are ``numba.njit`` functions; a
structure of plain Python functions runs the same kernels' Python code (``.py_func``), the
reference the tests compare the compiled run with (:func:`_free_run_reference` is the same loop in
Python).

A run stops at the first sample whose state or output is not finite or whose state exceeds
:data:`RUNAWAY` in magnitude; that sample and the later ones are NaN.

References
----------
E. Hairer, S. P. Nørsett and G. Wanner, *Solving Ordinary Differential Equations I: Nonstiff
Problems*, 2nd ed., Springer, 1993, §II.1.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit, types
from numba.core.errors import NumbaError
from numpy.typing import ArrayLike

from neckid.models.greybox.structure import GreyBoxStructure
from neckid.utils.checks import check_finite
from neckid.utils.types import FloatArray

__all__ = [
    "RUNAWAY",
    "advance",
    "check_functions",
    "evaluate",
    "free_run",
    "simulate_structure",
]

#: Largest state magnitude a run may reach before it counts as a runaway and stops.
RUNAWAY = 1e150

_VECTOR = types.float64[::1]
_MATRIX = types.float64[:, ::1]
_FUNCTION = types.FunctionType(_VECTOR(_VECTOR, _VECTOR, _VECTOR))
_SIGNATURE_TEXT = "float64[::1](float64[::1], float64[::1], float64[::1])"


@njit(_VECTOR(_VECTOR, _VECTOR, _VECTOR), cache=True)
def _unchanged(x: FloatArray, u: FloatArray, p: FloatArray) -> FloatArray:
    """The saturation of a structure without one: the state as it is."""
    return x.copy()


@njit(
    _VECTOR(
        _FUNCTION,
        _FUNCTION,
        _VECTOR,
        _VECTOR,
        _VECTOR,
        types.float64,
        types.int64,
        types.boolean,
        _VECTOR,
        _VECTOR,
    ),
    cache=True,
)
def _advance(
    state_equation: Any,
    saturation: Any,
    x: FloatArray,
    u: FloatArray,
    p: FloatArray,
    period: float,
    substeps: int,
    continuous: bool,
    lower: FloatArray,
    upper: FloatArray,
) -> FloatArray:
    """The state one sampling period after ``x`` with the input ``u`` held."""
    if not continuous:
        return np.minimum(np.maximum(saturation(state_equation(x, u, p), u, p), lower), upper)
    h = period / substeps
    n = x.shape[0]
    state = x.copy()
    stage = np.empty(n)
    for _ in range(substeps):
        k1 = state_equation(state, u, p)
        for j in range(n):
            stage[j] = state[j] + 0.5 * h * k1[j]
        k2 = state_equation(stage, u, p)
        for j in range(n):
            stage[j] = state[j] + 0.5 * h * k2[j]
        k3 = state_equation(stage, u, p)
        for j in range(n):
            stage[j] = state[j] + h * k3[j]
        k4 = state_equation(stage, u, p)
        for j in range(n):
            stage[j] = state[j] + (h / 6.0) * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        held = saturation(stage, u, p)
        state = np.empty(n)  # a new array: the saturation may hand back the stage itself
        for j in range(n):
            state[j] = min(max(held[j], lower[j]), upper[j])
    return state


@njit(
    types.int64(
        _FUNCTION,
        _FUNCTION,
        _FUNCTION,
        _VECTOR,
        _MATRIX,
        _VECTOR,
        types.float64,
        types.int64,
        types.boolean,
        _VECTOR,
        _VECTOR,
        _MATRIX,
        _MATRIX,
    ),
    cache=True,
)
def _free_run(
    state_equation: Any,
    saturation: Any,
    output_equation: Any,
    x0: FloatArray,
    u: FloatArray,
    p: FloatArray,
    period: float,
    substeps: int,
    continuous: bool,
    lower: FloatArray,
    upper: FloatArray,
    states: FloatArray,
    outputs: FloatArray,
) -> int:
    """Fill ``states`` and ``outputs`` from ``x(0) = x0``; return the samples filled."""
    state = np.minimum(np.maximum(x0, lower), upper)
    for t in range(u.shape[0]):
        if t > 0:
            state = _advance(
                state_equation,
                saturation,
                state,
                u[t - 1],
                p,
                period,
                substeps,
                continuous,
                lower,
                upper,
            )
        for value in state:
            if not np.isfinite(value) or abs(value) > RUNAWAY:
                return t
        y = output_equation(state, u[t], p)
        for value in y:
            if not np.isfinite(value):
                return t
        states[t] = state
        outputs[t] = y
    return u.shape[0]


def _free_run_reference(
    state_equation: Any,
    saturation: Any,
    output_equation: Any,
    x0: FloatArray,
    u: FloatArray,
    p: FloatArray,
    period: float,
    substeps: int,
    continuous: bool,
    lower: FloatArray,
    upper: FloatArray,
    states: FloatArray,
    outputs: FloatArray,
) -> int:
    """:func:`_free_run` in Python (plain-Python structures; the tests' reference)."""
    state = np.minimum(np.maximum(x0, lower), upper)
    for t in range(u.shape[0]):
        if t > 0:
            state = _advance.py_func(
                state_equation,
                saturation,
                state,
                u[t - 1],
                p,
                period,
                substeps,
                continuous,
                lower,
                upper,
            )
        if not np.all(np.isfinite(state)) or np.max(np.abs(state)) > RUNAWAY:
            return t
        y = np.asarray(output_equation(state, u[t], p), dtype=np.float64)
        if not np.all(np.isfinite(y)):
            return t
        states[t] = state
        outputs[t] = y
    return int(u.shape[0])


def _writable(values: Any) -> FloatArray:
    """``values`` as C-contiguous ``float64``, copied when read-only (the kernels' signatures)."""
    array = np.ascontiguousarray(values, dtype=np.float64)
    return array if array.flags.writeable else array.copy()


def _vector(values: Any) -> FloatArray:
    return _writable(values).reshape(-1)


def evaluate(function: Any, first: Any, second: Any, parameters: Any) -> FloatArray:
    """``function(first, second, parameters)`` of a structure, called from Python.

    The arguments are handed over as new C-contiguous ``float64`` vectors: a numba function
    then always sees the one signature the kernels use (a read-only row of a log would ask it
    for another), and a Python function cannot change the caller's arrays.
    """
    return np.asarray(
        function(_vector(first).copy(), _vector(second).copy(), _vector(parameters).copy()),
        dtype=np.float64,
    )


def _saturation(structure: GreyBoxStructure) -> Any:
    """The structure's saturation, or the identity (compiled or Python as its functions are)."""
    if structure.saturation is not None:
        return structure.saturation
    return _unchanged if structure.compiled else _unchanged.py_func


def _bounds(structure: GreyBoxStructure) -> tuple[FloatArray, FloatArray]:
    low, high = structure.state_bounds()
    return np.ascontiguousarray(low), np.ascontiguousarray(high)


def _compile_error(structure: GreyBoxStructure, error: Exception) -> TypeError:
    reason = " ".join(str(error).split())[:300]
    return TypeError(
        f"structure {structure.name!r}: its numba functions do not compile with the signature"
        f" {_SIGNATURE_TEXT} (x, u, p -> a new float64 array): {reason}; return np.array([...])"
        " of floats, or give plain Python functions (slower)"
    )


def check_functions(
    structure: GreyBoxStructure, y0: FloatArray, u0: FloatArray, parameters: FloatArray
) -> FloatArray:
    """Call each of the structure's functions once and check what it returns; return ``x(0)``.

    Raises
    ------
    TypeError
        A function does not return an array of real numbers, or a numba function does not
        compile with the kernels' signature.
    ValueError
        A function returns the wrong number of values.
    """
    where = f"structure {structure.name!r}"
    calls = (
        ("initial_state", structure.initial_state, (y0, u0), structure.n_states),
        ("state_equation", structure.state_equation, None, structure.n_states),
        ("saturation", _saturation(structure), None, structure.n_states),
        ("output_equation", structure.output_equation, None, structure.n_outputs),
    )
    x0 = np.zeros(structure.n_states)
    for role, function, arguments, size in calls:
        first, second = arguments or (x0, u0)
        try:
            value = function(_vector(first).copy(), _vector(second).copy(), _vector(parameters))
        except NumbaError as exc:
            raise _compile_error(structure, exc) from None
        if not isinstance(value, np.ndarray) or value.dtype.kind not in "fiu":
            got = value.dtype if isinstance(value, np.ndarray) else type(value).__name__
            raise TypeError(
                f"{where}: {role} must return a NumPy array of real numbers (np.array([...]));"
                f" got {got}"
            )
        array = value
        if array.shape != (size,):
            raise ValueError(
                f"{where}: {role} must return an array of shape ({size},); got {array.shape}"
            )
        if role == "initial_state":
            x0 = _vector(array)
    return x0


def advance(
    structure: GreyBoxStructure,
    x: FloatArray,
    u: FloatArray,
    parameters: FloatArray,
    period: float,
    substeps: int,
) -> FloatArray:
    """The state one sampling period after ``x`` with the input ``u`` held, ``(n_states,)``."""
    low, high = _bounds(structure)
    continuous = structure.time == "continuous"
    kernel: Any = _advance if structure.compiled else _advance.py_func
    try:  # a numba function whose types do not fit raises NumbaError or TypeError here
        state = kernel(
            structure.state_equation,
            _saturation(structure),
            _vector(x),
            _vector(u),
            _vector(parameters),
            float(period),
            int(substeps),
            continuous,
            low,
            high,
        )
    except (NumbaError, TypeError) as exc:
        raise _compile_error(structure, exc) from None
    return np.asarray(state, dtype=np.float64)


def free_run(
    structure: GreyBoxStructure,
    x0: FloatArray,
    u: FloatArray,
    parameters: FloatArray,
    period: float,
    substeps: int,
) -> tuple[FloatArray, FloatArray]:
    """Free run from ``x(0) = x0`` over the inputs ``u``; returns ``(states, outputs)``.

    Parameters
    ----------
    structure : GreyBoxStructure
    x0 : ndarray, shape (n_states,)
    u : ndarray, shape (n_samples, n_inputs)
    parameters : ndarray, shape (n_parameters,)
    period : float
        Sampling period, s.
    substeps : int
        Runge–Kutta steps per sampling period (continuous time; 1 for discrete time).

    Returns
    -------
    states : ndarray, shape (n_samples, n_states)
    outputs : ndarray, shape (n_samples, n_outputs)
        NaN from the first sample that is not finite or runs away (:data:`RUNAWAY`).
    """
    u = _writable(u)
    n = u.shape[0]
    states = np.full((n, structure.n_states), np.nan)
    outputs = np.full((n, structure.n_outputs), np.nan)
    low, high = _bounds(structure)
    continuous = structure.time == "continuous"
    kernel: Any = _free_run if structure.compiled else _free_run_reference
    with np.errstate(all="ignore"):
        try:
            filled = kernel(
                structure.state_equation,
                _saturation(structure),
                structure.output_equation,
                _vector(x0),
                u,
                _vector(parameters),
                float(period),
                int(substeps),
                continuous,
                low,
                high,
                states,
                outputs,
            )
        except (NumbaError, TypeError) as exc:  # a numba function whose types do not fit
            raise _compile_error(structure, exc) from None
    states[filled:] = np.nan
    outputs[filled:] = np.nan
    return states, outputs


def simulate_structure(
    structure: GreyBoxStructure,
    u: ArrayLike,
    parameters: ArrayLike,
    *,
    ts: float,
    x0: ArrayLike,
    substeps: int | None = None,
) -> tuple[FloatArray, FloatArray]:
    """A structure's free run at given parameters and initial state (no data, no fit).

    For making synthetic data and checking a structure by hand.

    Parameters
    ----------
    structure : GreyBoxStructure
    u : array_like, shape (n_samples,) or (n_samples, n_inputs)
        The inputs, held over each period.
    parameters : array_like, shape (n_parameters,)
        In the structure's order and units.
    ts : float
        Sampling period, s.
    x0 : array_like, shape (n_states,)
        The state at the first sample.
    substeps : int, optional
        Runge–Kutta steps per period; default 4 (continuous time), 1 (discrete time).

    Returns
    -------
    states : ndarray, shape (n_samples, n_states)
    outputs : ndarray, shape (n_samples, n_outputs)
        NaN from the first sample that is not finite or runs away.

    Raises
    ------
    ValueError
        Arrays of the wrong size, a non-finite value, ``ts <= 0``, ``substeps < 1``.

    Examples
    --------
    >>> from neckid.models.greybox import shipped_structures
    >>> tanks = shipped_structures()["cascaded-tanks"]
    >>> p = [0.05, 0.5, 0.06, 0.5, 0.06, 0.3, 0.0, 12.0, 0.5, 10.0]
    >>> states, y = simulate_structure(tanks, [3.0] * 5, p, ts=4.0, x0=[4.0, 3.0])
    >>> states.shape, y.shape, bool(y[-1, 0] > y[0, 0])
    ((5, 2), (5, 1), True)
    """
    structure.check()
    inputs = np.asarray(u, dtype=np.float64)
    inputs = inputs.reshape(inputs.shape[0], -1) if inputs.ndim else inputs.reshape(1, 1)
    values = _vector(parameters)
    state = _vector(x0)
    for name, array, size in (
        ("u columns", inputs[0], structure.n_inputs),
        ("parameters", values, len(structure.parameters)),
        ("x0", state, structure.n_states),
    ):
        if array.size != size:
            raise ValueError(
                f"{name} must have {size} values for structure {structure.name!r}; got {array.size}"
            )
    check_finite(inputs, "u")
    check_finite(values[None, :], "parameters")
    check_finite(state[None, :], "x0")
    if not (np.isfinite(ts) and ts > 0):
        raise ValueError(f"ts must be a positive number of seconds; got {ts!r}")
    steps = (4 if structure.time == "continuous" else 1) if substeps is None else int(substeps)
    if steps < 1:
        raise ValueError(f"substeps must be a whole number >= 1; got {substeps!r}")
    check_functions(structure, np.zeros(structure.n_outputs), inputs[0], values)
    return free_run(structure, state, inputs, values, float(ts), steps)
