"""The windows of a chirp run: the command's phase, and each window's frequency and amplitudes.

The machinery behind :func:`neckid.signals.bandwidth_from_chirp` (see its Notes).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import integrate
from scipy import signal as sps

from neckid.utils.checks import check_vector
from neckid.utils.types import FloatArray

__all__ = ["chirp_phase", "window_envelopes"]


def chirp_phase(
    time: FloatArray,
    cmd: FloatArray,
    frequency: ArrayLike | Callable[[FloatArray], ArrayLike] | None,
) -> FloatArray:
    """The command's phase: integrated from ``frequency``, or estimated from the command."""
    if frequency is None:
        if np.ptp(cmd) == 0:
            raise ValueError("command is constant; a chirp command must oscillate")
        return _phase_from_command(time, cmd)
    omega_raw = frequency(time) if callable(frequency) else frequency
    omega = check_vector(omega_raw, "frequency")
    if omega.size != time.size:
        raise ValueError(
            f"frequency must give one value per time stamp ({time.size}); got {omega.size}"
        )
    negative = np.flatnonzero(omega < 0)
    if negative.size:
        raise ValueError(
            f"frequency must be >= 0 rad/s; got {float(omega[negative[0]])!r} at row {negative[0]}"
        )
    return _phase_from_frequency(time, omega)


def window_envelopes(
    time: FloatArray,
    phase: FloatArray,
    cmd: FloatArray,
    out: FloatArray,
    cycles: int,
    min_samples: int,
) -> tuple[list[float], FloatArray, list[float], FloatArray, FloatArray]:
    """Centre, frequency, sweep and command and response amplitudes of each analysis window."""
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
    sweeps: list[float] = []
    cmd_amp: list[float] = []
    out_amp: list[float] = []
    for k in range(n_half - span + 1):
        lo, mid, hi = int(edges[k]), int(edges[k + cycles]), int(edges[k + span])
        if hi - lo + 1 < min_samples * cycles:
            break
        window = slice(lo, hi + 1)
        tw, pw = time[window], phase[window]
        duration = tw[-1] - tw[0]
        centres.append(0.5 * (tw[0] + tw[-1]))
        freqs.append(float((pw[-1] - pw[0]) / duration))
        sweeps.append(_window_sweep(time, phase, lo, mid, hi))
        cmd_amp.append(_harmonic_amplitude(tw, pw, cmd[window]))
        out_amp.append(_harmonic_amplitude(tw, pw, out[window]))

    if len(centres) < 2:
        raise ValueError(
            "fewer than two windows of the command hold at least"
            f" min_samples_per_cycle={min_samples} samples; sample faster or lower the chirp rate"
        )
    command_amplitude = np.asarray(cmd_amp)
    tiny = np.flatnonzero(command_amplitude <= 1e-12 * max(1.0, float(np.abs(cmd).max())))
    if tiny.size:
        raise ValueError(
            f"command has no oscillation in the window around t={centres[tiny[0]]:g} s"
            f" (amplitude {float(command_amplitude[tiny[0]])!r}); is it a chirp?"
        )
    return centres, np.asarray(freqs), sweeps, command_amplitude, np.asarray(out_amp)


def _phase_from_frequency(time: FloatArray, omega: FloatArray) -> FloatArray:
    return np.asarray(integrate.cumulative_trapezoid(omega, time, initial=0.0), dtype=np.float64)


def _cycle_bounds(phase: FloatArray) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """For each sample, the first and last index of the cycle centred on it (phase ± pi)."""
    last = phase.size - 1
    lo = np.minimum(np.searchsorted(phase, phase - math.pi, side="left"), last)
    hi = np.minimum(np.searchsorted(phase, phase + math.pi, side="right") - 1, last)
    return lo, np.maximum(hi, lo)


def _hilbert_phase(values: FloatArray) -> FloatArray:
    phase = np.unwrap(np.angle(sps.hilbert(values)))
    # Noise can make the estimated phase step back a little; the windows need a monotone phase.
    return np.asarray(np.maximum.accumulate(phase), dtype=np.float64)


def _phase_from_command(time: FloatArray, command: FloatArray) -> FloatArray:
    """Phase of a chirp command estimated from the samples (no frequency given).

    1. Phase of the analytic signal (Hilbert transform) of the mean-removed command.
    2. The command's local offset, its mean over the cycle centred on each sample, is removed and
       the analytic-signal phase taken again (a record-wide mean leaves a slowly varying offset
       that makes the phase wobble once per cycle).
    3. The instantaneous frequency is averaged over the cycle centred on each sample
       (phase advance / time) and integrated back into a phase.
    """
    phase = _hilbert_phase(command - command.mean())
    lo, hi = _cycle_bounds(phase)
    sums = np.concatenate([[0.0], np.cumsum(command)])
    local_mean = (sums[hi + 1] - sums[lo]) / (hi - lo + 1)
    phase = _hilbert_phase(command - local_mean)
    lo, hi = _cycle_bounds(phase)
    span = time[hi] - time[lo]
    omega = np.gradient(phase, time)
    wide = span > 0
    omega[wide] = (phase[hi[wide]] - phase[lo[wide]]) / span[wide]
    return _phase_from_frequency(time, omega)


def _harmonic_amplitude(time: FloatArray, phase: FloatArray, values: FloatArray) -> float:
    """First-harmonic amplitude at the window centre, by least squares.

    ``values ≈ a + b s + (c + e s) cos(phase) + (d + f s) sin(phase)`` with ``s = t - t_centre``;
    the amplitude at the centre is ``hypot(c, d)``.
    """
    centred = time - time.mean()
    cos, sin = np.cos(phase), np.sin(phase)
    basis = np.column_stack([np.ones_like(time), centred, cos, sin, centred * cos, centred * sin])
    coef, *_ = np.linalg.lstsq(basis, values, rcond=None)
    return float(math.hypot(coef[2], coef[3]))


def _window_sweep(time: FloatArray, phase: FloatArray, lo: int, mid: int, hi: int) -> float:
    """How much the mean frequency changes between the two halves of a window (0: not at all)."""
    if not lo < mid < hi:
        return math.inf
    first = (phase[mid] - phase[lo]) / (time[mid] - time[lo])
    second = (phase[hi] - phase[mid]) / (time[hi] - time[mid])
    if first <= 0 or second <= 0:
        return math.inf
    return float(max(second / first, first / second) - 1.0)
