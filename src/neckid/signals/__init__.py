"""Excitation signals and the bandwidth of a chirp run.

The generators are in :mod:`~neckid.signals.excitation` (the plans for a best linear approximation in
:mod:`~neckid.signals.plans`), the chirp-run analysis in
:mod:`~neckid.signals.bandwidth`. All frequencies are angular, in rad/s; all times in seconds. A signal is a 1-D float64 array,
one value per time stamp, ready to be a column of an :class:`~neckid.data.iodata.IOData`.
"""

from neckid.signals.bandwidth import BandwidthResult, bandwidth_from_chirp
from neckid.signals.excitation import (
    chirp,
    chirp_frequency,
    multisine,
    multisine_frequencies,
    paper_chirp,
    paper_chirp_frequency,
    prbs,
    random_binary,
    sine,
    staircase,
    step,
)
from neckid.signals.plans import MultisinePlan, multisine_plan

__all__ = [
    "BandwidthResult",
    "MultisinePlan",
    "bandwidth_from_chirp",
    "chirp",
    "chirp_frequency",
    "multisine",
    "multisine_frequencies",
    "multisine_plan",
    "paper_chirp",
    "paper_chirp_frequency",
    "prbs",
    "random_binary",
    "sine",
    "staircase",
    "step",
]
