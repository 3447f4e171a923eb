"""Reading the tables behind an IOData: named columns of a DataFrame, CSV, Parquet and ``.mat`` files.

:meth:`IOData.from_frame <neckid.data.iodata.IOData.from_frame>`, :meth:`~neckid.data.iodata.IOData.from_csv`,
:meth:`~neckid.data.iodata.IOData.from_parquet` and :meth:`~neckid.data.iodata.IOData.from_mat` are the entry
points (their docstrings hold the details). They call the functions here, which read and check a
table and return the keyword arguments of the :class:`~neckid.data.iodata.IOData` constructor; this
module does not import the container, so the dependency runs one way.

A table has one row per sample, a column per channel and, optionally, a column of time stamps in
seconds that must be sorted, distinct and uniform within 5 %
(:func:`~neckid.utils.checks.check_uniform_time`). Units travel in ``DataFrame.attrs["units"]``.
"""

from __future__ import annotations

import contextlib
import faulthandler
import multiprocessing
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from neckid.data.csv_logs import _header_hint, _read_csv
from neckid.utils.checks import check_uniform_time
from neckid.utils.memory import check_allocation
from neckid.utils.types import FloatArray

__all__ = ["file_fields", "frame_fields", "time_unit_scale"]


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
    units = dict(units) if units is not None else dict(frame.attrs.get("units", {}))
    if time is not None:
        _check_exact_integers(frame[time], f"time column {time!r}")
        times = _time_seconds(frame[time], time)
        if _time_kind(frame[time]) is None:
            times = times * time_unit_scale(time, units.get(time, ""))
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

    def columns(names: Sequence[str]) -> FloatArray:
        if not names:
            return np.zeros((len(frame), 0))
        out = np.empty((len(frame), len(names)))
        for j, c in enumerate(names):
            _check_values(frame[c], c)
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


#: The largest integer a float64 holds exactly: larger integers in a log would be rounded.
LARGEST_EXACT_INTEGER = 2**53

#: Units of time a time column may be in (its header ``time [ms]``, ``time (us)``, ``time_ms``,
#: or its unit in the file), in seconds.
TIME_UNITS = {
    "s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0,
    "ms": 1e-3, "msec": 1e-3, "millisecond": 1e-3, "milliseconds": 1e-3,
    "us": 1e-6, "\u00b5s": 1e-6, "\u03bcs": 1e-6, "usec": 1e-6, "microsecond": 1e-6,
    "microseconds": 1e-6,
    "ns": 1e-9, "nsec": 1e-9, "nanosecond": 1e-9, "nanoseconds": 1e-9,
    "min": 60.0, "minute": 60.0, "minutes": 60.0, "h": 3600.0, "hour": 3600.0, "hours": 3600.0,
}  # fmt: skip

_BRACKETED_UNIT = re.compile(r"[\[(]\s*([^\[\]()]*?)\s*[\])]\s*$")
_SUFFIX_UNIT = re.compile(r"[_ ](s|sec|ms|msec|us|\u00b5s|\u03bcs|usec|ns|nsec|min)$")


def time_unit_scale(name: str, unit: str = "") -> float:
    """Seconds per unit of a time column: from its header (``time [ms]``) or its ``unit``.

    A header that names a unit in brackets (``[ms]``, ``(us)``) or ends in one (``time_ms``) is
    honoured, as is a unit stored with the column; none means seconds. A unit that is not one of
    time, or a header and a stored unit that disagree, is refused.

    Examples
    --------
    >>> time_unit_scale("time [ms]")
    0.001
    >>> time_unit_scale("t_us"), time_unit_scale("time"), time_unit_scale("time", "ns")
    (1e-06, 1.0, 1e-09)
    """
    found = _BRACKETED_UNIT.search(str(name))
    header_unit = found.group(1) if found else None
    if header_unit is None:
        suffix = _SUFFIX_UNIT.search(str(name))
        header_unit = suffix.group(1) if suffix else None
    known = ", ".join(["s", "ms", "us", "ns", "min", "h"])
    scales = []
    for where, text in (("its header", header_unit), ("its stored unit", unit or None)):
        if text is None:
            continue
        scale = TIME_UNITS.get(text.strip().lower()) if text.strip() else 1.0
        if scale is None:
            raise ValueError(
                f"time column {name!r} is in {text!r} ({where}), not a unit of time neckid"
                f" knows ({known}): convert the stamps to seconds"
            )
        scales.append(scale)
    if len(set(scales)) > 1:
        raise ValueError(
            f"time column {name!r}: its header says {header_unit!r} but its stored unit is"
            f" {unit!r}; correct one of them"
        )
    return scales[0] if scales else 1.0


