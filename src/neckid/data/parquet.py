"""Reading the named columns of a Parquet log, checked before they are read.

pyarrow reports a damaged file in its own exception types (``ArrowInvalid``, ``ArrowIOError``,
``ArrowNotImplementedError``), pandas its damaged metadata in ``JSONDecodeError`` or
``UnicodeDecodeError``, often on several lines and without the file's name; a file may repeat a
column name, which pyarrow reports as "Multiple matches for FieldRef"; and a few kilobytes of
run-length encoded values can declare more rows than the machine's memory holds. Here each of
these is one error naming the file, raised before the values are read: only the columns asked
for are read, from the file's schema and row count.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from neckid.utils.memory import check_allocation

__all__ = ["BYTES_PER_VALUE", "read_parquet_columns"]

#: Memory one value of a column takes while it is read: pyarrow's table, the pandas frame and
#: the float64 arrays of the log (8 bytes each).
BYTES_PER_VALUE = 24


def read_parquet_columns(path: str | Path, names: Sequence[str] | None) -> pd.DataFrame:
    """The columns ``names`` of the Parquet file ``path``, with its ``attrs`` (units) if any.

    The file's schema and row count are read first: a name that is not a column, a column name
    the file repeats, or more rows than half the memory the machine has available would hold
    are refused before any value is read.

    Parameters
    ----------
    path : str or Path
        The Parquet file.
    names : sequence of str or None
        The columns to read (a name given twice is read once); ``None`` reads every column.

    Returns
    -------
    pandas.DataFrame
        One column per name, in the order given.

    Raises
    ------
    KeyError
        If a name is not a column of the file (the message lists those it has).
    ValueError
        If the file is not a readable Parquet file (damaged, truncated, not Parquet), repeats a
        column name that is asked for, or would need more memory than the machine has
        available. Every message starts with the file name.
    ImportError
        If pyarrow is not installed (``pip install neckid[parquet]``).
    """
    path = Path(path)
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise ImportError(
            f"reading {path.name} needs pyarrow, which is not installed: pip install"
            " 'neckid[parquet]' (or pip install pyarrow)",
            name="pyarrow",
        ) from None
    try:
        columns = [str(name) for name in pq.read_schema(path).names]
        n_rows = int(pq.read_metadata(path).num_rows)
    except Exception as exc:  # pyarrow's types on a damaged footer; the reason is kept
        raise _unreadable(path, exc) from None
    wanted = list(dict.fromkeys(columns if names is None else names))
    missing = [name for name in wanted if name not in columns]
    if missing:
        raise KeyError(f"{path.name}: columns {missing} are not in the table; it has {columns}")
    repeated = [name for name in wanted if columns.count(name) > 1]
    if repeated:
        raise ValueError(
            f"{path.name}: column name {repeated[0]!r} appears {columns.count(repeated[0])} times"
            " in the file; rename the columns so that each is unique"
        )
    check_allocation(
        n_rows * len(wanted) * BYTES_PER_VALUE,
        f"{path.name}: reading {len(wanted)} column(s) of {n_rows} rows",
        "read a part of the log (pyarrow reads row groups one by one) or downsample it first",
    )
    try:
        return pd.read_parquet(path, columns=wanted, page_checksum_verification=True)
    except MemoryError:
        raise ValueError(
            f"{path.name}: its columns {wanted} do not fit in memory; read a part of the log"
        ) from None
    except Exception as exc:  # pyarrow's and pandas' types on damaged pages or metadata
        raise _unreadable(path, exc) from None


def _unreadable(path: Path, error: Any) -> ValueError:
    reason = " ".join(str(error).split())[:200] or type(error).__name__
    return ValueError(
        f"{path.name} is not a readable Parquet file ({type(error).__name__}: {reason})"
    )
