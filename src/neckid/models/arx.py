"""Moved to :mod:`neckid.models.linear.arx`; this alias of the old path goes in the next release."""

import warnings

from neckid.models.linear.arx import *  # noqa: F403
from neckid.models.linear.arx import __all__  # noqa: F401

warnings.warn(
    "neckid.models.arx moved to neckid.models.linear.arx; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
