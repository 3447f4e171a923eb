"""Excitation signals and the bandwidth of a chirp run.

All frequencies are angular, in rad/s; all times in seconds. A signal is returned as a 1-D float64
array, one value per time stamp (or per sample), ready to be a column of an
:class:`~neckid.data.IOData`. Values carry the unit of the command they drive (the paper's
inclination commands are in degrees).

Contents
--------
- :func:`paper_chirp`, :func:`paper_chirp_frequency`: the up-chirp of the paper's eq. 14-15.
- :func:`chirp`: a general linear chirp.
- :func:`multisine`: sum of sinusoids at the DFT frequencies of a band, Schroeder or random phases.
- :func:`prbs`: a maximum-length pseudo-random binary sequence held for a clock period.
- :func:`staircase`, :func:`step`, :func:`sine`.
- :func:`bandwidth_from_chirp` and :class:`BandwidthResult`: the frequency at which the response
  amplitude first stays below a fraction of the command's (the paper's 90 % rule).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import integrate
from scipy import signal as sps

from neckid.data import ts_from_time

__all__ = [
    "BandwidthResult",
    "bandwidth_from_chirp",
    "paper_chirp",
    "paper_chirp_frequency",
]

FloatArray = NDArray[np.float64]


# ---------------------------------------------------------------------------------------- helpers
def _finite_float(value: float, argument: str) -> float:
    """Return ``value`` as a finite float or raise naming ``argument``."""
    if isinstance(value, bool):
        raise TypeError(f"{argument} must be a number; got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{argument} must be a number; got {value!r}") from exc
    if not math.isfinite(number):
        raise ValueError(f"{argument} must be finite; got {value!r}")
    return number


def _positive_float(value: float, argument: str) -> float:
    number = _finite_float(value, argument)
    if number <= 0:
        raise ValueError(f"{argument} must be > 0; got {value!r}")
    return number


def _positive_int(value: int, argument: str, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{argument} must be an int; got {value!r}")
    if value < minimum:
        raise ValueError(f"{argument} must be >= {minimum}; got {value!r}")
    return int(value)


def _time_vector(t: ArrayLike, argument: str = "t") -> FloatArray:
    """Return ``t`` as a 1-D finite float64 array (scalars become one-element arrays)."""
    try:
        array = np.asarray(t, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{argument} must be numeric; could not convert it: {exc}") from exc
    if array.ndim == 0:
        array = array.reshape(1)
    if array.ndim != 1:
        raise ValueError(
            f"{argument} must be 1-D (one value per time stamp); got shape {array.shape}"
        )
    bad = np.flatnonzero(~np.isfinite(array))
    if bad.size:
        raise ValueError(f"{argument} has a non-finite value {array[bad[0]]!r} at row {bad[0]}")
    return np.ascontiguousarray(array)


# ---------------------------------------------------------------------------------- paper chirp
def paper_chirp(
    t: ArrayLike, offset: float = 5.0, amplitude: float = 4.0, rate: float = 0.1
) -> FloatArray:
    r"""The up-chirp command of the paper's eq. 14-15: ``offset + amplitude * sin(rate * t**2)``.

    The paper writes it as ``CS = 5 + 4 sin(f t)`` with ``f = 0.1 t`` (eq. 14-15), an inclination
    command in degrees oscillating between 1° and 9° with a growing frequency.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time stamps in seconds (need not be uniform or sorted).
    offset : float, default 5.0
        The mean of the command (degrees, in the paper).
    amplitude : float, default 4.0
        The amplitude of the oscillation around ``offset`` (same unit as ``offset``).
    rate : float, default 0.1
        The paper's ``f = rate * t`` coefficient, in rad/s².

    Returns
    -------
    ndarray, shape (n_samples,)
        The command at each time stamp.

    Notes
    -----
    The phase is :math:`\phi(t) = f(t)\,t = r t^2`, so the instantaneous angular frequency is
    its derivative, :math:`\omega(t) = d\phi/dt = 2 r t`: for the paper's ``sin(0.1 t^2)`` it is
    **0.2 t rad/s, not 0.1 t**. Reading ``f = 0.1 t`` as the frequency underestimates every
    frequency by a factor of two. :func:`paper_chirp_frequency` returns the correct ``2 r t``.

    References
    ----------
    .. [1] UC3M Robotics Lab, "Model Identification of a Soft Robotic Neck", eq. 14-15.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.array([0.0, np.sqrt(np.pi / 0.2), np.sqrt(np.pi / 0.1)])
    >>> paper_chirp(t).round(12)
    array([5., 9., 5.])
    >>> paper_chirp_frequency(t).round(4)  # rad/s, 2 * 0.1 * t
    array([0.    , 0.7927, 1.121 ])
    """
    time = _time_vector(t)
    offset_value = _finite_float(offset, "offset")
    amplitude_value = _finite_float(amplitude, "amplitude")
    rate_value = _finite_float(rate, "rate")
    return offset_value + amplitude_value * np.sin(rate_value * time**2)


def paper_chirp_frequency(t: ArrayLike, rate: float = 0.1) -> FloatArray:
    """Instantaneous angular frequency of :func:`paper_chirp`, ``2 * rate * t`` in rad/s.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time stamps in seconds.
    rate : float, default 0.1
        The chirp's rate in rad/s² (the paper's ``f = 0.1 t``).

    Returns
    -------
    ndarray, shape (n_samples,)
        ``d/dt (rate * t**2) = 2 * rate * t`` in rad/s (for the paper, ``0.2 t``, not ``0.1 t``).

    Examples
    --------
    >>> paper_chirp_frequency([0.0, 10.0, 50.0])
    array([ 0.,  2., 10.])
    """
    time = _time_vector(t)
    return 2.0 * _finite_float(rate, "rate") * time


# ------------------------------------------------------------------------------------ bandwidth
BandwidthStatus = Literal["found", "not_reached", "below_at_start"]


@dataclass(frozen=True)
class BandwidthResult:
    """The bandwidth found in a chirp run, with the amplitude envelopes it was read from.

    One entry of the arrays per analysis window (one cycle of the command, windows half a cycle
    apart), so ``plot_bandwidth`` can draw a figure like the paper's Fig. 3.

    Attributes
    ----------
    bandwidth : float
        Angular frequency (rad/s) at which the amplitude ratio crosses ``threshold`` for the last
        time going down (linear interpolation between the two windows on either side). NaN when
        ``status`` is not ``"found"``.
    threshold : float
        The ratio used (0.9 for the paper's rule).
    status : {"found", "not_reached", "below_at_start"}
        ``"found"``: the ratio stays below ``threshold`` from ``bandwidth`` to the end of the record.
        ``"not_reached"``: the record ends before the ratio has stayed below ``threshold`` for
        ``min_windows_below`` windows. ``"below_at_start"``: the ratio is below ``threshold`` in every
        window, so the bandwidth is lower than the first frequency analysed.
    time : ndarray, shape (n_windows,)
        Centre of each window in seconds.
    frequency : ndarray, shape (n_windows,)
        Mean instantaneous angular frequency over each window (phase advance / duration), rad/s.
    command_amplitude, response_amplitude : ndarray, shape (n_windows,)
        Amplitude of the first harmonic of the command and of the response in each window.
    ratio : ndarray, shape (n_windows,)
        ``response_amplitude / command_amplitude``.
    crossing_index : int
        Index of the first window of the final run below ``threshold``: 0 for
        ``"below_at_start"``, -1 for ``"not_reached"``.
    """

    bandwidth: float
    threshold: float
    status: BandwidthStatus
    time: FloatArray
    frequency: FloatArray
    command_amplitude: FloatArray
    response_amplitude: FloatArray
    ratio: FloatArray
    crossing_index: int

    @property
    def bandwidth_hz(self) -> float:
        """The bandwidth in Hz, ``bandwidth / (2 pi)``."""
        return self.bandwidth / (2.0 * math.pi)


def _phase_from_frequency(time: FloatArray, omega: FloatArray) -> FloatArray:
    return np.asarray(integrate.cumulative_trapezoid(omega, time, initial=0.0), dtype=np.float64)


def _phase_from_command(command: FloatArray) -> FloatArray:
    """Unwrapped phase of the analytic signal of the mean-removed command, made non-decreasing."""
    analytic = sps.hilbert(command - command.mean())
    phase = np.unwrap(np.angle(analytic))
    # Noise can make the estimated phase step back a little; the windows need a monotone phase.
    return np.maximum.accumulate(phase)


def _harmonic_amplitude(time: FloatArray, phase: FloatArray, values: FloatArray) -> float:
    """Amplitude of ``values ≈ a + b (t - tc) + c cos(phase) + d sin(phase)`` by least squares."""
    centred = time - time.mean()
    basis = np.column_stack([np.ones_like(time), centred, np.cos(phase), np.sin(phase)])
    coef, *_ = np.linalg.lstsq(basis, values, rcond=None)
    return float(math.hypot(coef[2], coef[3]))


def bandwidth_from_chirp(
    t: ArrayLike,
    command: ArrayLike,
    response: ArrayLike,
    threshold: float = 0.9,
    frequency: ArrayLike | Callable[[FloatArray], ArrayLike] | None = None,
    *,
    cycles_per_window: int = 1,
    min_samples_per_cycle: int = 8,
    min_windows_below: int = 3,
) -> BandwidthResult:
    r"""Bandwidth of a system from a chirp run: where the response amplitude stays below 90 %.

    The paper's rule: the bandwidth is the frequency at which the amplitude of the response
    first stays below ``threshold`` (90 %) times the amplitude of the command.

    Parameters
    ----------
    t : array_like, shape (n_samples,)
        Time stamps in seconds, increasing and uniformly spaced (within 5 %).
    command : array_like, shape (n_samples,)
        The chirp command (for example :func:`paper_chirp`), any offset.
    response : array_like, shape (n_samples,)
        The measured response, same unit as the command (any offset or slow drift).
    threshold : float, default 0.9
        Fraction of the command's amplitude, > 0 (the paper uses 0.9).
    frequency : array_like of shape (n_samples,) or callable, optional
        Instantaneous angular frequency of the command (rad/s) at each time stamp, or a function
        of the time vector returning it (e.g. :func:`paper_chirp_frequency`). If omitted it is
        estimated from the command: the phase of the analytic signal (Hilbert transform) of the
        mean-removed command. Give it when known: the estimate is poor in the first cycle and
        when the command is noisy.
    cycles_per_window : int, default 1
        Length of an analysis window in cycles of the command. More cycles average more noise out
        (the variance of an amplitude falls as one over the samples in the window) but blur the
        frequency axis, since the chirp's frequency changes along the window.
    min_samples_per_cycle : int, default 8
        Windows holding fewer samples than this (frequencies too close to Nyquist) are not
        analysed; the envelope arrays stop there.
    min_windows_below : int, default 3
        How many consecutive windows (half a cycle apart) at the end of the record the ratio must
        stay below ``threshold`` for the bandwidth to count as found.

    Returns
    -------
    BandwidthResult
        The bandwidth in rad/s and the envelopes it was read from.

    Raises
    ------
    ValueError
        If an array holds NaN or inf, the lengths differ, the time stamps are not increasing and
        uniform, the command has no amplitude, or the record is shorter than two cycles.

    Warns
    -----
    UserWarning
        When the bandwidth is not found (``status`` other than ``"found"``; ``bandwidth`` is NaN).

    Notes
    -----
    *Phase.* The command's phase is :math:`\phi(t) = \int_0^t \omega(s)\,ds` (trapezoidal rule)
    from ``frequency``, or the unwrapped angle of the analytic signal of the mean-removed command.

    *Windows.* The record is cut into windows spanning ``cycles_per_window`` cycles of the command
    (:math:`\Delta\phi = 2\pi` each), starting every half cycle. A window's frequency is its mean
    instantaneous frequency :math:`\Delta\phi / \Delta t` (for a linear chirp, the frequency at
    its centre).

    *Amplitudes.* In each window, command and response are each fitted by least squares with
    :math:`a + b\,(t - t_c) + c\cos\phi(t) + d\sin\phi(t)`; the amplitude is
    :math:`\sqrt{c^2 + d^2}`. This is a local first-harmonic (lock-in) estimate in the spirit of
    the frequency-domain methods of Pintelon & Schoukens [2]_: the constant and slope terms absorb
    offsets, drifts and the decaying transient, the harmonic fit averages white noise out
    (its variance falls as one over the samples per cycle), and the phase lag of the response
    does not matter because both cosine and sine are fitted. Harmonics of a nonlinear response
    are left out, as in a describing function.

    *Rule.* ``ratio = response amplitude / command amplitude``. The bandwidth is taken after the
    last window whose ratio is at or above ``threshold``: from there on the ratio never rises to
    the threshold again within the record. It is interpolated linearly in frequency between that
    window and the next. The end of the record is the end of the evidence: the final run below
    the threshold must last ``min_windows_below`` windows, otherwise ``status`` is
    ``"not_reached"`` (a longer chirp is needed).

    References
    ----------
    .. [1] UC3M Robotics Lab, "Model Identification of a Soft Robotic Neck", Fig. 3.
    .. [2] R. Pintelon and J. Schoukens, *System Identification: A Frequency Domain Approach*,
       2nd ed., Wiley-IEEE Press, 2012.
    .. [3] L. Ljung, *System Identification: Theory for the User*, 2nd ed., Prentice Hall, 1999.

    Examples
    --------
    A first-order lag ``1 / (0.05 s + 1)`` has ``|G(jω)| = 0.9`` at
    ``ω = sqrt(1 / 0.81 - 1) / 0.05 ≈ 9.69`` rad/s:

    >>> import numpy as np
    >>> from scipy import signal
    >>> t = np.arange(0.0, 80.0, 0.01)
    >>> command = paper_chirp(t)
    >>> _, response, _ = signal.lsim(([1.0], [0.05, 1.0]), command, t, X0=[5.0 / 0.05])
    >>> result = bandwidth_from_chirp(t, command, response, frequency=paper_chirp_frequency)
    >>> result.status, round(result.bandwidth, 1)
    ('found', 9.7)
    """
    time = _time_vector(t, "t")
    ts_from_time(time, column="t")
    cmd = _time_vector(command, "command")
    out = _time_vector(response, "response")
    if cmd.size != time.size or out.size != time.size:
        raise ValueError(
            "t, command and response must have the same length; got"
            f" {time.size}, {cmd.size} and {out.size}"
        )
    threshold_value = _positive_float(threshold, "threshold")
    cycles = _positive_int(cycles_per_window, "cycles_per_window")
    min_samples = _positive_int(min_samples_per_cycle, "min_samples_per_cycle", minimum=4)
    min_below = _positive_int(min_windows_below, "min_windows_below", minimum=1)

    if frequency is None:
        if np.ptp(cmd) == 0:
            raise ValueError("command is constant; a chirp command must oscillate")
        phase = _phase_from_command(cmd)
    else:
        omega_raw = frequency(time) if callable(frequency) else frequency
        omega = _time_vector(omega_raw, "frequency")
        if omega.size != time.size:
            raise ValueError(
                f"frequency must give one value per time stamp ({time.size}); got {omega.size}"
            )
        negative = np.flatnonzero(omega < 0)
        if negative.size:
            raise ValueError(
                f"frequency must be >= 0 rad/s; got {omega[negative[0]]!r} at row {negative[0]}"
            )
        phase = _phase_from_frequency(time, omega)

    # Window boundaries at every half cycle of phase.
    n_half = int(np.floor((phase[-1] - phase[0]) / math.pi))
    span = 2 * cycles  # half cycles per window
    if n_half < span + 2:
        raise ValueError(
            f"the record holds {(phase[-1] - phase[0]) / (2 * math.pi):.2f} cycles of the command;"
            f" the bandwidth needs at least {cycles + 1} (cycles_per_window={cycles} plus one)"
        )
    levels = phase[0] + math.pi * np.arange(n_half + 1)
    edges = np.searchsorted(phase, levels, side="left")
    edges = np.minimum(edges, time.size - 1)

    centres: list[float] = []
    freqs: list[float] = []
    cmd_amp: list[float] = []
    out_amp: list[float] = []
    for k in range(n_half - span + 1):
        lo, hi = int(edges[k]), int(edges[k + span])
        if hi - lo + 1 < min_samples * cycles:
            break
        window = slice(lo, hi + 1)
        tw, pw = time[window], phase[window]
        duration = tw[-1] - tw[0]
        centres.append(0.5 * (tw[0] + tw[-1]))
        freqs.append(float((pw[-1] - pw[0]) / duration))
        cmd_amp.append(_harmonic_amplitude(tw, pw, cmd[window]))
        out_amp.append(_harmonic_amplitude(tw, pw, out[window]))

    if len(centres) < 2:
        raise ValueError(
            "fewer than two windows of the command hold at least"
            f" min_samples_per_cycle={min_samples} samples; sample faster or lower the chirp rate"
        )
    command_amplitude = np.asarray(cmd_amp)
    response_amplitude = np.asarray(out_amp)
    tiny = np.flatnonzero(command_amplitude <= 1e-12 * max(1.0, float(np.abs(cmd).max())))
    if tiny.size:
        raise ValueError(
            f"command has no oscillation in the window around t={centres[tiny[0]]:g} s"
            f" (amplitude {command_amplitude[tiny[0]]!r}); is it a chirp?"
        )
    ratio = response_amplitude / command_amplitude
    freq_array = np.asarray(freqs)

    above = np.flatnonzero(ratio >= threshold_value)
    status: BandwidthStatus
    if above.size == 0:
        status, bandwidth, crossing = "below_at_start", math.nan, 0
        warnings.warn(
            f"the amplitude ratio is below threshold={threshold_value:g} in every window, already"
            f" at {freq_array[0]:.4g} rad/s; the bandwidth is lower than the chirp's start",
            stacklevel=2,
        )
    elif ratio.size - 1 - above[-1] < min_below:
        status, bandwidth, crossing = "not_reached", math.nan, -1
        warnings.warn(
            f"the amplitude ratio has not stayed below threshold={threshold_value:g} for"
            f" {min_below} windows by the end of the record (last frequency"
            f" {freq_array[-1]:.4g} rad/s); use a longer or faster chirp",
            stacklevel=2,
        )
    else:
        i = int(above[-1])
        crossing = i + 1
        r0, r1 = ratio[i], ratio[i + 1]
        f0, f1 = freq_array[i], freq_array[i + 1]
        fraction = (r0 - threshold_value) / (r0 - r1) if r0 != r1 else 0.0
        bandwidth = float(f0 + fraction * (f1 - f0))
        status = "found"
    return BandwidthResult(
        bandwidth=bandwidth,
        threshold=threshold_value,
        status=status,
        time=np.asarray(centres),
        frequency=freq_array,
        command_amplitude=command_amplitude,
        response_amplitude=response_amplitude,
        ratio=ratio,
        crossing_index=crossing,
    )
