"""ROS 2 bags as logs: :func:`load_rosbag` (the reader is :mod:`neckid.data.rosbag`)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from neckid.data.iodata import IOData
from neckid.data.rosbag import GAP_FACTOR, ROSBAGS_MISSING, RosbagChannel

__all__ = ["GAP_FACTOR", "ROSBAGS_MISSING", "RosbagChannel", "load_rosbag"]


def load_rosbag(path: str | Path, channels: Mapping[str, Any], **options: Any) -> IOData:
    """Read a ROS 2 bag into an :class:`~neckid.IOData`; the same as :meth:`IOData.from_rosbag`.

    See :func:`neckid.data.rosbag.rosbag_fields` for the channels, the time stamps and the
    resampling rule.
    """
    return IOData.from_rosbag(path, channels, **options)
