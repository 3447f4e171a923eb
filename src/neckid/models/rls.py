"""Moved to :mod:`neckid.models.linear.rls`; this alias of the old path goes in the next release."""

import warnings

from neckid.models.linear.rls import *  # noqa: F403
from neckid.models.linear.rls import __all__  # noqa: F401

warnings.warn(
    "neckid.models.rls moved to neckid.models.linear.rls; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
