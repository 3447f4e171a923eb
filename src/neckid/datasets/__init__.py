"""Loaders for real data sets: the UC3M soft-neck bench logs, four public benchmarks, ROS 2 bags.

The files are not shipped with neckid; every loader takes a path. See
:mod:`neckid.datasets.softneck` for the soft-neck CSV layouts,
:mod:`neckid.datasets.benchmarks` for the benchmarks and their official splits,
:mod:`neckid.datasets.imu3d` for three-motor logs of the 3-D neck (read as the tilt vector), and
:mod:`neckid.datasets.rosbag` for ROS 2 bags (needs the optional dependency ``rosbags``, imported
only when a bag is read).
"""

from neckid.datasets.benchmarks import (
    SILVERBOX_TS,
    BenchmarkData,
    load_bouc_wen,
    load_cascaded_tanks,
    load_robot_arm,
    load_silverbox,
)
from neckid.datasets.imu3d import load_three_motor_log
from neckid.datasets.rosbag import RosbagChannel, load_rosbag
from neckid.datasets.softneck import (
    CHANNELS,
    SOFTNECK_LAYOUTS,
    SOFTNECK_TS,
    SoftneckLayout,
    load_softneck_directory,
    load_softneck_log,
)

__all__ = [
    "CHANNELS",
    "SILVERBOX_TS",
    "SOFTNECK_LAYOUTS",
    "SOFTNECK_TS",
    "BenchmarkData",
    "RosbagChannel",
    "SoftneckLayout",
    "load_bouc_wen",
    "load_cascaded_tanks",
    "load_robot_arm",
    "load_rosbag",
    "load_silverbox",
    "load_softneck_directory",
    "load_softneck_log",
    "load_three_motor_log",
]
