"""neckid: identify dynamic models of a tendon-driven soft robotic neck from input/output logs.

The public API, re-exported here:

- data: :class:`IOData`, :func:`as_experiments`, :class:`Lags`
- models: :class:`SetMembership`, :func:`gamma_curve`, :class:`NeuralNARX`, :class:`LinearARX`,
  :class:`RecursiveARX`, :class:`GainScheduledModel`, :func:`load_model`, :class:`ModelResult`
- regressor choice: :func:`select_lags`, :func:`lag_grid`, :func:`lipschitz_quotients`
- the operating-point protocol: :func:`identify_operating_points`, :func:`operating_points_from_logs`
- modules: :mod:`neckid.signals`, :mod:`neckid.metrics`, :mod:`neckid.plant`, :mod:`neckid.datasets`
"""

from neckid import datasets, metrics, plant, signals
from neckid._version import __version__
from neckid.data import IOData, as_experiments
from neckid.experiments.operating_points import (
    OperatingPointResult,
    identify_operating_points,
    operating_points_from_logs,
)
from neckid.metrics import fit_percent, mae, rmse
from neckid.models.arx import LinearARX
from neckid.models.base import ModelResult, NotFittedError
from neckid.models.io import load_model
from neckid.models.neural import NeuralNARX
from neckid.models.rls import RecursiveARX
from neckid.models.scheduled import GainScheduledModel
from neckid.models.set_membership import SetMembership, gamma_curve
from neckid.regressors import Lags
from neckid.selection import LagSelection, lag_grid, lipschitz_quotients, select_lags

__all__ = [
    "GainScheduledModel",
    "IOData",
    "LagSelection",
    "Lags",
    "LinearARX",
    "ModelResult",
    "NeuralNARX",
    "NotFittedError",
    "OperatingPointResult",
    "RecursiveARX",
    "SetMembership",
    "__version__",
    "as_experiments",
    "datasets",
    "fit_percent",
    "gamma_curve",
    "identify_operating_points",
    "lag_grid",
    "lipschitz_quotients",
    "load_model",
    "mae",
    "metrics",
    "operating_points_from_logs",
    "plant",
    "rmse",
    "select_lags",
    "signals",
]
