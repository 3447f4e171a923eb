r"""The plant a controller is designed on: an identified model's linear form, command to inclination.

The loop's controller sends a motor *velocity* command [rad/s] and reads the inclination [deg].
:func:`linear_form` turns a model into the discrete transfer function :math:`G(z)` between the
two, whatever the model's own input:

- ``velocity_command``: the model as it is;
- ``motor_position`` / ``motor_displacement`` [rad]: through the drive, the motor integrates
  the command: :math:`T/(z - 1)` (the position at the start of sample :math:`k`, before command
  :math:`k` acts, as :func:`neckid.plant.closed_loop` logs it), or with a first-order velocity
  loop of time constant :math:`\tau_m` the zero-order-hold equivalent of
  :math:`1/(s(\tau_m s + 1))`;
- ``motor_velocity`` [rad/s]: :math:`z^{-1}` (the velocity reached over the previous sample),
  or the zero-order-hold equivalent of :math:`1/(\tau_m s + 1)`;

a model with several of these inputs adds their paths (the benchmark's models take the
displacement and the measured velocity). Condition channels (payload) are constants and drop
out.

Which models have a linear form: :class:`~neckid.LinearARX`, :class:`~neckid.RecursiveARX`
(its final estimate), :class:`~neckid.models.linear.subspace.SubspaceStateSpace`
(:func:`neckid.export.control.to_control`) and :class:`~neckid.models.koopman.KoopmanEDMD` (its
lifted linear system, without the constant state that carries the offsets); :class:`~neckid.GainScheduledModel` frozen at an
inclination; a python-control ``TransferFunction`` / ``StateSpace`` of command to inclination;
and any NARX model (Set Membership, neural, polynomial) *linearised* at an inclination
(:func:`neckid.design.linearise.linearise`). Anything else is refused with a message.

The loop adds ``computation_delay`` samples: :func:`neckid.plant.closed_loop` computes command
:math:`k` from the output of sample :math:`k - 1` (1, the default); the lab's bench reads the
sensor and commands in the same period (0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.design.linearise import (
    COMMAND,
    POSITION_CHANNELS,
    VELOCITY_CHANNELS,
    NoLinearFormError,
    linearise,
)
from neckid.utils.checks import check_number, check_ts
from neckid.utils.types import FloatArray

__all__ = ["LinearForm", "linear_form"]


@dataclass(frozen=True)
class LinearForm:
    r"""A plant :math:`G(z)` from the velocity command [rad/s] to the inclination [deg], and the loop's delay.

    Attributes
    ----------
    num, den : ndarray
        :math:`G(z)`, coefficients in descending powers of :math:`z`.
    ts : float
        Period, s.
    computation_delay : int
        Samples between a measurement and the command computed from it (1 in
        :func:`neckid.plant.closed_loop`).
    source : str
        What it came from, in words.
    """

    num: FloatArray
    den: FloatArray
    ts: float
    computation_delay: int = 1
    source: str = ""

    def response(self, omega: ArrayLike) -> np.ndarray:
        r""":math:`G(e^{j\omega T})\,e^{-j\omega T d}` (the plant and the loop's delay).

        Parameters
        ----------
        omega : array_like
            rad/s.

        Returns
        -------
        ndarray of complex, the shape of ``omega``
        """
        w = np.asarray(omega, dtype=np.float64)
        z = np.exp(1j * w * self.ts)
        return np.asarray(
            np.polyval(self.num, z) / np.polyval(self.den, z) * z ** (-self.computation_delay)
        )

    def plant(self) -> Any:
        """:math:`G(z)` as a ``control.TransferFunction`` (without the loop's delay)."""
        import control

        return control.tf(self.num, self.den, dt=self.ts, inputs=[COMMAND], outputs=["inclination"])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``num``, ``den``, ``ts``, ``computation_delay``, ``source``."""
        return {
            "num": [float(v) for v in self.num],
            "den": [float(v) for v in self.den],
            "ts": self.ts,
            "computation_delay": self.computation_delay,
            "source": self.source,
        }


def _drive_paths(ts: float, time_constant: float) -> dict[str, tuple[FloatArray, FloatArray]]:
    """``(num, den)`` from the velocity command to the motor position and the motor velocity."""
    if time_constant == 0.0:
        return {
            "position": (np.array([ts]), np.array([1.0, -1.0])),
            "velocity": (np.array([1.0]), np.array([1.0, 0.0])),
        }
    e = math.exp(-ts / time_constant)
    tau = time_constant
    # ZOH equivalents of 1/(s (tau s + 1)) and 1/(tau s + 1).
    position_num = np.array([ts - tau * (1.0 - e), tau * (1.0 - e) - ts * e])
    return {
        "position": (position_num, np.polymul([1.0, -1.0], [1.0, -e])),
        "velocity": (np.array([1.0 - e]), np.array([1.0, -e])),
    }


def _add(
    total: tuple[FloatArray, FloatArray], part: tuple[FloatArray, FloatArray]
) -> tuple[FloatArray, FloatArray]:
    num = np.polyadd(np.polymul(total[0], part[1]), np.polymul(part[0], total[1]))
    return _poly(num), _poly(np.polymul(total[1], part[1]))


def _poly(values: Any) -> FloatArray:
    return np.asarray(values, dtype=np.float64)


def _siso(system: Any, output: int, inputs: list[str]) -> list[tuple[str, FloatArray, FloatArray]]:
    import control

    tf = control.tf(system) if not isinstance(system, control.TransferFunction) else system
    return [
        (name, np.asarray(tf.num[output][j], float), np.asarray(tf.den[output][j], float))
        for j, name in enumerate(inputs)
    ]


def _compose(
    paths: list[tuple[str, FloatArray, FloatArray]],
    ts: float,
    time_constant: float,
    conditions: tuple[str, ...],
) -> tuple[FloatArray, FloatArray]:
    drive = _drive_paths(ts, time_constant)
    total: tuple[FloatArray, FloatArray] = (np.zeros(1), np.ones(1))
    used = 0
    for name, num, den in paths:
        if name in conditions:
            continue
        if name == COMMAND:
            part = (num, den)
        elif name in POSITION_CHANNELS:
            position_num, position_den = drive["position"]
            part = (_poly(np.polymul(num, position_num)), _poly(np.polymul(den, position_den)))
        elif name in VELOCITY_CHANNELS:
            velocity_num, velocity_den = drive["velocity"]
            part = (_poly(np.polymul(num, velocity_num)), _poly(np.polymul(den, velocity_den)))
        else:
            raise NoLinearFormError(
                f"the model's input {name!r} is not fed by the loop's velocity command: a design"
                f" takes a model of {COMMAND}, {' or '.join(POSITION_CHANNELS)} (through the"
                f" drive) or {VELOCITY_CHANNELS[0]} to the inclination"
            )
        total = _add(total, part)
        used += 1
    if not used:
        raise NoLinearFormError("the model has no input fed by the loop's velocity command")
    num = np.trim_zeros(total[0], "f")
    return (num if num.size else np.zeros(1)), total[1]


def _koopman_increments(lifted: Any) -> Any:
    """A Koopman model's lifted system without its constant state: the map from the inputs.

    The last lifted state is the constant 1 (no input reaches it, it reaches only the offsets),
    so the transfer from the inputs to the outputs is that of the other states, exactly.
    """
    import control

    a, b, c, d = (np.asarray(m, dtype=np.float64) for m in (lifted.A, lifted.B, lifted.C, lifted.D))
    return control.ss2tf(
        control.StateSpace(
            a[:-1, :-1],
            b[:-1],
            c[:, :-1],
            d,
            dt=lifted.dt,
            inputs=list(lifted.input_labels),
            outputs=list(lifted.output_labels),
        )
    )


def _output_index(names: list[str], output: str | None) -> int:
    wanted = output if output is not None else ("inclination" if "inclination" in names else None)
    if wanted is None:
        if len(names) == 1:
            return 0
        raise ValueError(f"output: the model has outputs {names}; name the inclination's")
    if wanted not in names:
        raise ValueError(f"output {wanted!r} is not an output of the model {names}")
    return names.index(wanted)


def linear_form(
    model: Any,
    *,
    inclination: float | None = None,
    computation_delay: int = 1,
    drive_time_constant: float = 0.0,
    output: str | None = None,
) -> LinearForm:
    r"""The linear form of a model, from the velocity command [rad/s] to the inclination [deg].

    Parameters
    ----------
    model : fitted model or control.TransferFunction / StateSpace
        See the module docstring for which models have one.
    inclination : float, optional
        Operating point [deg]: required for a :class:`~neckid.GainScheduledModel` and for the
        nonlinear models (linearised there), refused for the linear ones.
    computation_delay : int, default 1
        Samples of delay the loop adds (see the module docstring).
    drive_time_constant : float, default 0
        :math:`\tau_m` [s] of the drive's velocity loop between command and motor position (0: a
        plain integrator; the simulated neck's is 0.015 s).
    output : str, optional
        The model's inclination output (default ``"inclination"``, or the only output).

    Returns
    -------
    LinearForm

    Raises
    ------
    NoLinearFormError
        A ``TypeError``: the model has no linear form (a nonlinear model without an operating
        point, a model whose state is not its input/output history, an input the loop does
        not feed).
    ValueError
        A bad argument (``inclination`` missing or not allowed, an unknown output).

    Examples
    --------
    >>> import control
    >>> form = linear_form(control.tf([0.1], [1, -1], dt=0.02))
    >>> form.computation_delay, round(abs(complex(form.response(3.0))), 3)
    (1, 1.667)
    """
    import control

    from neckid.export.control import to_control
    from neckid.models.koopman.model import KoopmanEDMD
    from neckid.models.linear.arx import LinearARX
    from neckid.models.linear.rls import RecursiveARX
    from neckid.models.linear.subspace import SubspaceStateSpace
    from neckid.models.scheduled.model import GainScheduledModel

    delay = check_number(computation_delay, "computation_delay", low=0, integer=True)
    tau = check_number(drive_time_constant, "drive_time_constant", low=0)
    if isinstance(model, control.TransferFunction | control.StateSpace):
        if model.ninputs != 1 or model.noutputs != 1 or not model.isdtime(strict=True):
            raise ValueError(
                "a python-control system to design on must be discrete-time and SISO (velocity"
                f" command -> inclination); got {model.ninputs} input(s), {model.noutputs}"
                f" output(s), dt={model.dt!r}"
            )
        ts = check_ts(model.dt)
        ((_, num, den),) = _siso(model, 0, [COMMAND])
        return LinearForm(num, den, ts, delay, "python-control system")
    name = type(model).__name__
    if not callable(getattr(model, "state_map", None)) or not hasattr(model, "ts_"):
        raise NoLinearFormError(
            f"a design takes a fitted neckid model or a discrete python-control system; got {name}"
        )
    if isinstance(model, GainScheduledModel):
        if inclination is None:
            raise ValueError(
                "inclination is required for a GainScheduledModel: the operating point [deg]"
                " to freeze it at (or design a scheduled controller over its range)"
            )
        system = to_control(model, inclination=float(inclination), form="tf", name="scheduled")
        index = 0
        source = f"{name} at {float(inclination):g} deg"
    elif isinstance(model, LinearARX | RecursiveARX | SubspaceStateSpace):
        if inclination is not None:
            raise ValueError(
                f"inclination applies to the scheduled and the nonlinear models; a {name} is"
                f" linear: leave it out (got {inclination!r})"
            )
        system = to_control(model, form="tf")
        index = _output_index(list(system.output_labels), output)
        source = name
    elif isinstance(model, KoopmanEDMD):
        if inclination is not None:
            raise ValueError(
                f"inclination applies to the scheduled and the nonlinear models; a {name}'s"
                f" lifted system is linear everywhere: leave it out (got {inclination!r})"
            )
        lifted = to_control(model, form="ss")
        system = _koopman_increments(lifted)
        index = _output_index(list(system.output_labels), output)
        source = f"{name} (its lifted linear system: {lifted.nstates - 1} states and the constant)"
    else:
        if inclination is None:
            raise NoLinearFormError(
                f"a {name} is nonlinear and has no linear form of its own; give an operating"
                " point (inclination=DEG, --inclination DEG) to design on its linearisation"
                " there"
            )
        system = linearise(model, float(inclination), output=output)
        index = 0
        source = f"{name} linearised at {inclination:g} deg"
    inputs = list(system.input_labels)
    conditions = tuple(getattr(getattr(model, "lags_", None), "conditions", ()) or ())
    ts = check_ts(float(model.ts_))
    num, den = _compose(_siso(system, index, inputs), ts, tau, conditions)
    if tau:
        source += f", drive time constant {tau:g} s"
    return LinearForm(num, den, ts, delay, source)