def _time_kind(column: pd.Series) -> str | None:
    """``"datetime"`` or ``"timedelta"`` for a column of dates or durations, else None."""
    if isinstance(column, pd.DataFrame):
        return None
    if pd.api.types.is_datetime64_any_dtype(column.dtype):
        return "datetime"
    if pd.api.types.is_timedelta64_dtype(column.dtype):
        return "timedelta"
    if column.dtype == object:
        inferred = pd.api.types.infer_dtype(column, skipna=True)
        if inferred in ("datetime", "datetime64", "date"):
            return "datetime"
        if inferred in ("timedelta", "timedelta64"):
            return "timedelta"
    return None


def _time_seconds(column: pd.Series, name: str) -> pd.Series:
    """Time stamps in seconds: numbers as they are, dates and durations since the first sample.

    Dates and durations are a Parquet or pandas ``datetime64`` / ``timedelta64`` column (or
    Python ``datetime`` / ``timedelta`` objects).
    """
    kind = _time_kind(column)
    if kind is None:
        return pd.to_numeric(column, errors="coerce")
    try:
        stamps: Any = pd.to_datetime(column) if kind == "datetime" else pd.to_timedelta(column)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(
            f"time column {name!r} holds {kind}s that cannot be read ({exc}); store seconds"
        ) from None
    if not len(stamps):
        return pd.Series(np.zeros(0), index=column.index)
    missing = np.flatnonzero(stamps.isna().to_numpy())
    if missing.size:
        raise ValueError(
            f"time column {name!r} has no time stamp at row {int(missing[0])} (NaT); fill or"
            " drop those rows first"
        )
    since: Any = stamps - stamps.iloc[0]  # a Series of timedeltas
    return pd.Series(since.dt.total_seconds().to_numpy(), index=column.index)


def _check_values(column: pd.Series, name: str) -> None:
    """Refuse dates as channel values, and whole numbers that a float cannot hold exactly."""
    if isinstance(column, pd.DataFrame):
        return  # a repeated name: refused elsewhere
    kind = _time_kind(column)
    if kind is not None:
        raise ValueError(
            f"column {name!r} holds {kind}s (row 0 holds {column.iloc[0]!r}), not numbers; a"
            " channel must be numeric: convert it to seconds or a number first, or name it as"
            " the time column"
        )
    _check_exact_integers(column, f"column {name!r}")


