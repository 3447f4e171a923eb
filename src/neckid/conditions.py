"""Moved to :mod:`neckid.data.conditions` and :mod:`neckid.data.sidecar`; this alias goes in the next release."""

import warnings

from neckid.data.conditions import ConditionValue, check_conditions, parse_condition
from neckid.data.sidecar import apply_conditions, read_sidecar, sidecar_path

__all__ = [
    "ConditionValue",
    "apply_conditions",
    "check_conditions",
    "parse_condition",
    "read_sidecar",
    "sidecar_path",
]

warnings.warn(
    "neckid.conditions moved to neckid.data.conditions and neckid.data.sidecar; import from"
    " there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
