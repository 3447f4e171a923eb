"""Input/output logs: the :class:`IOData` container, its readers and the experiments' conditions.

- :mod:`.iodata`: :class:`IOData` (immutable arrays, names, units, sampling period, conditions)
  and :func:`as_experiments`;
- :mod:`.readers`: CSV, Parquet and MAT files; :mod:`.rosbag`: ROS 2 bags;
- :mod:`.conditions`: named constant conditions (payload, controller, neck) and their sidecars.
"""

from neckid.data.iodata import IOData, as_experiments

__all__ = ["IOData", "as_experiments"]
