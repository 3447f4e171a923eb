"""The checks :class:`~neckid.IOData` runs on its arrays, channel names and units.

Each returns the value in the container's form (a contiguous 2-D float64 array, time down the
rows; a tuple of names or units) or raises an error that names the argument, the rule and the
value, and for arrays the row and column.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from neckid.utils.types import FloatArray

__all__ = ["as_2d", "channel_names", "channel_units"]


def as_2d(values: ArrayLike | None, argument: str, n_samples: int | None = None) -> FloatArray:
    """Return ``values`` as a contiguous 2-D float64 array, time down the rows."""
    if values is None:
        if n_samples is None:
            raise ValueError(f"{argument} is required")
        return np.zeros((n_samples, 0))
    if np.iscomplexobj(values):
        raise TypeError(
            f"{argument} holds complex numbers; a log holds real values: take .real, .imag or abs"
            " explicitly"
        )
    try:
        array = np.asarray(values, dtype=np.float64)
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
    if len(units) != count:
        raise ValueError(f"{argument} has {len(units)} entries for {count} channels")
    return units
