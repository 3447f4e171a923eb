"""Moved to :mod:`neckid.loops.operating_points`; this alias of the old path goes in the next release."""

import warnings

from neckid.loops.operating_points import *  # noqa: F403
from neckid.loops.operating_points import __all__  # noqa: F401

warnings.warn(
    "neckid.experiments.operating_points moved to neckid.loops.operating_points; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
