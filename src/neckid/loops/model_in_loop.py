r"""Model in the loop: an identified model takes the neck's place beside the same controller.

A free run (``model.simulate``) replays the *recorded* inputs; in a closed-loop test those inputs
came from a controller that saw the real neck. :func:`model_in_the_loop` closes the loop on the
model instead: the same :class:`~neckid.plant.InclinationController`, the same reference, and
:func:`~neckid.plant.closed_loop` (so the same timing) with the model's ``simulator()`` as the
plant. It then scores the model's output *and* the control signal it makes the controller send
against the measured ones: a model good in free run can still be poor in the loop (the loop
amplifies a wrong gain or phase near the crossover), and the other way round.

The controller commands a motor *velocity*; the demo's NARX models take the motor *position*.
:class:`VelocityDrive` is the neck's drive between the two, with the simulated neck's equations
(:mod:`neckid.plant.soft_neck`): a first-order velocity loop
:math:`\dot w = \mathrm{clip}((\mathrm{clip}(u, \pm w_{max}) - w)/\tau_m, \pm a_{max})`,
:math:`\dot q = w`, the command held over the sample (zero-order hold), and the position of row
``k`` taken at the *start* of sample ``k``, before command ``k`` acts — as the logs of
:func:`~neckid.plant.closed_loop` and :meth:`~neckid.plant.SoftNeck.run` record it. With
``time_constant=0`` and no limits it is the plain integrator
:math:`q(k+1) = q(k) + t_s\,u(k)`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData
from neckid.metrics import coverage, fit_percent, rmse
from neckid.models.base import check_is_fitted
from neckid.plant.control import closed_loop
from neckid.plant.soft_neck import SoftNeckParameters
from neckid.systems import BoundedSimulator, Controller, Simulator, StateMap
from neckid.utils.checks import check_finite, check_number, check_ts
from neckid.utils.types import FloatArray

__all__ = ["DriveStateMap", "LoopComparison", "ModelPlant", "VelocityDrive", "model_in_the_loop"]


#: Channel prefixes of the drive's state in closed-loop logs (``_1`` .. ``_3`` for three motors).
POSITION = "motor_position"
VELOCITY = "motor_velocity"


def channel_names(prefix: str, count: int) -> tuple[str, ...]:
    """``prefix`` for one channel, ``prefix_1`` .. ``prefix_n`` for several (as closed-loop logs)."""
    return (prefix,) if count == 1 else tuple(f"{prefix}_{i}" for i in range(1, count + 1))


class VelocityDrive:
    r"""The neck's motor drive: velocity command in, motor position (and velocity) out.

    Parameters
    ----------
    ts : float, default 0.02
        Sampling period, s; the command is held over each sample.
    time_constant : float, default 0.015
        Time constant :math:`\tau_m` of the drive's velocity loop, s (0: the velocity follows the
        command at once).
    speed_limit : float, optional, default 4.0
        The command is clipped to ``±speed_limit`` rad/s; ``None``: no clipping.
    acceleration_limit : float, optional, default 200.0
        Largest :math:`|\dot w|`, rad/s²; ``None``: no limit.
    n_motors : int, default 1
        Number of motors (each runs the same law on its own command).

    Notes
    -----
    Over one sample the command :math:`v = \mathrm{clip}(u, \pm w_{max})` is constant, so the
    drive law has a closed form: while :math:`|v - w| > \tau_m a_{max}` the velocity ramps at
    :math:`\pm a_{max}`, then it relaxes as :math:`v + (w - v) e^{-t/\tau_m}`, and the position
    integrates either exactly. The simulated neck integrates the same law with Runge–Kutta 4 and
    agrees to about 1e-9 rad; what the drive leaves out is the stall of a motor winding against
    the tendon force limit (a model does not know the tendon force).

    Examples
    --------
    >>> from neckid.loops.model_in_loop import VelocityDrive
    >>> drive = VelocityDrive(ts=0.5, time_constant=0.0, speed_limit=None, acceleration_limit=None)
    >>> [float(drive.step([2.0])[0]) for _ in range(3)]   # position at the start of each sample
    [0.0, 1.0, 2.0]
    """

    def __init__(
        self,
        ts: float = 0.02,
        time_constant: float = 0.015,
        speed_limit: float | None = 4.0,
        acceleration_limit: float | None = 200.0,
        n_motors: int = 1,
    ) -> None:
        self.ts = check_ts(ts)
        self.time_constant: float = check_number(time_constant, "time_constant", low=0)
        self.speed_limit: float | None = (
            None
            if speed_limit is None
            else check_number(speed_limit, "speed_limit", low=0, closed="neither")
        )
        self.acceleration_limit: float | None = (
            None
            if acceleration_limit is None
            else check_number(acceleration_limit, "acceleration_limit", low=0, closed="neither")
        )
        self.n_motors: int = check_number(n_motors, "n_motors", low=1, integer=True)
        self.reset()

    @classmethod
    def from_parameters(
        cls, parameters: SoftNeckParameters | None = None, ts: float = 0.02, n_motors: int = 1
    ) -> VelocityDrive:
        """The drive of a :class:`~neckid.plant.SoftNeck` with these parameters (default ones)."""
        p = parameters if parameters is not None else SoftNeckParameters()
        return cls(
            ts,
            p.motor_time_constant,
            p.motor_speed_limit,
            p.motor_acceleration_limit,
            n_motors,
        )

    def reset(self, position: ArrayLike | None = None, velocity: ArrayLike | None = None) -> None:
        """Start again at ``position`` [rad] and ``velocity`` [rad/s] (default 0, one per motor)."""
        self.motor_position = self._vector(position, "position")
        self.motor_velocity = self._vector(velocity, "velocity")

    def _vector(self, value: ArrayLike | None, argument: str) -> FloatArray:
        if value is None:
            return np.zeros(self.n_motors)
        array = np.asarray(value, dtype=np.float64).reshape(-1)
        if array.shape[0] != self.n_motors:
            raise ValueError(
                f"{argument} must have {self.n_motors} value(s), one per motor; got {array.shape[0]}"
            )
        check_finite(array[None, :], argument)
        return array.copy()

    def advance(
        self, position: ArrayLike, velocity: ArrayLike, command: ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """Position and velocity one sample later under ``command`` (a pure function).

        Parameters
        ----------
        position, velocity, command : array_like, shape (n_motors,)
            Now [rad], [rad/s], and the velocity command held over the sample [rad/s].

        Returns
        -------
        position, velocity : ndarray, shape (n_motors,)
        """
        q0 = self._vector(position, "position")
        w0 = self._vector(velocity, "velocity")
        target = self._vector(command, "command")
        if self.speed_limit is not None:
            target = np.clip(target, -self.speed_limit, self.speed_limit)
        q1 = np.empty(self.n_motors)
        w1 = np.empty(self.n_motors)
        for i in range(self.n_motors):
            q1[i], w1[i] = self._advance_one(float(q0[i]), float(w0[i]), float(target[i]))
        return q1, w1

    def _advance_one(self, q: float, w: float, v: float) -> tuple[float, float]:
        ts, tau, a_max = self.ts, self.time_constant, self.acceleration_limit
        left = ts
        gap = v - w
        if a_max is not None and abs(gap) > tau * a_max:
            # The acceleration limit binds: ramp at a_max until the gap is tau * a_max (or the end).
            ramp = min((abs(gap) - tau * a_max) / a_max, ts)
            slope = math.copysign(a_max, gap)
            q += w * ramp + 0.5 * slope * ramp * ramp
            w += slope * ramp
            left = ts - ramp
        if left <= 0.0:
            return q, w
        if tau == 0.0:
            return q + v * left, v
        decay = math.exp(-left / tau)
        return q + v * left + (w - v) * tau * (1.0 - decay), v + (w - v) * decay

    def step(self, command: ArrayLike) -> FloatArray:
        """Apply one sample of command; return the position at the start of the sample [rad]."""
        now = self.motor_position.copy()
        self.motor_position, self.motor_velocity = self.advance(
            self.motor_position, self.motor_velocity, command
        )
        return now

    def state_map(self, bounds: bool = False) -> DriveStateMap:
        """The drive's state functions (:class:`DriveStateMap`), for python-control.

        Parameters
        ----------
        bounds : bool, default False
            Ignored (the drive has no band); there for the
            :class:`~neckid.systems.HasStateMap` protocol.

        Returns
        -------
        DriveStateMap
            State ``[position, velocity]``; see :func:`neckid.export.control.to_iosystem`.
        """
        return DriveStateMap(self)

    def __repr__(self) -> str:
        return (
            f"VelocityDrive(ts={self.ts!r}, time_constant={self.time_constant!r},"
            f" speed_limit={self.speed_limit!r}, acceleration_limit={self.acceleration_limit!r},"
            f" n_motors={self.n_motors!r})"
        )


class DriveStateMap(StateMap):
    """State functions of a :class:`VelocityDrive`: ``x = [position, velocity]``, no feedthrough.

    The state is the motor position [rad] and velocity [rad/s] at the start of the sample
    (``motor_position``, ``motor_velocity``; ``_1`` .. ``_3`` with three motors), which are also
    the outputs (taken before the command of the sample acts, as :meth:`VelocityDrive.step`
    returns the position). The input is the velocity command [rad/s]; the update is
    :meth:`VelocityDrive.advance`.

    Parameters
    ----------
    drive : VelocityDrive
        Its law and limits (its own state is neither read nor changed).
    """

    feedthrough = False

    def __init__(self, drive: VelocityDrive) -> None:
        super().__init__()
        self._drive = drive
        n = drive.n_motors
        self.inputs = list(channel_names("velocity_command", n))
        self.outputs = list(channel_names(POSITION, n) + channel_names(VELOCITY, n))
        self.states = list(self.outputs)
        self.ts = drive.ts
        self._n = n

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        return x.copy()

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        position, velocity = self._drive.advance(x[: self._n], x[self._n :], u)
        return np.concatenate([position, velocity])

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        """Zeros: the drive at rest at position 0, as after :meth:`VelocityDrive.reset`.

        Parameters
        ----------
        y0, u0 : array_like, optional
            Ignored.

        Returns
        -------
        ndarray, shape (2 * n_motors,)
        """
        return np.zeros(2 * self._n)


class ModelPlant:
    """A fitted model's simulator as the neck: velocity command(s) in, the model's outputs out.

    Each model input is fed from the loop by its name: a command channel (``command``, e.g.
    ``velocity_command``) gets the controller's command of this sample, ``motor_position`` and
    ``motor_velocity`` (``_1`` .. ``_3`` with three motors) get the drive's state at the start of
    the sample. So a model of motor position -> inclination and one of velocity command ->
    inclination both run behind the same controller.

    Parameters
    ----------
    model : fitted estimator
        Any neckid model (``simulator()``, ``input_names_``, ``output_names_``, ``ts_``).
    drive : VelocityDrive, optional
        Default: the simulated neck's drive (:meth:`VelocityDrive.from_parameters`).
    command : str, default "velocity_command"
        Name (prefix with several motors) of the command channel.
    outputs : sequence of str, optional
        The model outputs returned by :meth:`step`, in this order (the controller measures the
        first ones). Default: all the model's outputs.
    y0 : array_like, shape (n_outputs,) or (max_lag, n_outputs), optional
        Outputs before the first sample, model order (default zeros). Past commands are zero and
        past positions and velocities the drive's starting state (the neck at rest).
    position0 : array_like, shape (n_motors,), optional
        The drive's starting position [rad] (default 0).

    Attributes
    ----------
    lower, upper : list of ndarray
        The band of each step (Set Membership models, whose simulator has ``step_bounds``);
        empty for other models.
    """

    def __init__(
        self,
        model: Any,
        drive: VelocityDrive | None = None,
        *,
        command: str = "velocity_command",
        outputs: Sequence[str] | None = None,
        y0: ArrayLike | None = None,
        position0: ArrayLike | None = None,
    ) -> None:
        check_is_fitted(model)
        self.model = model
        self.ts = float(model.ts_)
        self.drive = drive if drive is not None else VelocityDrive.from_parameters(ts=self.ts)
        if not math.isclose(self.drive.ts, self.ts, rel_tol=1e-9):
            raise ValueError(
                f"the drive runs at ts={self.drive.ts!r} s, the model at {self.ts!r} s"
            )
        self.n_motors = self.drive.n_motors
        names = tuple(model.output_names_)
        self.output_names = tuple(outputs) if outputs is not None else names
        missing = [n for n in self.output_names if n not in names]
        if missing:
            raise ValueError(
                f"outputs names {missing[0]!r}, which is not an output of the model {list(names)}"
            )
        self._out_index = [names.index(n) for n in self.output_names]
        units = tuple(getattr(model, "output_units_", ("",) * len(names)))
        self.output_units = tuple(units[i] for i in self._out_index)
        sources = {
            **{n: ("command", i) for i, n in enumerate(channel_names(command, self.n_motors))},
            **{n: ("position", i) for i, n in enumerate(channel_names(POSITION, self.n_motors))},
            **{n: ("velocity", i) for i, n in enumerate(channel_names(VELOCITY, self.n_motors))},
        }
        unknown = [n for n in model.input_names_ if n not in sources]
        if unknown:
            raise ValueError(
                f"the model's input {unknown[0]!r} cannot be fed from the loop: a model in the loop"
                f" takes its inputs among {list(sources)} (command {command!r}; set command= to"
                " the name of the model's command channel)"
            )
        self._sources = [sources[n] for n in model.input_names_]
        self._y0 = y0
        self._position0 = position0
        self._simulator: Simulator = model.simulator()
        self._bounded = callable(getattr(self._simulator, "step_bounds", None))
        self.reset()

    def _inputs(self, command: FloatArray) -> FloatArray:
        values = {
            "command": command,
            "position": self.drive.motor_position,
            "velocity": self.drive.motor_velocity,
        }
        return np.array([values[kind][i] for kind, i in self._sources])

    @property
    def motor_position(self) -> FloatArray:
        """The drive's position now [rad] (logged by :func:`~neckid.plant.closed_loop`)."""
        return self.drive.motor_position.copy()

    @property
    def motor_velocity(self) -> FloatArray:
        """The drive's velocity now [rad/s]."""
        return self.drive.motor_velocity.copy()

    def reset(self) -> None:
        """Back to the starting state: drive at ``position0`` and rest, model history at rest."""
        self.drive.reset(self._position0)
        self._simulator.reset(y0=self._y0, u0=self._inputs(np.zeros(self.n_motors)))
        self.lower: list[FloatArray] = []
        self.upper: list[FloatArray] = []

    def step(self, command: ArrayLike) -> FloatArray:
        """Feed this sample's command; return the model's outputs (``outputs`` order)."""
        u = np.asarray(command, dtype=np.float64).reshape(-1)
        inputs = self._inputs(u)
        if self._bounded:
            y, low, high = cast(BoundedSimulator, self._simulator).step_bounds(inputs)
            self.lower.append(np.asarray(low)[self._out_index])
            self.upper.append(np.asarray(high)[self._out_index])
        else:
            y = self._simulator.step(inputs)
        self.drive.step(u)
        return np.asarray(y, dtype=np.float64)[self._out_index]


