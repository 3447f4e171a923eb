"""The inclination-scheduled model G(z, i) = N(i) / (z − P(i)) from CFF-RLS at operating points.

- :mod:`.model`: :class:`GainScheduledModel`;
- :mod:`.points`: one operating point identified by CFF-RLS (:func:`identify_point`);
- :mod:`.simulator`: the step-by-step simulator.
"""

from neckid.models.scheduled.model import DEFAULT_SEGMENTS, GainScheduledModel
from neckid.models.scheduled.points import FORMS, OperatingPoint, default_window, identify_point
from neckid.models.scheduled.simulator import GainScheduledSimulator, clipped_polyval

__all__ = [
    "DEFAULT_SEGMENTS",
    "FORMS",
    "GainScheduledModel",
    "GainScheduledSimulator",
    "OperatingPoint",
    "clipped_polyval",
    "default_window",
    "identify_point",
]
