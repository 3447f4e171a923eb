"""Moved to :mod:`neckid.data.conditions` and :mod:`neckid.data.sidecar`; this alias goes in the next release."""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING

from neckid.data.conditions import ConditionValue, check_conditions, parse_condition
from neckid.data.sidecar import apply_conditions, read_sidecar, sidecar_path

if TYPE_CHECKING:
    from neckid.data.iodata import IOData

__all__ = [
    "ConditionValue",
    "apply_conditions",
    "check_conditions",
    "conditions_as_inputs",
    "parse_condition",
    "read_sidecar",
    "sidecar_path",
]


def conditions_as_inputs(data: IOData, names: Sequence[str]) -> IOData:
    """Moved to the method :meth:`neckid.IOData.conditions_as_inputs`."""
    return data.conditions_as_inputs(names)


warnings.warn(
    "neckid.conditions moved to neckid.data.conditions and neckid.data.sidecar; import from"
    " there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
