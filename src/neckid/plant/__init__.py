"""The simulated soft neck and the inclination controller used to run closed-loop experiments."""

from neckid.plant.control import InclinationController, closed_loop
from neckid.plant.soft_neck import SoftNeck, SoftNeckParameters

__all__ = ["InclinationController", "SoftNeck", "SoftNeckParameters", "closed_loop"]
