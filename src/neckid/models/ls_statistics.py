"""Moved to :mod:`neckid.models.linear.ls_statistics`; this alias of the old path goes in the next release."""

import warnings

from neckid.models.linear.ls_statistics import *  # noqa: F403
from neckid.models.linear.ls_statistics import __all__  # noqa: F401

warnings.warn(
    "neckid.models.ls_statistics moved to neckid.models.linear.ls_statistics; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
