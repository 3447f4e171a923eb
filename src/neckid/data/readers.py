"""Reading the tables behind an IOData: named columns of a DataFrame, CSV, Parquet and ``.mat`` files.

:meth:`IOData.from_frame <neckid.data.iodata.IOData.from_frame>`, :meth:`~neckid.data.iodata.IOData.from_csv`,
:meth:`~neckid.data.iodata.IOData.from_parquet` and :meth:`~neckid.data.iodata.IOData.from_mat` are the entry
points (their docstrings hold the details). They call the functions here, which read and check a
table and return the keyword arguments of the :class:`~neckid.data.iodata.IOData` constructor; this
module does not import the container, so the dependency runs one way.

A table has one row per sample, a column per channel and, optionally, a column of time stamps in
seconds that must be sorted, distinct and uniform within 5 %
(:func:`~neckid.validation.check_uniform_time`). Units travel in ``DataFrame.attrs["units"]``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from neckid._typing import FloatArray
from neckid.validation import check_uniform_time

__all__ = ["file_fields", "frame_fields", "not_text_message"]


def frame_fields(
    frame: pd.DataFrame,
    inputs: Sequence[str],
    outputs: Sequence[str] = (),
    *,
    time: str | None = None,
    ts: float | None = None,
    units: Mapping[str, str] | None = None,
) -> dict[str, Any]:
    """The IOData keyword arguments held in named columns of a DataFrame.

    Parameters
    ----------
    frame : pandas.DataFrame
        One row per sample.
    inputs, outputs : sequence of str
        Column names of the input and output channels.
    time : str, optional
        Column of time stamps in seconds. Exactly one of ``time`` and ``ts`` must be given.
    ts : float, optional
        Sampling period in seconds, when there is no time column.
    units : mapping of str to str, optional
        Unit of each channel by name; ``frame.attrs["units"]`` is used when absent.

    Returns
    -------
    dict
        ``u``, ``y`` (shape ``(n_samples, n_channels)``), ``ts``, ``t0``, ``input_names``,
        ``output_names``, ``input_units`` and ``output_units``.

    Raises
    ------
    TypeError
        If ``frame`` is not a DataFrame.
    KeyError
        If a named column is not in the table (the message lists the columns there are).
    ValueError
        If not exactly one of ``time`` and ``ts`` is given, a column is not numeric (the message
        names the column and the row), or the time stamps are not sorted, distinct and uniform.

    Examples
    --------
    >>> frame = pd.DataFrame({"time": [0.0, 0.5, 1.0], "cmd": [1.0, 2.0, 3.0]})
    >>> fields = frame_fields(frame, ["cmd"], time="time")
    >>> fields["ts"], fields["input_names"], fields["u"].shape
    (0.5, ['cmd'], (3, 1))
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
        times = pd.to_numeric(frame[time], errors="coerce")
        bad = np.flatnonzero(times.isna().to_numpy())
        if bad.size:
            row = int(bad[0])
            raise ValueError(
                f"time column {time!r} is not numeric: row {row} holds {frame[time].iloc[row]!r};"
                " time must be in seconds"
            )
        ts_value, t0 = check_uniform_time(times.to_numpy(dtype=np.float64), time)
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

    return {
        "u": columns(inputs),
        "y": columns(outputs),
        "ts": ts_value,
        "t0": t0,
        "input_names": list(inputs),
        "output_names": list(outputs),
        "input_units": [units.get(c, "") for c in inputs],
        "output_units": [units.get(c, "") for c in outputs],
    }


