"""neckid: identify dynamic models of a tendon-driven soft robotic neck from input/output logs.

The public API, re-exported here:

- data: :class:`IOData`, :func:`as_experiments`, :class:`Lags`
- the method registry: :func:`methods` (name -> :class:`Method`), :func:`get_method`
- models: :class:`SetMembership`, :class:`ParallelSetMembership`, :func:`gamma_curve`,
  :class:`NeuralNARX`, :class:`LinearARX`, :class:`LPVARX`, :class:`RecursiveARX`, :class:`GainScheduledModel`, :func:`load_model`, :class:`ModelResult`
- exports for other tools (MATLAB, JSON): :func:`export_model`, :func:`write_export`;
  python-control systems: :func:`to_control`, :func:`to_iosystem`
- controllers designed from models: :mod:`neckid.design`, :func:`load_controller`
- regressor choice: :func:`select_lags`, :func:`lag_grid`, :func:`lipschitz_quotients`
- which model, how far to trust it: :func:`compare` (safe selection on the training logs, one
  free run per test log), :func:`select_safely`
- the operating-point protocol: :func:`identify_operating_points`, :func:`operating_points_from_logs`
- modules: :mod:`neckid.signals`, :mod:`neckid.metrics`, :mod:`neckid.plant`, :mod:`neckid.datasets`

Notes
-----
The names are loaded lazily (PEP 562): ``import neckid`` loads none of the modules behind them, so
it does not pay for scikit-learn, pandas, SciPy's statistics or the numba kernels until a name
that needs them is first used. ``from neckid import X`` and ``neckid.X`` give the same objects as
importing ``X`` from its own module. Type checkers read the imports under ``TYPE_CHECKING``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from neckid._version import __version__
from neckid.utils import numba_cache as _numba_cache

# Before any kernel module imports numba: a read-only install caches its kernels in the user's
# cache folder (neckid.utils.numba_cache); a writable one, or NUMBA_CACHE_DIR, is left as it is.
_numba_cache.configure_numba_cache()

if TYPE_CHECKING:
    from neckid import datasets, design, metrics, plant, signals
    from neckid.data.iodata import IOData, as_experiments
    from neckid.design.files import load_controller
    from neckid.export import export_model, write_export
    from neckid.export.control import to_control, to_iosystem
    from neckid.loops.operating_points import (
        OperatingPointResult,
        identify_operating_points,
        operating_points_from_logs,
    )
    from neckid.metrics import fit_percent, mae, rmse
    from neckid.models.base import DivergenceError, ModelResult, NotFittedError
    from neckid.models.io import load_model
    from neckid.models.linear.arx import LinearARX
    from neckid.models.linear.rls import RecursiveARX
    from neckid.models.lpv.model import LPVARX
    from neckid.models.neural.narx import NeuralNARX
    from neckid.models.polynomial.narx import PolynomialNARX
    from neckid.models.scheduled.model import GainScheduledModel
    from neckid.models.set_membership.narx import SetMembership, gamma_curve
    from neckid.models.set_membership.parallel import ParallelSetMembership
    from neckid.registry import Method, get_method, methods
    from neckid.regressors import Lags
    from neckid.selection.comparison import Comparison, SafeSelection, compare, select_safely
    from neckid.selection.lags import LagSelection, lag_grid, lipschitz_quotients, select_lags

__all__ = [
    "LPVARX",
    "Comparison",
    "DivergenceError",
    "GainScheduledModel",
    "IOData",
    "LagSelection",
    "Lags",
    "LinearARX",
    "Method",
    "ModelResult",
    "NeuralNARX",
    "NotFittedError",
    "OperatingPointResult",
    "ParallelSetMembership",
    "PolynomialNARX",
    "RecursiveARX",
    "SafeSelection",
    "SetMembership",
    "__version__",
    "as_experiments",
    "compare",
    "datasets",
    "design",
    "export_model",
    "fit_percent",
    "gamma_curve",
    "get_method",
    "identify_operating_points",
    "lag_grid",
    "lipschitz_quotients",
    "load_controller",
    "load_model",
    "mae",
    "methods",
    "metrics",
    "operating_points_from_logs",
    "plant",
    "rmse",
    "select_lags",
    "select_safely",
    "signals",
    "to_control",
    "to_iosystem",
    "write_export",
]

# Public submodules, and the module each other public name lives in (the same imports as above).
_SUBMODULES = frozenset({"datasets", "design", "metrics", "plant", "signals"})
_NAME_TO_MODULE = {
    "Comparison": "neckid.selection.comparison",
    "SafeSelection": "neckid.selection.comparison",
    "compare": "neckid.selection.comparison",
    "select_safely": "neckid.selection.comparison",
    "IOData": "neckid.data.iodata",
    "as_experiments": "neckid.data.iodata",
    "load_controller": "neckid.design.files",
    "export_model": "neckid.export",
    "write_export": "neckid.export",
    "to_control": "neckid.export.control",
    "to_iosystem": "neckid.export.control",
    "OperatingPointResult": "neckid.loops.operating_points",
    "identify_operating_points": "neckid.loops.operating_points",
    "operating_points_from_logs": "neckid.loops.operating_points",
    "fit_percent": "neckid.metrics",
    "mae": "neckid.metrics",
    "rmse": "neckid.metrics",
    "LinearARX": "neckid.models.linear.arx",
    "DivergenceError": "neckid.models.base",
    "ModelResult": "neckid.models.base",
    "NotFittedError": "neckid.models.base",
    "load_model": "neckid.models.io",
    "NeuralNARX": "neckid.models.neural.narx",
    "PolynomialNARX": "neckid.models.polynomial.narx",
    "RecursiveARX": "neckid.models.linear.rls",
    "LPVARX": "neckid.models.lpv.model",
    "GainScheduledModel": "neckid.models.scheduled.model",
    "SetMembership": "neckid.models.set_membership.narx",
    "gamma_curve": "neckid.models.set_membership.narx",
    "ParallelSetMembership": "neckid.models.set_membership.parallel",
    "Lags": "neckid.regressors",
    "Method": "neckid.registry",
    "get_method": "neckid.registry",
    "methods": "neckid.registry",
    "LagSelection": "neckid.selection.lags",
    "lag_grid": "neckid.selection.lags",
    "lipschitz_quotients": "neckid.selection.lags",
    "select_lags": "neckid.selection.lags",
}


# Hidden from type checkers, which read the imports under TYPE_CHECKING instead: a visible module
# __getattr__ would make them accept any name, so `from neckid import Typo` would pass unchecked.
if not TYPE_CHECKING:

    def __getattr__(name: str) -> object:
        """Import a public name on first use and keep it in the module's namespace (PEP 562)."""
        if name in _SUBMODULES:
            return importlib.import_module(f"{__name__}.{name}")
        if name not in _NAME_TO_MODULE:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(_NAME_TO_MODULE[name]), name)
        globals()[name] = value
        return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
