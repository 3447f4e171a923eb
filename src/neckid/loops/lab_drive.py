r"""The bench drive as a model identified from the logs: gains by direction and by speed.

The soft-neck bench's drive (Maxon RE16, 24:1 gear, CiA 402 velocity mode) runs a command
:math:`c` as :math:`c_e = \mathrm{sign}(c)\max(|c|, v_{min})`, :math:`v_{min} = 0.12783` rad/s
(its smallest velocity, :func:`~neckid.loops.controllers.executed_velocity`), and the logs say it
does not move the motor by :math:`T c_e` per sample: over a run, integrating the executed command
drifts 2.3–5.1 rad away from the logged motor position. :class:`LabDrive` models it as an
integrator with one gain per direction and per regime (a command at or above the smallest velocity,
or one raised to it),

.. math::

    q_{k+1} = q_k + T\,g(c_{k-d}), \qquad w_k = h(c_{k-1-d}), \qquad
    g(c) = \begin{cases} g_+ c_e & c \ge v_{min} \\ g_- c_e & c \le -v_{min} \\
    g_{s+} c_e & 0 < c < v_{min} \\ g_{s-} c_e & -v_{min} < c < 0 \end{cases}

(:math:`h` alike with its own four gains), where :math:`q_k` is the motor position of row
:math:`k` [rad] (read before command :math:`k` acts, as the logs hold it), :math:`w_k` the
*measured* motor velocity of row :math:`k` [rad/s] (the drive's reading of the previous sample),
and :math:`d` an extra delay of whole samples. :func:`identify_drive` fits it on logs:

- the position gains by least squares on the motor's displacement over windows of ``window``
  samples (1 s by default: shorter than the PI loop's 2.6 s oscillation, long enough to average
  the position's sample-to-sample jitter), pooled over the logs;
- the velocity gains by least squares on the measured velocity, sample by sample;
- :math:`d` as the candidate with the smaller one-sample position residual.

On the payload split's six training staircases (0 g and 600 g, int/fra/ada) the data choose
:math:`d = 0` (one-sample residual 0.0135 rad against 0.0145 rad for :math:`d = 1`), and
:data:`LAB_DRIVE_GAINS`: :math:`g_+ = 0.95`, :math:`g_- = 1.00`, and for the commands raised to
the smallest velocity :math:`g_{s+} \approx 0`, :math:`g_{s-} = 1.07`: winding the tendon at the
smallest velocity stalls, unwinding does not. The fixed and adaptive fractional controllers
command that regime 24–38 % of the time; with it the drift left on the test runs falls from
0.8–2.5 rad (two gains; 2.4–5.1 rad for the plain integrator) to 0.03–2.2 rad (docs/in_loop.md).
The measured velocity is not the position's derivative (over a training run its integral exceeds
the position change by 2.1–4.4 rad), so the two are fitted apart, as a model identified on the
logs sees them. What no constant gain removes is the run-to-run change of the asymmetry.

References
----------
- ``shared/data/softneck/CONTROLLERS.md`` ("What every run shares": the smallest velocity) and
  ``SOURCE.md`` (the column layouts); the drive: github.com/HUMASoft/CiA402Device.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData
from neckid.loops.controllers.drive import DRIVE_MIN_VELOCITY, executed_velocity
from neckid.loops.controllers.references import LAB_TS
from neckid.utils.checks import check_number, check_ts
from neckid.utils.types import FloatArray

__all__ = ["LAB_DRIVE_GAINS", "LAB_DRIVE_VELOCITY_GAINS", "DriveFit", "LabDrive", "identify_drive"]

#: :func:`identify_drive` on the payload split's training staircases
#: (``stair/{ada,fra,int}{000,600}response.csv``), delay 0: position gains
#: (g+, g−, gs+, gs−) ...
LAB_DRIVE_GAINS = (0.9526, 1.0027, -0.0059, 1.0717)
#: ... and measured-velocity gains (h+, h−, hs+, hs−).
LAB_DRIVE_VELOCITY_GAINS = (0.9544, 0.9845, 0.6328, -0.2861)

POSITION = "motor_position"
VELOCITY = "motor_velocity"
COMMAND = "velocity_command"

#: Names of the four gains, in order.
GAIN_NAMES = ("positive", "negative", "small_positive", "small_negative")


def regimes(command: ArrayLike, minimum: float = DRIVE_MIN_VELOCITY) -> FloatArray:
    """The executed command split into the four regimes of :class:`LabDrive`, one column each.

    Parameters
    ----------
    command : array_like, shape (n,)
        Velocity commands [rad/s].
    minimum : float, default 0.12783
        The smallest velocity [rad/s].

    Returns
    -------
    ndarray, shape (n, 4)
        Executed command [rad/s] where the regime holds (``c ≥ v_min``, ``c ≤ −v_min``,
        ``0 < c < v_min``, ``−v_min < c < 0``), 0 elsewhere.

    Examples
    --------
    >>> regimes([0.5, -0.05, 0.0]).tolist()
    [[0.5, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, -0.12783], [0.0, 0.0, 0.0, 0.0]]
    """
    c = np.asarray(command, dtype=np.float64).reshape(-1)
    executed = executed_velocity(c, minimum)
    small = np.abs(c) < minimum
    positive, negative = executed > 0.0, executed < 0.0
    masks = (positive & ~small, negative & ~small, positive & small, negative & small)
    return np.column_stack([np.where(mask, executed, 0.0) for mask in masks])


def _delayed(values: FloatArray, delay: int) -> FloatArray:
    if delay == 0:
        return values
    return np.vstack([np.zeros((delay, values.shape[1])), values[:-delay]])


def _gains(values: ArrayLike, argument: str) -> tuple[float, float, float, float]:
    array = np.asarray(values, dtype=np.float64).reshape(-1)
    if array.shape != (4,) or not np.all(np.isfinite(array)):
        raise ValueError(f"{argument} must be 4 finite gains {GAIN_NAMES}; got {values!r}")
    return (float(array[0]), float(array[1]), float(array[2]), float(array[3]))


class LabDrive:
    """The bench drive: velocity command in, motor position and measured velocity out.

    Parameters
    ----------
    gains : (float, float, float, float), default (1, 1, 1, 1)
        Position gains :math:`(g_+, g_-, g_{s+}, g_{s-})`: the motor moves ``gain × T ×
        executed command`` per sample (see the module docstring for the regimes).
    velocity_gains : (float, float, float, float), default (1, 1, 1, 1)
        Gains :math:`(h_+, h_-, h_{s+}, h_{s-})` of the measured velocity.
    delay : int, default 0
        Extra samples between a command and its effect.
    minimum : float, default 0.12783
        The smallest velocity, rad/s.
    ts : float, default 0.025
        Period, s.

    Notes
    -----
    The defaults are the plain integrator of the executed command. :meth:`identified` gives the
    drive with :data:`LAB_DRIVE_GAINS`. Like :class:`~neckid.loops.model_in_loop.VelocityDrive`,
    :meth:`step` takes a command and returns the position at the *start* of the sample, and
    :attr:`motor_position`, :attr:`motor_velocity` hold the state (one motor).

    Examples
    --------
    >>> drive = LabDrive(gains=(0.5, 1, 1, 1), ts=1.0)
    >>> [float(drive.step([2.0])[0]) for _ in range(3)], float(drive.motor_velocity[0])
    ([0.0, 1.0, 2.0], 2.0)
    """

    n_motors = 1

    def __init__(
        self,
        gains: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0),
        velocity_gains: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0),
        delay: int = 0,
        minimum: float = DRIVE_MIN_VELOCITY,
        ts: float = LAB_TS,
    ) -> None:
        self.gains = _gains(gains, "gains")
        self.velocity_gains = _gains(velocity_gains, "velocity_gains")
        self.delay: int = check_number(delay, "delay", low=0, integer=True)
        self.minimum = check_number(minimum, "minimum", low=0)
        self.ts = check_ts(ts)
        self.reset()

    @classmethod
    def identified(cls, ts: float = LAB_TS) -> LabDrive:
        """The drive identified on the shared training logs (:data:`LAB_DRIVE_GAINS`)."""
        return cls(LAB_DRIVE_GAINS, LAB_DRIVE_VELOCITY_GAINS, delay=0, ts=ts)

    def reset(self, position: ArrayLike | None = None, velocity: ArrayLike | None = None) -> None:
        """Start at ``position`` [rad] and measured ``velocity`` [rad/s] (default 0), no past command."""
        self.motor_position = self._one(position, "position")
        self.motor_velocity = self._one(velocity, "velocity")
        self._pending = [np.zeros(4)] * self.delay  # regimes not acting yet, oldest first

    @staticmethod
    def _one(value: ArrayLike | None, argument: str) -> FloatArray:
        if value is None:
            return np.zeros(1)
        array = np.asarray(value, dtype=np.float64).reshape(-1)
        if array.shape != (1,) or not np.isfinite(array[0]):
            raise ValueError(f"{argument} must be one finite value (one motor); got {value!r}")
        return array.copy()

    def step(self, command: ArrayLike) -> FloatArray:
        """Apply one sample of command [rad/s]; return the position at the start of the sample [rad]."""
        now = self.motor_position.copy()
        value = float(np.asarray(command, dtype=np.float64).reshape(-1)[0])
        if not math.isfinite(value):
            raise ValueError(f"command must be finite; got {value}")
        self._pending.append(regimes([value], self.minimum)[0])
        acting = self._pending.pop(0)
        self.motor_position = now + self.ts * float(acting @ np.array(self.gains))
        self.motor_velocity = np.array([float(acting @ np.array(self.velocity_gains))])
        return now

    def simulate(self, command: ArrayLike, position0: float = 0.0) -> tuple[FloatArray, FloatArray]:
        """Position and measured velocity of every row for a logged command (a free run).

        Parameters
        ----------
        command : array_like, shape (n,)
            Velocity command of each row [rad/s].
        position0 : float, default 0
            Position of the first row [rad].

        Returns
        -------
        position, velocity : ndarray, shape (n,)
            Row ``k``: before command ``k`` acts [rad], [rad/s] (the velocity of row 0 is 0).
        """
        split = _delayed(regimes(command, self.minimum), self.delay)
        moved = self.ts * (split @ np.array(self.gains))
        position = position0 + np.concatenate([[0.0], np.cumsum(moved[:-1])])
        measured = split @ np.array(self.velocity_gains)
        return position, np.concatenate([[0.0], measured[:-1]])

    def __repr__(self) -> str:
        return (
            f"LabDrive(gains={self.gains!r}, velocity_gains={self.velocity_gains!r},"
            f" delay={self.delay!r}, minimum={self.minimum!r}, ts={self.ts!r})"
        )


@dataclass(frozen=True)
class DriveFit:
    """What :func:`identify_drive` found.

    Attributes
    ----------
    drive : LabDrive
        The identified drive.
    residuals : dict of int to float
        One-sample position residual RMS [rad] of each candidate delay; the smallest won.
    window : int
        Samples per displacement window of the position fit.
    logs : tuple of str
        The logs' names.
    training : tuple of IOData
        The logs themselves (:meth:`drift` refits two gains on them for comparison).
    """

    drive: LabDrive
    residuals: dict[int, float]
    window: int
    logs: tuple[str, ...]
    training: tuple[IOData, ...] = ()

    def drift(self, logs: Sequence[IOData]) -> pd.DataFrame:
        r"""The drift of the drive's position from each log's, beside simpler drives'.

        Parameters
        ----------
        logs : sequence of IOData
            Soft-neck logs with ``motor_position`` and ``velocity_command``.

        Returns
        -------
        pandas.DataFrame
            One row per log: ``log``; ``end_drift_rad`` and ``max_drift_rad`` (the drive's
            position minus the log's at the last row, and the largest absolute difference over
            the run, rad); the same for the integrator of the executed command (all gains 1,
            ``integrator_*``) and for two gains (:math:`g_{s\pm} = g_\pm`, fitted on the same
            logs as this drive, ``two_gains_*``); ``positive_gain``, ``negative_gain``: the two
            gains fitted on that log alone (same window), to show the run-to-run spread.
        """
        plain = LabDrive(delay=self.drive.delay, minimum=self.drive.minimum, ts=self.drive.ts)
        two = _position_gains(self.training, self.window, self.drive.delay, self.drive.minimum, 2)
        pooled = LabDrive(
            (two[0], two[1], two[0], two[1]), delay=self.drive.delay, minimum=self.drive.minimum
        )
        rows = []
        for log in logs:
            position, command = log.channel(POSITION), log.channel(COMMAND)
            row: dict[str, object] = {"log": log.name}
            for label, drive in (("", self.drive), ("integrator_", plain), ("two_gains_", pooled)):
                error = drive.simulate(command, float(position[0]))[0] - position
                row[f"{label}end_drift_rad"] = float(error[-1])
                row[f"{label}max_drift_rad"] = float(np.abs(error).max())
            alone = _position_gains([log], self.window, self.drive.delay, self.drive.minimum, 2)
            row["positive_gain"], row["negative_gain"] = float(alone[0]), float(alone[1])
            rows.append(row)
        return pd.DataFrame(rows)


def _regimes_of(log: IOData, delay: int, minimum: float, count: int) -> FloatArray:
    split = _delayed(regimes(log.channel(COMMAND), minimum), delay)
    if count == 2:  # one gain per direction: the small commands share the large ones'
        return split[:, :2] + split[:, 2:]
    return split


def _position_gains(
    logs: Sequence[IOData], window: int, delay: int, minimum: float, count: int = 4
) -> FloatArray:
    """Position gains by least squares on the displacement over ``window`` samples, logs pooled."""
    rows, targets = [], []
    for log in logs:
        split = _regimes_of(log, delay, minimum, count)
        cumulative = log.ts * np.vstack([np.zeros((1, count)), np.cumsum(split, axis=0)])
        position = log.channel(POSITION)
        start = np.arange(position.shape[0] - window)
        rows.append(cumulative[start + window] - cumulative[start])
        targets.append(position[start + window] - position[start])
    return np.linalg.lstsq(np.vstack(rows), np.concatenate(targets), rcond=None)[0]


def _velocity_gains(logs: Sequence[IOData], delay: int, minimum: float) -> FloatArray:
    """Velocity gains by least squares: the measured velocity of row k on the command of row k−1−d."""
    rows, targets = [], []
    for log in logs:
        rows.append(_regimes_of(log, delay, minimum, 4)[:-1])
        targets.append(log.channel(VELOCITY)[1:])
    return np.linalg.lstsq(np.vstack(rows), np.concatenate(targets), rcond=None)[0]


def _one_step_residual(
    logs: Sequence[IOData], gains: FloatArray, delay: int, minimum: float
) -> float:
    errors = []
    for log in logs:
        moved = log.ts * (_regimes_of(log, delay, minimum, 4) @ gains)
        errors.append(np.diff(log.channel(POSITION)) - moved[:-1])
    return float(np.sqrt(np.mean(np.square(np.concatenate(errors)))))


def _check_logs(records: list[IOData], window: int) -> None:
    if not records:
        raise ValueError("logs must hold at least one log; got none")
    for log in records:
        missing = [n for n in (POSITION, COMMAND, VELOCITY) if n not in log.input_names]
        if missing:
            raise ValueError(
                f"log {log.name!r} has no input {missing[0]!r}: the drive is identified from"
                " the velocity command, the motor position and the measured motor velocity"
            )
        if log.n_samples < window + 2:
            raise ValueError(
                f"log {log.name!r} has {log.n_samples} rows; window={window} needs at least"
                f" {window + 2}"
            )
        if not math.isclose(log.ts, records[0].ts, rel_tol=1e-9):
            raise ValueError(f"the logs' ts differ: {records[0].ts} and {log.ts} s")


def identify_drive(
    logs: IOData | Sequence[IOData],
    *,
    window: int = 40,
    delays: Sequence[int] = (0, 1),
    minimum: float = DRIVE_MIN_VELOCITY,
) -> DriveFit:
    """Identify the drive (:class:`LabDrive`) from logged commands, motor positions and velocities.

    Parameters
    ----------
    logs : IOData or sequence of IOData
        Soft-neck logs (:func:`neckid.datasets.load_softneck_log`, 6 or 7 columns) with the inputs
        ``velocity_command``, ``motor_position`` and ``motor_velocity``; the training logs only.
    window : int, default 40
        Samples per displacement window of the position fit (40: 1 s at 0.025 s).
    delays : sequence of int, default (0, 1)
        Candidate extra delays, samples.
    minimum : float, default 0.12783
        The smallest velocity, rad/s.

    Returns
    -------
    DriveFit

    Raises
    ------
    ValueError
        If a log lacks a channel, is shorter than ``window + 2`` rows, or the logs' sampling
        periods differ.

    Notes
    -----
    A gain whose regime never occurs in the logs comes out 0 (least squares' minimum-norm
    solution).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> c = np.sin(np.arange(800) * 0.05) + 0.1
    >>> truth = LabDrive(gains=(0.9, 1.1, 0.0, 1.2), velocity_gains=(0.8, 1.0, 1.0, 1.0))
    >>> q, w = truth.simulate(c, position0=2.0)
    >>> log = IOData(u=np.column_stack([q, c, w]), y=np.zeros(800), ts=0.025,
    ...              input_names=["motor_position", "velocity_command", "motor_velocity"])
    >>> fit = identify_drive([log])
    >>> np.round(fit.drive.gains, 6).tolist(), fit.drive.delay
    ([0.9, 1.1, 0.0, 1.2], 0)
    """
    records = [logs] if isinstance(logs, IOData) else list(logs)
    size: int = check_number(window, "window", low=1, integer=True)
    _check_logs(records, size)
    low = check_number(minimum, "minimum", low=0)
    candidates = sorted({check_number(d, "delays", low=0, integer=True) for d in delays})
    if not candidates:
        raise ValueError("delays must hold at least one delay; got none")
    fits = {d: _position_gains(records, size, d, low) for d in candidates}
    residuals = {d: _one_step_residual(records, fits[d], d, low) for d in candidates}
    delay = min(candidates, key=lambda d: residuals[d])
    drive = LabDrive(
        _gains(fits[delay], "gains"),
        _gains(_velocity_gains(records, delay, low), "velocity_gains"),
        delay=delay,
        minimum=low,
        ts=records[0].ts,
    )
    return DriveFit(
        drive, residuals, size, tuple(log.name or "" for log in records), tuple(records)
    )
