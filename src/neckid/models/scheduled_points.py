"""Moved to :mod:`neckid.models.scheduled.points`; this alias of the old path goes in the next release."""

import warnings

from neckid.models.scheduled.points import *  # noqa: F403
from neckid.models.scheduled.points import __all__  # noqa: F401

warnings.warn(
    "neckid.models.scheduled_points moved to neckid.models.scheduled.points; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
