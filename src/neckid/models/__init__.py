"""Every identified model, one subpackage per family, and what they share.

- :mod:`neckid.models.linear`: :class:`LinearARX`, :class:`RecursiveARX` (CFF-RLS),
  :class:`SubspaceStateSpace`;
- :mod:`neckid.models.set_membership`: :class:`SetMembership`, :class:`MultiStepSetMembership`,
  :class:`ParallelSetMembership`;
- :mod:`neckid.models.polynomial`: :class:`PolynomialNARX`;
- :mod:`neckid.models.pnlss`: :class:`PolynomialStateSpace` (PNLSS);
- :mod:`neckid.models.neural`: :class:`NeuralNARX`;
- :mod:`neckid.models.scheduled`: :class:`GainScheduledModel`;
- :mod:`neckid.models.greybox`: :class:`GreyBoxNeck`, :class:`GreyBoxODE` (your own equations);
- shared: :mod:`~neckid.models.base` (the contract and simulators), :mod:`~neckid.models.results`,
  :mod:`~neckid.models.kstep`, :mod:`~neckid.models.bands`, :mod:`~neckid.models.domain`,
  :mod:`~neckid.models.cache`, :mod:`~neckid.models.io`, :mod:`~neckid.models.online`,
  :mod:`~neckid.models.conformal`, :mod:`~neckid.models.adaptive_conformal`.

The estimators are loaded on first use (PEP 562): ``import neckid.models`` loads no family.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from neckid.models.greybox import GreyBoxNeck, GreyBoxODE
    from neckid.models.linear import LinearARX, RecursiveARX, SubspaceStateSpace
    from neckid.models.neural import NeuralNARX
    from neckid.models.pnlss import PolynomialStateSpace
    from neckid.models.polynomial import PolynomialNARX
    from neckid.models.scheduled import GainScheduledModel
    from neckid.models.set_membership import (
        MultiStepSetMembership,
        ParallelSetMembership,
        SetMembership,
    )

__all__ = [
    "GainScheduledModel",
    "GreyBoxNeck",
    "GreyBoxODE",
    "LinearARX",
    "MultiStepSetMembership",
    "NeuralNARX",
    "ParallelSetMembership",
    "PolynomialNARX",
    "PolynomialStateSpace",
    "RecursiveARX",
    "SetMembership",
    "SubspaceStateSpace",
]

_FAMILY = {
    "LinearARX": "neckid.models.linear",
    "RecursiveARX": "neckid.models.linear",
    "SubspaceStateSpace": "neckid.models.linear",
    "SetMembership": "neckid.models.set_membership",
    "MultiStepSetMembership": "neckid.models.set_membership",
    "ParallelSetMembership": "neckid.models.set_membership",
    "PolynomialNARX": "neckid.models.polynomial",
    "PolynomialStateSpace": "neckid.models.pnlss",
    "NeuralNARX": "neckid.models.neural",
    "GainScheduledModel": "neckid.models.scheduled",
    "GreyBoxNeck": "neckid.models.greybox",
    "GreyBoxODE": "neckid.models.greybox",
}

if not TYPE_CHECKING:

    def __getattr__(name: str) -> object:
        """Import an estimator on first use (PEP 562)."""
        if name not in _FAMILY:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(_FAMILY[name]), name)
        globals()[name] = value
        return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
