"""The bandwidth of a chirp run: where the response amplitude first stays below the command's.

:func:`bandwidth_from_chirp` and :class:`BandwidthResult` apply the paper's 90 % rule to a
chirp run (the command and the measured response); :func:`neckid.report.signal_plots.plot_bandwidth`
draws its envelopes. The windows it reads are measured in :mod:`neckid.signals._windows`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from neckid.signals._windows import chirp_phase, window_envelopes
from neckid.utils.checks import check_number, check_time_vector, check_uniform_time, check_vector
from neckid.utils.types import FloatArray

__all__ = ["BandwidthResult", "bandwidth_from_chirp"]


# ------------------------------------------------------------------------------------ bandwidth
BandwidthStatus = Literal["found", "not_reached", "below_at_start"]

#: A window is measured when the command's mean frequency over its second half is within this
#: fraction of that over its first half (and the other way round, for a down-chirp).
_MAX_WINDOW_SWEEP = 0.5


@dataclass(frozen=True)
class BandwidthResult:
    """The bandwidth found in a chirp run, with the amplitude envelopes it was read from.

    One entry of the arrays per analysis window (one cycle of the command, windows half a cycle
    apart), so :func:`neckid.report.signal_plots.plot_bandwidth` can draw a figure like the
    paper's Fig. 3.

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
        measured window, so the bandwidth is lower than the first frequency measured (or the
        response is not in the command's unit); :attr:`reason` says which chirp would measure it.
    time : ndarray, shape (n_windows,)
        Centre of each window in seconds.
    frequency : ndarray, shape (n_windows,)
        Mean instantaneous angular frequency over each window (phase advance / duration), rad/s.
    command_amplitude, response_amplitude : ndarray, shape (n_windows,)
        Amplitude of the first harmonic of the command and of the response in each window.
    ratio : ndarray, shape (n_windows,)
        ``response_amplitude / command_amplitude``.
    crossing_index : int
        Index of the first window of the final run below ``threshold``: :attr:`first_measured` for
        ``"below_at_start"``, -1 for ``"not_reached"``.
    reason : str
        One sentence saying how the bandwidth was found or why none is reported, and what chirp
        would measure it (for example ``"... start the chirp at or below 0.56 rad/s and sweep it
        no faster than 0.025 rad/s^2 ..."``); the warning of a run without a bandwidth says the same.
    first_measured : int
        Index of the first window the rule uses (1 or more). The first window holds the plant's
        start transient; the next ones are skipped while they sweep too fast: the command's
        frequency changes by more than half from their first half to their second (at the start
        of a chirp from 0 rad/s, one cycle spans 0 to twice its mean frequency), so they hold no
        amplitude at one frequency. They are kept in the arrays, for the figure. ``n_windows``
        when no window can be measured.
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
    reason: str = ""
    first_measured: int = 0

    @property
    def omega(self) -> float:
        """The bandwidth in rad/s (the same as :attr:`bandwidth`)."""
        return self.bandwidth

    @property
    def bandwidth_hz(self) -> float:
        """The bandwidth in Hz, ``bandwidth / (2 pi)``."""
        return self.bandwidth / (2.0 * math.pi)


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
        estimated from the command (see Notes). Give it when known: the estimate is poor in the
        first cycle, at the very end, and when the command is noisy.
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
        When the bandwidth is not found (``status`` other than ``"found"``; ``bandwidth`` is NaN);
        the message is :attr:`BandwidthResult.reason`.

    Notes
    -----
    *Phase.* The command's phase is :math:`\phi(t) = \int_0^t \omega(s)\,ds` (trapezoidal rule)
    from ``frequency``; otherwise it is estimated from the command: the unwrapped angle of its
    analytic signal (Hilbert transform) after removing its local mean over one cycle, with the
    instantaneous frequency averaged over one cycle and integrated again. The estimate is worst
    in the first cycle and at the end of the record (Hilbert edge effects).

    *Windows.* The record is cut into windows spanning ``cycles_per_window`` cycles of the command
    (:math:`\Delta\phi = 2\pi` each), starting every half cycle. A window's frequency is its mean
    instantaneous frequency :math:`\Delta\phi / \Delta t` (for a linear chirp, the frequency at
    its centre).

    *Amplitudes.* In each window, command and response are each fitted by least squares with
    :math:`a + b s + (c + e s)\cos\phi(t) + (d + f s)\sin\phi(t)`, :math:`s = t - t_c`; the
    amplitude at the window centre :math:`t_c` is :math:`\sqrt{c^2 + d^2}`. This is a local
    first-harmonic (lock-in) estimate in the spirit of the frequency-domain methods of Pintelon &
    Schoukens [2]_: the constant and slope terms absorb offsets, drifts and the decaying transient;
    the terms in :math:`s` let the amplitude change linearly along the window (without them the
    slope term and a chirp whose amplitude is falling share variance and bias the amplitude low
    when a window spans a large change of frequency); the fit averages white noise out (its
    variance falls as one over the samples in the window); and the phase lag of the response
    does not matter because both cosine and sine are fitted. Harmonics of a nonlinear response
    are left out, as in a describing function.

    *Windows that sweep too fast.* A window holds an amplitude at one frequency only if the
    frequency changes little along it. With :math:`\bar\omega_1, \bar\omega_2` the mean
    frequencies of its two halves, a window is measured when
    :math:`\max(\bar\omega_2/\bar\omega_1, \bar\omega_1/\bar\omega_2) - 1 \le 0.5`. At the start of a chirp from 0 rad/s this fails: its first cycle
    spans 0 to twice its mean frequency (the ratio of the halves is :math:`1/(\sqrt2 - 1) = 2.4`
    for any rate). The first window is never measured: it holds the plant's start transient
    (and the edge of the Hilbert estimate, when the frequency is not given). The leading windows
    that are not measured are drawn but not used by the rule
    (:attr:`BandwidthResult.first_measured`).
    A linear chirp of rate :math:`\alpha` sweeps :math:`2\pi\alpha c/\omega` rad/s over a window of
    :math:`c` cycles at :math:`\omega`, so a bandwidth :math:`\omega_b` can be measured only if
    the chirp dwells below it: when the ratio is below ``threshold`` in every measured window, the
    result advises a start frequency :math:`\omega_s` of a third of the first measured frequency
    and a rate :math:`\alpha \le \omega_s^2 / (4\pi c)` (a sweep of a quarter within the first
    window). The paper's chirp (:math:`\alpha = 0.2` rad/s², from 0) therefore cannot measure a
    bandwidth below about 1.5 rad/s, its first measured window: a lag :math:`1/(0.5 s + 1)`
    (0.97 rad/s) gets ``"below_at_start"`` and the advice to start at or below 0.51 rad/s and
    sweep no faster than 0.021 rad/s², a chirp that measures it within 2 %.

    *Rule.* ``ratio = response amplitude / command amplitude``. The bandwidth is taken after the
    last measured window whose ratio is at or above ``threshold``: from there on the ratio never rises to
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
    >>> from neckid.signals import paper_chirp, paper_chirp_frequency
    >>> t = np.arange(0.0, 80.0, 0.01)
    >>> command = paper_chirp(t)
    >>> _, response, _ = signal.lsim(([1.0], [0.05, 1.0]), command, t, X0=[5.0 / 0.05])
    >>> result = bandwidth_from_chirp(t, command, response, frequency=paper_chirp_frequency)
    >>> result.status, round(result.bandwidth, 1)
    ('found', 9.7)
    """
    time, cmd, out = _chirp_arrays(t, command, response)
    threshold_value = check_number(threshold, "threshold", low=0, closed="neither")
    cycles = check_number(cycles_per_window, "cycles_per_window", low=1, integer=True)
    min_samples = check_number(min_samples_per_cycle, "min_samples_per_cycle", low=6, integer=True)
    min_below = check_number(min_windows_below, "min_windows_below", low=1, integer=True)
    phase = chirp_phase(time, cmd, frequency)
    centres, freq_array, sweeps, command_amplitude, response_amplitude = window_envelopes(
        time, phase, cmd, out, cycles, min_samples
    )
    ratio = response_amplitude / command_amplitude

    # The first window holds the plant's start transient (and the Hilbert edge effect when the
    # phase is estimated): never measured. Then those that sweep too fast.
    unmeasured = np.asarray(sweeps) > _MAX_WINDOW_SWEEP
    unmeasured[0] = True
    first = int(np.argmin(unmeasured)) if not unmeasured.all() else ratio.size
    status, bandwidth, crossing, reason = _bandwidth_rule(
        ratio,
        freq_array,
        first,
        _skipped_windows(first, freq_array, sweeps),
        threshold_value,
        cycles,
        min_below,
    )
    if status != "found":
        warnings.warn(reason, stacklevel=2)
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
        reason=reason,
        first_measured=first,
    )


def _chirp_arrays(
    t: ArrayLike, command: ArrayLike, response: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The checked time stamps, command and response of a chirp run (same length, uniform time)."""
    time = check_time_vector(t, "t")
    check_uniform_time(time, "t")
    cmd = check_vector(command, "command")
    out = check_vector(response, "response")
    if cmd.size != time.size or out.size != time.size:
        raise ValueError(
            "t, command and response must have the same length; got"
            f" {time.size}, {cmd.size} and {out.size}"
        )
    return time, cmd, out


def _bandwidth_rule(
    ratio: FloatArray,
    freq_array: FloatArray,
    first: int,
    skipped: str,
    threshold_value: float,
    cycles: int,
    min_below: int,
) -> tuple[BandwidthStatus, float, int, str]:
    """Status, bandwidth, crossing index and reason from the amplitude ratio of each window."""
    above = np.flatnonzero(ratio[first:] >= threshold_value) + first
    if first == ratio.size:
        start, rate = _advised_chirp(float(freq_array[0]), cycles)
        reason = (
            f"no window can be measured: {skipped}; sweep slower, at most {rate:.2g} rad/s^2 at"
            f" {start:.3g} rad/s"
        )
        return "not_reached", math.nan, -1, reason
    if above.size == 0:
        start, rate = _advised_chirp(float(freq_array[first]), cycles)
        reason = (
            f"the amplitude ratio is below threshold={threshold_value:g} in every measured window,"
            f" already {ratio[first]:.3g} at {freq_array[first]:.3g} rad/s (the first measured),"
            f" so the bandwidth is below about {freq_array[first]:.3g} rad/s, or the response is"
            f" not in the command's unit (its gain at low frequency is not 1); {skipped}."
            f" To measure it, start the chirp at or below {start:.3g} rad/s and sweep it no"
            f" faster than {rate:.2g} rad/s^2 (neckid.signals.chirp with"
            f" omega_start <= {start:.3g} and (omega_end - omega_start) / duration <= {rate:.2g})"
        )
        return "below_at_start", math.nan, first, reason
    if ratio.size - 1 - above[-1] < min_below:
        reason = (
            f"the amplitude ratio has not stayed below threshold={threshold_value:g} for"
            f" {min_below} windows by the end of the record (last frequency"
            f" {freq_array[-1]:.4g} rad/s); use a longer or faster chirp"
        )
        return "not_reached", math.nan, -1, reason
    i = int(above[-1])
    r0, r1 = ratio[i], ratio[i + 1]
    f0, f1 = freq_array[i], freq_array[i + 1]
    fraction = (r0 - threshold_value) / (r0 - r1) if r0 != r1 else 0.0
    bandwidth = float(f0 + fraction * (f1 - f0))
    reason = (
        f"the amplitude ratio falls below threshold={threshold_value:g} for good between"
        f" {f0:.4g} and {f1:.4g} rad/s (ratio {r0:.3g} and {r1:.3g}), at {bandwidth:.4g} rad/s"
        f" by linear interpolation; {skipped}"
    )
    return "found", bandwidth, i + 1, reason


def _advised_chirp(frequency: float, cycles: int) -> tuple[float, float]:
    """Start frequency (rad/s) and largest rate (rad/s^2) of a chirp that measures below ``frequency``.

    It starts at a third of ``frequency`` and sweeps a quarter of its start frequency per window.
    """
    start = frequency / 3.0
    return start, start**2 / (4.0 * math.pi * cycles)


def _skipped_windows(first: int, frequency: FloatArray, sweeps: list[float]) -> str:
    """Words for the leading windows the rule does not use (``first >= 1``)."""
    last = frequency[min(first, frequency.size) - 1]
    what = (
        f"the first window ({frequency[0]:.3g} rad/s) is"
        if first == 1
        else f"the first {first} windows ({frequency[0]:.3g} to {last:.3g} rad/s) are"
    )
    fast = [s for s in sweeps[:first] if s > _MAX_WINDOW_SWEEP]
    sweep = (
        f", and the command's frequency changes by more than {_MAX_WINDOW_SWEEP:.0%} within"
        f" {'it' if first == 1 else 'them'} ({max(fast):.0%})"
        if fast
        else ""
    )
    holder = "it" if first == 1 else "the first"
    return f"{what} not used: {holder} holds the start transient{sweep}"
