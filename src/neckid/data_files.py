"""IOData to and from tables and files: pandas DataFrames, CSV, Parquet and MATLAB ``.mat``.

The :class:`~neckid.data.IOData` methods :meth:`~neckid.data.IOData.to_frame`,
:meth:`~neckid.data.IOData.from_frame`, :meth:`~neckid.data.IOData.from_csv`,
:meth:`~neckid.data.IOData.from_parquet`, :meth:`~neckid.data.IOData.from_mat`,
:meth:`~neckid.data.IOData.to_csv` and :meth:`~neckid.data.IOData.to_parquet` are the entry points
(their docstrings hold the details) and call the functions here, which keep the container's
module free of file formats.

A table has one row per sample, a column per channel and, optionally, a ``time`` column in
seconds whose stamps must be sorted, distinct and uniform within 5 %
(:func:`~neckid.validation.check_uniform_time`). Units travel in ``DataFrame.attrs["units"]``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from neckid.data import IOData
from neckid.validation import check_uniform_time

__all__ = [
    "from_frame",
    "read_csv",
    "read_mat",
    "read_parquet",
    "to_frame",
    "write_csv",
    "write_parquet",
]

FloatArray = NDArray[np.float64]


def to_frame(data: IOData, time: str | None = "time") -> pd.DataFrame:
    """A DataFrame with a time column (seconds) and one column per channel; see :meth:`IOData.to_frame`."""
    columns: dict[str, FloatArray] = {}
    if time is not None:
        columns[time] = data.time
    for i, n in enumerate(data.input_names):
        columns[n] = data.u[:, i].copy()
    for i, n in enumerate(data.output_names):
        columns[n] = data.y[:, i].copy()
    frame = pd.DataFrame(columns)
    frame.attrs["units"] = dict(
        zip(
            data.input_names + data.output_names,
            data.input_units + data.output_units,
            strict=True,
        )
    )
    frame.attrs["inputs"] = list(data.input_names)
    frame.attrs["outputs"] = list(data.output_names)
    frame.attrs["ts"] = data.ts
    return frame


def from_frame(
    frame: pd.DataFrame,
    inputs: Sequence[str],
    outputs: Sequence[str] = (),
    *,
    time: str | None = None,
    ts: float | None = None,
    units: Mapping[str, str] | None = None,
    name: str | None = None,
) -> IOData:
    """An IOData from named columns of a DataFrame; see :meth:`IOData.from_frame`.

    Raises
    ------
    TypeError
        If ``frame`` is not a DataFrame.
    KeyError
        If a named column is not in the table (the message lists the columns there are).
    ValueError
        If not exactly one of ``time`` and ``ts`` is given, a column is not numeric (the message
        names the column and row), or the time stamps are not sorted, distinct and uniform.
    """
    if not isinstance(frame, pd.DataFrame):
        raise TypeError(f"frame must be a pandas DataFrame; got {type(frame).__name__}")
    if isinstance(inputs, str):
        inputs = [inputs]
    if isinstance(outputs, str):
        outputs = [outputs]
    wanted = [*inputs, *outputs, *([time] if time is not None else [])]
    missing = [c for c in wanted if c not in frame.columns]
    if missing:
        raise KeyError(
            f"columns {missing} are not in the table; it has {list(map(str, frame.columns))}"
        )
    if (time is None) == (ts is None):
        raise ValueError("give exactly one of time= (a time column) and ts= (the sampling period)")
    t0 = 0.0
    if time is not None:
        ts_value, t0 = check_uniform_time(frame[time].to_numpy(dtype=np.float64), time)
    elif ts is not None:  # always true here: exactly one of time and ts was given
        ts_value = ts
    units = dict(units) if units is not None else dict(frame.attrs.get("units", {}))

    def columns(names: Sequence[str]) -> FloatArray:
        if not names:
            return np.zeros((len(frame), 0))
        out = np.empty((len(frame), len(names)))
        for j, c in enumerate(names):
            try:
                out[:, j] = pd.to_numeric(frame[c], errors="raise").to_numpy(dtype=np.float64)
            except (TypeError, ValueError):
                values = pd.to_numeric(frame[c], errors="coerce")
                row = int(np.flatnonzero(values.isna() & frame[c].notna())[0])
                raise ValueError(
                    f"column {c!r} is not numeric: row {row} holds {frame[c].iloc[row]!r}"
                ) from None
        return out

    return IOData(
        u=columns(inputs),
        y=columns(outputs),
        ts=ts_value,
        input_names=list(inputs),
        output_names=list(outputs),
        input_units=[units.get(c, "") for c in inputs],
        output_units=[units.get(c, "") for c in outputs],
        t0=t0,
        name=name,
    )


def _from_file_frame(
    path: Path,
    frame: pd.DataFrame,
    inputs: Sequence[str],
    outputs: Sequence[str],
    time: str | None,
    ts: float | None,
    units: Mapping[str, str] | None,
) -> IOData:
    """A table read from a file; an explicit ``ts`` overrides the default time column."""
    if ts is not None and time == "time":
        time = None
    return from_frame(frame, inputs, outputs, time=time, ts=ts, units=units, name=path.name)


def read_csv(
    path: str | Path,
    inputs: Sequence[str],
    outputs: Sequence[str] = (),
    *,
    time: str | None = "time",
    ts: float | None = None,
    units: Mapping[str, str] | None = None,
    **read_csv: Any,
) -> IOData:
    """Read a CSV log with a header row; see :meth:`IOData.from_csv`."""
    path = Path(path)
    return _from_file_frame(path, pd.read_csv(path, **read_csv), inputs, outputs, time, ts, units)


def read_parquet(
    path: str | Path,
    inputs: Sequence[str],
    outputs: Sequence[str] = (),
    *,
    time: str | None = "time",
    ts: float | None = None,
    units: Mapping[str, str] | None = None,
) -> IOData:
    """Read a Parquet log (needs the ``parquet`` extra); see :meth:`IOData.from_parquet`."""
    path = Path(path)
    return _from_file_frame(path, pd.read_parquet(path), inputs, outputs, time, ts, units)


def read_mat(
    path: str | Path,
    inputs: Sequence[str],
    outputs: Sequence[str] = (),
    *,
    time: str | None = None,
    ts: float | str | None = None,
    units: Mapping[str, str] | None = None,
) -> IOData:
    """Read a MATLAB ``.mat`` file (v4 to v7.2) of vectors; see :meth:`IOData.from_mat`.

    Raises
    ------
    KeyError
        If a named variable is not in the file (the message lists the variables there are).
    """
    from scipy.io import loadmat

    path = Path(path)
    content = loadmat(path, squeeze_me=True)
    variables = {k: v for k, v in content.items() if not k.startswith("__")}
    if isinstance(ts, str):
        if ts not in variables:
            raise KeyError(
                f"variable {ts!r} (ts) is not in {path.name}; it has {sorted(variables)}"
            )
        ts = float(np.asarray(variables[ts]).ravel()[0])
    names = [*inputs, *outputs, *([time] if time else [])]
    missing = [n for n in names if n not in variables]
    if missing:
        raise KeyError(f"variables {missing} are not in {path.name}; it has {sorted(variables)}")
    frame = pd.DataFrame({n: np.asarray(variables[n], dtype=np.float64).ravel() for n in names})
    return from_frame(frame, inputs, outputs, time=time, ts=ts, units=units, name=path.name)


def write_parquet(data: IOData, path: str | Path) -> None:
    """Write a Parquet file with a ``time`` column; units go in the file's metadata."""
    frame = to_frame(data)
    frame.attrs = {"units": frame.attrs["units"]}
    frame.to_parquet(Path(path), index=False)


def write_csv(data: IOData, path: str | Path) -> None:
    """Write a CSV file with a header row and a ``time`` column (seconds)."""
    to_frame(data).to_csv(Path(path), index=False)
