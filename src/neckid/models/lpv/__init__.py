"""Linear parameter-varying models: an ARX whose coefficients follow a condition or a signal.

:class:`~neckid.models.lpv.model.LPVARX` (``lpv`` in the registry): its scheduling variables,
LPV monomials and frozen models are in :mod:`neckid.models.lpv.schedule`, the schedule in words
(for ``neckid info``) in :mod:`neckid.models.lpv.summary`.
"""

from neckid.models.lpv.model import LPVARX

__all__ = ["LPVARX"]
