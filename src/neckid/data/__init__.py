"""Input/output logs: the :class:`IOData` container, its readers and the experiments' conditions.

- :mod:`.iodata`: :class:`IOData` (immutable arrays, names, units, sampling period, conditions)
  and :func:`as_experiments`;
- :mod:`.readers`: CSV, Parquet and MAT files; :mod:`.rosbag`: ROS 2 bags;
- :mod:`.conditions`: named constant conditions (payload, controller, neck) and their sidecars;
- :mod:`.preprocess`: preprocessing steps (:class:`Relative`, :class:`LowPass`, ...) in a
  :class:`Pipeline` that a model records and applies again to every new log.
"""

from neckid.data.iodata import IOData, as_experiments
from neckid.data.preprocess import (
    LowPass,
    Pipeline,
    Relative,
    RemoveOffset,
    Resample,
    Restamp,
    Tilt,
)

__all__ = [
    "IOData",
    "LowPass",
    "Pipeline",
    "Relative",
    "RemoveOffset",
    "Resample",
    "Restamp",
    "Tilt",
    "as_experiments",
]
