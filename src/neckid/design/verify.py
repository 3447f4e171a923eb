r"""How a designed controller is checked: margins on models, the simulated neck, models in the loop, SM bands.

- :func:`margins_on_models`: the margins of the controller on each model's linear form (the one
  it was designed on meets the spec by construction; the others say how robust it is);
- :func:`simulated_neck_tests`: the paper's closed-loop tests 1–3 on the simulated neck
  (:class:`~neckid.plant.SoftNeck`, :func:`~neckid.plant.closed_loop`), the tracking error
  RMS :math:`\sqrt{\overline{(r - y)^2}}` [deg] of each controller (the demo's PI beside);
- :func:`models_in_the_loop`: each identified model in place of the neck behind the controller
  (:func:`~neckid.loops.model_in_loop.model_in_the_loop`): the tracking error the model
  predicts, and its fit to the neck's loop;
- :func:`set_membership_check`: the Set Membership model in the loop through its central
  estimate, its lower and its upper bounding function, and a per-step adversary that takes,
  at each step, whichever bound is farther from the reference. Each bounding function
  :math:`\underline f`, :math:`\overline f` belongs to the feasible set (it is Lipschitz with
  :math:`\gamma` and consistent with the data within :math:`\varepsilon`; Milanese & Novara,
  *Automatica* 40, 2004), so a loop with it is a loop with a plant the SM model cannot rule
  out. The adversary is an outer estimate of the worst case: a different feasible function at
  each step, more than any one function can do.

The references of tests 1–3 are those of :mod:`neckid.experiments.paper` (20 s at 0.02 s):
a 5° sine at 2 rad/s around 15°, a 5° staircase every 3 s from 1 s up to 30°, a 20° step at 1 s.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData
from neckid.design.controllers import DesignedController
from neckid.design.linear_form import LinearForm
from neckid.design.loop_shaping import closed_loop_stable, loop_margins
from neckid.models.base import NarxSimulator
from neckid.signals import sine, staircase, step
from neckid.systems import Controller
from neckid.utils.types import FloatArray

__all__ = [
    "PAPER_TESTS",
    "NeckTests",
    "margins_on_models",
    "models_in_the_loop",
    "paper_test_references",
    "set_membership_check",
    "simulated_neck_tests",
    "tracking_rms",
]

#: The paper's closed-loop tests (the names of :data:`neckid.experiments.paper.EXPERIMENTS`).
PAPER_TESTS = ("test 1: sine 2 rad/s", "test 2: 5° staircase", "test 3: 20° step")


def paper_test_references(ts: float = 0.02, duration: float = 20.0) -> dict[str, FloatArray]:
    """The references of the paper's tests 1–3 [deg], as the demo runs them.

    Parameters
    ----------
    ts : float, default 0.02
        Period, s.
    duration : float, default 20
        Length, s.

    Returns
    -------
    dict of str to ndarray, shape (n,)

    Examples
    --------
    >>> refs = paper_test_references()
    >>> [float(r.max()) for r in refs.values()]
    [20.0, 30.0, 20.0]
    """
    t = np.arange(round(duration / ts)) * ts
    return {
        PAPER_TESTS[0]: sine(t, amplitude=5.0, omega=2.0, offset=15.0),
        PAPER_TESTS[1]: staircase(t, step=5.0, step_duration=3.0, start_time=1.0, maximum=30.0),
        PAPER_TESTS[2]: step(t, amplitude=20.0, step_time=1.0),
    }


def tracking_rms(log: IOData, reference: ArrayLike | None = None) -> float:
    """RMS of ``reference − inclination`` [deg] over a closed-loop log.

    Parameters
    ----------
    log : IOData
        From :func:`~neckid.plant.closed_loop` (its ``reference`` input and first output).
    reference : array_like, optional
        Default the log's ``reference`` channel.

    Returns
    -------
    float
    """
    r = log.channel("reference") if reference is None else np.asarray(reference, dtype=float)
    return float(np.sqrt(np.mean((r - log.y[:, 0]) ** 2)))


def margins_on_models(
    controller: DesignedController,
    forms: Mapping[str, LinearForm],
    inclination: float | None = None,
) -> pd.DataFrame:
    """The controller's margins on each linear form.

    Parameters
    ----------
    controller : DesignedController
    forms : mapping of str to LinearForm
        Model name -> its linear form (:func:`~neckid.design.linear_form.linear_form`).
    inclination : float, optional
        Where a scheduled controller takes its gains [deg].

    Returns
    -------
    pandas.DataFrame
        Index the model names; columns ``phase_margin_deg``, ``crossover_rad_s``,
        ``gain_margin``, ``phase_slope_deg_per_rad_s``, ``sensitivity_peak``,
        ``closed_loop_stable``.
    """
    kp, kf = controller.gains(0.0 if inclination is None else float(inclination))
    rows = {}
    for name, form in forms.items():
        margins = loop_margins(form, lambda w: kp + kf * controller.operator.response(w))
        row = margins.to_dict()
        row["closed_loop_stable"] = closed_loop_stable(form, kp, kf, controller.operator)
        rows[name] = row
    return pd.DataFrame.from_dict(rows, orient="index")


@dataclass(frozen=True)
class NeckTests:
    """Tests 1–3 on the simulated neck.

    Attributes
    ----------
    table : pandas.DataFrame
        Tracking error RMS [deg]: one row per controller, one column per test.
    logs : dict
        ``logs[controller][test]``: the :func:`~neckid.plant.closed_loop` log.
    """

    table: pd.DataFrame
    logs: dict[str, dict[str, IOData]]


def simulated_neck_tests(
    controllers: Mapping[str, Controller],
    *,
    ts: float = 0.02,
    seed: int = 7,
    duration: float = 20.0,
    parameters: Any = None,
) -> NeckTests:
    """Each controller on the simulated neck through the paper's tests 1–3.

    Parameters
    ----------
    controllers : mapping of str to Controller
        E.g. ``{"demo PI": InclinationController(ts=0.02), "designed": controller}``.
    ts : float, default 0.02
        Period, s (the controllers' too).
    seed : int, default 7
        The neck's sensor-noise seed (the same for every run).
    duration : float, default 20
        Length of each test, s.
    parameters : SoftNeckParameters, optional
        The neck (default the calibrated one).

    Returns
    -------
    NeckTests
    """
    from neckid.plant import SoftNeck, closed_loop

    references = paper_test_references(ts, duration)
    table = pd.DataFrame(index=list(controllers), columns=list(references), dtype=float)
    logs: dict[str, dict[str, IOData]] = {name: {} for name in controllers}
    for name, controller in controllers.items():
        for test, reference in references.items():
            neck = SoftNeck(parameters, ts=ts, seed=seed)
            log = closed_loop(neck, controller, reference, ts)
            logs[name][test] = log
            table.loc[name, test] = tracking_rms(log, reference)
    return NeckTests(table, logs)


def models_in_the_loop(
    controller: Controller, models: Mapping[str, Any], records: Mapping[str, IOData]
) -> pd.DataFrame:
    """Each model in place of the neck behind the controller, on each record's reference.

    Parameters
    ----------
    controller : Controller
        The controller of the records.
    models : mapping of str to fitted model
        Any neckid models (a model of the motor position gets it from the simulated neck's
        drive, :class:`~neckid.loops.model_in_loop.VelocityDrive`).
    records : mapping of str to IOData
        The neck's closed-loop logs with this controller (``simulated_neck_tests(...).logs``).

    Returns
    -------
    pandas.DataFrame
        Index ``(model, test)``; columns ``tracking_rms_deg`` (what the model predicts),
        ``neck_tracking_rms_deg`` (what the neck did), ``output_fit`` and ``command_fit`` [%]
        against the neck's loop.
    """
    from neckid.loops.model_in_loop import model_in_the_loop

    rows = {}
    for name, model in models.items():
        for test, record in records.items():
            comparison = model_in_the_loop(model, controller, record)
            scores = comparison.scores()
            rows[(name, test)] = {
                "tracking_rms_deg": tracking_rms(comparison.loop, record.channel("reference")),
                "neck_tracking_rms_deg": tracking_rms(record),
                "output_fit": scores["output_fit"],
                "command_fit": scores["command_fit"],
            }
    return pd.DataFrame.from_dict(rows, orient="index")


class _BoundSimulator(NarxSimulator):
    """The SM model stepped through one bounding function, or a per-step adversary."""

    def __init__(self, model: Any, side: str, reference: FloatArray | None) -> None:
        self._model = model
        self._side = side
        self._reference = reference
        self._k = 0
        super().__init__(model.lags_, self._rows)

    def reset(self, y0: ArrayLike | None = None, u0: ArrayLike | None = None) -> None:
        """Start again (and the adversary at the reference's first sample)."""
        super().reset(y0, u0)
        self._k = 0

    def _rows(self, x: FloatArray) -> FloatArray:
        bounds = self._model.bounds(x)
        if self._side == "lower":
            return np.asarray(bounds.lower)
        if self._side == "upper":
            return np.asarray(bounds.upper)
        if self._side == "central":
            return np.asarray(bounds.central)
        reference = self._reference if self._reference is not None else np.zeros(1)
        r = reference[min(self._k, reference.shape[0] - 1)]
        self._k += 1
        low, high = np.asarray(bounds.lower), np.asarray(bounds.upper)
        return np.where(np.abs(r - low) >= np.abs(r - high), low, high)


class _BoundView:
    """A fitted SM model whose ``simulator()`` steps one bounding function (for ModelPlant)."""

    def __init__(self, model: Any, side: str, reference: FloatArray | None = None) -> None:
        self._model = model
        self._side = side
        self._reference = reference
        for name in ("input_names_", "output_names_", "output_units_", "ts_", "max_lag_", "lags_"):
            setattr(self, name, getattr(model, name))

    def __sklearn_is_fitted__(self) -> bool:
        return True

    def simulator(self) -> _BoundSimulator:
        return _BoundSimulator(self._model, self._side, self._reference)


def set_membership_check(
    controller: Controller,
    model: Any,
    reference: ArrayLike,
    *,
    ts: float | None = None,
    clip_to_data: bool = True,
) -> pd.DataFrame:
    """The controller with the SM model's central estimate, bounding functions and adversary.

    The loop starts at rest at the reference's first value: the model's history there and the
    drive at the motor position that holds the central estimate there
    (:func:`~neckid.design.linearise.equilibrium`).

    Parameters
    ----------
    controller : Controller
    model : SetMembership
        Fitted (anything with ``bounds(regressors)`` and ``lags_``: the NARX SM models).
    reference : array_like, shape (n,)
        Inclination reference [deg].
    ts : float, optional
        Default the model's.
    clip_to_data : bool, default True
        Clip the reference to the model's training range of the inclination, less 10 % of its
        width at each end: the bounds
        guarantee nothing useful outside the data (they widen with the distance to it), so a
        reference that leaves it tests the prior, not the controller.

    Returns
    -------
    pandas.DataFrame
        Index ``central``, ``lower``, ``upper``, ``adversary``; columns ``tracking_rms_deg``,
        ``max_error_deg``, ``finite`` (the loop stayed finite) and ``inside_data`` (the share
        of samples whose inclination stays inside the model's training range: outside it the
        bounds grow with the distance to the data and guarantee little).

    Raises
    ------
    TypeError
        If the model has no ``bounds``.
    """
    from neckid.loops.model_in_loop import ModelPlant, VelocityDrive
    from neckid.plant import closed_loop

    if not callable(getattr(model, "bounds", None)):
        raise TypeError(
            f"a Set Membership model is needed (with bounds); got {type(model).__name__}"
        )
    from neckid.design.linearise import POSITION_CHANNELS, equilibrium

    ranges = model.training_box()
    low, high = ranges.get(model.output_names_[0], (-np.inf, np.inf))
    r = np.asarray(reference, dtype=np.float64).reshape(-1)
    if clip_to_data:
        inset = 0.1 * (
            high - low
        )  # an equilibrium exists a little inside the data, not at its edge
        r = np.clip(r, low + inset, high - inset)
    period = float(model.ts_) if ts is None else float(ts)
    start = float(r[0])
    rest = equilibrium(model, start)
    positions = [v for n, v in zip(model.input_names_, rest, strict=True) if n in POSITION_CHANNELS]
    rows = {}
    for side in ("central", "lower", "upper", "adversary"):
        view = _BoundView(model, side, r if side == "adversary" else None)
        drive = VelocityDrive.from_parameters(ts=period)
        plant = ModelPlant(view, drive, y0=start, position0=positions[:1] or None)
        try:
            with np.errstate(all="ignore"):
                log = closed_loop(plant, controller, r, period)
            error = r - log.y[:, 0]
        except (ValueError, FloatingPointError):  # the loop left the finite numbers
            error = np.full(r.shape, np.inf)
        finite = bool(np.all(np.isfinite(error)))
        y = r - error
        rows[side] = {
            "inside_data": float(np.mean((y >= low) & (y <= high))),
            "tracking_rms_deg": float(np.sqrt(np.mean(error**2))) if finite else math.inf,
            "max_error_deg": float(np.max(np.abs(error))) if finite else math.inf,
            "finite": finite,
        }
    return pd.DataFrame.from_dict(rows, orient="index")
