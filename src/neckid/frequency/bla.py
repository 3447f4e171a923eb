r"""The robust best linear approximation from M realisations x P periods of a multisine.

:func:`robust_bla` splits a periodic experiment (:func:`neckid.signals.multisine_plan`) into its
realisations and periods, and returns per excited line :math:`k` the best linear approximation
:math:`\hat G_{BLA}(k)`, the variance of that estimate due to the noise,
:math:`\hat\sigma^2_{BLA,n}(k)`, its total variance :math:`\hat\sigma^2_{BLA}(k)` (noise plus the
stochastic nonlinear distortions) and their difference, the nonlinear part; at the lines it does
not excite, the output's level against its noise level (:mod:`neckid.frequency.levels`).

Notes
-----
Realisations come in blocks of :math:`n_u` (one experiment per input). For block :math:`b`, with
:math:`\bar U_b(k)`, :math:`\bar Y_b(k)` the period means of the DFT spectra (inputs x
experiments, outputs x experiments),

.. math::
    G_b = \bar Y_b \bar U_b^{-1},\qquad
    \hat G_{BLA} = \frac1B\sum_b G_b,\qquad
    \hat\sigma^2_{BLA} = \frac{1}{B(B-1)}\sum_b |G_b-\hat G_{BLA}|^2,

and, with :math:`E_b^{[p]} = Y_b^{[p]} - G_b U_b^{[p]}` the residual of period :math:`p` and
:math:`s^2_{E_b}` its sample variance over the :math:`P` periods,
:math:`\operatorname{var} G_b[i,l] = \sum_j s^2_{E_b}[i,j]\,|\bar U_b^{-1}[j,l]|^2 / P` and
:math:`\hat\sigma^2_{BLA,n} = \frac{1}{B^2}\sum_b \operatorname{var} G_b`
(Pintelon & Schoukens 2012, §4.3; Schoukens, Vaes & Pintelon 2016). The stochastic nonlinear
distortions add :math:`\hat\sigma^2_{BLA,NL} = \hat\sigma^2_{BLA} - \hat\sigma^2_{BLA,n}` to the
variance of :math:`\hat G_{BLA}`; one realisation alone sees :math:`B` times that
(:attr:`BestLinearApproximation.distortion_variance`).

Without nonlinear distortions and with Gaussian noise, :math:`\hat\sigma^2_{BLA} /
\hat\sigma^2_{BLA,n}` follows an F distribution with :math:`2(B-1)` and :math:`2B(P-1)` degrees
of freedom: a line where the ratio passes its quantile at ``level`` shows nonlinear distortions
(:attr:`BestLinearApproximation.nonlinear_detected`). The 95 % band of :math:`\hat G_{BLA}`
is the circle of radius :math:`\sqrt{F_{0.95}(2, 2(B-1))\,\hat\sigma^2_{BLA}}` (the complex error
over its estimated variance is F-distributed for circular Gaussian errors).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from neckid.frequency.levels import DistortionLevels, distortion_levels
from neckid.utils.checks import check_number, check_ts
from neckid.utils.types import BoolArray, FloatArray, IntArray

__all__ = ["BestLinearApproximation", "periodic_spectra", "robust_bla"]

ComplexArray = NDArray[np.complex128]


@dataclass(frozen=True)
class BestLinearApproximation:
    r"""The robust BLA at the excited lines, its variances, and the levels at the other lines.

    Attributes
    ----------
    lines : ndarray of int, shape (F,)
        Excited DFT lines ``k``; ``omega = 2 pi k / (period ts)``.
    omega : ndarray, shape (F,)
        Their angular frequencies, rad/s.
    frf : complex ndarray, shape (F, n_outputs, n_inputs)
        :math:`\hat G_{BLA}(k)`, output unit per input unit.
    noise_variance, total_variance : ndarray, shape (F, n_outputs, n_inputs)
        Variance of ``frf`` due to the noise, and its total variance (NaN with one block).
    n_blocks, n_periods : int
        ``B = M / n_inputs`` and ``P``.
    ts : float
        Sampling period, s. ``period``: samples per period.
    levels : DistortionLevels
        The output at the non-excited lines of the band.
    input_amplitude : ndarray, shape (n_inputs,)
        RMS over the excited lines of each input's line amplitude ``|U(k)|``: dividing a level
        at a non-excited line by it puts that level in the FRF's unit.
    input_names, output_names, input_units, output_units : tuple of str
    estimate : str
        Which estimate this is (``"robust BLA"``), as the CLI prints it.
    """

    lines: IntArray
    omega: FloatArray
    frf: ComplexArray
    noise_variance: FloatArray
    total_variance: FloatArray
    n_blocks: int
    n_periods: int
    ts: float
    period: int
    levels: DistortionLevels
    input_amplitude: FloatArray
    input_names: tuple[str, ...] = ()
    output_names: tuple[str, ...] = ()
    input_units: tuple[str, ...] = ()
    output_units: tuple[str, ...] = ()
    estimate: str = field(default="robust BLA")

    @property
    def nl_variance(self) -> FloatArray:
        """Variance of ``frf`` due to the stochastic nonlinear distortions (>= 0)."""
        return np.maximum(self.total_variance - self.noise_variance, 0.0)

    @property
    def distortion_variance(self) -> FloatArray:
        """Variance of one block's FRF around the BLA: the level of the distortions, ``B x nl``."""
        return self.n_blocks * self.nl_variance

    def band_radius(self, level: float = 0.95) -> FloatArray:
        """Radius of the ``level`` confidence circle of ``frf`` (F quantile on the total variance)."""
        if self.n_blocks < 2:
            variance, dof = self.noise_variance, 2 * self.n_blocks * (self.n_periods - 1)
        else:
            variance, dof = self.total_variance, 2 * (self.n_blocks - 1)
        return np.sqrt(stats.f.ppf(level, 2, max(dof, 1)) * variance)

    def nonlinear_detected(self, level: float = 0.99) -> BoolArray:
        """Per line and pair: total variance beyond the noise's at ``level`` (F test)."""
        if self.n_blocks < 2 or self.n_periods < 2:
            return np.zeros(self.frf.shape, dtype=bool)
        threshold = stats.f.ppf(
            level, 2 * (self.n_blocks - 1), 2 * self.n_blocks * (self.n_periods - 1)
        )
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(self.total_variance > threshold * self.noise_variance)

    def verdict(self, level: float = 0.99) -> str:
        """One line: where the nonlinear distortions are above the noise, and their kind."""
        return _verdict(self, level)

    def to_dict(self) -> dict[str, Any]:
        """Per line and pair, in dB (20 log10 of magnitudes and standard deviations) and degrees."""
        return _to_dict(self)


