r"""The output at the lines a multisine does not excite: nonlinear distortion detection and its kind.

An odd multisine excites odd DFT lines only. A static odd nonlinearity (:math:`x^3`) maps
odd lines onto odd lines, an even one (:math:`x^2`) onto even lines (the sum of two odd
numbers is even): power above the noise at the even lines says "even nonlinearity", at the odd
lines left out of a random-odd multisine "odd nonlinearity" (Pintelon & Schoukens 2012, §3.6;
Schoukens, Vaes & Pintelon 2016).

Notes
-----
At a non-excited line, with :math:`\bar Y^{[m]}` the period mean of realisation :math:`m` and
:math:`s^2_{Y^{[m]}}` its sample variance over the :math:`P` periods, the statistic
:math:`\sum_m |\bar Y^{[m]}|^2 / \sum_m (s^2_{Y^{[m]}} / P)` follows, for Gaussian noise and no
distortion, an F distribution with :math:`2M` and :math:`2M(P-1)` degrees of freedom: the line
is detected when it passes its quantile at ``level``. A kind of nonlinearity is declared when
more lines of its parity are detected than the binomial law of false alarms allows at ``level``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from neckid.utils.types import BoolArray, FloatArray, IntArray

__all__ = ["DistortionLevels", "distortion_levels"]


@dataclass(frozen=True)
class DistortionLevels:
    r"""The output's level at the non-excited lines of the band, against its noise level.

    Attributes
    ----------
    lines : ndarray of int
        Non-excited DFT lines between the lowest and highest excited one.
    omega : ndarray
        Their angular frequencies, rad/s.
    output_power : ndarray, shape (n_lines, n_outputs)
        :math:`\frac1M\sum_m |\bar Y^{[m]}(k)|^2`, output unit squared (amplitude spectrum).
    noise_power : ndarray, shape (n_lines, n_outputs)
        :math:`\frac1M\sum_m s^2_{Y^{[m]}}(k) / P`: what noise alone would give (NaN if P = 1).
    n_realisations, n_periods : int
    odd_multisine : bool
        True when every excited line is odd: only then do the even and odd lines tell the
        kind of nonlinearity.
    """

    lines: IntArray
    omega: FloatArray
    output_power: FloatArray
    noise_power: FloatArray
    n_realisations: int
    n_periods: int
    odd_multisine: bool

    @property
    def parity(self) -> NDArray[np.str_]:
        """``"even"`` or ``"odd"`` per line."""
        return np.where(self.lines % 2 == 0, "even", "odd")

    def detected(self, level: float = 0.99) -> BoolArray:
        """Per line and output: power above the noise's at ``level`` (F test)."""
        if self.n_periods < 2:
            return np.zeros(self.output_power.shape, dtype=bool)
        m, p = self.n_realisations, self.n_periods
        threshold = stats.f.ppf(level, 2 * m, 2 * m * (p - 1))
        return np.asarray(self.output_power > threshold * self.noise_power)

    def kind_detected(self, parity: str, level: float = 0.99) -> bool | None:
        """Whether the lines of ``parity`` show a nonlinearity (None: no such line, or P = 1)."""
        chosen = self.parity == parity
        if not chosen.any() or self.n_periods < 2 or not self.odd_multisine:
            return None
        hits = int(self.detected(level)[chosen].any(axis=1).sum())
        trials = int(chosen.sum())
        # any of n_outputs lines may fire: the false-alarm rate per line is 1 - level^n_outputs
        alarm = 1.0 - level ** self.output_power.shape[1]
        return bool(stats.binom.sf(hits - 1, trials, alarm) < 1.0 - level)

    def verdict(self, level: float = 0.99) -> str:
        """The kind of nonlinearity the non-excited lines show, in words."""
        if not self.odd_multisine:
            return "kind of nonlinearity not told (it needs an odd multisine)"
        words = []
        for parity, line_kind in (("even", "even lines"), ("odd", "non-excited odd lines")):
            found = self.kind_detected(parity, level)
            if found is None:
                words.append(f"no {line_kind} to tell an {parity} nonlinearity")
            else:
                words.append(f"{parity} nonlinearity {'detected' if found else 'not detected'}")
        return "; ".join(words)

    def to_dict(self, output_names: tuple[str, ...]) -> dict[str, Any]:
        """Lines, parity, and per output the levels in dB (10 log10 of powers) and detections."""
        with np.errstate(divide="ignore"):
            return {
                "lines": self.lines.tolist(),
                "omega_rad_s": self.omega.tolist(),
                "parity": self.parity.tolist(),
                "even_nonlinearity": self.kind_detected("even"),
                "odd_nonlinearity": self.kind_detected("odd"),
                "outputs": {
                    name: {
                        "output_db": (10 * np.log10(self.output_power[:, i])).round(3).tolist(),
                        "noise_db": (10 * np.log10(self.noise_power[:, i])).round(3).tolist(),
                        "detected": self.detected()[:, i].tolist(),
                    }
                    for i, name in enumerate(output_names)
                },
            }


def distortion_levels(
    y_spectra: NDArray[np.complex128], excited: IntArray, resolution: float
) -> DistortionLevels:
    """The levels at the non-excited lines between the first and the last excited one.

    Parameters
    ----------
    y_spectra : complex ndarray, shape (M, P, n_lines, n_outputs)
        :func:`~neckid.frequency.bla.periodic_spectra` of the outputs.
    excited : ndarray of int
        The excited lines.
    resolution : float
        Line spacing, rad/s.

    Returns
    -------
    DistortionLevels
    """
    m, p = y_spectra.shape[:2]
    band = np.arange(int(excited.min()), int(excited.max()) + 1)
    lines = np.setdiff1d(band, excited).astype(np.int64)
    chosen = y_spectra[:, :, lines]
    mean = chosen.mean(axis=1)
    output_power = np.mean(np.abs(mean) ** 2, axis=0)
    if p > 1:
        spread = np.sum(np.abs(chosen - mean[:, None]) ** 2, axis=1) / (p - 1)
        noise_power = np.mean(spread, axis=0) / p
    else:
        noise_power = np.full(output_power.shape, np.nan)
    return DistortionLevels(
        lines=lines,
        omega=np.asarray(lines * resolution, dtype=np.float64),
        output_power=output_power,
        noise_power=noise_power,
        n_realisations=m,
        n_periods=p,
        odd_multisine=bool(np.all(excited % 2 == 1)),
    )
