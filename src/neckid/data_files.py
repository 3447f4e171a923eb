"""Moved to :mod:`neckid.data.readers`; this alias of the old path goes in the next release."""

import warnings

from neckid.data.readers import *  # noqa: F403
from neckid.data.readers import __all__  # noqa: F401

warnings.warn(
    "neckid.data_files moved to neckid.data.readers; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
