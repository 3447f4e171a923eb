"""Moved to :mod:`neckid.loops.model_in_loop`; this alias of the old path goes in the next release."""

import warnings

from neckid.loops.model_in_loop import *  # noqa: F403
from neckid.loops.model_in_loop import __all__  # noqa: F401

warnings.warn(
    "neckid.experiments.model_in_loop moved to neckid.loops.model_in_loop; import from there (this alias goes in the next release)",
    DeprecationWarning,
    stacklevel=2,
)