def _check_exact_integers(column: pd.Series, what: str) -> None:
    """Refuse whole numbers beyond 2**53 in a column (``what`` names it): a float rounds them."""
    if isinstance(column, pd.DataFrame):
        return  # a repeated name: refused elsewhere
    if column.dtype == object:
        numbers = [
            (row, value)
            for row, value in enumerate(column.to_numpy())
            if isinstance(value, int | np.integer) and not isinstance(value, bool)
        ]
    elif pd.api.types.is_integer_dtype(column.dtype):
        rows = np.flatnonzero(column.notna().to_numpy())  # pandas' nullable integers: no NA
        values = column.iloc[rows].to_numpy(
            dtype=np.uint64 if column.dtype.kind == "u" else np.int64
        )
        big = np.flatnonzero(
            (values > LARGEST_EXACT_INTEGER)
            | ((values < -LARGEST_EXACT_INTEGER) if values.dtype.kind == "i" else False)
        )
        numbers = [(int(rows[big[0]]), values[big[0]])] if big.size else []
    else:
        return
    for row, value in numbers:
        if abs(int(value)) > LARGEST_EXACT_INTEGER:
            raise ValueError(
                f"{what} holds the whole number {int(value)} at row {row}, beyond 2**53"
                f" ({LARGEST_EXACT_INTEGER}): a float cannot hold it exactly; store it in a"
                " coarser unit or as a float"
            )


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
    inputs = [inputs] if isinstance(inputs, str) else list(inputs)
    outputs = [outputs] if isinstance(outputs, str) else list(outputs)
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not a {kind} file")
    if not path.exists():
        raise FileNotFoundError(f"{kind} file {str(path)!r} does not exist")
    # With ts given, the time column (the default "time" or the one named) is not read as time
    # stamps but checked against ts: a ts that contradicts the stamps is refused.
    stamps = time if ts is not None else None
    time = None if ts is not None else time
    if kind == "mat":
        channels = [*inputs, *outputs, *([time] if time else [])]
        try:
            frame, period = _mat_frame(path, [*channels, *([stamps] if stamps else [])], ts)
        except KeyError:
            if not stamps:
                raise
            frame, period = _mat_frame(path, channels, ts)
    else:
        if path.stat().st_size == 0:
            raise ValueError(f"log file {str(path)!r} is empty")
        if isinstance(ts, str):
            raise TypeError(f"ts must be a number of seconds for a {kind} file; got {ts!r}")
        period = ts
        wanted = [*inputs, *outputs, *([time] if time is not None else [])]
        if kind == "csv":
            frame = _read_csv(path, read_csv)
        else:
            from neckid.data.parquet import read_parquet_columns

            frame = read_parquet_columns(path, wanted)
            if stamps is not None and stamps not in frame.columns:
                with contextlib.suppress(KeyError):  # no such column: ts alone gives the time
                    frame[stamps] = read_parquet_columns(path, [stamps])[stamps].to_numpy()
        _check_cells(path, frame, wanted)
    try:
        if stamps is not None and period is not None:
            _check_ts_agrees(frame, stamps, float(period), units)
        fields = frame_fields(frame, inputs, outputs, time=time, ts=period, units=units)
    except KeyError as exc:
        hint = _header_hint(frame) if kind == "csv" else ""
        raise KeyError(f"{path.name}: {exc.args[0]}{hint}") from None
    except ValueError as exc:
        raise ValueError(f"{path.name}: {exc}") from None
    return {**fields, "name": path.name}


