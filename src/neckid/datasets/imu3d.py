"""Three-motor neck logs: motor encoders in, an IMU's inclination and orientation out.

A 3-D neck bench logs one row per sample with the three motors' encoder positions, the
inclination and orientation the IMU reports on the top platform, and perhaps the payload mass.
:func:`load_three_motor_log` reads such a CSV by column names and returns the log with the tilt
as a wrap-free pair (:mod:`neckid.data.tilt`), ready for identification: the orientation's wrap at
0/360° and its undefined value at zero inclination never reach a model.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from neckid.data.iodata import IOData
from neckid.data.tilt import Representation

__all__ = ["load_three_motor_log"]


def load_three_motor_log(
    path: str | Path,
    *,
    motors: Sequence[str] = ("motor_1", "motor_2", "motor_3"),
    inclination: str = "inclination",
    orientation: str = "orientation",
    payload: str | float | None = None,
    time: str | None = "time",
    ts: float | None = None,
    motor_unit: str = "rad",
    representation: Representation = "vector",
    sep: str = ",",
) -> IOData:
    r"""Read a three-motor IMU log (CSV with a header row) as motors in, tilt vector out.

    Parameters
    ----------
    path : path
        The CSV log.
    motors : sequence of str, default ("motor_1", "motor_2", "motor_3")
        The encoder columns, in the order of the tendons (any number, usually three).
    inclination, orientation : str
        The IMU's columns [deg]; the orientation may wrap at 0/360° (or ±180°).
    payload : str, float or None
        A column holding the payload mass [kg] (constant over the log), or its value; it becomes
        the ``payload`` condition (:attr:`IOData.conditions`), usable as a model input with
        ``Lags(..., conditions=["payload"])``.
    time, ts : as in :meth:`IOData.from_csv`
        A time column [s], or the sampling period for a log without one.
    motor_unit : str, default "rad"
        Unit of the encoder columns.
    representation : {"vector", "pitch_roll"}, default "vector"
        Outputs ``tilt_x``, ``tilt_y`` [deg] (:func:`neckid.data.tilt.to_tilt`) or ``pitch``,
        ``roll`` [deg] (:func:`neckid.data.tilt.to_pitch_roll`).
    sep : str, default ","
        Column separator.

    Returns
    -------
    IOData
        Inputs the motors [``motor_unit``], outputs the chosen pair [deg]; the name is the file
        name. ``data.with_polar(representation)`` gives inclination and orientation back.

    Raises
    ------
    FileNotFoundError, KeyError, ValueError
        As :meth:`IOData.from_csv` (a missing column is named with the columns there are); a
        payload column that is not constant is named with its two first different values.

    Examples
    --------
    >>> import os, tempfile
    >>> from neckid.datasets import load_three_motor_log
    >>> path = os.path.join(tempfile.mkdtemp(), "run.csv")
    >>> rows = ["time,motor_1,motor_2,motor_3,inclination,orientation,mass",
    ...         "0.00,0.1,0.0,0.0,10.0,359.0,0.2", "0.02,0.2,0.0,0.0,10.0,1.0,0.2"]
    >>> _ = open(path, "w").write("\n".join(rows) + "\n")
    >>> log = load_three_motor_log(path, payload="mass")
    >>> log.output_names, dict(log.conditions)
    (('tilt_x', 'tilt_y'), {'payload': 0.2})
    >>> [round(float(v), 3) for v in log.y[:, 1]]          # no jump across 0/360
    [-0.175, 0.175]
    """
    columns = list(motors)
    if not columns:
        raise ValueError("motors must name at least one encoder column; got none")
    extra = [payload] if isinstance(payload, str) else []
    raw = IOData.from_csv(
        path,
        [*columns, *extra],
        [inclination, orientation],
        time=time,
        ts=ts,
        units={**dict.fromkeys(columns, motor_unit), inclination: "deg", orientation: "deg"},
        sep=sep,
    )
    mass: float | None = None
    if isinstance(payload, str):
        values = raw.channel(payload)
        changed = np.flatnonzero(values != values[0])
        if changed.size:
            raise ValueError(
                f"{Path(path).name}: payload column {payload!r} must be constant over a log; row"
                f" {int(changed[0]) + 1} holds {values[changed[0]]!r} after {values[0]!r}"
            )
        mass = float(values[0])
    elif payload is not None:
        mass = float(payload)
    data = raw.select(inputs=columns, outputs=[inclination, orientation])
    if mass is not None:
        data = data.with_conditions(units={"payload": "kg"}, payload=mass)
    return data.with_tilt(representation, inclination=inclination, orientation=orientation)
