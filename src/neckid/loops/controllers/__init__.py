"""The controllers and references that recorded the UC3M soft-neck logs, as objects.

- :mod:`.lab`: the integer PI (:class:`LabPI`, Tustin integrator) and the fixed fractional
  controller (:class:`LabFractionalController`, truncated Grünwald–Letnikov sum);
- :mod:`.adaptive`: the adaptive fractional controller replayed from its parameter log
  (:class:`AdaptiveFractionalReplay`, :func:`load_adaptive_parameters`);
- :mod:`.tuner`: a re-implementation of the adaptive controller's online identifier and
  iso-damping tuner (:func:`~.tuner.iso_damping_tuning`, :func:`~.tuner.retune_log`),
  approximate by nature; :mod:`.tuned`: the adaptive controller that runs them online
  (:class:`AdaptiveFractionalTuner`, for a loop whose plant is a model);
- :mod:`.references`: the staircase, step, identification and adaptive references with their
  dither (:func:`reference_for_log`); :mod:`.glibc`: glibc's ``rand()`` that draws it;
- :mod:`.drive`: the drive's smallest velocity (:func:`executed_velocity`);
- :mod:`.reconstruct`: the controller check, each log's command rebuilt from its logged
  inclination (:func:`check_log`, :func:`failed_reads`).

Every controller follows :class:`neckid.systems.Controller` (``reset()``,
``step(reference, measurement) -> command``; a NaN measurement is a failed sensor read) and has
``state_map()``, so it runs in :func:`neckid.plant.closed_loop` and converts with
:func:`neckid.export.control.to_iosystem`. The facts come from ``shared/data/softneck/CONTROLLERS.md``;
the logs and parameter files are not distributed with neckid: loaders take a path.
"""

from __future__ import annotations

from neckid.loops.controllers.adaptive import (
    ADAPTIVE_START_GAINS,
    ADAPTIVE_WARMUP_GAINS,
    AdaptiveFractionalReplay,
    AdaptiveParameters,
    load_adaptive_parameters,
)
from neckid.loops.controllers.drive import (
    DRIVE_MIN_VELOCITY,
    MinimumVelocityDrive,
    executed_velocity,
)
from neckid.loops.controllers.glibc import GlibcRandom, glibc_rand
from neckid.loops.controllers.lab import (
    FRA_ID_GAINS,
    FRA_STAIR_GAINS,
    PI_GAINS,
    LabController,
    LabControllerStateMap,
    LabFractionalController,
    LabPI,
    grunwald_letnikov_weights,
)
from neckid.loops.controllers.reconstruct import (
    CLOSED_LOOP_LOGS,
    CommandCheck,
    check_log,
    check_shared_logs,
    controller_for_log,
    failed_reads,
    reconstruct_command,
)
from neckid.loops.controllers.references import (
    LAB_TS,
    LabReference,
    adaptive_reference,
    identification_reference,
    lab_dither,
    reference_for_log,
    staircase_reference,
    step_reference,
)
from neckid.loops.controllers.tuned import AdaptiveFractionalTuner

__all__ = [
    "ADAPTIVE_START_GAINS",
    "ADAPTIVE_WARMUP_GAINS",
    "CLOSED_LOOP_LOGS",
    "DRIVE_MIN_VELOCITY",
    "FRA_ID_GAINS",
    "FRA_STAIR_GAINS",
    "LAB_TS",
    "PI_GAINS",
    "AdaptiveFractionalReplay",
    "AdaptiveFractionalTuner",
    "AdaptiveParameters",
    "CommandCheck",
    "GlibcRandom",
    "LabController",
    "LabControllerStateMap",
    "LabFractionalController",
    "LabPI",
    "LabReference",
    "MinimumVelocityDrive",
    "adaptive_reference",
    "check_log",
    "check_shared_logs",
    "controller_for_log",
    "executed_velocity",
    "failed_reads",
    "glibc_rand",
    "grunwald_letnikov_weights",
    "identification_reference",
    "lab_dither",
    "load_adaptive_parameters",
    "reconstruct_command",
    "reference_for_log",
    "staircase_reference",
    "step_reference",
]