def _split(x: FloatArray, period: int, m: int, p: int, t: int, argument: str) -> FloatArray:
    expected = m * (t + p) * period
    if x.shape[0] != expected:
        raise ValueError(
            f"{argument} has {x.shape[0]} samples; {m} realisations x ({t} transient + {p})"
            f" periods x {period} samples make {expected}"
        )
    return x.reshape(m, t + p, period, x.shape[1])[:, t:]


def periodic_spectra(
    x: ArrayLike, period: int, n_realisations: int, n_periods: int, transient_periods: int = 1
) -> ComplexArray:
    """DFT of every measured period: shape ``(M, P, period // 2 + 1, n_channels)``.

    Parameters
    ----------
    x : array_like, shape (n_samples, n_channels)
        ``n_samples = M (T + P) period``: realisation after realisation, each ``T`` transient
        periods (dropped) then ``P`` periods.
    period, n_realisations, n_periods, transient_periods : int
        ``N``, ``M``, ``P``, ``T``.

    Returns
    -------
    complex ndarray
        ``X[m, p, k, c]``: line ``k`` of period ``p`` of realisation ``m``, scaled by ``2 / N``
        (a cosine of amplitude ``a`` at line ``k`` gives ``|X| = a``).
    """
    data = np.asarray(x, dtype=np.float64)
    data = data[:, None] if data.ndim == 1 else data
    n = check_number(period, "period", low=2, integer=True)
    m = check_number(n_realisations, "n_realisations", low=1, integer=True)
    p = check_number(n_periods, "n_periods", low=1, integer=True)
    t = check_number(transient_periods, "transient_periods", low=0, integer=True)
    periods = _split(data, n, m, p, t, "the log")
    return np.fft.rfft(periods, axis=2) * (2.0 / n)


def _excited(power: FloatArray, excited: ArrayLike | None, n_lines: int) -> IntArray:
    if excited is not None:
        lines = np.unique(np.asarray(excited, dtype=np.int64))
        if lines.size == 0 or lines.min() < 1 or lines.max() >= n_lines:
            raise ValueError(f"excited lines must lie in 1..{n_lines - 1}; got {lines!r}")
        return lines
    inner = power[1:]
    reference = np.quantile(inner, 0.99)
    lines = 1 + np.flatnonzero(inner >= 1e-2 * reference)  # within 20 dB of the strongest lines
    if reference <= 0 or lines.size == 0:
        raise ValueError("the input holds no excited line: is it a multisine?")
    return np.asarray(lines, dtype=np.int64)


