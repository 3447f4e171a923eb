"""Moved to :mod:`neckid.models.linear.rls_kernels`; this alias of the old path goes in the next release."""

import warnings

from neckid.models.linear.rls_kernels import *  # noqa: F403
from neckid.models.linear.rls_kernels import __all__  # noqa: F401

warnings.warn(
    "neckid.models.rls_kernels moved to neckid.models.linear.rls_kernels; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