@dataclass(frozen=True)
class LoopComparison:
    """A model (or plant) in the loop against a measured closed-loop record.

    Attributes
    ----------
    loop : IOData
        The log of the loop with the model (:func:`~neckid.plant.closed_loop` channels).
    measured : IOData
        The measured record.
    output_names, command_names : tuple of str
        The compared channels.
    n_initial : int
        Samples left out of every score (the model's ``max_lag_``, as in its free-run scores;
        0 for a plant).
    output_fit, output_rmse : ndarray, shape (n_outputs,)
        NRMSE fit [%] and RMSE (output units) of the loop's outputs against the measured ones.
    command_fit, command_rmse : ndarray, shape (n_motors,)
        The same for the control signal [rad/s].
    lower, upper : ndarray, shape (n_samples, n_outputs), optional
        The Set Membership band along the loop (bounds of the noise-free output at the loop's
        regressor), ``None`` for other models.
    band_coverage : ndarray, shape (n_outputs,), optional
        Share of the measured outputs inside ``[lower, upper]`` (past ``n_initial``).
    """

    loop: IOData
    measured: IOData
    output_names: tuple[str, ...]
    command_names: tuple[str, ...]
    n_initial: int
    output_fit: FloatArray
    output_rmse: FloatArray
    command_fit: FloatArray
    command_rmse: FloatArray
    lower: FloatArray | None = None
    upper: FloatArray | None = None
    band_coverage: FloatArray | None = None

    def scores(self) -> dict[str, float]:
        """The scores of the first output and command, flat (for a report row).

        Keys: ``output_fit`` [%], ``output_rmse``, ``command_fit`` [%], ``command_rmse``, and
        ``band_coverage`` (NaN without a band).
        """
        band = math.nan if self.band_coverage is None else float(self.band_coverage[0])
        return {
            "output_fit": float(self.output_fit[0]),
            "output_rmse": float(self.output_rmse[0]),
            "command_fit": float(self.command_fit[0]),
            "command_rmse": float(self.command_rmse[0]),
            "band_coverage": band,
        }

    def to_frame(self) -> pd.DataFrame:
        """Time, and per compared channel ``<name>_measured`` and ``<name>_loop`` (and the band)."""
        columns: dict[str, FloatArray] = {"time": self.measured.time}
        for names in (self.output_names, self.command_names):
            for n in names:
                columns[f"{n}_measured"] = self.measured.channel(n)
                columns[f"{n}_loop"] = self.loop.channel(n)
        if self.lower is not None and self.upper is not None:
            for j, n in enumerate(self.output_names):
                columns[f"{n}_lower"] = self.lower[:, j]
                columns[f"{n}_upper"] = self.upper[:, j]
        return pd.DataFrame(columns)


