"""The calibration checks of the simulated neck against the real bench and the paper.

Three figures, each computed the way it is measured on the bench (closed loop, the inclination
controller of :mod:`neckid.plant.control`):

* :func:`static_map`: a staircase of inclination targets (as in the real stair logs); the slope of
  inclination against motor position between 15° and 30° (real bench: about 7°/rad) and the
  motor-position difference between going up and coming down at the same inclination.
* :func:`chirp_bandwidth`: the paper's up-chirp ``5 + 4 sin(0.1 t²)`` as an inclination reference;
  the bandwidth by the paper's 90 % amplitude rule (paper: 4.2 rad/s).
* :func:`operating_point_models`: at each inclination, a constant reference plus a PRBS on the
  velocity command; least squares of ``rate(t+1) = P rate(t) + N u(t - input_delay)`` (paper:
  ``N = -0.059 i + 1.857``, ``P = 0.01175 i - 0.4797``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from neckid.plant.control import InclinationController, closed_loop
from neckid.plant.soft_neck import SoftNeck
from neckid.signals import BandwidthResult, bandwidth_from_chirp, paper_chirp, paper_chirp_frequency
from neckid.signals import prbs as prbs_signal
from neckid.utils.types import FloatArray

__all__ = [
    "OperatingPointModels",
    "StaticMap",
    "chirp_bandwidth",
    "operating_point_models",
    "static_map",
]


#: The paper's inclination-scheduled first-order model, ``N(i)`` and ``P(i)`` (i in degrees).
PAPER_GAIN = (-0.059, 1.857)
PAPER_POLE = (0.01175, -0.4797)
#: The paper's bandwidth from its up-chirp, rad/s.
PAPER_BANDWIDTH = 4.2
#: The real bench's static map between 15° and 30°, degrees per rad of motor (stair logs).
REAL_STATIC_SLOPE = 7.0


def _planar(neck: SoftNeck) -> None:
    if neck.configuration != "planar":
        raise ValueError(f"the calibration runs on a planar neck; got {neck.configuration!r}")


@dataclass(frozen=True)
class StaticMap:
    """Plateaus of a closed-loop staircase.

    Attributes
    ----------
    levels : ndarray
        Inclination targets of the plateaus, degrees, in the order run.
    inclination, motor_position : ndarray
        Mean measured inclination (deg) and motor position (rad) over the last 40 % of each plateau.
    slope : float
        Least-squares slope of inclination against motor position on the rising plateaus from 15°
        to 30°, degrees per rad.
    up_down : dict of float to float
        Motor position coming down minus going up, rad, at each inclination visited both ways.
    """

    levels: FloatArray
    inclination: FloatArray
    motor_position: FloatArray
    slope: float
    up_down: dict[float, float]


def static_map(
    neck: SoftNeck,
    controller: InclinationController | None = None,
    levels: Sequence[float] = (10.0, 15.0, 20.0, 25.0, 30.0, 25.0, 20.0, 15.0),
    hold: float = 10.0,
) -> StaticMap:
    """Run a staircase in closed loop; return the plateaus and the 15–30° slope.

    Parameters
    ----------
    neck : SoftNeck
        A planar neck.
    controller : InclinationController, optional
        Default ``InclinationController(ts=neck.ts)``.
    levels : sequence of float
        Inclination targets, degrees (default: the real stair logs' 10, 15, ..., 30, ..., 15).
    hold : float, default 10.0
        Seconds on each level.

    Returns
    -------
    StaticMap

    Examples
    --------
    >>> from neckid.plant import SoftNeck
    >>> from neckid.plant.calibration import static_map
    >>> result = static_map(SoftNeck(), levels=(15.0, 30.0, 15.0), hold=5.0)
    >>> bool(5.6 < result.slope < 8.4)      # the real neck: about 7 deg/rad
    True
    """
    _planar(neck)
    ctrl = controller if controller is not None else InclinationController(ts=neck.ts)
    per = round(hold / neck.ts)
    targets = np.asarray(levels, dtype=np.float64)
    data = closed_loop(neck, ctrl, np.repeat(targets, per), neck.ts)
    y = data.channel("inclination")
    q = data.channel("motor_position")
    start = per - round(0.4 * per)
    incl = np.array([y[k * per + start : (k + 1) * per].mean() for k in range(targets.size)])
    pos = np.array([q[k * per + start : (k + 1) * per].mean() for k in range(targets.size)])
    peak = int(np.argmax(targets))
    rising = np.arange(peak + 1)
    chosen = rising[(targets[rising] >= 15.0) & (targets[rising] <= 30.0)]
    if chosen.size < 2:
        chosen = rising
    slope = float(np.polyfit(pos[chosen], incl[chosen], 1)[0])
    up_down: dict[float, float] = {}
    for k in range(peak + 1, targets.size):
        ups = np.flatnonzero(targets[: peak + 1] == targets[k])
        if ups.size:
            up_down[float(targets[k])] = float(pos[k] - pos[ups[-1]])
    return StaticMap(targets, incl, pos, slope, up_down)


def chirp_bandwidth(
    neck: SoftNeck,
    controller: InclinationController | None = None,
    duration: float = 60.0,
) -> tuple[BandwidthResult, FloatArray, FloatArray, FloatArray]:
    """The paper's up-chirp as a closed-loop inclination reference; its bandwidth (90 % rule).

    Returns
    -------
    result : BandwidthResult
        ``result.bandwidth`` in rad/s (the paper: 4.2 rad/s).
    time, reference, inclination : ndarray
        The run, for a figure.

    Examples
    --------
    >>> from neckid.plant import SoftNeck
    >>> from neckid.plant.calibration import chirp_bandwidth
    >>> result, *_ = chirp_bandwidth(SoftNeck())
    >>> bool(2.0 < result.bandwidth < 8.0)
    True
    """
    _planar(neck)
    ctrl = controller if controller is not None else InclinationController(ts=neck.ts)
    time = np.arange(round(duration / neck.ts), dtype=np.float64) * neck.ts
    reference = paper_chirp(time)
    data = closed_loop(neck, ctrl, reference, neck.ts)
    response = data.channel("inclination")
    result = bandwidth_from_chirp(time, reference, response, frequency=paper_chirp_frequency)
    return result, time, reference, np.array(response)


@dataclass(frozen=True)
class OperatingPointModels:
    """First-order velocity to inclination-rate models identified at operating points.

    ``rate(t+1) = pole * rate(t) + gain * u(t - input_delay)``, with
    ``rate(t) = (y(t) - y(t-1)) / ts`` the backward difference of the measured inclination in
    deg/s and ``u`` the velocity command in rad/s.

    Attributes
    ----------
    inclination : ndarray
        Operating points, degrees.
    pole, gain : ndarray
        ``P`` and ``N`` at each operating point.
    input_delay : int
        Samples of delay on ``u`` in the regression.
    """

    inclination: FloatArray
    pole: FloatArray
    gain: FloatArray
    input_delay: int

    def trend(self) -> tuple[float, float]:
        """Least-squares slopes of ``gain`` and ``pole`` against inclination, per degree."""
        gain_slope = float(np.polyfit(self.inclination, self.gain, 1)[0])
        pole_slope = float(np.polyfit(self.inclination, self.pole, 1)[0])
        return gain_slope, pole_slope


def operating_point_models(
    neck: SoftNeck,
    controller: InclinationController | None = None,
    inclinations: Sequence[float] = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0),
    duration: float = 60.0,
    amplitude: float = 1.0,
    clock_period: float = 0.2,
    input_delay: int | None = None,
    seed: int = 0,
) -> OperatingPointModels:
    """Identify ``rate(t+1) = P rate(t) + N u(t - d)`` at each operating point (closed loop + PRBS).

    Parameters
    ----------
    neck : SoftNeck
        A planar neck.
    controller : InclinationController, optional
        Holds the operating point; default ``InclinationController(ts=neck.ts)``.
    inclinations : sequence of float
        Operating points, degrees.
    duration : float, default 60.0
        Seconds per operating point; the first 10 s (the approach) are not used.
    amplitude : float, default 1.0
        PRBS amplitude added to the command, rad/s.
    clock_period : float, default 0.2
        PRBS clock period, s.
    input_delay : int, optional
        ``d``; default the sensor delay in samples plus one (``neck.delay_samples + 1``: a command
        of sample ``t`` moves the motor during sample ``t`` and the link mostly in the next one).
        0 gives the paper's regression as written.
    seed : int, default 0
        Seed of the PRBS (``seed + k`` at the k-th operating point).

    Returns
    -------
    OperatingPointModels
    """
    _planar(neck)
    ctrl = controller if controller is not None else InclinationController(ts=neck.ts)
    d = neck.delay_samples + 1 if input_delay is None else int(input_delay)
    if d < 0:
        raise ValueError(f"input_delay must be >= 0 samples; got {input_delay!r}")
    n = round(duration / neck.ts)
    skip = round(10.0 / neck.ts)
    if n - skip < 50 + d:
        raise ValueError(f"duration must leave at least 50 samples after 10 s; got {duration!r}")
    points = np.asarray(inclinations, dtype=np.float64)
    poles = np.empty(points.size)
    gains = np.empty(points.size)
    for k, level in enumerate(points):
        excitation = prbs_signal(
            n, neck.ts, clock_period, levels=(-amplitude, amplitude), seed=seed + k
        )
        data = closed_loop(neck, ctrl, np.full(n, level), neck.ts, excitation=excitation)
        y = data.channel("inclination")[skip:]
        u = data.channel("velocity_command")[skip:]
        # rate(t) = (y(t) - y(t-1)) / ts, stored at rate[t - 1]
        rate = np.diff(y) / neck.ts
        t = np.arange(max(d, 1), rate.size)  # the target rate(t + 1) is rate[t]
        regressors = np.column_stack([rate[t - 1], u[t - d]])
        (pole, gain), *_ = np.linalg.lstsq(regressors, rate[t], rcond=None)
        poles[k] = pole
        gains[k] = gain
    return OperatingPointModels(points, poles, gains, d)
