"""Moved to :mod:`neckid.models.set_membership.training`; this alias of the old path goes in the next release."""

import warnings

from neckid.models.linear.arx import linear_sum
from neckid.models.set_membership.training import *  # noqa: F403
from neckid.models.set_membership.training import __all__ as _moved

__all__ = [*_moved, "linear_sum"]

warnings.warn(
    "neckid.models.sm_training moved to neckid.models.set_membership.training (linear_sum to neckid.models.linear.arx); import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
