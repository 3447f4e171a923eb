"""The inclination-scheduled model G(z, i) = N(i) / (z − P(i)) from CFF-RLS at operating points.

- :mod:`.model`: :class:`GainScheduledModel`;
- :mod:`.segments`: where the operating points lie in a record (dwells, bins, segments);
- :mod:`.points`: one operating point identified by CFF-RLS (:func:`identify_point`);
- :mod:`.point_table`: the table of the points a model was fitted to;
- :mod:`.regressor`: the first-order regressor (command and delay), and its default;
- :mod:`.summary`: the schedule in numbers and words (``neckid info``);
- :mod:`.simulator`: the step-by-step simulator.
"""

from neckid.models.scheduled.model import DEFAULT_SEGMENTS, GainScheduledModel
from neckid.models.scheduled.points import FORMS, OperatingPoint, default_window, identify_point
from neckid.models.scheduled.segments import (
    DWELL_BAND,
    DWELL_MEMORIES,
    find_dwells,
    smooth_inclination,
)
from neckid.models.scheduled.simulator import GainScheduledSimulator, clipped_polyval

__all__ = [
    "DEFAULT_SEGMENTS",
    "DWELL_BAND",
    "DWELL_MEMORIES",
    "FORMS",
    "GainScheduledModel",
    "GainScheduledSimulator",
    "OperatingPoint",
    "clipped_polyval",
    "default_window",
    "find_dwells",
    "identify_point",
    "smooth_inclination",
]