def _block_frf(u_spectra: ComplexArray, y_spectra: ComplexArray) -> tuple[ComplexArray, FloatArray]:
    """One block: u (n_u, P, F, n_u) and y (n_u, P, F, n_y) -> G (F, n_y, n_u), its variance."""
    u_mean = u_spectra.mean(axis=1).transpose(1, 2, 0)  # (F, inputs, experiments)
    y_mean = y_spectra.mean(axis=1).transpose(1, 2, 0)  # (F, outputs, experiments)
    if u_mean.shape[1] > 1:
        condition = float(np.median(np.linalg.cond(u_mean)))
        if not condition < 100.0:  # an orthogonal plan's is 1
            raise ValueError(
                f"the {u_mean.shape[1]} inputs are not excited independently (their spectra over"
                f" a block's experiments have condition number {condition:.3g} at the median"
                " line): give one input at a time, or run a multi-input plan (neckid excite"
                " --name a,b)"
            )
    inverse = np.linalg.inv(u_mean)
    frf = y_mean @ inverse
    p = u_spectra.shape[1]
    if p < 2:
        return frf, np.full(frf.shape, np.nan)
    u_periods = u_spectra.transpose(1, 2, 3, 0)  # (P, F, inputs, experiments)
    y_periods = y_spectra.transpose(1, 2, 3, 0)
    residual = y_periods - frf[None] @ u_periods  # (P, F, outputs, experiments)
    spread = np.sum(np.abs(residual - residual.mean(axis=0)) ** 2, axis=0) / (p - 1)
    variance = (spread / p) @ (np.abs(inverse) ** 2)  # (F, outputs, inputs)
    return frf, variance


def robust_bla(
    u: ArrayLike,
    y: ArrayLike,
    ts: float,
    *,
    period: int,
    n_realisations: int,
    n_periods: int,
    transient_periods: int = 1,
    excited: ArrayLike | None = None,
    names: tuple[tuple[str, ...], tuple[str, ...]] | None = None,
    units: tuple[tuple[str, ...], tuple[str, ...]] | None = None,
) -> BestLinearApproximation:
    """The robust best linear approximation of a multisine experiment (module docstring).

    Parameters
    ----------
    u : array_like, shape (n_samples, n_inputs)
        The measured inputs, ``n_samples = M (T + P) period`` (a :class:`MultisinePlan`'s layout).
    y : array_like, shape (n_samples, n_outputs)
        The measured outputs.
    ts : float
        Sampling period, s.
    period, n_realisations, n_periods, transient_periods : int
        ``N`` samples per period, ``M`` realisations (a multiple of ``n_inputs``), ``P``
        measured periods each after ``T`` transient periods.
    excited : array_like of int, optional
        The excited DFT lines (a plan's ``excited_lines``); default: the lines of the input
        within 20 dB of its strongest ones.
    names, units : ((inputs...), (outputs...)), optional
        Channel names and units, carried into the result.

    Returns
    -------
    BestLinearApproximation

    Raises
    ------
    ValueError
        If the lengths do not make whole realisations and periods, or ``M`` is not a multiple
        of the number of inputs.

    Examples
    --------
    >>> from neckid.signals import multisine_plan
    >>> plan = multisine_plan(128, 0.01, (1.0, 200.0), n_realisations=4, n_periods=2, seed=0)
    >>> y = 3.0 * plan.signal                           # a static gain of 3
    >>> bla = robust_bla(plan.signal, y, 0.01, period=128, n_realisations=4, n_periods=2)
    >>> bool(np.allclose(bla.frf, 3.0))
    True
    """
    sample_time = check_ts(ts)
    u_spectra = periodic_spectra(u, period, n_realisations, n_periods, transient_periods)
    y_spectra = periodic_spectra(y, period, n_realisations, n_periods, transient_periods)
    n_u = u_spectra.shape[-1]
    if n_realisations % n_u:
        raise ValueError(
            f"n_realisations={n_realisations} must be a multiple of the {n_u} inputs (M >= n_u)"
        )
    power = np.mean(np.abs(u_spectra.mean(axis=1)) ** 2, axis=(0, 2))
    lines = _excited(power, excited, u_spectra.shape[2])
    blocks = n_realisations // n_u
    frfs, variances = [], []
    for b in range(blocks):
        rows = slice(b * n_u, (b + 1) * n_u)
        frf, variance = _block_frf(u_spectra[rows][:, :, lines], y_spectra[rows][:, :, lines])
        frfs.append(frf)
        variances.append(variance)
    stacked = np.stack(frfs)
    mean = stacked.mean(axis=0)
    noise = np.sum(variances, axis=0) / blocks**2
    total = (
        np.sum(np.abs(stacked - mean) ** 2, axis=0) / (blocks * (blocks - 1))
        if blocks > 1
        else np.full(mean.shape, np.nan)
    )
    input_names, output_names = names or (
        tuple(f"u{i + 1}" for i in range(n_u)),
        tuple(f"y{i + 1}" for i in range(y_spectra.shape[-1])),
    )
    input_units, output_units = units or (("",) * n_u, ("",) * y_spectra.shape[-1])
    resolution = 2.0 * math.pi / (period * sample_time)
    return BestLinearApproximation(
        lines=lines,
        omega=np.asarray(lines * resolution, dtype=np.float64),
        frf=mean,
        noise_variance=noise,
        total_variance=total,
        n_blocks=blocks,
        n_periods=n_periods,
        ts=sample_time,
        period=period,
        levels=distortion_levels(y_spectra, lines, resolution),
        input_amplitude=np.sqrt(np.mean(np.abs(u_spectra[:, :, lines]) ** 2, axis=(0, 1, 2))),
        input_names=tuple(input_names),
        output_names=tuple(output_names),
        input_units=tuple(input_units),
        output_units=tuple(output_units),
    )


