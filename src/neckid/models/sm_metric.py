"""Moved to :mod:`neckid.models.set_membership.metric`; this alias of the old path goes in the next release."""

import warnings

from neckid.models.set_membership.metric import *  # noqa: F403
from neckid.models.set_membership.metric import __all__  # noqa: F401

warnings.warn(
    "neckid.models.sm_metric moved to neckid.models.set_membership.metric; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
