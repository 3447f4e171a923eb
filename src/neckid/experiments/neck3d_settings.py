"""The settings and constants of the 3-D demo (:mod:`neckid.experiments.neck3d`)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["METHODS_3D", "NARX_INPUTS", "OUTPUTS", "TESTS_3D", "Demo3DSettings"]

#: The registry methods of the 3-D demo, in the order of its tables.
METHODS_3D = ("sm", "sm-linear", "sm-parallel", "nn", "arx", "rls")
NARX_INPUTS = ("motor_position_1", "motor_position_2", "motor_position_3")
OUTPUTS = ("tilt_x", "tilt_y")
#: Records scored: the validation record and the three closed-loop tests.
TESTS_3D = (
    "validation",
    "test 1: circle at 15°",
    "test 2: orientation steps at 15°",
    "test 3: 20° step at 45°",
)


@dataclass(frozen=True)
class Demo3DSettings:
    """Everything that shapes the 3-D demo's numbers (written into its report).

    Attributes
    ----------
    seed : int
        Seeds the neck's noise, the multisine phases and the networks.
    quick : bool
        Shorter records, one chirp direction, a smaller lag grid and quick networks (tests).
    ts : float
        Sampling period [s].
    train_duration, validation_duration, test_duration : float
        Record lengths [s].
    chirp_duration : float
        Length of each bandwidth chirp [s].
    directions : tuple of float
        Orientations [deg] of the bandwidth chirps (0°: towards tendon 1; 60°: between tendons 1
        and 2; 90°: no tendon in line).
    pretension : float
        ``q_0`` [rad]: every motor's mean position, winding the three tendons taut.
    amplitude : float
        ``A`` [rad]: peak motor deviation per unit of the desired bending direction.
    band_low : float
        Lowest excited frequency [rad/s]; the highest is the smallest measured bandwidth.
    orientation_min_inclination : float
        Orientation errors are scored where the measured inclination is at least this [deg]
        (below it the direction is noise).
    """

    seed: int = 0
    quick: bool = False
    ts: float = 0.02
    train_duration: float = 120.0
    validation_duration: float = 60.0
    test_duration: float = 20.0
    chirp_duration: float = 60.0
    directions: tuple[float, ...] = (0.0, 60.0, 90.0)
    pretension: float = 1.5
    amplitude: float = 2.5
    band_low: float = 0.05
    orientation_min_inclination: float = 3.0

    @classmethod
    def make(cls, *, quick: bool = False, seed: int = 0) -> Demo3DSettings:
        """Default settings, or the shorter ``quick`` ones."""
        if quick:
            return cls(
                seed=seed,
                quick=True,
                train_duration=60.0,
                validation_duration=30.0,
                test_duration=12.0,
                chirp_duration=50.0,
                directions=(0.0,),
            )
        return cls(seed=seed)
