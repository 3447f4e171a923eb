"""Frequency-domain identification: the best linear approximation, its distortion levels, FRFs.

- :func:`robust_bla` (:mod:`~neckid.frequency.bla`): the robust BLA of a multisine experiment
  (M realisations x P periods), its noise and nonlinear variances, and the levels at the
  non-excited lines (:mod:`~neckid.frequency.levels`: detection, even or odd).
- :func:`etfe`, :func:`smoothed_frf`, :func:`indirect_frf` (:mod:`~neckid.frequency.spectral`):
  the empirical transfer function estimate and smoothed (Welch, Blackman-Tukey) estimates of
  arbitrary data with their confidence bands and coherence, and the closed-loop estimate through
  the reference.
- :func:`frequency_fit` (:mod:`~neckid.frequency.validation`): a model's frequency response over
  a measured one, and the figure of merit.

All frequencies are angular, in rad/s.
"""

from neckid.frequency.bla import BestLinearApproximation, periodic_spectra, robust_bla
from neckid.frequency.levels import DistortionLevels, distortion_levels
from neckid.frequency.spectral import FrequencyResponse, etfe, indirect_frf, smoothed_frf
from neckid.frequency.validation import FrequencyFit, frequency_fit, model_response

__all__ = [
    "BestLinearApproximation",
    "DistortionLevels",
    "FrequencyFit",
    "FrequencyResponse",
    "distortion_levels",
    "etfe",
    "frequency_fit",
    "indirect_frf",
    "model_response",
    "periodic_spectra",
    "robust_bla",
    "smoothed_frf",
]
