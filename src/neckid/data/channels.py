"""The checks :class:`~neckid.IOData` runs on its arrays, channel names and units.

Each returns the value in the container's form (a contiguous 2-D float64 array, time down the
rows; a tuple of names or units) or raises an error that names the argument, the rule and the
value, and for arrays the row and column.
"""

from __future__ import annotations

import datetime
import unicodedata
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from neckid.utils.types import FloatArray

__all__ = ["as_2d", "channel_names", "channel_units"]


#: The largest integer a float64 holds exactly: larger whole numbers would be rounded.
LARGEST_EXACT_INTEGER = 2**53


def as_2d(
    values: ArrayLike | None,
    argument: str,
    n_samples: int | None = None,
    names: Sequence[str] | str | None = None,
) -> FloatArray:
    """Return ``values`` as a contiguous 2-D float64 array, time down the rows.

    Values a float64 would not hold as they are are refused, naming the channel (``names``, one
    per column, when given; else the column): dates and durations (``datetime64``,
    ``timedelta64``, ``datetime`` objects: a float would be a count of days or nanoseconds since
    1970), whole numbers beyond 2**53 (rounded: encoder counts near 2**56 would collapse onto a
    few floats) and those beyond the float range.

    Examples
    --------
    >>> as_2d([1, 2, 3], "u").shape
    (3, 1)
    >>> as_2d([2**60, 1], "u", names=["encoder"])
    Traceback (most recent call last):
    ...
    ValueError: u channel 'encoder' holds the whole number 1152921504606846976 at row 0, beyond 2**53 (9007199254740992): a float64 cannot hold it exactly (it would be rounded); store it as a float in a coarser unit, or subtract an offset first
    """
    if values is None:
        if n_samples is None:
            raise ValueError(f"{argument} is required")
        return np.zeros((n_samples, 0))
    if np.iscomplexobj(values):
        raise TypeError(
            f"{argument} holds complex numbers; a log holds real values: take .real, .imag or abs"
            " explicitly"
        )
    _check_representable(values, argument, names)
    try:
        array = np.asarray(values, dtype=np.float64)
    except OverflowError as exc:
        raise ValueError(
            f"{argument} holds a number beyond the float range (about 1.8e308): {exc}"
        ) from None
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{argument} must be numeric; could not convert it: {exc}") from exc
    if array.ndim == 0:
        raise ValueError(f"{argument} must be 1-D or 2-D (time down the rows); got a scalar")
    if array.ndim == 1:
        array = array[:, None]
    if array.ndim != 2:
        raise ValueError(
            f"{argument} must be 1-D or 2-D (time down the rows); got shape {array.shape}"
        )
    return np.ascontiguousarray(array)


def _check_representable(
    values: ArrayLike, argument: str, names: Sequence[str] | str | None
) -> None:
    """Refuse dates, durations and whole numbers a float64 does not hold (see :func:`as_2d`)."""
    try:
        raw = np.asarray(values)
    except (TypeError, ValueError, OverflowError):
        return  # ragged or otherwise odd: the float conversion says what is wrong
    if raw.dtype.kind not in "OiuMm" or raw.size == 0:
        return
    table = raw.reshape(-1, 1) if raw.ndim <= 1 else raw.reshape(raw.shape[0], -1)

    def channel(column: int) -> str:
        listed = [names] if isinstance(names, str) else list(names or [])
        if len(listed) == table.shape[1]:
            return f"{argument} channel {str(listed[column])!r}"
        return f"{argument} column {column}" if table.shape[1] > 1 else argument

    if raw.dtype.kind in "Mm":
        what = "dates (datetime64)" if raw.dtype.kind == "M" else "durations (timedelta64)"
        raise TypeError(
            f"{channel(0)} holds {what}, not numbers: as floats they would be counts since 1970"
            " (or of nanoseconds); convert them to seconds (or a number) explicitly first"
        )
    if raw.dtype.kind in "iu":
        magnitude = np.abs(table.astype(np.float64))  # exact enough to find values beyond 2**53
        rows, columns = np.nonzero(magnitude >= LARGEST_EXACT_INTEGER)
        hits = [
            (int(r), int(c), int(table[r, c]))
            for r, c in zip(rows, columns, strict=True)
            if abs(int(table[r, c])) > LARGEST_EXACT_INTEGER
        ]
    else:
        hits = []
        for (row, column), value in np.ndenumerate(table):
            if isinstance(value, bool | np.bool_):
                continue
            if isinstance(
                value, datetime.date | datetime.timedelta | np.datetime64 | np.timedelta64
            ):
                raise TypeError(
                    f"{channel(column)} holds {type(value).__name__} values (row {row} holds"
                    f" {value!r}), not numbers; convert them to seconds (or a number) explicitly"
                    " first"
                )
            if isinstance(value, int | np.integer) and abs(int(value)) > LARGEST_EXACT_INTEGER:
                hits.append((row, column, int(value)))
                break
    if hits:
        row, column, value = min(hits)
        text = (
            str(value)
            if len(str(value)) <= 40
            else f"{str(value)[:12]}... ({len(str(value))} digits)"
        )
        raise ValueError(
            f"{channel(column)} holds the whole number {text} at row {row}, beyond 2**53"
            f" ({LARGEST_EXACT_INTEGER}): a float64 cannot hold it exactly (it would be"
            " rounded); store it as a float in a coarser unit, or subtract an offset first"
        )


def channel_names(
    names: Sequence[str] | None, count: int, prefix: str, argument: str
) -> tuple[str, ...]:
    """``count`` channel names: the given ones (distinct, non-empty) or ``prefix``, ``prefix1``, ..."""
    if names is None:
        if count == 1:
            return (prefix,)
        return tuple(f"{prefix}{i + 1}" for i in range(count))
    if isinstance(names, str):
        names = [names]
    names = tuple(str(n) for n in names)
    for name in names:
        bad = [c for c in name if unicodedata.category(c) in ("Cc", "Cf", "Zl", "Zp")]
        if bad:
            raise ValueError(
                f"{argument}: channel name {name!r} holds the control character {bad[0]!r}"
                " (a line break, tab or another invisible character): it would break the files"
                " neckid writes (CSV, MATLAB); rename the column"
            )
    if len(names) != count:
        raise ValueError(f"{argument} has {len(names)} names {list(names)} for {count} channels")
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise ValueError(f"{argument} must be unique; repeated: {dup}")
    return names


def channel_units(units: Sequence[str] | None, count: int, argument: str) -> tuple[str, ...]:
    """``count`` channel units: the given ones (text) or empty."""
    if units is None:
        return ("",) * count
    if isinstance(units, str):
        units = [units]
    units = tuple(str(x) for x in units)
    for unit in units:
        if any(unicodedata.category(c) in ("Cc", "Cf", "Zl", "Zp") for c in unit):
            raise ValueError(
                f"{argument}: unit {unit!r} holds a control character (a line break, tab or"
                " another invisible character); give the unit as plain text"
            )
    if len(units) != count:
        raise ValueError(f"{argument} has {len(units)} entries for {count} channels")
    return units