def _as_names(value: str | Sequence[str]) -> tuple[str, ...]:
    return (value,) if isinstance(value, str) else tuple(value)


def _rows(data: IOData, names: Sequence[str], argument: str) -> FloatArray:
    missing = [n for n in names if n not in (*data.input_names, *data.output_names)]
    if missing:
        raise ValueError(
            f"{argument}: the record has no channel {missing[0]!r} (its inputs are"
            f" {list(data.input_names)}, its outputs {list(data.output_names)}); pass"
            f" {argument}= with the record's channel name(s)"
        )
    return np.column_stack([data.channel(n) for n in names])


def model_in_the_loop(
    model: Any,
    controller: Controller,
    record: IOData,
    *,
    reference: str | Sequence[str] | None = None,
    command: str = "velocity_command",
    output: str | Sequence[str] | None = None,
    drive: VelocityDrive | None = None,
    excitation: ArrayLike | None = None,
) -> LoopComparison:
    """Close the loop of a measured record on a model; score its output and control signal.

    Parameters
    ----------
    model : fitted estimator or Plant
        A neckid model (its ``simulator()`` runs behind a :class:`ModelPlant`), or a plant with
        ``reset()`` and ``step(u) -> y`` that takes the command itself (a
        :class:`~neckid.plant.SoftNeck`: the loop then re-runs the experiment).
    controller : Controller
        The controller of the record, e.g. ``InclinationController(ts=record.ts)``; it is reset.
    record : IOData
        A measured closed-loop log, e.g. from :func:`~neckid.plant.closed_loop`.
    reference : str or sequence of str, optional
        The reference channel(s) of ``record``; default ``"reference"`` (or
        ``reference_inclination``, ``reference_orientation`` for two).
    command : str, default "velocity_command"
        The command channel of ``record`` (a prefix, ``_1`` .. ``_3``, with several motors);
        also the name of a model input fed with the command.
    output : str or sequence of str, optional
        The measured output(s) the controller sees, in its order; default the first
        ``controller.n_references`` outputs of ``record``.
    drive : VelocityDrive, optional
        Between the command and a model that takes the motor position; default the simulated
        neck's drive at ``record.ts``.
    excitation : array_like, shape (n_samples,) or (n_samples, n_motors), optional
        Added to the commands, as in :func:`~neckid.plant.closed_loop` (when the record had one).

    Returns
    -------
    LoopComparison

    Raises
    ------
    ValueError
        If a channel is missing from the record, the model has an input the loop cannot feed,
        or the sampling periods of the record, the model and the controller differ.

    Notes
    -----
    The loop is :func:`~neckid.plant.closed_loop` itself: command ``k`` is computed from output
    ``k − 1`` (zero before the first sample), and the plant's ``step`` returns output ``k``. The
    model starts at rest: its past outputs are the record's first row of ``output`` and its past
    commands zero; the drive starts at the record's first motor position (0 when absent).
    Scores skip the model's first ``max_lag_`` samples, like its free-run scores, so a row of
    free-run fits and a row of model-in-the-loop fits cover the same samples.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid.plant import InclinationController, SoftNeck, closed_loop
    >>> from neckid.loops.model_in_loop import model_in_the_loop
    >>> record = closed_loop(SoftNeck(seed=3), InclinationController(), np.full(100, 10.0), 0.02)
    >>> same = model_in_the_loop(SoftNeck(seed=3), InclinationController(), record)
    >>> float(same.output_rmse[0]), float(same.command_rmse[0])
    (0.0, 0.0)
    """
    n_ref = int(getattr(controller, "n_references", 1))
    if reference is None:
        reference = (
            "reference" if n_ref == 1 else ("reference_inclination", "reference_orientation")
        )
    ref_names = _as_names(reference)
    ref = _rows(record, ref_names, "reference")
    outputs = _as_names(output) if output is not None else tuple(record.output_names[:n_ref])
    measured_y = _rows(record, outputs, "output")
    n_motors = int(getattr(controller, "n_motors", 1))
    commands = channel_names(command, n_motors)
    _rows(record, commands, "command")
    positions = channel_names(POSITION, n_motors)
    position0 = (
        _rows(record, positions, "position")[0]
        if all(n in record.input_names for n in positions)
        else None
    )
    if callable(getattr(model, "simulator", None)):
        plant: Any = ModelPlant(
            model,
            drive
            if drive is not None
            else VelocityDrive.from_parameters(ts=record.ts, n_motors=n_motors),
            command=command,
            outputs=outputs,
            y0=_initial_outputs(model, measured_y[0], outputs),
            position0=position0,
        )
        n_initial = int(model.max_lag_)
    else:
        plant = model
        n_initial = 0
    loop = closed_loop(plant, controller, ref if n_ref > 1 else ref[:, 0], record.ts, excitation)
    loop_y = _rows(loop, outputs, "output")
    loop_u = _rows(loop, commands, "command")
    measured_u = _rows(record, commands, "command")
    lower = upper = band = None
    if isinstance(plant, ModelPlant) and plant.lower:
        lower, upper = np.vstack(plant.lower), np.vstack(plant.upper)
        band = coverage(measured_y, lower, upper, skip=n_initial)
    return LoopComparison(
        loop=loop,
        measured=record,
        output_names=outputs,
        command_names=commands,
        n_initial=n_initial,
        output_fit=fit_percent(measured_y, loop_y, skip=n_initial),
        output_rmse=rmse(measured_y, loop_y, skip=n_initial),
        command_fit=fit_percent(measured_u, loop_u, skip=n_initial),
        command_rmse=rmse(measured_u, loop_u, skip=n_initial),
        lower=lower,
        upper=upper,
        band_coverage=band,
    )


def _initial_outputs(model: Any, first_row: FloatArray, outputs: Sequence[str]) -> FloatArray:
    """The model's output row at rest: the record's first values, zero for unmeasured outputs."""
    row = np.zeros(len(model.output_names_))
    for value, name in zip(first_row, outputs, strict=True):
        if name in model.output_names_:
            row[model.output_names_.index(name)] = value
    return row
