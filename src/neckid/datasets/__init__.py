"""Loaders for real data sets: the UC3M soft-neck bench logs and four public benchmarks.

The files are not shipped with neckid; every loader takes a path. See
:mod:`neckid.datasets.softneck` for the soft-neck CSV layouts and
:mod:`neckid.datasets.benchmarks` for the benchmarks and their official splits.
"""

from neckid.datasets.benchmarks import (
    SILVERBOX_TS,
    BenchmarkData,
    load_bouc_wen,
    load_cascaded_tanks,
    load_robot_arm,
    load_silverbox,
)
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
    "SoftneckLayout",
    "load_bouc_wen",
    "load_cascaded_tanks",
    "load_robot_arm",
    "load_silverbox",
    "load_softneck_directory",
    "load_softneck_log",
]
