"""What a closed-loop experiment needs from a plant and from a controller.

The protocols live in :mod:`neckid.systems`, beside the state functions every system shares;
this module re-exports them for the imports of earlier releases
(``from neckid.plant.protocols import Plant``).
"""

from __future__ import annotations

from neckid.systems import BoundedSimulator, Controller, Plant, Simulator

__all__ = ["BoundedSimulator", "Controller", "Plant", "Simulator"]
