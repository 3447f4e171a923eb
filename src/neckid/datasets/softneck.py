"""Loaders for the UC3M soft-neck bench logs (headerless CSV, 3, 6 or 7 columns).

The logs come from the HUMASoft soft-neck test bench of the UC3M Robotics Lab (one tendon motor,
Maxon RE16 with a 24:1 gear in velocity mode, a tilt sensor on the top platform, sample time
0.025 s). Each row is one control period; there is no header. Three layouts exist:

========  ==============================================================================
columns   meaning (in file order)
========  ==============================================================================
3         time [s], filtered inclination [deg], motor position [rad]
6         time [s], filtered inclination [deg], motor position [rad], raw inclination [deg],
          velocity command [rad/s], measured motor velocity [rad/s]
7         time [s], filtered inclination [deg], filtered control signal, motor position [rad],
          raw inclination [deg], velocity command [rad/s], measured motor velocity [rad/s]
========  ==============================================================================

Channels are named as in :data:`CHANNELS`. The motor signals are inputs and the inclinations are
outputs; pick the ones a model uses with :meth:`~neckid.IOData.select`.

Source: github.com/munozyanez/phd_Archived (commit a9198c8, folder
``matlab/ExperimentalResults/data/``), the PhD code of J. Muñoz Yañez-Barnuevo; column meanings from
its ``main/neck-id.cpp`` and ``main/ieeeaccess-adaptive.cpp``. The repository has no licence file:
the logs are not redistributed with neckid, a loader takes a path.
"""

from __future__ import annotations

import logging
import math
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from neckid.data.iodata import IOData
from neckid.utils.checks import check_ts, check_uniform_time
from neckid.utils.formats import not_this_kind

__all__ = [
    "CHANNELS",
    "SOFTNECK_LAYOUTS",
    "SOFTNECK_TS",
    "SoftneckLayout",
    "conditions_from_name",
    "load_softneck_directory",
    "load_softneck_log",
]

logger = logging.getLogger(__name__)

#: Sample time of the soft-neck bench, in seconds.
SOFTNECK_TS = 0.025

#: Every channel a soft-neck log may hold: name -> (unit, kind, meaning).
CHANNELS: dict[str, tuple[str, Literal["input", "output"], str]] = {
    "motor_position": ("rad", "input", "tendon motor position at the gearbox output"),
    "velocity_command": ("rad/s", "input", "velocity command sent to the motor driver"),
    "motor_velocity": ("rad/s", "input", "measured motor velocity at the gearbox output"),
    "control_filtered": (
        "",
        "input",
        "the controller's filtered control signal (internal to the controller; unit not documented)",
    ),
    "inclination": ("deg", "output", "raw inclination of the top platform (0.01 deg steps)"),
    "inclination_filtered": (
        "deg",
        "output",
        "inclination through a first-order low-pass filter (bilinear, 1 rad/s)",
    ),
}


@dataclass(frozen=True)
class SoftneckLayout:
    """One column layout of the soft-neck logs.

    Attributes
    ----------
    n_columns : int
        Number of comma-separated fields per row, the time column included.
    columns : tuple of str
        Channel name of each column after the time column (keys of :data:`CHANNELS`).
    files : str
        Which files of the public set use it.
    """

    n_columns: int
    columns: tuple[str, ...]
    files: str


#: The layouts known, by number of columns.
SOFTNECK_LAYOUTS: dict[int, SoftneckLayout] = {
    3: SoftneckLayout(
        3,
        ("inclination_filtered", "motor_position"),
        "id/ol1/id000response.csv, stair/000response.csv, step/{200,400,600}stepresponse.csv",
    ),
    6: SoftneckLayout(
        6,
        (
            "inclination_filtered",
            "motor_position",
            "inclination",
            "velocity_command",
            "motor_velocity",
        ),
        "id/id000response.csv, step/{fra,int}*stepresponse.csv",
    ),
    7: SoftneckLayout(
        7,
        (
            "inclination_filtered",
            "control_filtered",
            "motor_position",
            "inclination",
            "velocity_command",
            "motor_velocity",
        ),
        "stair/{ada,fra,int}*response.csv",
    ),
}

#: Order of the channels in the IOData a loader returns (those present in the file).
_INPUT_ORDER = ("motor_position", "velocity_command", "motor_velocity", "control_filtered")
_OUTPUT_ORDER = ("inclination", "inclination_filtered")


