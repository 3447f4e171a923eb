r"""What the package's discrete-time systems share: how to step them and their state functions.

Two views of one system, each a structural type (:class:`typing.Protocol`: any object with the
methods fits, with no base class to inherit):

* **Stepping.** :class:`Plant` (``reset()``, then ``step(u) -> y``), :class:`Controller`
  (``step(reference, measurement) -> command``), :class:`Simulator` (an identified model's
  ``simulator()``: a plant with a history) and :class:`BoundedSimulator` (with each step's band).
  The simulated neck (:class:`~neckid.plant.SoftNeck`), an identified model's ``simulator()`` and
  a real rig's driver are plants; :class:`~neckid.plant.InclinationController` is a controller.
  :func:`~neckid.plant.closed_loop` and
  :func:`~neckid.loops.operating_points.identify_operating_points` take them.
* **State functions**, as python-control's ``NonlinearIOSystem`` has them: an output function
  and an update function of a packed state vector ``x``, both pure,
  ``y[k] = output(x[k], u[k])`` and ``x[k+1] = update(x[k], u[k])``
  (:class:`StateFunctions`). A system that can give its own (:class:`HasStateMap`) has one
  method, ``state_map(bounds=False)``; :func:`neckid.export.control.to_iosystem` talks to that method
  and to nothing else. :class:`StateMap` is the base class of every implementation (it caches
  the last evaluations), :class:`HistoryMap` the map of any simulator whose state is its last
  outputs and inputs (the NARX models).

The plant (:mod:`neckid.plant`), the models (:mod:`neckid.models`) and the loops
(:mod:`neckid.loops`) implement these without importing each other: this module imports none of
them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from neckid.utils.checks import check_finite
from neckid.utils.types import FloatArray

__all__ = [
    "BoundedSimulator",
    "Controller",
    "HasStateMap",
    "HistoryMap",
    "Plant",
    "Simulator",
    "StateFunctions",
    "StateMap",
    "has_lag_zero_input",
    "history_names",
    "history_rows",
    "input_row",
]


# ============================================================================ stepping
class Plant(Protocol):
    """A discrete-time plant: ``reset()``, then ``step(u) -> y`` once per sample.

    ``step`` applies the command of sample ``k`` and returns the output of sample ``k``, which
    must not depend on that command (no direct feedthrough), so that a loop can compute the next
    command from it.

    Examples
    --------
    >>> import numpy as np
    >>> class Integrator:
    ...     def reset(self):
    ...         self.y = 0.0
    ...     def step(self, u):
    ...         y, self.y = self.y, self.y + float(np.ravel(u)[0])
    ...         return np.array([y])
    >>> def first_outputs(plant: Plant, n: int) -> list[float]:
    ...     plant.reset()
    ...     return [float(plant.step([1.0])[0]) for _ in range(n)]
    >>> first_outputs(Integrator(), 3)
    [0.0, 1.0, 2.0]
    """

    def reset(self) -> object:  # pragma: no cover - protocol
        """Go back to the initial state."""

    def step(self, u: ArrayLike) -> ArrayLike:  # pragma: no cover - protocol
        """Apply the input ``u`` (shape ``(n_inputs,)``) for one sample; return this sample's output."""


class Controller(Protocol):
    """A discrete-time controller: ``reset()``, then ``step(reference, measurement) -> command``.

    For the neck, ``reference`` and ``measurement`` are the inclination in degrees (or
    inclination and orientation with three tendons) and the command is the motor velocity in
    rad/s, one value per motor.
    """

    def reset(self) -> object:  # pragma: no cover - protocol
        """Clear the controller's state (integrals, filters)."""

    def step(self, reference: ArrayLike, measurement: ArrayLike) -> ArrayLike:  # pragma: no cover
        """One control period: the command(s) from the reference and the last measurement."""


class Simulator(Protocol):
    """An identified model's step-by-step free run (``model.simulator()``): a plant with a history.

    ``reset(y0, u0)`` sets the past outputs and inputs (rows oldest first, one row repeated;
    default zeros); ``step(u)`` takes the input of sample ``t`` and returns the model output of
    sample ``t``. After ``reset(y0=y[:m], u0=u[:m])`` (``m`` the model's ``max_lag_``), stepping
    ``u[m:]`` gives what ``model.simulate`` gives. With no arguments ``reset()`` starts from
    rest, so a simulator is a :class:`Plant` and runs in :func:`~neckid.plant.closed_loop`.

    Notes
    -----
    A model with an input lag of 0 has direct feedthrough: ``step(u)`` returns an output that
    depends on ``u``, which a :class:`Plant` should not. :func:`~neckid.plant.closed_loop` still
    runs it as intended, because it computes the command of sample ``k`` from the output of
    sample ``k - 1``; the model then answers the command within the sample.
    """

    def reset(self, y0: ArrayLike | None = None, u0: ArrayLike | None = None) -> object:
        """Start again from the given (or zero) past outputs and inputs."""  # pragma: no cover

    def step(self, u: ArrayLike) -> ArrayLike:  # pragma: no cover - protocol
        """Advance one sample with input ``u`` (shape ``(n_inputs,)``); return ``y(t)``."""


