"""neckid: identify dynamic models of a tendon-driven soft robotic neck from input/output logs."""

from neckid._version import __version__
from neckid.data import IOData, as_experiments
from neckid.regressors import Lags

__all__ = ["IOData", "Lags", "__version__", "as_experiments"]
