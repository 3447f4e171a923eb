r"""The predictive controller's file: a controller file of ``kind`` ``"mpc"``.

The same JSON object as the PI's (``format`` ``"neckid-controller"``, ``version`` 1, written
atomically, read by :func:`neckid.design.load_controller`, ``neckid validate --in-loop
--controller FILE``, ``neckid info FILE``), with these keys:

================ =================================================================================
key              meaning
================ =================================================================================
kind             ``"mpc"``
law              the controller in words
ts               period [s]
problem          every field of :class:`~neckid.design.mpc.problem.MPCProblem`: ``a``, ``b``,
                 ``delay``, ``horizon``, ``control_horizon``, the weights, ``command_limit``
                 [rad/s], ``rate_limit`` [rad/s²], ``output_min`` / ``output_max`` [deg] (null:
                 none), ``tightening`` [deg], the slack's weights, ``disturbance_ratio`` and
                 ``disturbance_gain``, ``preview``, the prediction matrices ``free`` (rows of
                 :math:`F`), ``forced`` (:math:`\Phi`) and ``disturbance`` (:math:`g`), ``source``
solver           ``name`` (``"osqp"``), its tolerances, ``deadline`` [s], ``on_late``
model            the model designed on (path, sha256, class, channels)
robust           null, or the Set Membership model and its tightening (horizons, half-widths,
                 coverage on the design logs)
design           anything else the design recorded
================ =================================================================================

:func:`load_mpc` recomputes the prediction matrices from ``a``, ``b`` and the horizons and
refuses a file whose stored matrices differ (relative 1e-9): an edited coefficient without its
matrices, or the reverse. No code is read from the file.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from neckid.design.mpc.controller import SOLVER_SETTINGS, MPCController
from neckid.design.mpc.problem import MPCProblem, disturbance_gain, prediction_matrices

__all__ = ["load_mpc", "mpc_document", "save_mpc"]

_LAW = (
    "u_k = first move of argmin_U sum_j w_e (r_{k+j} - yhat_{k+j})^2 + w_u (du)^2 subject to"
    " |u| <= command_limit, |du| <= rate_limit ts, output limits tightened by w_j;"
    " yhat = F h_k + Phi U + g delta, h_k = past inclinations [deg] and commands [rad/s]"
)

_NUMBERS = (
    "tracking_weight",
    "move_weight",
    "command_limit",
    "rate_limit",
    "slack_weight",
    "slack_linear_weight",
    "disturbance_ratio",
)

#: Numbers of the problem that may be 0 (the others must be positive).
_MAY_BE_ZERO = ("move_weight", "slack_linear_weight")


def _limit(value: float) -> float | None:
    return None if math.isinf(value) else float(value)


def mpc_document(controller: MPCController) -> dict[str, Any]:
    """The JSON object of an MPC controller file (module docstring).

    Parameters
    ----------
    controller : MPCController

    Returns
    -------
    dict
    """
    pr = controller.problem
    info = dict(pr.info)
    problem = {
        "a": pr.a.tolist(),
        "b": pr.b.tolist(),
        "delay": pr.delay,
        "horizon": pr.horizon,
        "control_horizon": pr.control_horizon,
        **{name: float(getattr(pr, name)) for name in _NUMBERS},
        "output_min": _limit(pr.output_min),
        "output_max": _limit(pr.output_max),
        "tightening": pr.tightening.tolist(),
        "disturbance_gain": pr.disturbance_gain,
        "preview": pr.preview,
        "free": pr.free.tolist(),
        "forced": pr.forced.tolist(),
        "disturbance": pr.disturbance.tolist(),
        "source": pr.source,
    }
    return {
        "format": "neckid-controller",
        "version": 1,
        "kind": "mpc",
        "law": _LAW,
        "ts": pr.ts,
        "problem": problem,
        "solver": {
            "name": "osqp",
            **SOLVER_SETTINGS,
            "deadline": controller.deadline,
            "on_late": controller.on_late,
        },
        "model": info.pop("model", None),
        "robust": info.pop("robust", None),
        "design": info,
    }


def save_mpc(controller: MPCController, path: str | Path) -> Path:
    """Write an MPC controller file (atomically).

    Parameters
    ----------
    controller : MPCController
    path : str or Path
        Ends in ``.json``.

    Returns
    -------
    Path
    """
    from neckid.utils.files import write_json

    if not isinstance(controller, MPCController):
        raise TypeError(f"controller must be an MPCController; got {type(controller).__name__}")
    target = Path(path)
    if target.suffix.lower() != ".json":
        raise ValueError(
            f"a controller file is JSON: its name must end in .json; got {str(target)!r}"
        )
    write_json(target, mpc_document(controller))
    return target


def _array(table: dict[str, Any], key: str, path: Path, ndim: int) -> np.ndarray:
    try:
        values = np.asarray(table[key], dtype=np.float64)
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{path}: problem.{key} is missing or not numbers") from None
    if values.ndim != ndim or not np.all(np.isfinite(values)):
        raise ValueError(f"{path}: problem.{key} must be a {ndim}-D array of finite numbers")
    return values


def _number(table: dict[str, Any], key: str, path: Path, default: float | None = None) -> float:
    value = table.get(key, default)
    if value is None and default is not None:
        value = default
    if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
        raise ValueError(f"{path}: problem.{key} must be a number; got {value!r}")
    return float(value)


def _count(table: dict[str, Any], key: str, path: Path) -> int:
    value = table.get(key)
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(f"{path}: problem.{key} must be a whole number >= 0; got {value!r}")
    return value


def _checked(stored: np.ndarray, computed: np.ndarray, key: str, path: Path) -> None:
    if stored.shape != computed.shape or not np.allclose(stored, computed, rtol=1e-9, atol=1e-12):
        raise ValueError(
            f"{path}: problem.{key} is not the prediction matrix of the file's a, b, delay and"
            " horizons; the file was edited inconsistently"
        )


def load_mpc(document: dict[str, Any], path: str | Path) -> MPCController:
    """The controller of an MPC controller file's JSON object (already read and format-checked).

    Parameters
    ----------
    document : dict
        The file's object (``kind`` ``"mpc"``).
    path : str or Path
        The file, for the messages.

    Returns
    -------
    MPCController

    Raises
    ------
    ValueError
        A key missing or of the wrong type, matrices that do not match the coefficients.
    """
    file = Path(path)
    table = document.get("problem")
    if not isinstance(table, dict):
        raise ValueError(f"{file}: an mpc controller file needs its 'problem' object")
    a, b = _array(table, "a", file, 1), _array(table, "b", file, 1)
    delay, horizon = _count(table, "delay", file), _count(table, "horizon", file)
    control_horizon = _count(table, "control_horizon", file)
    if not 1 <= control_horizon <= horizon:
        raise ValueError(f"{file}: problem.control_horizon must be 1 to horizon ({horizon})")
    free, forced, disturbance = prediction_matrices(a, b, delay, horizon, control_horizon)
    for key, computed in (("free", free), ("forced", forced), ("disturbance", disturbance)):
        _checked(_array(table, key, file, computed.ndim), computed, key, file)
    tightening = _array(table, "tightening", file, 1)
    if tightening.shape != (horizon,) or np.any(tightening < 0):
        raise ValueError(f"{file}: problem.tightening must be {horizon} values >= 0 [deg]")
    numbers = {name: _number(table, name, file) for name in _NUMBERS}
    for name, value in numbers.items():
        if value < 0 or (value == 0 and name not in _MAY_BE_ZERO):
            rule = ">= 0" if name in _MAY_BE_ZERO else "> 0"
            raise ValueError(f"{file}: problem.{name} must be {rule}; got {value!r}")
    low = _number(table, "output_min", file, -math.inf)
    high = _number(table, "output_max", file, math.inf)
    if not low < high:
        raise ValueError(f"{file}: problem.output_min ({low}) must be below output_max ({high})")
    stored_gain = _number(table, "disturbance_gain", file)
    gain = disturbance_gain(numbers["disturbance_ratio"])
    if not math.isclose(stored_gain, gain, rel_tol=1e-9):
        raise ValueError(
            f"{file}: problem.disturbance_gain {stored_gain!r} is not the Kalman gain of"
            f" disturbance_ratio {numbers['disturbance_ratio']!r} ({gain:.10g})"
        )
    ts = document.get("ts")
    if isinstance(ts, bool) or not isinstance(ts, int | float) or not ts > 0:
        raise ValueError(f"{file}: ts must be a positive number of seconds; got {ts!r}")
    info = {k: document[k] for k in ("model", "robust") if document.get(k) is not None}
    info.update(document.get("design") or {})
    problem = MPCProblem(
        ts=float(ts),
        a=a,
        b=b,
        delay=delay,
        horizon=horizon,
        control_horizon=control_horizon,
        **numbers,
        output_min=low,
        output_max=high,
        tightening=tightening,
        disturbance_gain=gain,
        preview=bool(table.get("preview", False)),
        free=free,
        forced=forced,
        disturbance=disturbance,
        source=str(table.get("source", "")),
        info=info,
    )
    solver = document.get("solver") or {}
    deadline = solver.get("deadline")
    if deadline is not None and (
        isinstance(deadline, bool) or not isinstance(deadline, int | float) or not deadline > 0
    ):
        raise ValueError(
            f"{file}: solver.deadline must be a positive number of s; got {deadline!r}"
        )
    on_late = solver.get("on_late", "hold")
    if on_late not in ("hold", "use"):
        raise ValueError(f"{file}: solver.on_late must be 'hold' or 'use'; got {on_late!r}")
    return MPCController(
        problem, deadline=None if deadline is None else float(deadline), on_late=on_late
    )