def _db(variance: FloatArray) -> FloatArray:
    with np.errstate(divide="ignore"):
        return 10.0 * np.log10(variance)


def _pair_verdict(bla: BestLinearApproximation, i: int, j: int, level: float) -> str:
    if bla.n_blocks < 2 or bla.n_periods < 2:
        return "distortions not separable from the noise (needs M >= 2 n_u and P >= 2)"
    detected = bla.nonlinear_detected(level)[:, i, j]
    share = detected.mean()
    if share <= 0.1:
        return f"no nonlinear distortion above the noise at {100 * (1 - share):.0f} % of the lines"
    ratio = _db(bla.nl_variance[detected, i, j]) - _db(bla.noise_variance[detected, i, j])
    omega = bla.omega[detected]
    return (
        f"nonlinear distortions {np.median(ratio):.0f} dB above the noise at"
        f" {100 * share:.0f} % of the lines between {omega.min():.3g} and {omega.max():.3g} rad/s"
    )


def _verdict(bla: BestLinearApproximation, level: float) -> str:
    parts = []
    n_y, n_u = bla.frf.shape[1:]
    for i in range(n_y):
        for j in range(n_u):
            text = _pair_verdict(bla, i, j, level)
            if n_y * n_u > 1:
                text = f"{bla.output_names[i]} <- {bla.input_names[j]}: {text}"
            parts.append(text)
    parts.append(bla.levels.verdict(level))
    return "; ".join(parts)


def _to_dict(bla: BestLinearApproximation) -> dict[str, Any]:
    pairs = []
    band = bla.band_radius(0.95)
    detected = bla.nonlinear_detected()
    for i, out in enumerate(bla.output_names):
        for j, name in enumerate(bla.input_names):
            frf = bla.frf[:, i, j]
            pairs.append(
                {
                    "output": out,
                    "input": name,
                    "magnitude_db": (20 * np.log10(np.abs(frf))).round(4).tolist(),
                    "phase_deg": np.degrees(np.unwrap(np.angle(frf))).round(3).tolist(),
                    "noise_db": _db(bla.noise_variance[:, i, j]).round(3).tolist(),
                    "total_db": _db(bla.total_variance[:, i, j]).round(3).tolist(),
                    "nonlinear_db": _db(bla.nl_variance[:, i, j]).round(3).tolist(),
                    "band95_radius": band[:, i, j].tolist(),
                    "nonlinear_detected": detected[:, i, j].tolist(),
                }
            )
    return {
        "estimate": bla.estimate,
        "n_blocks": bla.n_blocks,
        "n_periods": bla.n_periods,
        "period_samples": bla.period,
        "ts": bla.ts,
        "lines": bla.lines.tolist(),
        "omega_rad_s": bla.omega.tolist(),
        "pairs": pairs,
        "levels": bla.levels.to_dict(bla.output_names),
        "verdict": bla.verdict(),
    }
