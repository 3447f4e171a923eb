r"""An identified model in the loop of a real soft-neck log: the lab's controller, reference and drive.

A free run replays a log's *recorded* motor signals. :func:`in_loop_on_log` closes the lab's loop
on the model instead: the controller that recorded the log (the PI, the fractional controller,
the adaptive one; :func:`lab_controller`), the log's reference with its ``rand()`` dither
(:func:`~neckid.loops.controllers.reference_for_log`), the drive model between the command and
the motor (:class:`~neckid.loops.lab_drive.LabDrive`, identified from training logs), and the
model in place of the neck. It reports the free-run fit beside the in-loop inclination and command
fits and what a control engineer reads (:class:`~neckid.loops.lab_loop_result.LabLoopResult`).

The loop runs in the bench's order (CONTROLLERS.md): in row :math:`k` the sensor gives the
inclination :math:`i_k`, the controller computes :math:`c_k` from
:math:`r_k + d_k - i_k`, and the drive executes :math:`c_k` over the sample. So the model's
inclination of row :math:`k` is computed first, from the drive's motor position and measured
velocity of row :math:`k` (both made by the commands of rows before :math:`k`), then the command.
This is not :func:`neckid.plant.closed_loop`'s order, which computes :math:`c_k` from
:math:`i_{k-1}` (one more sample of delay, 3.5 deg of phase at the PI loop's 2.6 s period).

The model's inputs are fed by name (:func:`loop_inputs`): ``velocity_command`` the controller's
command of the row (a model whose inclination reads the command of the same row would make an
algebraic loop, and is refused), ``motor_position`` the drive's position, ``motor_displacement``
the drive's position minus the log's first one (the benchmark's input), ``motor_velocity`` the
drive's measured velocity, and the log's conditions (payload) their constant values. A model that
carries preprocessing (``preprocessing_``) gets the same offsets as on the log (a
:class:`~neckid.data.preprocess.Relative` motor position is the displacement from the log's first
sample); a step that is more than an offset (a filter, a resampling) cannot be replayed on a
streamed signal and is refused.

The first ``max_lag_`` rows are the log's (outputs, commands and inputs: the model's initial
conditions, as in its free run), the loop closes from there, and every fit skips them. The log's
failed sensor reads are replayed: on those rows the controller holds its command.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from neckid.data.iodata import IOData
from neckid.datasets.softneck import load_softneck_log
from neckid.loops.controllers.adaptive import AdaptiveParameters, load_adaptive_parameters
from neckid.loops.controllers.reconstruct import controller_for_log, failed_reads
from neckid.loops.controllers.references import LabReference, reference_for_log
from neckid.loops.controllers.tuned import AdaptiveFractionalTuner
from neckid.loops.lab_drive import LabDrive
from neckid.loops.lab_loop_result import LabLoopResult, loop_figures
from neckid.loops.loop_checks import (
    CONTROLLER_CHECK_TOLERANCE,
    ControllerMismatchError,
    check_parameter_log,
    check_period,
    controller_check,
)
from neckid.metrics import fit_percent
from neckid.models.base import check_is_fitted
from neckid.selection.lags import free_run
from neckid.systems import Controller
from neckid.utils.types import BoolArray, FloatArray

__all__ = [
    "LoopInput",
    "in_loop_on_log",
    "lab_controller",
    "loop_inputs",
    "model_view",
    "run_lab_loop",
]

#: The controllers a log's name can name.
CONTROLLER_KINDS = ("int", "fra", "ada")
#: A loop whose inclination leaves ±this [deg] has run away (the neck bends < 40 deg).
RUNAWAY_DEG = 1000.0
#: The inclination channel the controller measures.
OUTPUT = "inclination"
COMMAND = "velocity_command"
DISPLACEMENT = "motor_displacement"
_SOURCES = {
    COMMAND: "command",
    "motor_position": "position",
    DISPLACEMENT: "position",
    "motor_velocity": "velocity",
}


def controller_kind(name: str) -> str | None:
    """``"int"``, ``"fra"`` or ``"ada"`` from a log's file name (the identification run: fra).

    Examples
    --------
    >>> controller_kind("stair/int200response.csv"), controller_kind("run.csv")
    ('int', None)
    """
    base = Path(name).name
    if base.startswith(CONTROLLER_KINDS):
        return base[:3]
    return "fra" if base == "id000response.csv" else None


def _parameter_file(path: Path, log_name: str) -> Path:
    """The ``adacon<payload>.csv`` of a log in a folder, or the file itself."""
    if path.is_file():
        return path
    digits = "".join(c for c in Path(log_name).name[3:6] if c.isdigit())
    candidate = path / f"adacon{digits}.csv"
    if not path.is_dir() or not candidate.is_file():
        raise FileNotFoundError(
            f"adaptive_parameters {str(path)!r} is neither a parameter file nor a folder holding"
            f" {candidate.name} (the parameter log of {Path(log_name).name})"
        )
    return candidate


def lab_controller(
    log_name: str,
    controller: str | Controller | None = None,
    adaptive_parameters: AdaptiveParameters | str | Path | None = None,
) -> tuple[Controller, str]:
    """The controller of a log, and how it is named in a report.

    Parameters
    ----------
    log_name : str
        The log's file name (``int*``, ``fra*``, ``ada*``, ``id000response.csv``).
    controller : {"int", "fra", "ada"} or Controller, optional
        Default: the one the name says. An object is used as it is.
    adaptive_parameters : AdaptiveParameters, str or Path, optional
        For ``ada``: the parameter log (a file, or a folder holding ``adacon<payload>.csv``),
        replayed (:class:`~neckid.loops.controllers.AdaptiveFractionalReplay`); without one, the
        re-implemented tuner (:class:`~neckid.loops.controllers.tuned.AdaptiveFractionalTuner`).

    Returns
    -------
    controller : Controller
    label : str

    Raises
    ------
    ValueError
        If no controller is given and the name says none, ``controller`` is another text, or
        adaptive parameters are given for a log that another controller made (its name says
        int or fra) or for another payload (:func:`~neckid.loops.loop_checks.check_parameter_log`).
    """
    if controller is not None and not isinstance(controller, str):
        return controller, type(controller).__name__
    kind = controller if controller is not None else controller_kind(log_name)
    if kind not in CONTROLLER_KINDS:
        raise ValueError(
            f"controller must be one of {list(CONTROLLER_KINDS)} or a controller object; got"
            f" {kind!r} (the log's name {Path(log_name).name!r} names none)"
        )
    named = f"{kind}{Path(log_name).name[3:]}" if controller_kind(log_name) != kind else log_name
    if kind != "ada":
        return controller_for_log(named), kind
    if adaptive_parameters is None:
        return AdaptiveFractionalTuner(), "ada (re-implemented tuner)"
    given = (
        adaptive_parameters.name
        if isinstance(adaptive_parameters, AdaptiveParameters)
        else str(adaptive_parameters)
    )
    check_parameter_log(log_name, controller_kind(log_name), given)
    if not isinstance(adaptive_parameters, AdaptiveParameters):
        adaptive_parameters = load_adaptive_parameters(
            _parameter_file(Path(adaptive_parameters), log_name)
        )
    return controller_for_log(
        "ada", adaptive_parameters
    ), f"ada (replay {adaptive_parameters.name})"


def model_view(model: Any, log: IOData) -> IOData:
    """The log as the model sees it: its channels, ``motor_displacement`` made, preprocessing applied.

    Parameters
    ----------
    model : fitted estimator
    log : IOData
        A soft-neck log with every channel (:func:`neckid.datasets.load_softneck_log`).

    Returns
    -------
    IOData
        The model's inputs (but its conditions, which stay conditions) and outputs, the log's
        rows.
    """
    data = log
    if DISPLACEMENT in model.input_names_ and DISPLACEMENT not in log.input_names:
        position = log.channel("motor_position")
        data = data.with_channel(DISPLACEMENT, position - position[0], unit="rad")
    pipeline = model.preprocessing_
    if pipeline is not None and len(pipeline):
        data = pipeline.apply(data)
    used = set(model.condition_names())
    inputs = [n for n in model.input_names_ if n not in used]
    missing = [
        n
        for n in (*inputs, *model.output_names_)
        if n not in (*data.input_names, *data.output_names)
    ]
    if missing:
        raise ValueError(
            f"the log {log.name!r} has no channel {missing[0]!r}, which the model takes"
        )
    return data.select(inputs=inputs, outputs=list(model.output_names_))


@dataclass(frozen=True)
class LoopInput:
    """How the loop feeds one model input.

    Attributes
    ----------
    name : str
        The model's input.
    source : {"command", "position", "velocity", "constant"}
        The controller's command, the drive's position or measured velocity, or a condition.
    offset : float
        Subtracted from the loop's value (the log's first position for a displacement); the
        value itself for a constant.
    """

    name: str
    source: str
    offset: float


def _offset(raw: FloatArray, seen: FloatArray, name: str) -> float:
    difference = raw - seen
    if np.ptp(difference) > 1e-9 * max(1.0, float(np.abs(raw).max())):
        raise ValueError(
            f"the model's preprocessing changes {name!r} by more than a constant offset; in the"
            " loop only offsets (relative, offset steps) can be replayed on a streamed signal"
        )
    return float(difference[0])


def loop_inputs(
    model: Any, log: IOData, view: IOData | None = None
) -> tuple[list[LoopInput], float]:
    """How each model input is fed in the loop, and the offset of the model's inclination.

    Parameters
    ----------
    model : fitted estimator
    log : IOData
        The soft-neck log.
    view : IOData, optional
        :func:`model_view` of it (made when not given).

    Returns
    -------
    inputs : list of LoopInput
        In the model's input order.
    output_offset : float
        Added to the model's inclination to give the controller's [deg].

    Raises
    ------
    ValueError
        If a model input cannot be fed, the model has no ``inclination`` output, or its
        preprocessing is more than offsets.
    """
    seen = model_view(model, log) if view is None else view
    conditions = model.condition_names()
    constants = log.conditions_as_inputs(conditions) if conditions else None
    feeds = []
    for name in model.input_names_:
        if name in conditions and constants is not None:
            feeds.append(LoopInput(name, "constant", float(constants.channel(name)[0])))
            continue
        if name not in _SOURCES:
            raise ValueError(
                f"the model's input {name!r} cannot be fed from the lab's loop: it feeds"
                f" {list(_SOURCES)} and the log's conditions"
            )
        raw_name = "motor_position" if name == DISPLACEMENT else name
        raw = log.channel(raw_name) if raw_name in log.input_names else seen.channel(name)
        feeds.append(LoopInput(name, _SOURCES[name], _offset(raw, seen.channel(name), name)))
    if OUTPUT not in model.output_names_:
        raise ValueError(
            f"the model has no output {OUTPUT!r} (its outputs: {list(model.output_names_)}):"
            " the lab's controllers measure the raw inclination"
        )
    return feeds, -_offset(log.channel(OUTPUT), seen.channel(OUTPUT), OUTPUT)


def _check_no_algebraic_loop(model: Any, feeds: Sequence[LoopInput]) -> None:
    lags = model.fitted_lags()
    commands = [i for i, f in enumerate(feeds) if f.source == "command"]
    if not commands or lags is None:
        return
    now = (lags.source == 1) & (lags.lag == 0) & np.isin(lags.channel, commands)
    if np.any(now):
        raise ValueError(
            "the model's inclination reads the velocity command of the same row (lag 0): in the"
            " loop that command is computed from that inclination; identify it with a delay of"
            " one sample or more (--orders NA,NB,1)"
        )


def _input_table(model: Any, view: IOData, feeds: Sequence[LoopInput]) -> FloatArray:
    """The model's inputs of every row of the log (constants for the conditions)."""
    n = view.n_samples
    return np.column_stack(
        [np.full(n, f.offset) if f.source == "constant" else view.channel(f.name) for f in feeds]
    )


