"""The Set Membership family (Milanese & Novara 2004): NARX, multi-step and parallel estimators.

Where things live:

- :mod:`.narx`: :class:`SetMembership`, the NARX estimator (prior ε, γ; optimal bounds and
  central estimate), its step-by-step simulator and :func:`gamma_curve`;
- :mod:`.multistep`: :class:`MultiStepSetMembership`, one SM model per horizon;
  :mod:`.horizon_fit`: one horizon's rows, ε and γ rules and fit; :mod:`.multistep_selection`:
  the settings of each horizon chosen by cross-validation over runs;
- :mod:`.parallel`: :class:`ParallelSetMembership`, SM bounds around a parallel (free-run) model;
- :mod:`.prior`: the γ*(ε) curve and the choice of ε; :mod:`.training`: the training tree, the
  prior's checks; :mod:`.update`: how an online update revises the prior; :mod:`.metric`: the
  learnt distance;
- :mod:`._kernels`: the compiled kd-tree, bounds, free run, γ*(ε), local constants and several
  priors over one tree (private to this family).

References
----------
M. Milanese and C. Novara, "Set Membership identification of nonlinear systems", Automatica
40(6), 957-975, 2004.
"""

from neckid.models.set_membership.multistep import MultiStepSetMembership, MultiStepSimulator
from neckid.models.set_membership.narx import (
    DEFAULT_GAMMA_MARGIN,
    GammaCurve,
    Invalidation,
    SetMembership,
    SetMembershipSimulator,
    SMBounds,
    choose_epsilon,
    gamma_curve,
)
from neckid.models.set_membership.parallel import (
    ParallelSetMembership,
    ParallelSetMembershipSimulator,
)

__all__ = [
    "DEFAULT_GAMMA_MARGIN",
    "GammaCurve",
    "Invalidation",
    "MultiStepSetMembership",
    "MultiStepSimulator",
    "ParallelSetMembership",
    "ParallelSetMembershipSimulator",
    "SMBounds",
    "SetMembership",
    "SetMembershipSimulator",
    "choose_epsilon",
    "gamma_curve",
]
