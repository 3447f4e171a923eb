r"""The bench drive's smallest velocity: what the motor executes of a velocity command.

The soft-neck bench's drive (Maxon RE16 with a 24:1 gear on a CiA 402 velocity-mode controller)
executes any command with :math:`0 < |c| < 0.12783` rad/s as :math:`\pm 0.12783` rad/s, its
smallest velocity; it has no other saturation, and its acceleration limit is far above what the
logs reach.

References
----------
- ``shared/data/softneck/CONTROLLERS.md`` ("What every run shares"), from
  github.com/HUMASoft/CiA402Device.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.systems import Plant
from neckid.utils.types import FloatArray

__all__ = ["DRIVE_MIN_VELOCITY", "MinimumVelocityDrive", "executed_velocity"]

#: The drive's smallest velocity, rad/s at the gearbox output.
DRIVE_MIN_VELOCITY = 0.12783


def executed_velocity(command: ArrayLike, minimum: float = DRIVE_MIN_VELOCITY) -> FloatArray:
    r"""The velocity the drive runs for a command: :math:`\mathrm{sign}(c)\max(|c|, v_{min})`, 0 at 0.

    Parameters
    ----------
    command : array_like
        Velocity command(s) [rad/s].
    minimum : float, default 0.12783
        The smallest velocity [rad/s].

    Returns
    -------
    ndarray of float
        Same shape [rad/s].

    Examples
    --------
    >>> executed_velocity([0.0, 0.05, -0.1, 0.5]).tolist()
    [0.0, 0.12783, -0.12783, 0.5]
    """
    c = np.asarray(command, dtype=np.float64)
    return np.where((c != 0.0) & (np.abs(c) < minimum), np.sign(c) * minimum, c)


class MinimumVelocityDrive:
    """A plant whose commands pass through the drive's smallest velocity first.

    ``step(u)`` gives ``plant.step(executed_velocity(u))``; everything else (``reset``, ``ts``,
    ``output_names``, motor attributes) is the wrapped plant's. Use it in
    :func:`neckid.plant.closed_loop` around a model whose input is the executed velocity.

    Parameters
    ----------
    plant : Plant
        The wrapped plant (a model's ``simulator()``, the simulated neck, ...).
    minimum : float, default 0.12783
        The smallest velocity [rad/s].
    """

    def __init__(self, plant: Plant, minimum: float = DRIVE_MIN_VELOCITY) -> None:
        self.plant = plant
        self.minimum = float(minimum)

    def reset(self) -> object:
        """Reset the wrapped plant."""
        return self.plant.reset()

    def step(self, u: ArrayLike) -> ArrayLike:
        """Apply the executed velocity of ``u`` for one sample; return the plant's output."""
        return self.plant.step(executed_velocity(u, self.minimum))

    def __getattr__(self, name: str) -> Any:
        if name == "plant":  # not yet set (copying, unpickling)
            raise AttributeError(name)
        return getattr(self.plant, name)