def file_fields(
    path: str | Path,
    kind: Literal["csv", "parquet", "mat"],
    inputs: Sequence[str],
    outputs: Sequence[str] = (),
    *,
    time: str | None = None,
    ts: float | str | None = None,
    units: Mapping[str, str] | None = None,
    **read_csv: Any,
) -> dict[str, Any]:
    """The IOData keyword arguments held in a CSV, Parquet or MATLAB file (``name``: the file's).

    Parameters
    ----------
    path : str or Path
        The file.
    kind : {"csv", "parquet", "mat"}
        Its format: a CSV file with a header row (read by :func:`pandas.read_csv`, which gets
        ``**read_csv``), a Parquet file (needs the ``parquet`` extra), or a MATLAB ``.mat`` file
        (v4 to v7.2) whose variables are vectors or one-column matrices.
    inputs, outputs : sequence of str
        Column (or variable) names of the channels.
    time : str, optional
        Column (or variable) of time stamps in seconds. For CSV and Parquet, an explicit ``ts``
        overrides the default time column ``"time"``.
    ts : float or str, optional
        Sampling period in seconds; for a ``.mat`` file it may name a scalar variable holding it.
    units : mapping of str to str, optional
        Unit of each channel by name.

    Returns
    -------
    dict
        What :func:`frame_fields` returns, plus ``name``, the file name.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    KeyError
        If a named column or variable is not in the file (the message lists those there are and,
        for a CSV, says when the file seems to use another separator or to have no header row).
    ValueError
        As :func:`frame_fields`, and for a CSV that cannot be read: not text in its encoding (the
        message gives the first bad byte, its offset and line), not parseable (a row with more
        fields than the header, an unclosed quote), an empty cell or NaN in a column that is read,
        or a header that repeats a name. Every message starts with the file name.
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not a {kind} file")
    if not path.exists():
        raise FileNotFoundError(f"{kind} file {str(path)!r} does not exist")
    if kind == "mat":
        frame, period = _mat_frame(path, [*inputs, *outputs, *([time] if time else [])], ts)
    else:
        if path.stat().st_size == 0:
            raise ValueError(f"log file {str(path)!r} is empty")
        frame = _read_csv(path, read_csv) if kind == "csv" else pd.read_parquet(path)
        if isinstance(ts, str):
            raise TypeError(f"ts must be a number of seconds for a {kind} file; got {ts!r}")
        period = ts
        if period is not None and time == "time":
            time = None
        _check_cells(path, frame, [*inputs, *outputs, *([time] if time is not None else [])])
    try:
        fields = frame_fields(frame, inputs, outputs, time=time, ts=period, units=units)
    except KeyError as exc:
        hint = _header_hint(frame) if kind == "csv" else ""
        raise KeyError(f"{path.name}: {exc.args[0]}{hint}") from None
    except ValueError as exc:
        raise ValueError(f"{path.name}: {exc}") from None
    return {**fields, "name": path.name}


def _read_csv(path: Path, read_csv: dict[str, Any]) -> pd.DataFrame:
    """``pandas.read_csv`` whose failures are ValueErrors naming the file and the reason."""
    try:
        frame = pd.read_csv(path, **read_csv)
        _check_header(path, frame, read_csv)
    except UnicodeDecodeError as exc:
        encoding = str(read_csv.get("encoding") or "utf-8")
        message = not_text_message(path, path.read_bytes(), encoding, exc)
        raise ValueError(f"{message}; save it as UTF-8 text or pass encoding=...") from None
    except pd.errors.EmptyDataError:
        raise ValueError(
            f"{path.name} holds no CSV header and no data (only blank lines or spaces)"
        ) from None
    except pd.errors.ParserError as exc:
        reason = " ".join(str(exc).replace("Error tokenizing data. C error: ", "").split())
        raise ValueError(f"{path.name}: cannot parse as CSV: {reason}") from None
    return frame


def not_text_message(path: Path, data: bytes, encoding: str, error: UnicodeDecodeError) -> str:
    """The message for a file that is not text in ``encoding``: the first bad byte and its line.

    ``error`` is the decoder's error; the position is found again by decoding ``data`` (the whole
    file) here, since a CSV parser reports it within a field.
    """
    try:
        data.decode(encoding)
    except UnicodeDecodeError as exc:
        offset = exc.start
    except LookupError:  # an encoding Python does not know: pandas would have said so first
        return f"{path.name} is not a text CSV: {error.reason}"
    else:
        return f"{path.name} is not a text CSV: {error.reason}"
    line = data.count(b"\n", 0, offset) + 1
    return (
        f"{path.name} is not a text CSV (byte 0x{data[offset]:02x} at offset {offset}, line"
        f" {line}, is not valid {encoding})"
    )


def _check_cells(path: Path, frame: pd.DataFrame, names: Sequence[str]) -> None:
    """Refuse an empty (or NaN) cell in a column that is read, naming the column and the row."""
    for name in names:
        if name not in frame.columns:
            continue  # frame_fields says which columns are missing
        column = frame[name]
        if isinstance(column, pd.DataFrame):
            continue  # a repeated name: frame_fields refuses it
        missing = np.flatnonzero(column.isna().to_numpy())
        if missing.size:
            row = int(missing[0])
            raise ValueError(
                f"{path.name}: column {name!r} has no value at row {row} (an empty cell or"
                f" NaN; {missing.size} in all); fill or drop those rows first"
            )


def _header_hint(frame: pd.DataFrame) -> str:
    """Why the named columns may be missing: another separator, or no header row."""
    names = [str(c) for c in frame.columns]
    if len(names) == 1:
        for separator in (";", "\t", "|", " "):
            if separator in names[0]:
                return f"; the header is one column holding {separator!r}: pass sep={separator!r}"
    try:
        [float(n) for n in names]
    except ValueError:
        return ""
    return (
        "; the first row holds numbers, not names: the file has no header row; pass"
        " header=None, names=[...] to name the columns"
    )


def _check_header(path: Path, frame: pd.DataFrame, read_csv: dict[str, Any]) -> None:
    """Refuse a CSV whose header repeats a column name (pandas would rename the second one)."""
    if read_csv.get("header", "infer") is None or not len(frame.columns):
        return
    first = pd.read_csv(
        path,
        nrows=1,
        header=None,
        dtype=str,
        keep_default_na=False,
        **{k: v for k, v in read_csv.items() if k not in ("header", "dtype", "keep_default_na")},
    )
    names = [str(n).strip() for n in first.iloc[0].tolist()]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(
            f"{path.name}: column name {repeated[0]!r} appears {names.count(repeated[0])} times in"
            " the header; rename the columns so that each is unique"
        )


def _mat_frame(
    path: Path, names: Sequence[str], ts: float | str | None
) -> tuple[pd.DataFrame, float | None]:
    """The named variables of a ``.mat`` file as columns, and ``ts`` read from it if named."""
    from scipy.io import loadmat

    content = loadmat(path, squeeze_me=True)
    variables = {k: v for k, v in content.items() if not k.startswith("__")}
    if isinstance(ts, str):
        if ts not in variables:
            raise KeyError(
                f"variable {ts!r} (ts) is not in {path.name}; it has {sorted(variables)}"
            )
        ts = float(np.asarray(variables[ts]).ravel()[0])
    missing = [n for n in names if n not in variables]
    if missing:
        raise KeyError(f"variables {missing} are not in {path.name}; it has {sorted(variables)}")
    frame = pd.DataFrame({n: np.asarray(variables[n], dtype=np.float64).ravel() for n in names})
    return frame, ts
