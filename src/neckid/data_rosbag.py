"""Moved to :mod:`neckid.data.rosbag`; this alias of the old path goes in the next release."""

import warnings

from neckid.data.rosbag import *  # noqa: F403
from neckid.data.rosbag import __all__  # noqa: F401

warnings.warn(
    "neckid.data_rosbag moved to neckid.data.rosbag; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
