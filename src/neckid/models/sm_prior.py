"""Moved to :mod:`neckid.models.set_membership.prior`; this alias of the old path goes in the next release."""

import warnings

from neckid.models.set_membership.prior import *  # noqa: F403
from neckid.models.set_membership.prior import __all__  # noqa: F401

warnings.warn(
    "neckid.models.sm_prior moved to neckid.models.set_membership.prior; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
