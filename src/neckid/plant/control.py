r"""The inclination controller of the closed-loop experiments, and the loop that runs it.

:class:`InclinationController` is a discrete PI with anti-windup whose output is the motor
velocity command (the bench's drives run in velocity mode). :func:`closed_loop` runs a reference
through a controller and any plant with ``reset()`` and ``step(u) -> y`` (the simulated neck or an
identified model's ``simulator()``) and logs everything in one :class:`~neckid.data.iodata.IOData`.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

import neckid.plant._kernels as _kernels
from neckid.data.iodata import IOData
from neckid.plant.soft_neck import DIVERGED_MESSAGE, SoftNeck
from neckid.systems import Controller, Plant, StateMap
from neckid.utils.checks import check_finite, check_number, check_ts
from neckid.utils.types import FloatArray

__all__ = ["ControllerStateMap", "InclinationController", "closed_loop"]


_TENDON_ANGLES = np.radians([0.0, 120.0, 240.0])
_TENDON_COS = np.cos(_TENDON_ANGLES)
_TENDON_SIN = np.sin(_TENDON_ANGLES)


class InclinationController:
    r"""Discrete PI inclination controller with anti-windup; output: motor velocity command(s).

    Parameters
    ----------
    kp : float, default 0.35
        Proportional gain, (rad/s) of motor velocity per degree of inclination error.
    ki : float, default 0.6
        Integral gain, (rad/s) per degree-second.
    ts : float, default 0.02
        Sampling period, s.
    command_limit : float, default 4.0
        Saturation of each velocity command, rad/s (the bench's 0.03 m/s tendon speed limit on a
        0.0075 m winch).
    configuration : {"planar", "three_tendon"}, default "planar"
        ``"planar"``: one command from the inclination error. ``"three_tendon"``: reference and
        measurement are (inclination, orientation) in degrees; the PI acts on the error of the
        bending vector :math:`i\,(\cos\varphi, \sin\varphi)` and each tendon ``k`` (at
        :math:`120° k`) gets the projection of the PI output on its direction, so the tendon on
        the side to lean to winds and the others unwind.

    Notes
    -----
    Planar: :math:`e_k = r_k - y_k`, :math:`v_k = k_p e_k + I_{k-1} + k_i t_s e_k`,
    :math:`u_k = \mathrm{clip}(v_k, \pm u_{max})`, and the integral keeps
    :math:`I_k = I_{k-1} + k_i t_s e_k` only when the command is not saturated or the error drives
    it back from the limit (conditional integration, the simplest anti-windup; Åström & Hägglund,
    *Advanced PID Control*, 2006, sec. 3.5). Three tendons: the same on the 2-D error vector, the
    commands :math:`u_j = d_j \cdot v` scaled down together when one exceeds the limit (the
    direction is kept).

    Examples
    --------
    >>> from neckid.plant import InclinationController
    >>> ctrl = InclinationController(kp=1.0, ki=0.0, command_limit=4.0)
    >>> ctrl.step(10.0, 8.0)
    array([2.])
    >>> ctrl.step(20.0, 0.0)       # saturated
    array([4.])
    """

    def __init__(
        self,
        kp: float = 0.35,
        ki: float = 0.6,
        ts: float = 0.02,
        command_limit: float = 4.0,
        configuration: Literal["planar", "three_tendon"] = "planar",
    ) -> None:
        self.kp: float = check_number(kp, "kp", low=0)
        self.ki: float = check_number(ki, "ki", low=0)
        self.command_limit: float = check_number(
            command_limit, "command_limit", low=0, closed="neither"
        )
        if configuration not in ("planar", "three_tendon"):
            raise ValueError(
                f"configuration must be 'planar' or 'three_tendon'; got {configuration!r}"
            )
        self.ts = check_ts(ts)
        self.configuration = configuration
        self.n_motors = 1 if configuration == "planar" else 3
        self.n_references = 1 if configuration == "planar" else 2
        self.reset()

    def reset(self) -> None:
        """Clear the integral."""
        self._integral = np.zeros(self.n_integrals)

    def _vector(self, value: ArrayLike, argument: str) -> FloatArray:
        array = np.asarray(value, dtype=np.float64).reshape(-1)
        if array.shape[0] != self.n_references:
            raise ValueError(
                f"{argument} must have {self.n_references} value(s) for the {self.configuration}"
                f" controller; got {array.shape[0]}"
            )
        check_finite(array[None, :], argument)
        if self.configuration == "planar":
            return array
        angle = math.radians(array[1])
        return array[0] * np.array([math.cos(angle), math.sin(angle)])

    def step(self, reference: ArrayLike, measurement: ArrayLike) -> FloatArray:
        """One control period: the velocity command(s) from the reference and the measurement.

        Parameters
        ----------
        reference, measurement : float or array_like of shape (2,)
            Inclination in degrees (planar), or (inclination, orientation) in degrees.

        Returns
        -------
        ndarray, shape (n_motors,)
            Velocity command(s), rad/s at the gearbox output, within ``±command_limit``.
        """
        command, self._integral = self.control_law(self._integral, reference, measurement)
        return command

    @property
    def n_integrals(self) -> int:
        """Size of the integral state: 1 (planar) or 2 (the bending vector's x and y)."""
        return 1 if self.configuration == "planar" else 2

    def control_law(
        self, integral: ArrayLike, reference: ArrayLike, measurement: ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """The PI law as a pure function: command and next integral from the integral given.

        :meth:`step` is this law applied to the controller's stored integral; here nothing is
        stored, so a simulation tool that keeps the state itself (python-control's
        ``NonlinearIOSystem``, see :func:`neckid.export.control.to_iosystem`) can call it with any state.

        Parameters
        ----------
        integral : array_like, shape (n_integrals,)
            The integral :math:`I_{k-1}` [rad/s] (a zero vector after :meth:`reset`).
        reference, measurement : float or array_like of shape (2,)
            As for :meth:`step` [deg].

        Returns
        -------
        command : ndarray, shape (n_motors,)
            Velocity command(s) [rad/s], within ``±command_limit``.
        integral : ndarray, shape (n_integrals,)
            :math:`I_k`, the integral the next period starts from (anti-windup applied).

        Raises
        ------
        ValueError
            If ``integral`` has the wrong size or a value is NaN or inf.

        Examples
        --------
        >>> from neckid.plant import InclinationController
        >>> ctrl = InclinationController(kp=1.0, ki=1.0, ts=0.5)
        >>> command, integral = ctrl.control_law([0.0], 10.0, 8.0)
        >>> command, integral
        (array([3.]), array([1.]))
        """
        start = np.asarray(integral, dtype=np.float64).reshape(-1)
        if start.shape[0] != self.n_integrals:
            raise ValueError(
                f"integral must have {self.n_integrals} value(s) for the {self.configuration}"
                f" controller; got {start.shape[0]}"
            )
        check_finite(start[None, :], "integral")
        error = self._vector(reference, "reference") - self._vector(measurement, "measurement")
        candidate = start + self.ki * self.ts * error
        wanted = self.kp * error + candidate
        if self.configuration == "planar":
            raw = wanted
        else:
            raw = _TENDON_COS * wanted[0] + _TENDON_SIN * wanted[1]
        peak = float(np.max(np.abs(raw)))
        saturated = peak > self.command_limit
        command = raw * (self.command_limit / peak) if saturated else raw
        # Conditional integration: integrate unless saturated and the error pushes further out.
        keep = not saturated or float(np.dot(error, wanted)) < 0.0
        return np.asarray(command, dtype=np.float64), (candidate if keep else start.copy())

    def state_map(self, bounds: bool = False) -> ControllerStateMap:
        """The controller's state functions (:class:`ControllerStateMap`), for python-control.

        Parameters
        ----------
        bounds : bool, default False
            Ignored (a controller has no band); there for the
            :class:`~neckid.systems.HasStateMap` protocol.

        Returns
        -------
        ControllerStateMap
            State ``[integral, last measurement]``; see :func:`neckid.export.control.to_iosystem`.
        """
        return ControllerStateMap(self)


class ControllerStateMap(StateMap):
    """State functions of an :class:`InclinationController`; feedthrough of the reference only.

    ``x = [integral, last measurement]``: the PI integral :math:`I_{k-1}` [rad/s] (``integral``,
    or ``integral_x``, ``integral_y`` for the bending vector with three tendons) and the
    measurement of the previous sample [deg] (``inclination[t-1]``, and
    ``orientation[t-1]``). The inputs are the references then the measurements [deg]; the
    command of sample ``k`` reads the measurement of sample ``k - 1`` from the state, as
    :func:`closed_loop` does, so the map has no feedthrough from the measurement. The outputs
    are the velocity commands [rad/s].

    Parameters
    ----------
    controller : InclinationController
        Its :meth:`~InclinationController.control_law` is the map (the controller's own integral
        is neither read nor changed).
    """

    def __init__(self, controller: InclinationController) -> None:
        super().__init__()
        self._controller = controller
        planar = controller.configuration == "planar"
        references = ["reference"] if planar else ["reference_inclination", "reference_orientation"]
        measured = ["inclination"] if planar else ["inclination", "orientation"]
        self.inputs = references + measured
        self.outputs = _names_for("velocity_command", controller.n_motors)
        integrals = ["integral"] if planar else ["integral_x", "integral_y"]
        self.states = integrals + [f"{n}[t-1]" for n in measured]
        self.ts = controller.ts
        self._n_int = controller.n_integrals
        self._n_ref = controller.n_references

    def _law(self, x: FloatArray, u: FloatArray) -> tuple[FloatArray, FloatArray]:
        return self._controller.control_law(x[: self._n_int], u[: self._n_ref], x[self._n_int :])

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        return self._law(x, u)[0]

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        return np.concatenate([self._law(x, u)[1], u[self._n_ref :]])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """Zeros, as after :meth:`InclinationController.reset`, with a zero first measurement.

        Parameters
        ----------
        y0, u0 : array_like, optional
            Ignored.

        Returns
        -------
        ndarray, shape (n_integrals + n_references,)
        """
        return np.zeros(len(self.states))


def _names_for(prefix: str, count: int) -> list[str]:
    return [prefix] if count == 1 else [f"{prefix}_{i}" for i in range(1, count + 1)]


def closed_loop(
    plant: Plant,
    controller: Controller,
    reference: ArrayLike,
    ts: float,
    excitation: ArrayLike | None = None,
) -> IOData:
    """Run a reference through a controller and a plant; log reference, commands and outputs.

    Parameters
    ----------
    plant : Plant
        A :class:`~neckid.plant.SoftNeck`, or an identified model's ``simulator()``, or anything
        with ``reset()`` and ``step(u) -> y`` (:class:`~neckid.plant.Plant`). ``step`` takes the command of sample ``k`` and returns the
        output of sample ``k`` (which must not depend on that command).
    controller : Controller
        Anything with ``reset()`` and ``step(reference, measurement) -> command``
        (:class:`~neckid.plant.Controller`); usually an :class:`InclinationController`.
    reference : array_like, shape (n_samples,) or (n_samples, 2)
        Inclination target in degrees, or (inclination, orientation) targets for three tendons.
    ts : float
        Sampling period, s. If the plant or the controller has a ``ts`` attribute it must match.
    excitation : array_like, shape (n_samples,) or (n_samples, n_motors), optional
        Added to the controller's command before it goes to the plant (e.g. a small PRBS for
        persistent excitation when identifying at an operating point), rad/s.

    Returns
    -------
    IOData
        Inputs ``reference`` (or ``reference_inclination``, ``reference_orientation``) [deg], the
        velocity commands sent to the plant (excitation included) [rad/s], and, when the plant
        has ``motor_position`` / ``motor_velocity`` attributes, those at the start of each
        sample; outputs the plant's outputs (names from ``plant.output_names`` when it has them,
        else ``inclination`` [, ``orientation``]).

    Notes
    -----
    The command of sample ``k`` is computed from the output of sample ``k - 1`` (the plant's
    output is only known after its ``step``), i.e. one sample of computation delay, like a real-time
    loop that applies at the next tick what it computed in this one. The first command uses a
    zero measurement (the neck at rest).

    With the built-in pair, a :class:`~neckid.plant.SoftNeck` and an
    :class:`InclinationController` (those classes exactly, not subclasses, which may override
    ``step``), the whole loop runs in one compiled kernel (``neckid.plant._kernels``): about 3
    µs per sample instead of about 30, most of it the neck's own integration
    (``benchmarks/bench_closed_loop.py``). It gives the same log as stepping the objects
    (``tests/test_plant.py`` checks it) and leaves the neck, its noise generator and the
    controller's integral as the stepped loop would.

    Raises
    ------
    ValueError
        If the reference or excitation hold NaN or inf or have the wrong shape, or the sampling
        periods disagree.
    TypeError
        If the plant or controller lacks ``reset``/``step``.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid.plant import InclinationController, SoftNeck, closed_loop
    >>> data = closed_loop(SoftNeck(), InclinationController(), np.full(250, 10.0), ts=0.02)
    >>> data.input_names
    ('reference', 'velocity_command', 'motor_position', 'motor_velocity')
    >>> bool(abs(data.y[-25:, 0].mean() - 10.0) < 0.3)
    True
    """
    for obj, name in ((plant, "plant"), (controller, "controller")):
        for method in ("reset", "step"):
            if not callable(getattr(obj, method, None)):
                raise TypeError(f"{name} must have a {method}() method; got {type(obj).__name__}")
    ts_value = check_ts(ts)
    for obj, name in ((plant, "plant"), (controller, "controller")):
        other = getattr(obj, "ts", None)
        if isinstance(other, int | float) and not math.isclose(other, ts_value, rel_tol=1e-9):
            raise ValueError(f"ts is {ts_value!r} s but the {name} runs at ts={other!r} s")
    ref = np.asarray(reference, dtype=np.float64)
    if ref.ndim == 1:
        ref = ref[:, None]
    n_ref_attr: Any = getattr(controller, "n_references", ref.shape[1])
    n_ref = int(n_ref_attr)
    if ref.ndim != 2 or ref.shape[1] != n_ref or ref.shape[0] == 0:
        raise ValueError(
            f"reference must have shape (n_samples,) or (n_samples, {n_ref}) for this controller;"
            f" got {np.shape(reference)}"
        )
    ref_names = ["reference"] if n_ref == 1 else ["reference_inclination", "reference_orientation"]
    check_finite(ref, "reference", ref_names)
    n = ref.shape[0]
    motors_attr: Any = getattr(controller, "n_motors", None) or getattr(plant, "n_motors", 1)
    n_motors = int(motors_attr)
    if excitation is None:
        extra = np.zeros((n, n_motors))
    else:
        extra = np.asarray(excitation, dtype=np.float64)
        if extra.ndim == 1:
            extra = extra[:, None]
        if extra.shape != (n, n_motors):
            raise ValueError(
                f"excitation must have shape ({n}, {n_motors}) (one row per reference sample, one"
                f" column per motor); got {np.shape(excitation)}"
            )
        check_finite(extra, "excitation")
    has_motors = hasattr(plant, "motor_position") and hasattr(plant, "motor_velocity")

    plant.reset()
    controller.reset()
    if (
        type(plant) is SoftNeck
        and type(controller) is InclinationController
        and controller.n_motors == plant.n_motors
    ):
        commands, positions, velocities, y_all = _compiled_loop(plant, controller, ref, extra)
    else:
        commands, positions, velocities, y_all = _stepped_loop(
            plant, controller, ref, extra, has_motors
        )
    n_out = y_all.shape[1]
    default_out = ["inclination", "orientation"][:n_out] if n_out <= 2 else None
    out_names = list(getattr(plant, "output_names", default_out) or [])
    if len(out_names) != n_out:
        out_names = [f"y{i + 1}" for i in range(n_out)] if n_out > 1 else ["inclination"]
    out_units = list(getattr(plant, "output_units", ("deg",) * n_out))
    if len(out_units) != n_out:
        out_units = ["deg"] * n_out
    u_parts = [ref, commands]
    u_names = ref_names + _names_for("velocity_command", n_motors)
    u_units = ["deg"] * n_ref + ["rad/s"] * n_motors
    if has_motors:
        u_parts += [positions, velocities]
        u_names += _names_for("motor_position", n_motors) + _names_for("motor_velocity", n_motors)
        u_units += ["rad"] * n_motors + ["rad/s"] * n_motors
    return IOData(
        np.hstack(u_parts),
        y_all,
        ts_value,
        input_names=u_names,
        output_names=out_names,
        input_units=u_units,
        output_units=out_units,
        name="closed_loop",
    )


def _stepped_loop(
    plant: Plant, controller: Controller, ref: FloatArray, extra: FloatArray, has_motors: bool
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The loop for any plant and controller: one ``step`` of each per sample, from Python."""
    n, n_ref = ref.shape
    n_motors = extra.shape[1]
    commands = np.empty((n, n_motors))
    positions = np.empty((n, n_motors))
    velocities = np.empty((n, n_motors))
    outputs: list[FloatArray] = []
    measurement = np.zeros(n_ref)
    motor_source: Any = plant
    for k in range(n):
        command = np.asarray(controller.step(ref[k] if n_ref > 1 else ref[k, 0], measurement))
        commands[k] = command.reshape(-1) + extra[k]
        if has_motors:
            positions[k] = np.asarray(motor_source.motor_position).reshape(-1)
            velocities[k] = np.asarray(motor_source.motor_velocity).reshape(-1)
        y = np.asarray(plant.step(commands[k]), dtype=np.float64).reshape(-1)
        outputs.append(y)
        measurement = y[:n_ref]
    return commands, positions, velocities, np.vstack(outputs)


def _compiled_loop(
    neck: SoftNeck, controller: InclinationController, ref: FloatArray, extra: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The same loop for the built-in neck and PI, in one compiled kernel (both just reset).

    The sensor noise is drawn for all samples at once, which gives the same numbers as one draw
    per ``SoftNeck.step``; the neck's state and the controller's integral end as after the
    stepped loop.
    """
    n = ref.shape[0]
    m = neck.n_motors
    commands = np.empty((n, m))
    positions = np.empty((n, m))
    velocities = np.empty((n, m))
    outputs = np.empty((n, neck.n_outputs))
    noise = neck._rng.standard_normal((n, neck._n_dof))
    gains = np.array([controller.kp, controller.ki * controller.ts, controller.command_limit])
    integral = np.array(controller._integral, dtype=np.float64)
    done = _kernels.closed_loop_compiled(
        neck._state,
        neck._buffer,
        neck._head,
        np.ascontiguousarray(ref),
        np.ascontiguousarray(extra),
        noise,
        neck._packed,
        neck._directions,
        neck._n_sub,
        neck._dt,
        gains,
        _TENDON_COS,
        _TENDON_SIN,
        integral,
        commands,
        outputs,
        positions,
        velocities,
    )
    controller._integral = integral
    if done < n:
        raise FloatingPointError(DIVERGED_MESSAGE)
    return commands, positions, velocities, outputs
