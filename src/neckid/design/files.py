r"""The controller file: a designed controller as JSON, and back.

A controller file is one JSON object (``format`` ``"neckid-controller"``, ``version`` 1):

============== ==================================================================================
key            meaning
============== ==================================================================================
kind           ``"pi"``, ``"fractional"``, ``"scheduled-pi"`` or ``"scheduled-fractional"``
law            the control law in words (error, command, units)
ts             period [s]
gains          ``kp`` [(rad/s)/deg] and ``kf`` (``ki`` for a PI [(rad/s)/(deg s)]; the gain of
               :math:`s^\\alpha` otherwise); with the ``"gl"`` discretisation also ``kd_lab``, the
               gain to give the lab's ``FPDBlock`` (its step-1 sum): :math:`k_f T^{-(1+\\alpha)}`
order          :math:`\\alpha` (−1 for the PI's integrator)
discretisation ``method`` (``"tustin"``, ``"gl"`` with ``threshold`` and ``taps``, ``"oustaloup"``
               with ``band`` [rad/s], ``sections`` and ``prewarp`` [rad/s])
command_limit  saturation [rad/s] with conditional integration, or null
schedule       null, or ``inclinations`` [deg] with ``kp`` and ``kf`` at each (interpolated in the
               measured inclination)
model          the model designed on: ``path``, ``sha256`` of the file, ``class``, ``inclination``
spec           ``phase_margin`` [deg], ``crossover`` [rad/s], ``flat_phase``
achieved       margins on the model: ``phase_margin_deg``, ``crossover_rad_s``, ``gain_margin``,
               ``phase_slope_deg_per_rad_s``, ``sensitivity_peak``, ``closed_loop_stable``
design         everything else the design recorded (the plant's transfer function, the order's
               rule, the designs of a schedule)
============== ==================================================================================

:func:`load_controller` rebuilds a :class:`~neckid.design.controllers.DesignedController` from
the gains, order and discretisation (the taps are recomputed and checked against the stored
ones): it runs in :func:`neckid.plant.closed_loop`, converts with
:meth:`~neckid.design.controllers.DesignedController.to_control` and
:func:`neckid.export.control.to_iosystem`. No code is ever loaded from the file.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from neckid.design.controllers import DesignedController, GainSchedule
from neckid.design.operators import (
    DiscreteOperator,
    grunwald_letnikov_operator,
    oustaloup_operator,
    tustin_integrator,
)
from neckid.utils.formats import not_this_kind

__all__ = [
    "FORMAT",
    "VERSION",
    "controller_document",
    "load_controller",
    "model_description",
    "save_controller",
]

FORMAT = "neckid-controller"
VERSION = 1

_LAW = (
    "u_k = kp e_k + kf v_k, v = D(z) e; e_k = reference_k - inclination_{k-1} [deg],"
    " u_k: velocity command [rad/s]"
)


def model_description(
    path: str | Path, model: Any, inclination: float | None = None
) -> dict[str, Any]:
    """What a controller file says about the model it was designed on.

    Parameters
    ----------
    path : str or Path
        The model file.
    model : fitted model
        Loaded from it.
    inclination : float, optional
        The operating point designed at [deg].

    Returns
    -------
    dict
        ``path``, ``sha256`` (of the file's bytes), ``class``, ``inputs``, ``outputs``, ``ts``,
        ``inclination``.
    """
    file = Path(path)
    return {
        "path": str(file),
        "sha256": hashlib.sha256(file.read_bytes()).hexdigest(),
        "class": type(model).__name__,
        "inputs": list(getattr(model, "input_names_", ())),
        "outputs": list(getattr(model, "output_names_", ())),
        "ts": float(getattr(model, "ts_", math.nan)),
        "inclination": inclination,
    }


def _discretisation(operator: DiscreteOperator) -> dict[str, Any]:
    return {"method": operator.method, **operator.parameters}


def controller_document(controller: DesignedController) -> dict[str, Any]:
    """The JSON object of a controller file (see the module docstring).

    Parameters
    ----------
    controller : DesignedController

    Returns
    -------
    dict
    """
    op = controller.operator
    gains: dict[str, Any] = {"kp": controller.kp, "kf": controller.kf}
    if op.method == "tustin":
        gains["ki"] = controller.kf
    if op.method == "gl":
        gains["kd_lab"] = controller.kf * op.ts ** (-(1.0 + op.order))
    schedule = None
    if controller.schedule is not None:
        schedule = {
            "variable": "measured inclination [deg]",
            "inclinations": controller.schedule.inclinations.tolist(),
            "kp": np.asarray(controller.schedule.kp).tolist(),
            "kf": np.asarray(controller.schedule.kf).tolist(),
        }
    info = dict(controller.info)
    return {
        "format": FORMAT,
        "version": VERSION,
        "kind": controller.kind,
        "law": _LAW,
        "ts": controller.ts,
        "gains": gains,
        "order": op.order,
        "discretisation": _discretisation(op),
        "command_limit": controller.command_limit,
        "schedule": schedule,
        "model": info.pop("model", None),
        "spec": info.pop("spec", None),
        "achieved": info.pop("achieved", None),
        "design": info,
    }


def save_controller(controller: DesignedController, path: str | Path) -> Path:
    """Write a controller file (atomically: a failed write leaves no half file).

    Parameters
    ----------
    controller : DesignedController
    path : str or Path
        Ends in ``.json``.

    Returns
    -------
    Path
    """
    from neckid.utils.files import write_json

    if type(controller).__name__ == "MPCController":  # neckid.design.mpc's, its own file keys
        from neckid.design.mpc.files import save_mpc

        return save_mpc(controller, path)  # type: ignore[arg-type]
    if not isinstance(controller, DesignedController):
        raise TypeError(f"controller must be a DesignedController; got {type(controller).__name__}")
    target = Path(path)
    if target.suffix.lower() != ".json":
        raise ValueError(
            f"a controller file is JSON: its name must end in .json; got {str(target)!r}"
        )
    write_json(target, controller_document(controller))
    return target


def _field(document: dict[str, Any], key: str, path: Path) -> Any:
    if key not in document:
        raise ValueError(
            f"{path}: the controller file has no {key!r} (is it a neckid controller file?)"
        )
    return document[key]


def _finite(value: Any, key: str, path: Path) -> float:
    """A number of the file that must be finite; the refusal names the file and the key."""
    number = value if isinstance(value, int | float) and not isinstance(value, bool) else None
    if number is None or not math.isfinite(number):
        raise ValueError(f"{path}: {key} must be a finite number; got {value!r}")
    return float(number)


#: Relative difference above which two keys that hold one gain twice disagree.
TWIN_TOLERANCE = 1e-9


def _gains(document: dict[str, Any], operator: DiscreteOperator, path: Path) -> tuple[float, float]:
    """``(kp, kf)`` of the file, every gain finite, and each gain written twice agreeing.

    A PI's integral gain is ``kf`` and ``ki``; a Grünwald–Letnikov controller's fractional gain
    is ``kf`` and ``kd_lab`` = ``kf`` T^-(1+α). One of a pair edited alone is refused (naming
    both keys): which of the two the user meant cannot be told.
    """
    gains = _field(document, "gains", path)
    if not (isinstance(gains, dict) and "kp" in gains and "kf" in gains):
        raise ValueError(f"{path}: 'gains' must hold 'kp' and 'kf'; got {gains!r}")
    values = {k: _finite(v, f"gains.{k}", path) for k, v in gains.items() if k in _GAIN_KEYS}
    kf = values["kf"]
    twins = {}
    if operator.method == "tustin" and "ki" in values:
        twins["ki"] = (values["ki"], kf, "the same gain as kf")
    if operator.method == "gl" and "kd_lab" in values:
        expected = kf * operator.ts ** (-(1.0 + operator.order))
        twins["kd_lab"] = (values["kd_lab"], expected, "kf T^-(1+order)")
    for key, (given, expected, rule) in twins.items():
        if not math.isclose(given, expected, rel_tol=TWIN_TOLERANCE, abs_tol=1e-300):
            raise ValueError(
                f"{path}: gains.{key} = {given!r} disagrees with gains.kf = {kf!r} ({key} is"
                f" {rule}, {expected:.10g}): the two keys hold one gain; edit both, or remove"
                f" gains.{key}"
            )
    return values["kp"], kf


#: The gains a controller file may hold.
_GAIN_KEYS = ("kp", "kf", "ki", "kd_lab")


def _operator(document: dict[str, Any], path: Path) -> DiscreteOperator:
    ts = _finite(_field(document, "ts", path), "ts", path)
    order = _finite(_field(document, "order", path), "order", path)
    spec = _field(document, "discretisation", path)
    method = spec.get("method") if isinstance(spec, dict) else None
    if method == "tustin":
        return tustin_integrator(ts)
    if method == "gl":
        operator = grunwald_letnikov_operator(order, ts, float(spec.get("threshold", 0.01)))
        stored = spec.get("taps")
        taps = operator.parameters["taps"]
        if stored is not None and (
            len(stored) != len(taps) or not np.allclose(stored, taps, rtol=1e-12)
        ):
            raise ValueError(
                f"{path}: the stored Grünwald–Letnikov taps are not those of order {order} and"
                f" threshold {spec.get('threshold', 0.01)}; the file was edited inconsistently"
            )
        return operator
    if method == "oustaloup":
        band = spec.get("band")
        if not (isinstance(band, list) and len(band) == 2):
            raise ValueError(f"{path}: discretisation 'oustaloup' needs band [low, high] in rad/s")
        return oustaloup_operator(
            order,
            ts,
            (float(band[0]), float(band[1])),
            int(spec.get("sections", 5)),
            spec.get("prewarp"),
        )
    raise ValueError(
        f"{path}: discretisation method must be 'tustin', 'gl' or 'oustaloup'; got {method!r}"
    )


def load_controller(path: str | Path) -> Any:
    """Load a controller file written by :func:`save_controller` (or ``neckid design``).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    DesignedController or MPCController
        A :class:`~neckid.design.controllers.DesignedController` whose ``info`` holds the file's
        ``model``, ``spec``, ``achieved`` and ``design``; for ``kind`` ``"mpc"`` a
        :class:`~neckid.design.mpc.MPCController` (:func:`neckid.design.mpc.files.load_mpc`).

    Raises
    ------
    ValueError
        If the file is not a neckid controller file of a known version, or is inconsistent (a
        key missing, taps that do not match the order, a bad schedule).
    OSError
        If it cannot be read.
    """
    file = Path(path)
    binary = not_this_kind(file, "a controller file (JSON, written by neckid design)")
    if binary is not None:
        raise ValueError(binary)
    try:
        document = json.loads(file.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{file}: not a JSON file ({exc.msg} at line {exc.lineno})") from None
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"{file} is not a controller file: not UTF-8 text (byte {exc.start}); a controller"
            " file is the JSON that neckid design writes"
        ) from None
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise ValueError(f"{file}: not a neckid controller file (its 'format' is not {FORMAT!r})")
    if document.get("version") != VERSION:
        raise ValueError(
            f"{file}: controller file version {document.get('version')!r}; this neckid reads"
            f" version {VERSION}"
        )
    if document.get("kind") == "mpc":  # a predictive controller (neckid.design.mpc.files)
        from neckid.design.mpc.files import load_mpc

        return load_mpc(document, file)
    operator = _operator(document, file)
    kp, kf = _gains(document, operator, file)
    limit = document.get("command_limit")
    if limit is not None:
        _finite(limit, "command_limit", file)
    schedule = None
    if document.get("schedule") is not None:
        table = document["schedule"]
        try:
            schedule = GainSchedule(
                np.asarray(table.get("inclinations"), dtype=np.float64),
                np.asarray(table.get("kp"), dtype=np.float64),
                np.asarray(table.get("kf"), dtype=np.float64),
            )
        except (ValueError, TypeError, AttributeError) as exc:
            raise ValueError(f"{file}: schedule: {exc}") from None
    info = {
        k: document.get(k) for k in ("model", "spec", "achieved") if document.get(k) is not None
    }
    info.update(document.get("design") or {})
    controller = DesignedController(
        kp,
        kf,
        operator,
        command_limit=document.get("command_limit"),
        schedule=schedule,
        info=info,
    )
    if controller.kind != document.get("kind"):
        raise ValueError(
            f"{file}: kind {document.get('kind')!r} does not match its discretisation and"
            f" schedule ({controller.kind!r})"
        )
    return controller
