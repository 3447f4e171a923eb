"""Grey-box models: the soft neck's, and user-defined state-space models with physical parameters.

- :class:`GreyBoxNeck` (:mod:`.model`): slack (backlash) → Prandtl–Ishlinskii operator →
  stable first- or second-order dynamics, fitted on the free-run error (:mod:`.fitting`);
- :mod:`.hysteresis`: the play operator, the reflection-coefficient dynamics;
- :class:`GreyBoxODE` (:mod:`.ode`): a user's :class:`GreyBoxStructure` (:mod:`.structure`:
  state and output equations, parameters, initial state) fitted on the free-run error
  (:mod:`.ode_fitting`), integrated by :mod:`.ode_kernels`; shipped structures
  (:mod:`.catalog`): ``cascaded-tanks`` (:mod:`.tanks`).
"""

from neckid.models.greybox.catalog import shipped_structures
from neckid.models.greybox.model import GreyBoxNeck, GreyBoxSimulator
from neckid.models.greybox.ode import GreyBoxODE, GreyBoxODESimulator
from neckid.models.greybox.ode_kernels import simulate_structure
from neckid.models.greybox.structure import (
    GreyBoxStructure,
    StructureParameter,
    UnknownStructureError,
)

__all__ = [
    "GreyBoxNeck",
    "GreyBoxODE",
    "GreyBoxODESimulator",
    "GreyBoxSimulator",
    "GreyBoxStructure",
    "StructureParameter",
    "UnknownStructureError",
    "shipped_structures",
    "simulate_structure",
]