class BoundedSimulator(Simulator, Protocol):
    """A :class:`Simulator` that also gives each step's band (the Set Membership models).

    ``step_bounds(u)`` advances like ``step`` and returns ``(y, lower, upper)``, each of shape
    ``(n_outputs,)``; :func:`neckid.loops.model_in_loop.model_in_the_loop` carries the band
    along a closed loop.
    """

    def step_bounds(self, u: ArrayLike) -> tuple[ArrayLike, ArrayLike, ArrayLike]:
        """Advance one sample; return the central output and the band."""  # pragma: no cover


# ============================================================================ state functions
class StateFunctions(Protocol):
    """A system's one-step map on a packed state: ``output(x, u)`` and ``update(x, u)``, both pure.

    The functions of python-control's ``NonlinearIOSystem`` (``outfcn`` and ``updfcn``) without
    the time and the parameters: for ``k = 0, 1, …``, ``y[k] = output(x[k], u[k])`` and
    ``x[k+1] = update(x[k], u[k])``, so the output of sample ``k`` comes with the input of sample
    ``k``, as a simulator's ``step(u(t)) -> y(t)``.

    Attributes
    ----------
    inputs, outputs, states : list of str
        Names of the input, output and state channels, in the order of ``u``, ``y`` and ``x``.
    ts : float
        Sampling period, s.
    feedthrough : bool
        Whether the output reads ``u`` (direct feedthrough). When it does not, the output is a
        function of the state alone, and a loop built on the system has no algebraic loop.
    """

    inputs: list[str]
    outputs: list[str]
    states: list[str]
    ts: float
    feedthrough: bool

    def output(self, x: ArrayLike, u: ArrayLike) -> FloatArray:  # pragma: no cover - protocol
        """The outputs at state ``x`` (shape ``(n_states,)``) and input ``u`` (``(n_inputs,)``)."""

    def update(self, x: ArrayLike, u: ArrayLike) -> FloatArray:  # pragma: no cover - protocol
        """The state one sample later, shape ``(n_states,)``."""

    def initial_state(
        self, y0: ArrayLike | None, u0: ArrayLike | None
    ) -> FloatArray:  # pragma: no cover - protocol
        """The state at given initial conditions (past outputs and inputs, as ``reset`` takes)."""


class HasStateMap(Protocol):
    """A system that gives its own state functions: ``state_map(bounds=False)``.

    Every neckid model (:meth:`neckid.models.base.Estimator.state_map`), the loop's controller
    (:meth:`neckid.plant.InclinationController.state_map`) and the motor drive
    (:meth:`neckid.loops.model_in_loop.VelocityDrive.state_map`) have it;
    :func:`neckid.export.control.to_iosystem` turns any of them into a python-control system.
    """

    def state_map(self, bounds: bool = False) -> StateFunctions:  # pragma: no cover - protocol
        """The system's state functions.

        Parameters
        ----------
        bounds : bool, default False
            Add the outputs ``<output>_lower`` and ``<output>_upper`` (each step's band) when
            the system has bounds; ignored otherwise.

        Returns
        -------
        StateFunctions
        """


