"""neckid: identify dynamic models of a tendon-driven soft robotic neck from input/output logs."""

from neckid._version import __version__
from neckid.data import IOData, as_experiments
from neckid.models.arx import LinearARX
from neckid.models.base import ModelResult, NotFittedError
from neckid.models.io import load_model
from neckid.regressors import Lags

__all__ = [
    "IOData",
    "Lags",
    "LinearARX",
    "ModelResult",
    "NotFittedError",
    "__version__",
    "as_experiments",
    "load_model",
]
