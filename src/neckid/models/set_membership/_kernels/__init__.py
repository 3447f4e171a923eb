"""The Set Membership family's compiled kernels: the kd-tree and its bounds, γ*(ε), local constants.

- :mod:`.tree`: :class:`SMTree` (a kd-tree with per-node target ranges), the exact branch-and-bound
  bounds;
- :mod:`.free_run`: the compiled free run (the screened walk of :mod:`.priors`, one prior);
- :mod:`.gamma`: γ*(ε) over a grid of ε (:func:`gamma_star`), by branch and bound over the tree
  (:mod:`.gamma_search`, pruned further by the per-region slope bound of :mod:`.slope`) or over
  all pairs;
- :mod:`.local`: local Lipschitz constants and the bounds that use them;
- :mod:`.screens`: squared distances summed in any order (vectorised), a lower bound of the
  exact ones, with which the order-free walks prune;
- :mod:`.priors`: the point constants and bounds of several priors in one walk of the tree
  (the cross-validation of the multi-step model).

Private to :mod:`neckid.models.set_membership`: the estimators import from here, nothing else in
the package does. The plain NumPy references the kernels are tested against live in the tests.
"""

from neckid.models.set_membership._kernels.free_run import free_run
from neckid.models.set_membership._kernels.gamma import (
    TREE_MIN_POINTS,
    GammaMethod,
    gamma_star,
    gamma_star_blocked,
)
from neckid.models.set_membership._kernels.local import (
    check_constants,
    learn_constants,
    local_bounds,
    point_gamma,
)
from neckid.models.set_membership._kernels.tree import LEAF_SIZE, SMTree, build_tree

__all__ = [
    "LEAF_SIZE",
    "TREE_MIN_POINTS",
    "GammaMethod",
    "SMTree",
    "build_tree",
    "check_constants",
    "free_run",
    "gamma_star",
    "gamma_star_blocked",
    "learn_constants",
    "local_bounds",
    "point_gamma",
]