class StateMap:
    """Base class of the state functions: ``output`` and ``update`` on top of two hooks, cached.

    A subclass sets ``inputs``, ``outputs``, ``states`` and ``ts`` (and ``feedthrough`` when its
    output does not read ``u``), and implements ``_output(x, u)`` (the outputs),
    ``_next(x, u, out)`` (the next state, given the outputs ``out`` of the same ``x`` and ``u``)
    and :meth:`initial_state`. Both hooks get ``x`` and ``u`` as flat float arrays. The last
    :attr:`CACHE_SIZE` outputs are kept: python-control asks for the same few several times per
    sample; without feedthrough one evaluation per state serves every input.

    Attributes
    ----------
    inputs, outputs, states : list of str
        Channel names, in the order of ``u``, ``y`` and ``x``.
    ts : float
        Sampling period, s.
    feedthrough : bool, default True
        Whether the output reads ``u``.
    """

    inputs: list[str]
    outputs: list[str]
    states: list[str]
    ts: float
    feedthrough: bool = True

    #: Evaluations kept: python-control asks for the same few several times per sample.
    CACHE_SIZE = 4

    def __init__(self) -> None:
        self._cache: dict[tuple[bytes, bytes], FloatArray] = {}

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        raise NotImplementedError  # pragma: no cover - abstract

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        raise NotImplementedError  # pragma: no cover - abstract

    def output(self, x: ArrayLike, u: ArrayLike) -> FloatArray:
        """The outputs at state ``x`` and input ``u``.

        Parameters
        ----------
        x : array_like, shape (n_states,)
            The state.
        u : array_like, shape (n_inputs,)
            The input of this sample.

        Returns
        -------
        ndarray, shape (n_outputs,)
            A copy (the cache keeps its own).
        """
        x_arr = np.asarray(x, dtype=np.float64).reshape(-1)
        u_arr = np.asarray(u, dtype=np.float64).reshape(-1)
        key = (x_arr.tobytes(), u_arr.tobytes() if self.feedthrough else b"")
        if key not in self._cache:
            if len(self._cache) >= self.CACHE_SIZE:
                self._cache.pop(next(iter(self._cache)))
            self._cache[key] = self._output(x_arr, u_arr)
        return self._cache[key].copy()

    def update(self, x: ArrayLike, u: ArrayLike) -> FloatArray:
        """The state one sample later.

        Parameters
        ----------
        x : array_like, shape (n_states,)
            The state.
        u : array_like, shape (n_inputs,)
            The input of this sample.

        Returns
        -------
        ndarray, shape (n_states,)
        """
        x_arr = np.asarray(x, dtype=np.float64).reshape(-1)
        u_arr = np.asarray(u, dtype=np.float64).reshape(-1)
        return self._next(x_arr, u_arr, self.output(x_arr, u_arr))

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """The state at given initial conditions.

        Parameters
        ----------
        y0, u0 : array_like, optional
            Past outputs and inputs, as the system's ``reset`` takes them (default zeros).

        Returns
        -------
        ndarray, shape (n_states,)
        """
        raise NotImplementedError  # pragma: no cover - abstract


# ============================================================================ history maps
def history_names(names: Sequence[str], m: int) -> list[str]:
    """State names of ``m`` history rows of the channels ``names``, oldest row first.

    Parameters
    ----------
    names : sequence of str
        Channel names.
    m : int
        Number of rows.

    Returns
    -------
    list of str
        ``<name>[t-m]`` … ``<name>[t-1]``, channel by channel within a row.

    Examples
    --------
    >>> history_names(["y", "u"], 2)
    ['y[t-2]', 'u[t-2]', 'y[t-1]', 'u[t-1]']
    """
    return [f"{n}[t-{m - r}]" for r in range(m) for n in names]


def history_rows(value: ArrayLike | None, m: int, width: int, argument: str) -> FloatArray:
    """A simulator's initial history: ``(m, width)`` rows, oldest first.

    ``None`` gives zeros; a single row (or a scalar) is repeated ``m`` times; otherwise the shape
    must be ``(m, width)``. Values must be finite; ``argument`` names them in errors.

    Parameters
    ----------
    value : array_like, optional
        The history: ``None``, a scalar, one row of ``width`` values, or ``(m, width)`` rows.
    m : int
        Number of rows.
    width : int
        Number of channels.
    argument : str
        The argument's name in error messages (``"y0"``, ``"u0"``, …).

    Returns
    -------
    ndarray, shape (m, width)
        In the channels' units.

    Raises
    ------
    ValueError
        For another shape, or a NaN or inf.
    """
    if value is None:
        return np.zeros((m, width))
    if isinstance(value, str | bytes | dict) or np.iscomplexobj(value):
        raise TypeError(
            f"{argument} must be numbers: one row of {width} value(s) or ({m}, {width}) rows;"
            f" got {type(value).__name__} {value!r:.60}"
        )
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise TypeError(
            f"{argument} must be numbers: one row of {width} value(s) or ({m}, {width}) rows;"
            f" got {value!r:.60} ({exc})"
        ) from None
    if array.ndim <= 1 and array.size not in (1, width):
        raise ValueError(
            f"{argument} must have shape ({width},) or ({m}, {width}); got {np.shape(value)}"
        )
    if array.ndim <= 1:
        array = np.broadcast_to(
            array.reshape(1, -1) if array.ndim else array.reshape(1, 1), (m, width)
        )
    if array.shape != (m, width):
        raise ValueError(
            f"{argument} must have shape ({width},) or ({m}, {width}); got {np.shape(value)}"
        )
    check_finite(np.asarray(array), argument)
    return np.array(array, dtype=np.float64)


