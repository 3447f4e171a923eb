r"""What a log's loop must agree with before a model runs in it: controller, period, parameter log.

:func:`~neckid.loops.lab_loop.in_loop_on_log` runs a controller on a log's reference. Every
in-loop figure compares the model's loop with the *logged* one, so the controller must be the
one that made the log. Three checks, each refusing with a ``ValueError`` that names the log and
the controller:

- **the controller check** (:func:`controller_check`): the controller is fed the logged raw
  inclination row by row and its commands are compared with the logged ones. A right controller
  reproduces them to the logs' print precision: measured on the 21 closed-loop logs of the shared
  set (``check_shared_logs``), at most 5.0e-6 rad/s for the PI and the fixed fractional controller
  and 7.3e-6 rad/s for the adaptive runs replayed from their parameter logs. A wrong one is off by
  0.57–4.3 rad/s (the adaptive replay on a fra log 1.19 rad/s, the fra controller on an int log
  3.7 rad/s, another payload's parameter log 0.57–0.76 rad/s, the re-implemented tuner on an ada
  log 0.78–1.03 rad/s). :data:`CONTROLLER_CHECK_TOLERANCE` = 1e-4 rad/s sits 14 times above the
  worst right controller and 5,700 times below the closest wrong one. An adaptive replay's first
  stair row is left out of the check and reported apart: its command depends on starting gains
  that no log holds (CONTROLLERS.md gives them to five digits; 1.2–1.7e-4 rad/s there).
- **the period** (:func:`check_period`): a controller designed at another sampling period than
  the log's would run its law at the wrong rate;
- **the parameter log** (:func:`check_parameter_log`): an adaptive parameter log replays the
  adaptive controller; it is refused for a log another controller made (by the log's name), and
  a parameter file of another payload than the log's.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from neckid.loops.controllers.adaptive import AdaptiveFractionalReplay
from neckid.systems import Controller
from neckid.utils.types import BoolArray, FloatArray

__all__ = [
    "CONTROLLER_CHECK_TOLERANCE",
    "ControllerMismatchError",
    "check_parameter_log",
    "check_period",
    "controller_check",
    "replay_commands",
]

#: Largest |replayed − logged| command [rad/s] of a controller that made the log (see the module).
CONTROLLER_CHECK_TOLERANCE = 1e-4

#: What a log's name says about the controller that made it.
_MADE_BY = {
    "int": "the PI (int)",
    "fra": "the fixed fractional controller (fra)",
    "ada": "the adaptive controller (ada)",
}


class ControllerMismatchError(ValueError):
    """A controller that does not reproduce the log's commands (the controller check failed).

    Attributes
    ----------
    log, controller : str
        The log's and the controller's names.
    check, tolerance : float
        The largest ``|replayed − logged|`` command and the tolerance, rad/s.
    """

    def __init__(self, log: str, controller: str, check: float, tolerance: float) -> None:
        self.log, self.controller = log, controller
        self.check, self.tolerance = check, tolerance
        super().__init__(
            f"{log}: the controller {controller} does not reproduce the log's commands: the"
            f" controller check (its commands fed the logged inclination, against the logged"
            f" ones) is {check:.3g} rad/s, beyond the tolerance {tolerance:.0e} rad/s (the"
            " controller that made a log reproduces it to about 5e-6 rad/s); every in-loop"
            " figure would compare two different loops"
        )


def replay_commands(
    controller: Controller, reference: FloatArray, inclination: FloatArray, failed: BoolArray
) -> FloatArray:
    """The controller's command of every row fed the logged inclination (held on failed reads).

    Parameters
    ----------
    controller : Controller
        Reset first (pass a copy to keep the original's state).
    reference : ndarray, shape (n,)
        Reference plus dither of every row [deg].
    inclination : ndarray, shape (n,)
        The logged raw inclination [deg].
    failed : ndarray of bool, shape (n,)
        Failed sensor reads (fed as NaN: the controller holds its command).

    Returns
    -------
    ndarray, shape (n,)
        Velocity command [rad/s].
    """
    controller.reset()
    measured = np.where(failed, math.nan, inclination)
    return np.array(
        [
            float(np.asarray(controller.step(r, y)).reshape(-1)[0])
            for r, y in zip(reference, measured, strict=True)
        ]
    )


def controller_check(
    controller: Controller,
    reference: FloatArray,
    inclination: FloatArray,
    command: FloatArray,
    failed: BoolArray,
) -> tuple[float, float]:
    """The controller check: the largest ``|replayed − logged|`` command, and the unlogged row's.

    Parameters
    ----------
    controller : Controller
        Not changed (a copy is replayed).
    reference, inclination, command : ndarray, shape (n,)
        Reference plus dither [deg], logged raw inclination [deg], logged command [rad/s].
    failed : ndarray of bool, shape (n,)
        Failed sensor reads.

    Returns
    -------
    check : float
        Over every row but an adaptive replay's first stair row [rad/s].
    first_stair_row : float
        That row's difference (NaN for other controllers) [rad/s].
    """
    import copy

    replayed = replay_commands(copy.deepcopy(controller), reference, inclination, failed)
    difference = np.abs(replayed - np.asarray(command, dtype=np.float64))
    unlogged = math.nan
    if isinstance(controller, AdaptiveFractionalReplay) and controller.warmup_rows < len(
        difference
    ):
        unlogged = float(difference[controller.warmup_rows])
        difference = np.delete(difference, controller.warmup_rows)
    return (float(np.max(difference)) if difference.size else math.nan), unlogged


def check_period(controller: Any, label: str, ts: float, log: str) -> None:
    """Refuse a controller whose sampling period is not the log's.

    Raises
    ------
    ValueError
        Naming both periods.
    """
    period = getattr(controller, "ts", None)
    if period is None or math.isclose(float(period), ts, rel_tol=1e-6):
        return
    raise ValueError(
        f"{log}: the controller {label} runs every {float(period):g} s but the log is sampled"
        f" every {ts:g} s: a controller runs at the period it was designed at; design it again"
        " at the log's period"
    )


def _payload(name: str) -> str | None:
    digits = "".join(c for c in name if c.isdigit())
    return digits or None


def check_parameter_log(log: str, kind: str | None, parameters: str) -> None:
    """Refuse an adaptive parameter log for a log that it did not drive.

    Parameters
    ----------
    log : str
        The log's file name.
    kind : {"int", "fra", "ada"} or None
        The controller the log's name says made it.
    parameters : str
        The parameter log's (or its folder's) name.

    Raises
    ------
    ValueError
        If the log's name says another controller made it, or the parameter file's payload is
        not the log's.
    """
    base = Path(log).name
    if kind is not None and kind != "ada":
        raise ValueError(
            f"{base} was made by {_MADE_BY[kind]}, as its name says; the adaptive parameter"
            f" logs {parameters!r} replay the adaptive controller of the ada* runs: give"
            f" --controller {kind} (or none: the log's name chooses)"
        )
    if kind == "ada" and Path(parameters).suffix.lower() == ".csv":
        mine, theirs = _payload(base[3:6]), _payload(Path(parameters).name)
        if mine is not None and theirs is not None and mine != theirs:
            raise ValueError(
                f"{base} is the {mine} g adaptive run but the parameter log"
                f" {Path(parameters).name} is the {theirs} g one: give adacon{mine}.csv or"
                " the folder holding it"
            )