def _row(feeds: Sequence[LoopInput], command: float, drive: LabDrive) -> FloatArray:
    values = {
        "command": command,
        "position": float(drive.motor_position[0]),
        "velocity": float(drive.motor_velocity[0]),
    }
    return np.array(
        [f.offset if f.source == "constant" else values[f.source] - f.offset for f in feeds]
    )


def run_lab_loop(
    model: Any,
    controller: Controller,
    reference: FloatArray,
    log: IOData,
    *,
    drive: LabDrive | None = None,
    failed: BoolArray | None = None,
) -> tuple[pd.DataFrame, int | None]:
    """Run the lab's loop with ``model`` as the neck over the rows of ``log``.

    Parameters
    ----------
    model : fitted estimator
        Any neckid model (``state_map()``, ``max_lag_``, an ``inclination`` output).
    controller : Controller
        Reset first; ``step(reference, inclination) -> command``.
    reference : ndarray, shape (n,)
        Reference plus dither of every row [deg].
    log : IOData
        The log: its first ``max_lag_`` rows are the initial conditions, its first motor
        position and velocity the drive's start.
    drive : LabDrive, optional
        Default :meth:`LabDrive.identified`.
    failed : ndarray of bool, shape (n,), optional
        Failed sensor reads (the controller holds its command there).

    Returns
    -------
    loop : pandas.DataFrame
        Columns ``reference``, ``velocity_command``, ``motor_position``, ``motor_velocity``,
        ``inclination`` (NaN from a divergence on).
    diverged_at : int or None
        First row whose inclination was not finite or beyond ±1000 deg.
    """
    check_is_fitted(model)
    view = model_view(model, log)
    feeds, output_offset = loop_inputs(model, log, view)
    _check_no_algebraic_loop(model, feeds)
    n, m = log.n_samples, int(model.max_lag_)
    ref = np.asarray(reference, dtype=np.float64).reshape(-1)
    if ref.shape[0] != n:
        raise ValueError(f"reference has {ref.shape[0]} rows; the log {n}")
    engine = drive if drive is not None else LabDrive.identified(ts=log.ts)
    if not math.isclose(engine.ts, log.ts, rel_tol=1e-9):
        raise ValueError(f"the drive runs at ts={engine.ts} s, the log at {log.ts} s")
    state_map = model.state_map()
    head = max(m, 1)
    x = state_map.initial_state(view.y[:head], _input_table(model, view, feeds)[:head])
    out = list(model.output_names_).index(OUTPUT)
    measured = log.channel(OUTPUT)
    hold = np.zeros(n, dtype=bool) if failed is None else np.asarray(failed, dtype=bool)
    columns = np.full((n, 5), np.nan)
    engine.reset(log.channel("motor_position")[0], _first(log, "motor_velocity"))
    controller.reset()
    command, diverged = 0.0, None
    for k in range(n):
        columns[k, 2:4] = engine.motor_position[0], engine.motor_velocity[0]
        u = _row(feeds, command, engine)
        if k < m:
            inclination = float(measured[k])
        else:
            try:
                inclination = float(state_map.output(x, u)[out]) + output_offset
            except (ValueError, ArithmeticError, OverflowError):
                inclination = math.nan
            if not (math.isfinite(inclination) and abs(inclination) < RUNAWAY_DEG):
                diverged = k
                break
        command = float(
            np.asarray(controller.step(ref[k], math.nan if hold[k] else inclination))[0]
        )
        columns[k, [0, 1, 4]] = ref[k], command, inclination
        if k >= m:
            u[[i for i, f in enumerate(feeds) if f.source == "command"]] = command
            x = state_map.update(x, u)
        engine.step([command])
    frame = pd.DataFrame(
        columns,
        columns=["reference", COMMAND, "motor_position", "motor_velocity", OUTPUT],
    )
    return frame, diverged


