"""Moved to :mod:`neckid.models.scheduled.simulator`; this alias of the old path goes in the next release."""

import warnings

from neckid.models.scheduled.simulator import *  # noqa: F403
from neckid.models.scheduled.simulator import __all__  # noqa: F401

warnings.warn(
    "neckid.models.scheduled_simulator moved to neckid.models.scheduled.simulator; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
