"""The frequency demo: a random-odd multisine on the simulated neck, its BLA and distortion levels.

The neck runs in its inclination loop (:func:`neckid.plant.closed_loop`) with a random-odd
multisine reference around an operating point. Two robust BLAs come out of the same run
(:func:`neckid.frequency.robust_bla`): the loop's, from the reference to the inclination (the
paper's bandwidth is read from it with the 90 % rule), and the plant's, from the velocity command
to the inclination; with a periodic reference the period means remove the noise that the
feedback would otherwise correlate with the command, so this closed-loop BLA is not biased
(Pintelon & Schoukens 2012, §2.6).
"""

from __future__ import annotations

from dataclasses import dataclass

from neckid.data import IOData
from neckid.frequency import BestLinearApproximation, robust_bla
from neckid.frequency.summary import bandwidth_from_frf, model_classes
from neckid.signals import MultisinePlan, multisine_plan

__all__ = ["FrequencyDemo", "run_frequency_demo"]


@dataclass(frozen=True)
class FrequencyDemo:
    """What the frequency demo measured.

    Attributes
    ----------
    plan : MultisinePlan
        The reference played (degrees of inclination).
    log : IOData
        The closed-loop log: reference, velocity command, motor position and velocity in;
        inclination out.
    loop : BestLinearApproximation
        Reference [deg] -> inclination [deg].
    plant : BestLinearApproximation
        Velocity command [rad/s] -> inclination [deg].
    bandwidth : float
        Where the loop's BLA falls below 0.9 for good, rad/s.
    advice : str
        The model classes the plant's levels call for (:func:`model_classes`).
    """

    plan: MultisinePlan
    log: IOData
    loop: BestLinearApproximation
    plant: BestLinearApproximation
    bandwidth: float
    advice: str


def run_frequency_demo(
    seed: int = 0,
    *,
    operating_point: float = 15.0,
    rms: float = 2.0,
    period: int = 2048,
    n_realisations: int = 6,
    n_periods: int = 3,
) -> FrequencyDemo:
    """Play a random-odd multisine reference on the simulated neck's loop; its two BLAs.

    Parameters
    ----------
    seed : int, default 0
        Phases, left-out lines and the neck's sensor noise.
    operating_point : float, default 15.0
        Mean inclination, degrees.
    rms : float, default 2.0
        RMS of the reference around it, degrees.
    period, n_realisations, n_periods : int
        Samples per period (2048 at 0.02 s: 41 s, lines 0.153 rad/s apart), ``M`` and ``P``
        (one transient period each): 6 x 4 x 41 s = 16 min of neck time, well under a second to
        simulate.

    Returns
    -------
    FrequencyDemo
    """
    from neckid.plant import InclinationController, SoftNeck, closed_loop

    ts = 0.02
    plan = multisine_plan(
        period,
        ts,
        (0.15, 15.0),
        kind="random-odd",
        n_realisations=n_realisations,
        n_periods=n_periods,
        rms=rms,
        offset=operating_point,
        seed=seed,
    )
    log = closed_loop(SoftNeck(seed=seed), InclinationController(), plan.signal[:, 0], ts=ts)
    settings = {
        "period": period,
        "n_realisations": n_realisations,
        "n_periods": n_periods,
        "excited": plan.excited_lines,
    }
    names = {}
    for key, channel in (("loop", "reference"), ("plant", "velocity_command")):
        index = log.input_names.index(channel)
        names[key] = robust_bla(
            log.u[:, [index]],
            log.y,
            ts,
            names=((channel,), log.output_names),
            units=((log.input_units[index],), log.output_units),
            **settings,  # type: ignore[arg-type]
        )
    loop, plant = names["loop"], names["plant"]
    return FrequencyDemo(
        plan=plan,
        log=log,
        loop=loop,
        plant=plant,
        bandwidth=bandwidth_from_frf(loop.omega, loop.frf[:, 0, 0]),
        advice=model_classes(plant),
    )
