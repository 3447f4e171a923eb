"""The simulated soft neck and the inclination controller used to run closed-loop experiments."""

from neckid.plant.control import InclinationController, closed_loop
from neckid.plant.soft_neck import SoftNeck, SoftNeckParameters
from neckid.systems import Controller, Plant

__all__ = [
    "Controller",
    "InclinationController",
    "Plant",
    "SoftNeck",
    "SoftNeckParameters",
    "closed_loop",
]
