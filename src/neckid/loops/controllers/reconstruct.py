r"""The controller check: each log's velocity command rebuilt from its logged raw inclination.

Fed the logged raw inclination row by row (a failed sensor read as a NaN, :func:`failed_reads`),
the matching lab controller (:func:`controller_for_log`) and the run's reference with its dither
(:func:`~.references.reference_for_log`) give back the logged velocity command to the logs'
print precision (six significant digits: about 5e-6 rad/s). :func:`check_log` measures it on one
log, :func:`check_shared_logs` on every closed-loop log of the shared set.

References
----------
- ``shared/data/softneck/CONTROLLERS.md`` (the controllers, references and failed rows) and
  ``shared/data/softneck/SOURCE.md`` (the column layouts and units).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neckid.data.iodata import IOData
from neckid.datasets.softneck import load_softneck_log
from neckid.loops.controllers.adaptive import (
    AdaptiveFractionalReplay,
    AdaptiveParameters,
    load_adaptive_parameters,
)
from neckid.loops.controllers.lab import (
    FRA_ID_GAINS,
    FRA_STAIR_GAINS,
    PI_GAINS,
    LabController,
    LabFractionalController,
    LabPI,
)
from neckid.loops.controllers.references import (
    ADAPTIVE_WARMUP_ROWS,
    LabReference,
    reference_for_log,
)
from neckid.utils.types import BoolArray, FloatArray

__all__ = [
    "CLOSED_LOOP_LOGS",
    "CommandCheck",
    "check_log",
    "check_shared_logs",
    "controller_for_log",
    "failed_reads",
    "reconstruct_command",
]

#: The closed-loop logs of the shared set (relative to ``softneck/``), in report order.
CLOSED_LOOP_LOGS = tuple(
    [
        f"stair/{c}{p}response.csv"
        for c in ("int", "fra", "ada")
        for p in ("000", "200", "400", "600")
    ]
    + [f"step/{c}{p}stepresponse.csv" for c in ("int", "fra") for p in ("000", "200", "400", "600")]
    + ["id/id000response.csv"]
)

#: Channels that a failed read repeats exactly (those the log holds).
_REPEATED = ("inclination", "inclination_filtered", "velocity_command", "control_filtered")


def failed_reads(data: IOData) -> BoolArray:
    """Rows of a failed sensor read: every logged signal but the motor's repeats the previous row.

    On a failed read the bench updates nothing and keeps the last command, so the row repeats
    the previous one's filtered inclination, filtered command (7-column logs), raw inclination
    and command exactly.

    Parameters
    ----------
    data : IOData
        A soft-neck log (:func:`neckid.datasets.load_softneck_log`) with ``inclination`` and
        ``velocity_command``.

    Returns
    -------
    ndarray of bool, shape (n_samples,)
        True on the failed rows (never the first).
    """
    names = [n for n in _REPEATED if n in data.input_names or n in data.output_names]
    if "inclination" not in names or "velocity_command" not in names:
        raise ValueError(
            f"{data.name}: the controller check needs the raw inclination and the velocity"
            " command (6- and 7-column logs)"
        )
    repeated = np.ones(data.n_samples - 1, dtype=bool)
    for name in names:
        values = data.channel(name)
        repeated &= values[1:] == values[:-1]
    return np.concatenate([[False], repeated])


def reconstruct_command(
    controller: LabController,
    reference: FloatArray,
    inclination: FloatArray,
    failed: BoolArray | None = None,
) -> FloatArray:
    """Run a controller on a logged inclination: the command of every row.

    Parameters
    ----------
    controller : LabController
        Reset first.
    reference : ndarray, shape (n,)
        Reference plus dither [deg] (:attr:`~.references.LabReference.values`).
    inclination : ndarray, shape (n,)
        The logged raw inclination [deg].
    failed : ndarray of bool, shape (n,), optional
        Failed reads (the command is held there).

    Returns
    -------
    ndarray, shape (n,)
        Velocity command [rad/s].
    """
    ref = np.asarray(reference, dtype=np.float64).reshape(-1)
    y = np.array(inclination, dtype=np.float64).reshape(-1)
    if ref.shape != y.shape:
        raise ValueError(
            f"the reference has {ref.shape[0]} rows but the inclination {y.shape[0]}; a lab"
            " reference is built for the whole log"
        )
    if failed is not None:
        y[np.asarray(failed, dtype=bool)] = np.nan
    controller.reset()
    return np.array([controller.step(r, m)[0] for r, m in zip(ref, y, strict=True)])


@dataclass(frozen=True)
class CommandCheck:
    """A log's reconstructed velocity command beside the logged one.

    Attributes
    ----------
    name : str
        The log's name.
    controller : str
        ``"int"``, ``"fra"`` or ``"ada"``.
    command, logged : ndarray, shape (n,)
        Reconstructed and logged velocity command [rad/s].
    failed : ndarray of bool, shape (n,)
        Failed sensor reads.
    first_stair_row : int or None
        The adaptive runs' first stair row (801), whose command depends on starting gains
        that no log holds; None for the others.
    """

    name: str
    controller: str
    command: FloatArray
    logged: FloatArray
    failed: BoolArray
    first_stair_row: int | None = None

    @property
    def difference(self) -> FloatArray:
        """``|command − logged|`` per row [rad/s]."""
        return np.abs(self.command - self.logged)

    @property
    def max_difference(self) -> float:
        """The largest absolute difference over every row [rad/s]."""
        return float(self.difference.max())

    @property
    def max_difference_logged_gains(self) -> float:
        """The largest difference over the rows whose gains a log holds [rad/s].

        Every row but an adaptive run's first stair row (the same as :attr:`max_difference`
        for the int and fra logs).
        """
        keep = np.ones(self.difference.shape[0], dtype=bool)
        if self.first_stair_row is not None:
            keep[self.first_stair_row] = False
        return float(self.difference[keep].max())


def _controller_kind(name: str) -> str:
    base = Path(name).name
    if base.startswith(("int", "fra", "ada")):
        return base[:3]
    if base == "id000response.csv":
        return "fra"
    raise ValueError(f"{name!r}: no lab controller is known for this log")


def controller_for_log(
    name: str, adaptive_parameters: AdaptiveParameters | None = None
) -> LabController:
    """The controller that recorded a shared closed-loop log, from its name.

    Parameters
    ----------
    name : str
        The log's file name (or path).
    adaptive_parameters : AdaptiveParameters, optional
        Needed for the ``ada`` logs (the matching ``adacon*.csv``).

    Returns
    -------
    LabController
        :class:`~.lab.LabPI` (int), :class:`~.lab.LabFractionalController` (fra; the
        identification run's own gains for ``id000response.csv``) or
        :class:`~.adaptive.AdaptiveFractionalReplay` (ada).

    Examples
    --------
    >>> type(controller_for_log("int200stepresponse.csv")).__name__
    'LabPI'
    >>> controller_for_log("id/id000response.csv").kp
    0.2342
    """
    kind = _controller_kind(name)
    if kind == "int":
        return LabPI(*PI_GAINS)
    if kind == "fra":
        gains = FRA_ID_GAINS if Path(name).name.startswith("id") else FRA_STAIR_GAINS
        return LabFractionalController(*gains)
    if adaptive_parameters is None:
        raise ValueError(f"{name!r}: the adaptive controller needs its parameter log (adacon*.csv)")
    return AdaptiveFractionalReplay(adaptive_parameters)


def check_log(
    log: str | Path | IOData,
    adaptive_parameters: AdaptiveParameters | str | Path | None = None,
    controller: LabController | None = None,
    reference: LabReference | None = None,
) -> CommandCheck:
    """Rebuild a log's velocity command from its raw inclination; compare with the logged one.

    Parameters
    ----------
    log : str, Path or IOData
        A 6- or 7-column soft-neck log (a path, or one read by
        :func:`neckid.datasets.load_softneck_log` with every row kept).
    adaptive_parameters : AdaptiveParameters, str or Path, optional
        The ``adacon*.csv`` of an ``ada`` log.
    controller : LabController, optional
        Default :func:`controller_for_log` of the log's name.
    reference : LabReference, optional
        Default :func:`~.references.reference_for_log` of the log's name.

    Returns
    -------
    CommandCheck
        ``max_difference`` is the largest absolute difference [rad/s].

    Examples
    --------
    >>> from pathlib import Path
    >>> folder = Path("../shared/data/softneck")   # not distributed with neckid
    >>> if folder.is_dir():                         # doctest: +SKIP
    ...     check_log(folder / "stair/int200response.csv").max_difference < 1e-5
    True
    """
    data = log if isinstance(log, IOData) else load_softneck_log(Path(log))
    name = data.name or str(log)
    if isinstance(adaptive_parameters, str | Path):
        adaptive_parameters = load_adaptive_parameters(adaptive_parameters)
    ctrl = controller or controller_for_log(name, adaptive_parameters)
    ref = reference or reference_for_log(name)
    failed = failed_reads(data)
    command = reconstruct_command(ctrl, ref.values, data.channel("inclination"), failed)
    kind = _controller_kind(name)
    return CommandCheck(
        name=name,
        controller=kind,
        command=command,
        logged=data.channel("velocity_command").copy(),
        failed=failed,
        first_stair_row=ADAPTIVE_WARMUP_ROWS if kind == "ada" else None,
    )


def check_shared_logs(data_dir: str | Path) -> Mapping[str, CommandCheck]:
    """:func:`check_log` on every closed-loop log of the shared set.

    Parameters
    ----------
    data_dir : str or Path
        The folder holding ``softneck/`` and ``softneck_adaptive/``.

    Returns
    -------
    dict of str to CommandCheck
        Keyed as :data:`CLOSED_LOOP_LOGS` (``"stair/ada000response.csv"``, ...).

    Raises
    ------
    FileNotFoundError
        If a log or parameter file is missing.
    """
    root = Path(data_dir)
    checks = {}
    for key in CLOSED_LOOP_LOGS:
        params = None
        if Path(key).name.startswith("ada"):
            payload = Path(key).name[3:6]
            params = load_adaptive_parameters(root / "softneck_adaptive" / f"adacon{payload}.csv")
        checks[key] = check_log(root / "softneck" / key, params)
    return checks
