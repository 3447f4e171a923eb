"""Every column of a log file, whatever its format: what ``neckid info`` describes.

:func:`whole_table` reads a CSV with a header row, a Parquet file or a MATLAB ``.mat`` file
(v4 to v7.3) into one table of columns, the time column in seconds, without knowing in advance
which columns are channels. The readers that build an ``IOData``
(:mod:`neckid.data.readers`) read only the columns named.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from neckid.data.csv_logs import read_csv_frame
from neckid.data.parquet import read_parquet_columns
from neckid.data.readers import (
    _mat_variables,
    _time_kind,
    _time_seconds,
    _Unreadable,
    time_unit_scale,
)

__all__ = ["whole_table"]


def _mat_table(path: Path) -> tuple[pd.DataFrame, list[str]]:
    """The numeric vectors of a ``.mat`` file of the most common length; the others, described."""
    variables = _mat_variables(path, [])
    vectors: dict[str, np.ndarray] = {}
    skipped: list[str] = []
    for name, value in variables.items():
        if isinstance(value, _Unreadable) and value.what == "not read":
            value = _mat_variables(path, [name]).get(name, value)
        array = None if isinstance(value, _Unreadable) else np.asarray(value)
        if array is None or array.dtype.kind not in "biuf" or np.squeeze(array).ndim != 1:
            if isinstance(value, _Unreadable):
                what = value.what
            elif array is not None and array.dtype.kind in "US":
                what = "text"
            else:
                what = f"shape {np.shape(value)}, {np.asarray(value).dtype}"
            skipped.append(f"{name} ({what})")
            continue
        vectors[name] = np.squeeze(array).astype(np.float64)
    if not vectors:
        raise ValueError(
            f"{path.name} holds no numeric vector to describe (variables: {', '.join(skipped)})"
        )
    lengths = [v.size for v in vectors.values()]
    common = max(set(lengths), key=lengths.count)
    for name in [n for n, v in vectors.items() if v.size != common]:
        skipped.append(f"{name} ({vectors.pop(name).size} values, the others {common})")
    return pd.DataFrame(vectors), skipped


def whole_table(path: str | Path, *, sep: str = ",", time: str = "time") -> dict[str, Any]:
    """Every column of a CSV, Parquet or ``.mat`` log, by the file's extension.

    Parameters
    ----------
    path : str or Path
        The log: ``.parquet``, ``.mat``, or anything else read as CSV with a header row.
    sep : str, default ","
        The CSV separator.
    time : str, default "time"
        The time column; dates and durations (Parquet ``datetime64`` / ``timedelta64``) become
        seconds since the first sample.

    Returns
    -------
    dict
        ``{"frame": DataFrame, "format": "csv" | "parquet" | "mat", "skipped": [...]}``:
        ``skipped`` describes the ``.mat`` variables that are no numeric vector of the common
        length.

    Raises
    ------
    ValueError
        If the file cannot be read as its format, naming the file and why.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    skipped: list[str] = []
    if suffix == ".parquet":
        frame, kind = read_parquet_columns(path, None), "parquet"
    elif suffix == ".mat":
        (frame, skipped), kind = _mat_table(path), "mat"
    else:
        frame, kind = read_csv_frame(path, sep=sep), "csv"
    if time in frame.columns:
        try:
            seconds = _time_seconds(frame[time], time)
            if _time_kind(frame[time]) is None:
                units = frame.attrs.get("units", {})
                seconds = seconds * time_unit_scale(time, units.get(time, ""))
            frame[time] = seconds
        except ValueError as exc:
            raise ValueError(f"{path.name}: {exc}") from None
    return {"frame": frame, "format": kind, "skipped": skipped}
