r"""Frequency responses of arbitrary data: ETFE, smoothed estimates, and the closed-loop indirect one.

- :func:`etfe`: the empirical transfer function estimate :math:`Y(k)/U(k)` of one record (MATLAB's
  ``etfe`` without smoothing): no averaging, so no band and no coherence.
- :func:`smoothed_frf`: :math:`\hat G = \hat S_{uy}/\hat S_{uu}` from Welch's averaged periodograms
  (Hann segments, 50 % overlap) or from Blackman-Tukey's lag-windowed covariances (MATLAB's
  ``spa``: Hann lag window of width ``min(30, N/10)`` by default), with the coherence and a 95 %
  band.
- :func:`indirect_frf`: in a closed loop, :math:`\hat G = \hat S_{ry}/\hat S_{ru}` through the
  reference :math:`r`, which the noise does not reach: unbiased where the direct estimate tends to
  :math:`-1/C` (Pintelon & Schoukens 2012, §2.6 and ch. 9; Wellstead 1981).

Notes
-----
The band. With :math:`n_d` independent averages, a least-squares estimate at one frequency has
:math:`|\hat G - G|^2 / \widehat{\operatorname{var}}\,\hat G \sim F(2, 2n_d - 2)` for circular
Gaussian noise, and :math:`\widehat{\operatorname{var}}\,\hat G = \frac{1-\gamma^2}{(n_d-1)
\gamma^2}|\hat G|^2` (Bendat & Piersol, *Random Data*, 4th ed., Wiley 2010, eq. 9.90): the band
is the circle of radius :math:`\sqrt{F_{0.95}(2, 2n_d-2)\,\widehat{\operatorname{var}}\,\hat G}`.
Overlapping Welch segments count as :math:`n_d = K / (1 + 2\sum_j (1 - j/K)\rho_j^2)` with
:math:`\rho_j` the overlap correlation of the windows (Welch 1967); a Blackman-Tukey estimate as
:math:`n_d = N / \sum_\tau w^2(\tau)` (Jenkins & Watts 1968). The indirect estimate uses
:math:`\widehat{\operatorname{var}}\,\hat G = \hat S_{ee}\hat S_{rr} / ((n_d - 1)|\hat S_{ru}|^2)`
with :math:`e = y - \hat G u` the part of the output the reference does not explain.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal as sps
from scipy import stats

from neckid.utils.checks import check_number, check_ts
from neckid.utils.types import FloatArray

__all__ = ["FrequencyResponse", "etfe", "indirect_frf", "smoothed_frf"]

ComplexArray = NDArray[np.complex128]


@dataclass(frozen=True)
class FrequencyResponse:
    """A frequency response estimate, its coherence and its 95 % band.

    Attributes
    ----------
    omega : ndarray, shape (F,)
        Angular frequencies, rad/s.
    frf : complex ndarray, shape (F,)
        The estimate, output unit per input unit.
    coherence : ndarray, shape (F,)
        Squared coherence in [0, 1] between input and output (for ``indirect``: between the
        reference and the input); NaN for the raw ETFE.
    band_radius : ndarray, shape (F,)
        Radius of the 95 % confidence circle around ``frf`` (NaN for the raw ETFE).
    averages : float
        Effective number of independent averages ``n_d``.
    estimate : str
        Which estimate: ``"ETFE"``, ``"Welch"``, ``"Blackman-Tukey"`` or ``"indirect through
        <reference>"``.
    """

    omega: FloatArray
    frf: ComplexArray
    coherence: FloatArray
    band_radius: FloatArray
    averages: float
    estimate: str

    def inside(self, truth: ArrayLike) -> NDArray[np.bool_]:
        """Whether ``truth`` (complex, shape (F,)) lies inside the 95 % band, per frequency."""
        return np.asarray(np.abs(np.asarray(truth) - self.frf) <= self.band_radius)

    def to_dict(self) -> dict[str, Any]:
        """Magnitude (dB), phase (degrees, unwrapped), coherence and band radius per frequency."""
        with np.errstate(divide="ignore"):
            return {
                "estimate": self.estimate,
                "averages": self.averages,
                "omega_rad_s": self.omega.tolist(),
                "magnitude_db": (20 * np.log10(np.abs(self.frf))).round(4).tolist(),
                "phase_deg": np.degrees(np.unwrap(np.angle(self.frf))).round(3).tolist(),
                "coherence": self.coherence.round(5).tolist(),
                "band95_radius": self.band_radius.tolist(),
            }


def _signals(*arrays: ArrayLike) -> list[FloatArray]:
    out = []
    for index, array in enumerate(arrays):
        x = np.asarray(array, dtype=np.float64)
        if x.ndim == 2 and x.shape[1] == 1:
            x = x[:, 0]
        if x.ndim != 1:
            raise ValueError(f"signal {index + 1} must be one channel; got shape {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError(
                f"signal {index + 1} holds NaN or inf at row {np.argmin(np.isfinite(x))}"
            )
        out.append(x - x.mean())
    if len({x.size for x in out}) != 1:
        raise ValueError(f"signals must have one length; got {[x.size for x in out]}")
    return out


def etfe(u: ArrayLike, y: ArrayLike, ts: float) -> FrequencyResponse:
    """The empirical transfer function estimate ``Y(k) / U(k)`` of one record (means removed).

    Parameters
    ----------
    u, y : array_like, shape (n_samples,)
        Input and output.
    ts : float
        Sampling period, s.

    Returns
    -------
    FrequencyResponse
        At the DFT lines ``1 .. n/2`` where ``U`` is not zero; no band (NaN): one record is
        not an average (its variance does not fall with the record length).

    Examples
    --------
    >>> u = np.random.default_rng(0).standard_normal(256)
    >>> y = 2.0 * u
    >>> bool(np.allclose(etfe(u, y, 0.01).frf, 2.0))
    True
    """
    sample_time = check_ts(ts)
    x, z = _signals(u, y)
    lines = np.arange(1, x.size // 2 + 1)
    u_spectrum, y_spectrum = np.fft.rfft(x)[lines], np.fft.rfft(z)[lines]
    keep = np.abs(u_spectrum) > 1e-12 * np.abs(u_spectrum).max()
    nan = np.full(int(keep.sum()), np.nan)
    return FrequencyResponse(
        omega=2 * math.pi * lines[keep] / (x.size * sample_time),
        frf=y_spectrum[keep] / u_spectrum[keep],
        coherence=nan,
        band_radius=nan.copy(),
        averages=1.0,
        estimate="ETFE",
    )


def _welch_averages(window: FloatArray, step: int, count: int) -> float:
    energy = float(np.sum(window**2))
    total = 0.0
    for j in range(1, count):
        shift = j * step
        if shift >= window.size:
            break
        rho = float(np.sum(window[:-shift] * window[shift:])) / energy
        total += (1 - j / count) * rho**2
    return count / (1 + 2 * total)


def _welch(
    signals: list[FloatArray], ts: float, segment: int
) -> tuple[FloatArray, dict[tuple[int, int], ComplexArray], float]:
    window = sps.get_window("hann", segment)
    step = segment - segment // 2
    count = 1 + (signals[0].size - segment) // step
    spectra = {}
    omega = np.array([])
    for a in range(len(signals)):
        for b in range(a, len(signals)):
            freq, value = sps.csd(
                signals[a], signals[b], fs=1 / ts, window=window, noverlap=segment // 2
            )
            spectra[(a, b)] = value[
                2:
            ]  # from the second line: the first is in the Hann lobe around DC
            omega = 2 * math.pi * freq[2:]
    return omega, spectra, _welch_averages(window, step, count)


def _blackman_tukey(
    signals: list[FloatArray], ts: float, width: int, n_frequencies: int
) -> tuple[FloatArray, dict[tuple[int, int], ComplexArray], float]:
    n = signals[0].size
    lags = np.arange(-width, width + 1)
    lag_window = 0.5 * (1 + np.cos(math.pi * lags / width))
    omega = math.pi / ts * np.arange(1, n_frequencies + 1) / n_frequencies
    kernel = np.exp(-1j * np.outer(omega * ts, lags)) * lag_window
    spectra = {}
    for a in range(len(signals)):
        for b in range(a, len(signals)):
            full = sps.correlate(signals[b], signals[a], mode="full", method="fft") / n
            covariance = full[n - 1 - width : n + width]  # R_ba(tau), tau = -width..width
            spectra[(a, b)] = kernel @ covariance
    return omega, spectra, n / float(np.sum(lag_window**2))


def _band(frf: ComplexArray, coherence: FloatArray, averages: float) -> FloatArray:
    dof = max(2 * averages - 2, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        variance = (1 - coherence) / (max(averages - 1, 1e-9) * coherence) * np.abs(frf) ** 2
    return np.sqrt(stats.f.ppf(0.95, 2, dof) * variance)


def _spectra(
    signals: list[FloatArray],
    ts: float,
    method: str,
    segment: int | None,
    lag_width: int | None,
) -> tuple[FloatArray, dict[tuple[int, int], ComplexArray], float, str]:
    n = signals[0].size
    if method == "welch":
        length = n // 8 if segment is None else segment
        length = check_number(length, "segment", low=8, high=n, integer=True)
        return (*_welch(signals, ts, length), "Welch")
    if method == "blackman-tukey":
        width = min(30, n // 10) if lag_width is None else lag_width
        width = check_number(width, "lag_width", low=2, high=n - 1, integer=True)
        return (*_blackman_tukey(signals, ts, width, 128), "Blackman-Tukey")
    raise ValueError(f"method must be 'welch' or 'blackman-tukey'; got {method!r}")


def smoothed_frf(
    u: ArrayLike,
    y: ArrayLike,
    ts: float,
    *,
    method: Literal["welch", "blackman-tukey"] = "welch",
    segment: int | None = None,
    lag_width: int | None = None,
) -> FrequencyResponse:
    r"""A smoothed frequency response :math:`\hat S_{uy} / \hat S_{uu}` with coherence and 95 % band.

    Parameters
    ----------
    u, y : array_like, shape (n_samples,)
        Input and output (means removed here).
    ts : float
        Sampling period, s.
    method : {"welch", "blackman-tukey"}, default "welch"
        Averaged Hann periodograms of ``segment`` samples, 50 % overlap; or a Hann lag window of
        half-width ``lag_width`` on the covariances (MATLAB's ``spa``), at 128 frequencies up
        to Nyquist.
    segment : int, optional
        Welch segment length, default ``n_samples // 8``.
    lag_width : int, optional
        Blackman-Tukey lag window half-width, default ``min(30, n_samples // 10)``.

    Returns
    -------
    FrequencyResponse
        The band assumes the output noise uncorrelated with the input: an open loop (in a
        closed loop use :func:`indirect_frf`).

    Examples
    --------
    >>> from scipy import signal as sps
    >>> u = np.random.default_rng(0).standard_normal(4096)
    >>> y = sps.lfilter([0.5], [1.0, -0.5], u)
    >>> g = smoothed_frf(u, y, 1.0)
    >>> truth = 0.5 / (1 - 0.5 * np.exp(-1j * g.omega))
    >>> bool(g.inside(truth).mean() > 0.8)
    True
    """
    sample_time = check_ts(ts)
    signals = _signals(u, y)
    omega, spectra, averages, name = _spectra(signals, sample_time, method, segment, lag_width)
    s_uu, s_uy, s_yy = spectra[(0, 0)].real, spectra[(0, 1)], spectra[(1, 1)].real
    frf = s_uy / s_uu
    coherence = np.clip(np.abs(s_uy) ** 2 / (s_uu * s_yy), 0.0, 1.0)
    return FrequencyResponse(
        omega=omega,
        frf=frf,
        coherence=coherence,
        band_radius=_band(frf, coherence, averages),
        averages=averages,
        estimate=name,
    )


def indirect_frf(
    r: ArrayLike,
    u: ArrayLike,
    y: ArrayLike,
    ts: float,
    *,
    method: Literal["welch", "blackman-tukey"] = "welch",
    segment: int | None = None,
    lag_width: int | None = None,
    reference_name: str = "r",
) -> FrequencyResponse:
    r"""The plant's frequency response in a closed loop through the reference: :math:`\hat S_{ry}/\hat S_{ru}`.

    Parameters
    ----------
    r : array_like, shape (n_samples,)
        The loop's reference (or an excitation added to the command): a signal the noise does
        not reach.
    u, y : array_like, shape (n_samples,)
        The plant's input (the command) and output (the measurement).
    ts, method, segment, lag_width
        As :func:`smoothed_frf`.
    reference_name : str, default "r"
        Named in ``estimate``.

    Returns
    -------
    FrequencyResponse
        ``coherence`` is between ``r`` and ``u``: where it is small the reference does not reach
        the plant's input and the band is wide.

    Notes
    -----
    With :math:`u = S r - S C v` and :math:`y = G u + v` (sensitivity :math:`S`, controller
    :math:`C`, noise :math:`v`), :math:`S_{ry}/S_{ru} = G` since :math:`S_{rv} = 0`, while the
    direct :math:`S_{uy}/S_{uu} = (G S^2 S_{rr} - C^* |S|^2 S_{vv}) / (|S|^2 (S_{rr} + |C|^2 S_{vv}))`
    tends to :math:`-1/C` where the noise dominates.
    """
    sample_time = check_ts(ts)
    signals = _signals(r, u, y)
    omega, spectra, averages, name = _spectra(signals, sample_time, method, segment, lag_width)
    s_rr, s_uu, s_yy = spectra[(0, 0)].real, spectra[(1, 1)].real, spectra[(2, 2)].real
    s_ru, s_ry, s_uy = spectra[(0, 1)], spectra[(0, 2)], spectra[(1, 2)]
    frf = s_ry / s_ru
    residual = np.maximum(s_yy + np.abs(frf) ** 2 * s_uu - 2 * np.real(frf * np.conj(s_uy)), 0.0)
    variance = residual * s_rr / (max(averages - 1, 1e-9) * np.abs(s_ru) ** 2)
    dof = max(2 * averages - 2, 1.0)
    return FrequencyResponse(
        omega=omega,
        frf=frf,
        coherence=np.clip(np.abs(s_ru) ** 2 / (s_rr * s_uu), 0.0, 1.0),
        band_radius=np.sqrt(stats.f.ppf(0.95, 2, dof) * variance),
        averages=averages,
        estimate=f"indirect through {reference_name} ({name}, G = S_ry / S_ru)",
    )