def has_lag_zero_input(lags: Any) -> bool:
    """Whether a regressor has an input term of lag 0 (the model's output reads ``u(t)``).

    Parameters
    ----------
    lags : ResolvedLags
        A fitted model's ``lags_`` (anything with arrays ``source``, 1 for an input term, and
        ``lag``).

    Returns
    -------
    bool
    """
    return bool(np.any((lags.source == 1) & (lags.lag == 0)))


class HistoryMap(StateMap):
    """State functions of a model whose simulator's state is its last ``m`` outputs and inputs.

    The NARX models (and any model with a :class:`Simulator`). The state is the simulator's
    history, oldest row first, ``m = max(max_lag_, 1)`` rows each:
    ``x = [y(t−m), …, y(t−1), u(t−m), …, u(t−1)]`` (rows flattened, channel by channel), in the
    output and input units. The output function rebuilds the simulator from ``x``
    (``reset(y0, u0)`` then ``step(u)``), so it reproduces ``model.simulate`` to the last bit.

    Parameters
    ----------
    model : fitted estimator
        With ``simulator()``, ``max_lag_``, ``input_names_``, ``output_names_`` and ``ts_``; its
        ``lags_``, when it has one, tells whether the output reads ``u(t)`` (without one it is
        assumed to).
    bounds : bool
        Add the outputs ``<output>_lower`` and ``<output>_upper`` (the step's band) when the
        simulator has ``step_bounds`` (:class:`BoundedSimulator`); ignored otherwise.
    """

    def __init__(self, model: Any, bounds: bool) -> None:
        super().__init__()
        self._simulator = model.simulator()
        self._bounds = bounds and callable(getattr(self._simulator, "step_bounds", None))
        self.m = max(int(model.max_lag_), 1)
        self.n_out, self.n_in = len(model.output_names_), len(model.input_names_)
        self.inputs = list(model.input_names_)
        self.outputs = list(model.output_names_)
        if self._bounds:
            self.outputs += [
                f"{n}_{side}" for side in ("lower", "upper") for n in model.output_names_
            ]
        self.states = self._state_names(model)
        self.ts = float(model.ts_)
        self.feedthrough = self._feedthrough(model)

    def _feedthrough(self, model: Any) -> bool:
        lags = getattr(model, "lags_", None)
        return lags is None or has_lag_zero_input(lags)

    def _state_names(self, model: Any) -> list[str]:
        return history_names(model.output_names_, self.m) + history_names(
            model.input_names_, self.m
        )

    def _split(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        n_y = self.m * self.n_out
        return x[:n_y].reshape(self.m, self.n_out), x[n_y:].reshape(self.m, self.n_in)

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        y_hist, u_hist = self._split(x)
        self._simulator.reset(y0=y_hist, u0=u_hist)
        if self._bounds:
            return np.concatenate(self._simulator.step_bounds(u))
        return np.asarray(self._simulator.step(u), dtype=np.float64)

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        y_hist, u_hist = self._split(x)
        return np.concatenate([y_hist[1:].ravel(), out[: self.n_out], u_hist[1:].ravel(), u])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """The history at given initial conditions.

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (m, n_outputs), optional
            Past outputs, oldest first; one row is repeated; default zeros.
        u0 : array_like, shape (n_inputs,) or (m, n_inputs), optional
            Past inputs, the same way.

        Returns
        -------
        ndarray, shape (m * (n_outputs + n_inputs),)
        """
        y_hist = history_rows(y0, self.m, self.n_out, "y0")
        u_hist = history_rows(u0, self.m, self.n_in, "u0")
        return np.concatenate([y_hist.ravel(), u_hist.ravel()])


def input_row(u: ArrayLike, width: int) -> FloatArray:
    """A simulator's input of one sample as a ``(1, width)`` row, checked: one finite value per input.

    Examples
    --------
    >>> input_row([0.5, 1.0], 2)
    array([[0.5, 1. ]])
    """
    row = np.asarray(u, dtype=np.float64).reshape(1, -1)
    if row.shape[1] != width:
        raise ValueError(f"u must have {width} values (one per input); got {row.shape[1]}")
    check_finite(row, "u")
    return row