def _first(log: IOData, name: str) -> float:
    return float(log.channel(name)[0]) if name in log.input_names else 0.0


def _fit(measured: FloatArray, modelled: FloatArray, skip: int) -> float:
    if not np.all(np.isfinite(modelled[skip:])):
        return -math.inf
    return float(fit_percent(measured, modelled, skip=skip)[0])


def _reference(log: IOData, reference: LabReference | None) -> LabReference:
    ref = reference if reference is not None else reference_for_log(log.name or "")
    if len(ref) < log.n_samples:
        raise ValueError(
            f"the reference has {len(ref)} rows, the log {log.n_samples}: pass the run's reference"
        )
    if len(ref) == log.n_samples:
        return ref
    n = log.n_samples  # a log cut short: the reference's first rows
    return LabReference(ref.name, ref.nominal[:n], ref.dither[:n], ref.draws[:n], ref.ts)


def in_loop_on_log(
    model: Any,
    log: IOData | str | Path,
    controller: str | Controller | None = None,
    drive: LabDrive | None = None,
    *,
    adaptive_parameters: AdaptiveParameters | str | Path | None = None,
    reference: LabReference | None = None,
    settle: float = 3.0,
    band: float = 1.0,
    check_tolerance: float | None = CONTROLLER_CHECK_TOLERANCE,
) -> LabLoopResult:
    """Run an identified model in the loop of a real log; compare with its free run and the log.

    Parameters
    ----------
    model : fitted estimator
        Any neckid model with an ``inclination`` output and inputs the loop can feed (see the
        module docstring).
    log : IOData, str or Path
        A closed-loop soft-neck log (6 or 7 columns; every row kept), or its path.
    controller : {"int", "fra", "ada"} or Controller, optional
        Default: the one the log's name says (:func:`lab_controller`).
    drive : LabDrive, optional
        Default :meth:`LabDrive.identified` (the drive identified on the payload split's
        training logs).
    adaptive_parameters : AdaptiveParameters, str or Path, optional
        For an ``ada`` log: its parameter log (file or folder), replayed; without it the
        re-implemented tuner runs.
    reference : LabReference, optional
        Default :func:`~neckid.loops.controllers.reference_for_log` of the log's name (its first
        rows for a log cut short).
    settle : float, default 3.0
        Seconds of each stair left out of the oscillation measures.
    band : float, default 1.0
        Settling band of the stair table, deg.
    check_tolerance : float or None, default 1e-4
        The largest controller check [rad/s] accepted
        (:data:`~neckid.loops.loop_checks.CONTROLLER_CHECK_TOLERANCE`, see
        :mod:`neckid.loops.loop_checks`); ``None`` runs a controller that does not reproduce
        the log's commands anyway.

    Returns
    -------
    LabLoopResult

    Raises
    ------
    ValueError
        If no controller or reference is known for the log, the controller runs at another
        period than the log, or the model cannot run in the loop.
    ControllerMismatchError
        A ``ValueError``: the controller does not reproduce the log's commands (its check
        exceeds ``check_tolerance``); raised before the loop runs.

    Examples
    --------
    >>> from pathlib import Path
    >>> log = Path("../shared/data/softneck/stair/int200response.csv")   # not distributed
    >>> if log.is_file():                                                   # doctest: +SKIP
    ...     result = in_loop_on_log(model, log)
    ...     result.summary()["period_s"], result.summary()["logged_period_s"]
    """
    data = log if isinstance(log, IOData) else load_softneck_log(Path(log))
    name = data.name or str(log)
    ctrl, label = lab_controller(name, controller, adaptive_parameters)
    check_period(ctrl, label, data.ts, Path(name).name)
    ref = _reference(data, reference)
    failed = failed_reads(data) if COMMAND in data.input_names else None
    check, first_stair_row = math.nan, math.nan
    if failed is not None:
        check, first_stair_row = controller_check(
            ctrl, ref.values, data.channel(OUTPUT), data.channel(COMMAND), failed
        )
        if check_tolerance is not None and not check <= check_tolerance:
            raise ControllerMismatchError(Path(name).name, label, check, check_tolerance)
    engine = drive if drive is not None else LabDrive.identified(ts=data.ts)
    view = model_view(model, data)
    simulated, skip = free_run(model, view, diverged="keep")
    loop, diverged = run_lab_loop(model, ctrl, ref.values, data, drive=engine, failed=failed)
    loop.insert(1, "reference_nominal", ref.nominal)
    measured_y = data.channel(OUTPUT)
    y_loop = loop[OUTPUT].to_numpy()
    rms, found, stairs = loop_figures(y_loop, ref.nominal, data.ts, settle=settle, band=band)
    logged = loop_figures(measured_y, ref.nominal, data.ts, settle=settle, band=band)
    command_fit = (
        _fit(data.channel(COMMAND), loop[COMMAND].to_numpy(), skip)
        if COMMAND in data.input_names
        else math.nan
    )
    free = simulated[:, list(model.output_names_).index(OUTPUT)]
    return LabLoopResult(
        log=name,
        controller=label,
        loop=loop,
        measured=data,
        free_run=free - _offset_of(data, view),
        n_initial=skip,
        free_run_fit=_fit(measured_y, free - _offset_of(data, view), skip),
        inclination_fit=_fit(measured_y, y_loop, skip),
        command_fit=command_fit,
        tracking_rms=rms,
        logged_tracking_rms=logged[0],
        oscillation=found,
        logged_oscillation=logged[1],
        stairs=stairs,
        logged_stairs=logged[2],
        controller_check=check,
        controller_check_first_stair_row=first_stair_row,
        diverged_at=diverged,
        settings={
            "drive": repr(engine),
            "reference": ref.name,
            "settle_s": settle,
            "band_deg": band,
        },
    )


def _offset_of(log: IOData, view: IOData) -> float:
    """The view's inclination minus the log's (0 without an output offset)."""
    return float(view.channel(OUTPUT)[0] - log.channel(OUTPUT)[0])
