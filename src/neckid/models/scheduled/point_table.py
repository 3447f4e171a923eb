"""The operating-point table of a fitted scheduled model, and how it is kept in a model file.

:attr:`GainScheduledModel.operating_points_
<neckid.models.scheduled.model.GainScheduledModel>` is a :class:`pandas.DataFrame` with one row
per operating point found, kept in the fit or not, with the columns of
:data:`POINT_COLUMNS` (the first ones are those of
:class:`~neckid.loops.operating_points.OperatingPointResult.table`, so
:func:`~neckid.report.scheduled_plots.plot_gain_schedule` draws it as ``points=``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from neckid.models.scheduled.points import OperatingPoint
from neckid.models.scheduled.segments import OperatingSegment
from neckid.utils.types import FloatArray

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["POINT_COLUMNS", "given_table", "point_table", "table_arrays", "table_from_arrays"]

#: Columns of the table: ``inclination`` [deg], ``gain`` (``N``), ``pole`` (``P``),
#: ``converged`` (bool; missing when unknown: points given to ``from_points``, older files),
#: ``used`` (whether the lines go through it), ``start_s`` and ``stop_s`` (first and last time
#: stamp of its samples [s]; NaN when unknown), ``n_samples`` (samples it was identified on),
#: ``experiment`` (index of its record, -1 for a bin over several or unknown) and ``kind``
#: (``"dwell"``, ``"bin"``, ``"segment"``, ``"experiment"`` or ``"given"``).
POINT_COLUMNS = (
    "inclination",
    "gain",
    "pole",
    "converged",
    "used",
    "start_s",
    "stop_s",
    "n_samples",
    "experiment",
    "kind",
)

#: Numeric columns as stored in a model file (array ``points_<column>``); ``converged`` is
#: stored as 1.0, 0.0 or NaN (unknown), ``used`` as 1.0 or 0.0.
_STORED = ("inclination", "gain", "pole", "converged", "used", "start_s", "stop_s", "n_samples")


def point_table(
    segments: Sequence[OperatingSegment], points: Sequence[OperatingPoint], used: Sequence[bool]
) -> pd.DataFrame:
    """The table of points identified on ``segments`` (one point per segment)."""
    import pandas as pd

    rows = [
        {
            "inclination": point.inclination,
            "gain": point.gain,
            "pole": point.pole,
            "converged": bool(point.converged),
            "used": bool(keep),
            "start_s": segment.span[0],
            "stop_s": segment.span[1],
            "n_samples": int(point.n_samples),
            "experiment": int(segment.experiment),
            "kind": segment.kind,
        }
        for segment, point, keep in zip(segments, points, used, strict=True)
    ]
    return _typed(pd.DataFrame(rows, columns=list(POINT_COLUMNS)))


def given_table(inclinations: FloatArray, gains: FloatArray, poles: FloatArray) -> pd.DataFrame:
    """The table of points given as numbers (``from_points``, files without a table)."""
    import pandas as pd

    n = inclinations.size
    return _typed(
        pd.DataFrame(
            {
                "inclination": inclinations,
                "gain": gains,
                "pole": poles,
                "converged": [pd.NA] * n,
                "used": [True] * n,
                "start_s": np.full(n, np.nan),
                "stop_s": np.full(n, np.nan),
                "n_samples": np.zeros(n, dtype=int),
                "experiment": np.full(n, -1),
                "kind": ["given"] * n,
            },
            columns=list(POINT_COLUMNS),
        )
    )


def _typed(table: pd.DataFrame) -> pd.DataFrame:
    return table.astype(
        {
            "inclination": "float64",
            "gain": "float64",
            "pole": "float64",
            "converged": "boolean",
            "used": "bool",
            "start_s": "float64",
            "stop_s": "float64",
            "n_samples": "int64",
            "experiment": "int64",
            "kind": "object",
        }
    )


def table_arrays(table: pd.DataFrame) -> tuple[dict[str, NDArray[Any]], list[str]]:
    """The table as numeric arrays ``points_<column>`` and the list of kinds (for the meta)."""
    arrays = {}
    for column in _STORED:
        values = table[column]
        if column == "converged":
            values = values.astype("Float64").fillna(np.nan)
        arrays[f"points_{column}"] = np.asarray(values, dtype=np.float64)
    arrays["points_experiment"] = np.asarray(table["experiment"], dtype=np.float64)
    return arrays, [str(kind) for kind in table["kind"]]


def table_from_arrays(
    arrays: Mapping[str, NDArray[Any]], kinds: Sequence[str] | None, used: tuple[FloatArray, ...]
) -> pd.DataFrame:
    """The table read back; a file without one gets the points the lines went through.

    Raises
    ------
    ValueError
        If the stored columns differ in length or hold values they cannot (a non-finite
        inclination, gain or pole, a flag other than 0 and 1).
    """
    import pandas as pd

    if "points_inclination" not in arrays:  # files written before the table
        return given_table(*used)
    columns = {c: np.asarray(arrays.get(f"points_{c}"), dtype=np.float64) for c in _STORED}
    columns["experiment"] = np.asarray(arrays.get("points_experiment"), dtype=np.float64)
    n = columns["inclination"].size
    names = [str(k) for k in kinds] if isinstance(kinds, list | tuple) else []
    if any(v.shape != (n,) for v in columns.values()) or len(names) != n:
        raise ValueError(
            "the operating-point table must have one value per point in every column; got"
            f" lengths {[int(np.size(v)) for v in columns.values()]} and {len(names)} kinds"
        )
    finite = ("inclination", "gain", "pole", "used", "n_samples", "experiment")
    flags = np.concatenate([columns["used"], columns["converged"][~np.isnan(columns["converged"])]])
    if not all(np.isfinite(columns[c]).all() for c in finite) or not np.isin(flags, (0, 1)).all():
        raise ValueError(
            "the operating-point table holds a non-finite value or a flag other than 0 and 1"
        )
    converged = [pd.NA if np.isnan(v) else bool(v) for v in columns["converged"]]
    frame = pd.DataFrame({**columns, "converged": converged, "kind": names})
    frame["used"] = frame["used"].astype(bool)
    return _typed(frame[list(POINT_COLUMNS)])