def _check_ts_agrees(
    frame: pd.DataFrame, name: str, ts: float, units: Mapping[str, str] | None
) -> None:
    """Refuse a ``ts`` that departs by more than 1 % from the step of the time column ``name``.

    A table without that column, or whose column holds no readable time stamps, has nothing to
    contradict ``ts``: ``ts`` gives the time alone.
    """
    if name not in frame.columns or isinstance(frame[name], pd.DataFrame):
        return
    column = frame[name]
    try:
        stored = dict(units if units is not None else frame.attrs.get("units", {}))
        seconds = _time_seconds(column, name)
        if _time_kind(column) is None:
            seconds = seconds * time_unit_scale(name, stored.get(name, ""))
    except ValueError:
        return
    steps = np.diff(seconds.to_numpy(dtype=np.float64))
    steps = steps[np.isfinite(steps) & (steps > 0)]
    if not steps.size:
        return
    step = float(np.median(steps))
    if abs(step - ts) > 0.01 * ts:
        raise ValueError(
            f"ts={ts:g} s (--ts) contradicts the time column {name!r}, whose stamps are"
            f" {step:.6g} s apart: give no ts to use the time column, correct ts (one within 1 %"
            " of the stamps' step is taken as given), or ignore the column (time=None, --time '')"
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


#: The first bytes of an HDF5 file (MATLAB v7.3 writes them after a 512-byte text header).
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def _is_hdf5(path: Path) -> bool:
    with path.open("rb") as handle:
        head = handle.read(520)
    return head[:8] == _HDF5_SIGNATURE or head[512:520] == _HDF5_SIGNATURE


def _mat_variables(path: Path, names: Sequence[str]) -> dict[str, Any]:
    """The variables ``names`` of a ``.mat`` file (v4 to v7.3) that it holds, as arrays.

    The file is parsed in a forked child process where the platform allows it: SciPy's MATLAB
    reader and the HDF5 library are compiled code, and some damaged files crash them (a bus
    error or a segmentation fault, seen when fuzzing), which in this process would end the
    program without a word. A crash of the child becomes one clear error naming the file.
    """
    if path.stat().st_size == 0:
        raise ValueError(f"{path.name}: the MATLAB file is empty")
    if "fork" not in multiprocessing.get_all_start_methods():
        return _mat_variables_here(path, names)
    context = multiprocessing.get_context("fork")
    receiver, sender = context.Pipe(duplex=False)
    child = context.Process(target=_mat_child, args=(sender, path, tuple(names)), daemon=True)
    child.start()
    sender.close()
    try:
        status, value = receiver.recv()
    except EOFError:
        child.join()
        raise ValueError(
            f"{path.name} is not a readable MATLAB .mat file: the MATLAB reader crashed on it"
            f" (exit status {child.exitcode}); the file is damaged"
        ) from None
    finally:
        receiver.close()
    child.join()
    if status == "error":
        raise ValueError(str(value))
    return dict(value)


def _mat_child(sender: Any, path: Path, names: tuple[str, ...]) -> None:
    """In the child process: read the variables and send them, or the error's message."""
    # A crash here is reported by the parent in one line; no fault dump on the shared stderr.
    faulthandler.disable()
    try:
        sender.send(("ok", _mat_variables_here(path, names)))
    except ValueError as exc:
        sender.send(("error", str(exc)))
    except Exception as exc:  # anything else the readers raise: reported, not a crash
        sender.send(("error", f"{path.name} is not a readable MATLAB .mat file ({exc!r})"))
    finally:
        sender.close()


def _mat_variables_here(path: Path, names: Sequence[str]) -> dict[str, Any]:
    """:func:`_mat_variables` in this process."""
    if path.stat().st_size == 0:
        raise ValueError(f"{path.name}: the MATLAB file is empty")
    if _is_hdf5(path):
        return _mat73_variables(path, names)
    from scipy.io import loadmat, whosmat

    try:
        listed = whosmat(path)  # names, shapes and classes, from the headers: nothing read yet
    except NotImplementedError:  # scipy says so for v7.3 files it did not recognise above
        return _mat73_variables(path, names)
    except Exception as exc:  # scipy raises many types on a damaged file; the reason is kept
        raise _not_a_mat_file(path, exc) from None
    wanted = [(n, shape) for n, shape, _ in listed if n in names]
    n_values = sum(int(np.prod(shape, dtype=object)) for _, shape in wanted)
    check_allocation(
        8 * n_values,
        f"{path.name}: reading the variables {[n for n, _ in wanted]} ({n_values} values)",
        "the file is damaged, or save a part of it in MATLAB and read that",
    )
    try:
        content = loadmat(path, squeeze_me=True, variable_names=[n for n, _ in wanted])
    except MemoryError:
        raise ValueError(
            f"{path.name} is not a readable MATLAB file: it declares more data than fits in memory"
        ) from None
    except Exception as exc:  # as above
        raise _not_a_mat_file(path, exc) from None
    variables: dict[str, Any] = {n: _Unreadable("not read") for n, _, _ in listed}
    variables.update({k: v for k, v in content.items() if not k.startswith("__")})
    return variables


def _not_a_mat_file(path: Path, error: Exception) -> ValueError:
    reason = " ".join(str(error).split()) or type(error).__name__
    return ValueError(
        f"{path.name} is not a readable MATLAB .mat file ({type(error).__name__}: {reason[:200]})"
    )


def _mat73_variables(path: Path, names: Sequence[str]) -> dict[str, Any]:
    """Variables of a MATLAB v7.3 file (HDF5), read with h5py.

    Numeric ones are arrays; the others a description of what they are (refused by
    :func:`_mat_vector`).
    """
    try:
        import h5py
    except ImportError:
        raise ValueError(
            f"{path.name} is a MATLAB v7.3 file (HDF5), which needs h5py: pip install h5py (or"
            " neckid[data]), or save it in MATLAB with save(..., '-v7')"
        ) from None
    variables: dict[str, Any] = {}
    try:
        with h5py.File(path, "r") as handle:
            for key in handle:
                if key.startswith("#"):
                    continue  # MATLAB's hidden #refs# group
                item = handle[key]
                if not isinstance(item, h5py.Dataset):
                    variables[key] = _Unreadable("a struct, not a numeric vector")
                    continue
                matlab_class = item.attrs.get("MATLAB_class", b"")
                if isinstance(matlab_class, bytes):
                    matlab_class = matlab_class.decode("ascii", "replace")
                if key not in names:
                    variables[key] = _Unreadable("not read")
                elif matlab_class == "char":
                    variables[key] = _Unreadable("text, not numbers")
                elif matlab_class == "cell" or item.dtype.kind == "O":
                    variables[key] = _Unreadable("a cell array, not a numeric vector")
                elif item.dtype.names is not None:
                    variables[key] = (
                        _Unreadable("complex numbers")
                        if set(item.dtype.names) == {"real", "imag"}
                        else _Unreadable("a record, not a numeric vector")
                    )
                elif item.attrs.get("MATLAB_empty", 0):
                    variables[key] = np.zeros(0)
                elif item.size > 10**9:
                    variables[key] = _Unreadable(f"{item.size} values, more than fit in memory")
                else:
                    variables[key] = np.squeeze(item[()])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(
            f"{path.name} is not a readable MATLAB v7.3 file ({type(exc).__name__}:"
            f" {' '.join(str(exc).split())[:200]})"
        ) from None
    return variables


class _Unreadable:
    """A variable of a ``.mat`` file that is not numbers: what it is, for the message."""

    def __init__(self, what: str) -> None:
        self.what = what


def _mat_vector(path: Path, name: str, value: Any) -> np.ndarray:
    """A variable as a 1-D real array; text, complex, cells, structs and matrices refused."""
    if isinstance(value, _Unreadable):
        raise ValueError(f"{path.name}: variable {name!r} holds {value.what}; a channel must be a"
                         " real numeric vector")  # fmt: skip
    array = np.asarray(value)
    kind = array.dtype.kind
    if hasattr(value, "tocsc"):  # scipy.sparse: a 0-d array of one object for NumPy
        what = "a sparse matrix"
    elif kind in "USa" or (kind == "O" and any(isinstance(v, str) for v in array.ravel()[:1])):
        what = "text"
    elif kind == "c":
        what = "complex numbers"
    elif kind in "OV":
        what = "a cell array or a struct"
    elif kind in "biuf":
        what = ""
    else:
        what = f"values of type {array.dtype}"
    if what:
        raise ValueError(
            f"{path.name}: variable {name!r} holds {what}; a channel must be a real numeric vector"
        )
    if array.ndim > 1:
        shape = "x".join(str(n) for n in array.shape)
        raise ValueError(
            f"{path.name}: variable {name!r} is a {shape} matrix; a channel must be a vector (one"
            " value per sample): save each column as its own variable"
        )
    if array.size == 0:
        raise ValueError(f"{path.name}: variable {name!r} is empty")
    if array.ndim == 0:
        raise ValueError(
            f"{path.name}: variable {name!r} is a single number, not a vector of samples"
        )
    return array.astype(np.float64) if kind == "b" else array


def _mat_frame(
    path: Path, names: Sequence[str], ts: float | str | None
) -> tuple[pd.DataFrame, float | None]:
    """The named variables of a ``.mat`` file as columns, and ``ts`` read from it if named.

    Every variable read must be a real numeric vector (a row or column matrix counts), all of
    one length; MATLAB v7.3 files (HDF5) are read with h5py when it is installed.
    """
    variables = _mat_variables(path, [*names, *([ts] if isinstance(ts, str) else [])])
    listed = sorted(k for k in variables)
    if isinstance(ts, str):
        if ts not in variables:
            raise KeyError(f"variable {ts!r} (ts) is not in {path.name}; it has {listed}")
        value = variables[ts]
        array = None if isinstance(value, _Unreadable) else np.asarray(value)
        if array is None or array.size != 1 or array.dtype.kind not in "iuf":
            raise ValueError(
                f"{path.name}: variable {ts!r} (ts) must hold one real number of seconds; got"
                f" {value.what if isinstance(value, _Unreadable) else f'shape {array.shape}, dtype {array.dtype}'}"  # type: ignore[union-attr]
            )
        ts = float(array.ravel()[0])
    missing = [n for n in names if n not in variables]
    if missing:
        raise KeyError(f"variables {missing} are not in {path.name}; it has {listed}")
    columns = {n: _mat_vector(path, n, variables[n]) for n in dict.fromkeys(names)}
    lengths = {n: int(v.shape[0]) for n, v in columns.items()}
    if len(set(lengths.values())) > 1:
        described = ", ".join(f"{n!r} has {k}" for n, k in lengths.items())
        raise ValueError(
            f"{path.name}: the variables read have unequal lengths ({described} samples); every"
            " channel needs one value per sample"
        )
    return pd.DataFrame(columns), ts
