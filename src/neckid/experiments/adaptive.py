"""Moved to :mod:`neckid.loops.adaptive`; this alias of the old path goes in the next release."""

import warnings

from neckid.loops.adaptive import *  # noqa: F403
from neckid.loops.adaptive import __all__  # noqa: F401

warnings.warn(
    "neckid.experiments.adaptive moved to neckid.loops.adaptive; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