def _read_rows(path: Path) -> tuple[NDArray[np.float64], SoftneckLayout]:
    """Parse a headerless comma-separated log; refuse unknown layouts and bad rows."""
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not a soft-neck log")
    if not path.is_file():
        raise FileNotFoundError(f"soft-neck log {str(path)!r} does not exist")
    binary = not_this_kind(path, "a soft-neck log (text)")
    if binary is not None:
        raise ValueError(binary)
    data = path.read_bytes()
    try:
        text = data.decode("utf-8-sig")  # a byte-order mark (Windows editors) is dropped
    except UnicodeDecodeError as exc:
        from neckid.data.csv_logs import not_text_message

        message = not_text_message(path, data, "utf-8", exc)
        raise ValueError(f"{message}; soft-neck logs are UTF-8 (ASCII) text") from None
    lines = text.splitlines()
    # Blank lines at the end (or anywhere) and comment lines (#) carry no sample.
    numbered = [
        (i + 1, line)
        for i, line in enumerate(lines)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if len(numbered) > 1 and not text.endswith(("\n", "\r")):
        # A log still being written may end inside its last number (0.12 of 0.1234).
        line_no, last = numbered.pop()
        warnings.warn(
            f"{path.name}: the last line (line {line_no}, {_clip(last)}) has no line break: it"
            " may be cut short (a writer still writing?), so it is left out; end the file with a"
            " line break to keep it",
            UserWarning,
            stacklevel=3,
        )
    if not numbered:
        raise ValueError(f"{path} holds no data row")
    first_line_no, first = numbered[0]
    fields = first.rstrip(",").split(",")
    layout = SOFTNECK_LAYOUTS.get(len(fields))
    if layout is None:
        known = ", ".join(str(k) for k in sorted(SOFTNECK_LAYOUTS))
        raise ValueError(
            f"{path.name}: unknown soft-neck log layout with {len(fields)} columns (known: {known});"
            f" first row (line {first_line_no}): {_clip(first)}. Read other layouts with"
            " IOData.from_csv and name the columns yourself"
        )
    names = ("time", *layout.columns)
    values = np.empty((len(numbered), layout.n_columns))
    for row, (line_no, line) in enumerate(numbered):
        parts = line.rstrip().rstrip(",").split(",")
        if len(parts) != layout.n_columns:
            raise ValueError(
                f"{path.name} line {line_no}: {len(parts)} fields where the {layout.n_columns}-column"
                f" layout (set by the first row) needs {layout.n_columns}: {_clip(line)}"
            )
        for col, part in enumerate(parts):
            try:
                value = float(part)
            except ValueError:
                header = " (a soft-neck log has no header row)" if row == 0 else ""
                raise ValueError(
                    f"{path.name} line {line_no}, column {col + 1} ({names[col]}):"
                    f" {_clip(part)} is not a number{header}; row: {_clip(line)}"
                ) from None
            if not math.isfinite(value):
                raise ValueError(
                    f"{path.name} line {line_no}, column {col + 1} ({names[col]}): non-finite"
                    f" value {_clip(part)}; row: {_clip(line)}"
                )
            values[row, col] = value
    return values, layout


def _clip(text: str, width: int = 80) -> str:
    """``repr`` of a stripped field or row, cut to ``width`` characters (one line, printable)."""
    shown = repr(text.strip())
    return shown if len(shown) <= width else shown[: width - 5] + "...'"


def _regularise_time(
    time: NDArray[np.float64],
    ts: float | None,
    repeated_stamps: str,
    name: str,
) -> tuple[NDArray[np.bool_], float, float]:
    """Check the time column; return (rows to keep, ts, t0).

    Steps must be one sample period (within 5 %) or zero (a repeated stamp); anything else
    (time going back, a gap) is refused with the row (:func:`~neckid.utils.checks.check_uniform_time`).
    """
    ts_checked = None if ts is None else check_ts(ts)
    try:
        ts_value, t0 = check_uniform_time(time, "time", ts=ts_checked, allow_repeats=True)
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from exc
    repeated = np.diff(time) == 0
    keep = np.ones(time.size, dtype=bool)
    n_repeated = int(repeated.sum())
    if n_repeated:
        rows = (np.flatnonzero(repeated) + 1).tolist()
        if repeated_stamps == "raise":
            raise ValueError(
                f"{name}: {n_repeated} repeated time stamp(s), first at data row {rows[0]}"
                f" (t={time[rows[0]]:g} s); pass repeated_stamps='restamp' or 'drop'"
            )
        if repeated_stamps == "drop":
            keep[rows] = False
            logger.info(
                "%s: dropped %d rows with a repeated time stamp: %s", name, n_repeated, rows
            )
        else:
            logger.info(
                "%s: %d repeated time stamps (data rows %s) kept as consecutive samples; time"
                " rebuilt as t0 + k * ts",
                name,
                n_repeated,
                rows,
            )
    return keep, ts_value, t0


_NAME_PATTERN = re.compile(r"^(ada|fra|int)?(\d{3})(?:step)?response\.csv$")


def conditions_from_name(name: str) -> dict[str, dict[str, Any]]:
    """The conditions a soft-neck log's file name encodes, as ``IOData`` keyword arguments.

    ``<controller><payload in g>[step]response.csv``: the controller is ``ada`` (adaptive
    fractional), ``fra`` (fixed fractional) or ``int`` (integer PI), absent for open-loop or
    unlabelled runs; the payload is in grams in the name and in kilograms in the result. Other
    names give no conditions.

    Examples
    --------
    >>> conditions_from_name("int400response.csv")
    {'conditions': {'payload': 0.4, 'controller': 'int'}, 'condition_units': {'payload': 'kg'}}
    >>> conditions_from_name("600stepresponse.csv")["conditions"]
    {'payload': 0.6}
    >>> conditions_from_name("my_run.csv")
    {}
    """
    match = _NAME_PATTERN.match(name)
    if not match:
        return {}
    conditions: dict[str, Any] = {"payload": int(match.group(2)) / 1000.0}
    if match.group(1):
        conditions["controller"] = match.group(1)
    return {"conditions": conditions, "condition_units": {"payload": "kg"}}


def load_softneck_log(
    path: str | Path,
    *,
    inputs: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
    ts: float | None = SOFTNECK_TS,
    repeated_stamps: Literal["restamp", "drop", "raise"] = "restamp",
) -> IOData:
    r"""Read one soft-neck bench log (headerless CSV with 3, 6 or 7 columns).

    The layout is recognised by the number of columns of the first row (see the module docstring
    and :data:`SOFTNECK_LAYOUTS`). Channels present in the file become:

    - inputs, in this order: ``motor_position`` [rad], ``velocity_command`` [rad/s],
      ``motor_velocity`` [rad/s], ``control_filtered`` (7-column logs: the controller's filtered
      control signal, unit not documented; an extra channel, not an actuator signal);
    - outputs, in this order: ``inclination`` [deg] (raw sensor reading; 6- and 7-column logs) and
      ``inclination_filtered`` [deg] (the raw one through a 1 rad/s low-pass filter; all logs).

    The raw inclination is the output to identify where it exists (the filtered one lags by the
    filter). Use ``inputs=`` / ``outputs=`` (or :meth:`~neckid.IOData.select` afterwards) to keep
    the channels a model needs; a name may move between kinds there.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    inputs, outputs : sequence of str, optional
        Channels to keep (names from :data:`CHANNELS`); ``None`` keeps all of that kind present.
    ts : float or None, default 0.025
        Sampling period in seconds; ``None`` infers it as the median positive time step.
    repeated_stamps : {"restamp", "drop", "raise"}, default "restamp"
        What to do with rows whose time stamp repeats the previous one. The staircase logs
        (``stair/``) repeat the stamp at every 10 s stair change (5 times in 90 s): the logger's
        clock restarts each segment, but the rows are consecutive control periods (the low-pass
        filtered inclination follows its recursion through them exactly). ``"restamp"`` keeps every
        row and rebuilds time as ``t0 + k * ts``, so the time of the last row drifts by one sample
        per repeat (0.125 s over a stair log); ``"drop"`` removes the second row of each pair
        (keeps the original clock, loses those samples); ``"raise"`` refuses the log.

    Returns
    -------
    IOData
        Named after the file (``name`` is the file name), ``t0`` the first time stamp. The
        experiment's conditions come from the file name (:func:`conditions_from_name`): the
        payload on the head [kg] and the controller that ran (``"ada"``, ``"fra"``, ``"int"``).

    Raises
    ------
    ValueError
        For an unknown layout (the message shows the first row), a row with another number of
        fields, a field that is not a finite number (file line and column are named), time going
        back, or a gap larger than 5 % of ``ts``.
    KeyError
        If ``inputs`` or ``outputs`` names a channel that the log does not hold.

    Notes
    -----
    Source and provenance: see the module docstring. Sample time 0.025 s; angles of the
    inclination in degrees, motor angles in radians at the gearbox output (24:1 gear).

    Examples
    --------
    >>> import os, tempfile
    >>> from neckid.datasets import load_softneck_log
    >>> path = os.path.join(tempfile.mkdtemp(), "fra000stepresponse.csv")
    >>> rows = [f"{20 + 0.025 * k}, {0.1 * k}, {0.5 + 0.01 * k}, {0.12 * k}, 2.0, 1.9"
    ...         for k in range(4)]
    >>> _ = open(path, "w").write("\n".join(rows) + "\n")
    >>> data = load_softneck_log(path)
    >>> data
    IOData(n_samples=4, ts=0.025, inputs=['motor_position', 'velocity_command', 'motor_velocity'],
           outputs=['inclination', 'inclination_filtered'], name='fra000stepresponse.csv',
           conditions={'payload': 0.0, 'controller': 'fra'})
    >>> data.t0, data.unit("motor_position"), data.unit("inclination")
    (20.0, 'rad', 'deg')
    >>> dict(data.conditions), data.condition_units["payload"]
    ({'payload': 0.0, 'controller': 'fra'}, 'kg')
    >>> load_softneck_log(path, inputs=["motor_position"], outputs=["inclination"])
    IOData(n_samples=4, ts=0.025, inputs=['motor_position'], outputs=['inclination'], name=...)
    """
    path = Path(path)
    if repeated_stamps not in ("restamp", "drop", "raise"):
        raise ValueError(
            f"repeated_stamps must be 'restamp', 'drop' or 'raise'; got {repeated_stamps!r}"
        )
    values, layout = _read_rows(path)
    keep, ts_value, t0 = _regularise_time(values[:, 0], ts, repeated_stamps, path.name)
    values = values[keep]
    by_name = {n: values[:, j + 1] for j, n in enumerate(layout.columns)}
    input_names = [n for n in _INPUT_ORDER if n in by_name]
    output_names = [n for n in _OUTPUT_ORDER if n in by_name]
    data = IOData(
        u=np.column_stack([by_name[n] for n in input_names]),
        y=np.column_stack([by_name[n] for n in output_names]),
        ts=ts_value,
        input_names=input_names,
        output_names=output_names,
        input_units=[CHANNELS[n][0] for n in input_names],
        output_units=[CHANNELS[n][0] for n in output_names],
        t0=t0,
        name=path.name,
        **conditions_from_name(path.name),
    )
    if inputs is not None or outputs is not None:
        data = data.select(inputs=inputs, outputs=outputs)
    return data


def load_softneck_directory(
    path: str | Path,
    pattern: str = "**/*.csv",
    **options: object,
) -> dict[str, IOData]:
    r"""Read every soft-neck log under a folder.

    Parameters
    ----------
    path : str or Path
        The folder (for the public set: ``softneck/`` with ``id/``, ``stair/``, ``step/``).
    pattern : str, default ``"**/*.csv"``
        Glob pattern of the files, relative to ``path``.
    **options
        Passed to :func:`load_softneck_log` (``inputs``, ``outputs``, ``ts``, ``repeated_stamps``).

    Returns
    -------
    dict of str to IOData
        Keyed by the path relative to ``path`` with ``/`` separators (``"stair/ada000response.csv"``),
        sorted by key. Logs of different layouts have different channels.

    Raises
    ------
    FileNotFoundError
        If ``path`` is not a folder or no file matches.
    ValueError
        If a file cannot be read; the message names it.

    Examples
    --------
    >>> import os, tempfile
    >>> from neckid.datasets import load_softneck_directory
    >>> folder = tempfile.mkdtemp()
    >>> os.makedirs(os.path.join(folder, "step"))
    >>> for name in ("200stepresponse.csv", "400stepresponse.csv"):
    ...     rows = [f"{0.025 * k}, {0.1 * k}, {0.5 + 0.01 * k}" for k in range(5)]
    ...     _ = open(os.path.join(folder, "step", name), "w").write("\n".join(rows) + "\n")
    >>> sorted(load_softneck_directory(folder))
    ['step/200stepresponse.csv', 'step/400stepresponse.csv']
    """
    folder = Path(path)
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder} is not a folder of soft-neck logs")
    files = sorted(p for p in folder.glob(pattern) if p.is_file())
    if not files:
        raise FileNotFoundError(f"no file matches {pattern!r} under {folder}")
    logs: dict[str, IOData] = {}
    for file in files:
        key = file.relative_to(folder).as_posix()
        try:
            logs[key] = load_softneck_log(file, **options)  # type: ignore[arg-type]
        except ValueError as exc:
            raise ValueError(f"{key}: {exc}") from exc
    return logs
