"""Grey-box models of the soft neck: tendon slack, hysteresis, low-order dynamics.

- :class:`GreyBoxNeck` (:mod:`.model`): slack (backlash) → Prandtl–Ishlinskii operator →
  stable first- or second-order dynamics, fitted on the free-run error (:mod:`.fitting`);
- :mod:`.hysteresis`: the play operator, the reflection-coefficient dynamics.
"""

from neckid.models.greybox.model import GreyBoxNeck, GreyBoxSimulator

__all__ = ["GreyBoxNeck", "GreyBoxSimulator"]
