r"""What a control engineer reads off a closed-loop record: tracking error, oscillation, stair steps.

All functions take the loop's inclination and the *nominal* reference (the dither left out: it is
an excitation the loop follows only in part), in degrees, one row per sample, and the sampling
period in seconds. A *segment* is a run of rows where the nominal reference is constant
(:func:`reference_segments`): the stairs of a staircase, the step of a step log.

- :func:`tracking_error_rms`: :math:`\sqrt{\mathrm{mean}_k (r_k - y_k)^2}` [deg] over the segments.
- :func:`oscillation`: the period [s] and amplitude [deg] of the loop's dominant oscillation in the
  *settled* part of each segment (its first ``settle`` seconds left out). The error
  :math:`e = r - y` of segment :math:`j` is fitted by least squares with its own offset and phase,
  :math:`e_k \approx c_j + a_j \cos 2\pi f t_k + b_j \sin 2\pi f t_k`, for every :math:`f` of a
  fine grid; the period is :math:`1/f^\star` of the frequency that explains the most variance
  summed over the segments (a periodogram with a free phase per segment, as Lomb–Scargle's, so
  the gaps between segments do not matter), the amplitude the root-mean-square over the
  segments of :math:`\sqrt{a_j^2 + b_j^2}` at :math:`f^\star`. On a pure sinusoid both are exact
  to the grid's step; the ratio of the explained variance to the error's variance
  (``share``) says how much of the settled error is that oscillation (near 1: a limit cycle,
  near 0: noise).
- :func:`stair_responses`: per segment after the first row, the overshoot [%] past the new level
  relative to the step :math:`|\Delta r|`, and the settling time [s]: from the segment's start to
  the last sample outside :math:`|y - r| \le` ``band`` (+ one sample), NaN when the last sample is
  still outside (the loop does not settle there).

References
----------
- N. R. Lomb, "Least-squares frequency analysis of unequally spaced data", *Astrophysics and
  Space Science* 39, 1976 (the least-squares periodogram).
- K. Ogata, *Modern Control Engineering*, 5th ed., Prentice Hall, 2010, sec. 5-3 (overshoot and
  settling time of a step response).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from neckid.utils.checks import check_number, check_ts
from neckid.utils.types import FloatArray

__all__ = [
    "Oscillation",
    "oscillation",
    "reference_segments",
    "stair_responses",
    "tracking_error_rms",
]

#: Segments shorter than this many seconds are not stairs (a multisine's constant stretches).
MIN_SEGMENT_SECONDS = 2.0


def _vector(values: ArrayLike, argument: str) -> FloatArray:
    array = np.asarray(values, dtype=np.float64).reshape(-1)
    if array.shape[0] == 0:
        raise ValueError(f"{argument} must have at least one sample; got none")
    return array


def _pair(inclination: ArrayLike, reference: ArrayLike) -> tuple[FloatArray, FloatArray]:
    y = _vector(inclination, "inclination")
    r = _vector(reference, "reference")
    if y.shape != r.shape:
        raise ValueError(
            f"inclination and reference must have the same length; got {y.shape[0]} and"
            f" {r.shape[0]}"
        )
    return y, r


def reference_segments(
    reference: ArrayLike, ts: float, minimum: float = MIN_SEGMENT_SECONDS
) -> list[tuple[int, int]]:
    """Rows ``[start, stop)`` where the nominal reference is constant for at least ``minimum`` s.

    Parameters
    ----------
    reference : array_like, shape (n,)
        Nominal reference [deg] (no dither).
    ts : float
        Sampling period, s.
    minimum : float, default 2.0
        Shortest segment, s.

    Returns
    -------
    list of (int, int)

    Examples
    --------
    >>> reference_segments([1.0] * 100 + [2.0] * 100, ts=0.025)
    [(0, 100), (100, 200)]
    """
    r = _vector(reference, "reference")
    step = check_ts(ts)
    edges = np.flatnonzero(np.diff(r) != 0.0) + 1
    bounds = np.concatenate([[0], edges, [r.shape[0]]])
    shortest = max(math.ceil(minimum / step - 1e-9), 1)
    return [(int(a), int(b)) for a, b in itertools.pairwise(bounds) if b - a >= shortest]


def tracking_error_rms(
    inclination: ArrayLike,
    reference: ArrayLike,
    ts: float,
    segments: list[tuple[int, int]] | None = None,
) -> float:
    """Root-mean-square of ``reference − inclination`` over the segments [deg].

    Parameters
    ----------
    inclination, reference : array_like, shape (n,)
        The loop's inclination and the nominal reference [deg].
    ts : float
        Sampling period, s.
    segments : list of (int, int), optional
        Default :func:`reference_segments` of ``reference`` (every row when there is none).

    Returns
    -------
    float
    """
    y, r = _pair(inclination, reference)
    parts = reference_segments(r, ts) if segments is None else segments
    rows = np.concatenate([np.arange(a, b) for a, b in parts]) if parts else np.arange(y.shape[0])
    return float(np.sqrt(np.mean((r[rows] - y[rows]) ** 2)))


@dataclass(frozen=True)
class Oscillation:
    r"""The dominant oscillation of a loop's settled tracking error.

    Attributes
    ----------
    period : float
        :math:`1/f^\star`, s (NaN without a settled segment).
    amplitude : float
        Root-mean-square over the segments of the fitted sinusoid's amplitude, deg.
    share : float
        Share of the settled error's variance (each segment's mean removed) that the sinusoid
        at :math:`f^\star` explains, in [0, 1].
    """

    period: float
    amplitude: float
    share: float


def _settled_parts(
    error: FloatArray, segments: list[tuple[int, int]], skip: int
) -> list[FloatArray]:
    return [error[a + skip : b] for a, b in segments if b - (a + skip) >= 8]


def oscillation(
    inclination: ArrayLike,
    reference: ArrayLike,
    ts: float,
    *,
    settle: float = 3.0,
    frequencies: ArrayLike | None = None,
    segments: list[tuple[int, int]] | None = None,
) -> Oscillation:
    """Period and amplitude of the dominant oscillation of ``reference − inclination``.

    Parameters
    ----------
    inclination, reference : array_like, shape (n,)
        The loop's inclination and the nominal reference [deg].
    ts : float
        Sampling period, s.
    settle : float, default 3.0
        Seconds left out at the start of each segment (the step's transient).
    frequencies : array_like, optional
        The grid of trial frequencies, Hz; default 0.1 … 4 Hz in steps of 0.005 Hz, then
        ±0.01 Hz around the best in steps of 0.0001 Hz.
    segments : list of (int, int), optional
        Default :func:`reference_segments` of ``reference``.

    Returns
    -------
    Oscillation

    Notes
    -----
    See the module docstring; each segment's fit is ordinary least squares on
    ``[1, cos 2πft, sin 2πft]``, and the frequency maximises the explained sum of squares over
    the segments.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(2000) * 0.025
    >>> y = 10.0 + 2.0 * np.sin(2 * np.pi * t / 2.6)
    >>> found = oscillation(y, np.full(2000, 10.0), 0.025)
    >>> round(found.period, 2), round(found.amplitude, 2)
    (2.6, 2.0)
    """
    y, r = _pair(inclination, reference)
    step = check_ts(ts)
    skip = round(check_number(settle, "settle", low=0) / step)
    parts = _settled_parts(
        r - y, reference_segments(r, step) if segments is None else segments, skip
    )
    if not parts:
        return Oscillation(math.nan, math.nan, math.nan)
    centred = [p - p.mean() for p in parts]
    total = float(sum(c @ c for c in centred))
    if frequencies is None:  # coarse, then fine around the coarse peak (its lobe is ~0.1 Hz wide)
        coarse = np.arange(0.1, 4.0 + 1e-12, 0.005)
        peak = coarse[int(np.argmax(_explained_sum(centred, coarse, step)))]
        grid = np.arange(max(peak - 0.01, 0.05), peak + 0.01 + 1e-12, 0.0001)
    else:
        grid = _vector(frequencies, "frequencies")
    explained = _explained_sum(centred, grid, step)
    best = int(np.argmax(explained))
    amplitudes = [_explained(c, grid[best : best + 1], step)[1][0] for c in centred]
    return Oscillation(
        period=float(1.0 / grid[best]),
        amplitude=float(np.sqrt(np.mean(np.square(amplitudes)))),
        share=float(explained[best] / total) if total > 0.0 else math.nan,
    )


def _explained_sum(centred: list[FloatArray], grid: FloatArray, ts: float) -> FloatArray:
    """Explained sum of squares per frequency, summed over the segments."""
    return np.sum([_explained(c, grid, ts)[0] for c in centred], axis=0)


def _explained(centred: FloatArray, grid: FloatArray, ts: float) -> tuple[FloatArray, FloatArray]:
    """Explained sum of squares and amplitude of ``c + a cos + b sin`` fits, per frequency."""
    n = centred.shape[0]
    t = np.arange(n) * ts
    phase = 2.0 * np.pi * np.outer(grid, t)
    cos, sin = np.cos(phase), np.sin(phase)
    # Remove each basis vector's mean: the offset is fitted too.
    cos -= cos.mean(axis=1, keepdims=True)
    sin -= sin.mean(axis=1, keepdims=True)
    cc = np.einsum("ij,ij->i", cos, cos)
    ss = np.einsum("ij,ij->i", sin, sin)
    cs = np.einsum("ij,ij->i", cos, sin)
    cy, sy = cos @ centred, sin @ centred
    det = cc * ss - cs * cs
    ok = det > 1e-12 * np.maximum(cc * ss, 1e-300)
    a = np.where(ok, (ss * cy - cs * sy) / np.where(ok, det, 1.0), 0.0)
    b = np.where(ok, (cc * sy - cs * cy) / np.where(ok, det, 1.0), 0.0)
    return a * cy + b * sy, np.hypot(a, b)


def stair_responses(
    inclination: ArrayLike,
    reference: ArrayLike,
    ts: float,
    *,
    band: float = 1.0,
    segments: list[tuple[int, int]] | None = None,
    start: float | None = None,
) -> pd.DataFrame:
    """Overshoot and settling time of the loop on each stair (segment).

    Parameters
    ----------
    inclination, reference : array_like, shape (n,)
        The loop's inclination and the nominal reference [deg].
    ts : float
        Sampling period, s.
    band : float, default 1.0
        Settling band, deg: ``|y − r| ≤ band`` (the staircases' dither is ±1 deg).
    segments : list of (int, int), optional
        Default :func:`reference_segments` of ``reference``.
    start : float, optional
        The level before the first segment [deg]; default the inclination at its first row.

    Returns
    -------
    pandas.DataFrame
        One row per segment: ``level`` [deg], ``step`` [deg] (level minus the previous one),
        ``overshoot_percent`` (``100 max(0, max_k s (y_k − level)) / |step|``, ``s`` the step's
        sign; NaN for a zero step), ``settling_time_s`` (NaN: not settled by the segment's end).

    Examples
    --------
    >>> import numpy as np
    >>> y = np.concatenate([np.full(10, 0.0), [5.0, 6.0, 5.5], np.full(200, 5.0)])
    >>> table = stair_responses(y, np.r_[np.zeros(10), np.full(203, 5.0)], 0.025, band=0.2,
    ...                         segments=[(10, 213)], start=0.0)
    >>> table[["overshoot_percent", "settling_time_s"]].round(3).values.tolist()
    [[20.0, 0.075]]
    """
    y, r = _pair(inclination, reference)
    step_s = check_ts(ts)
    width = check_number(band, "band", low=0, closed="neither")
    parts = reference_segments(r, step_s) if segments is None else segments
    rows = []
    previous = float(y[parts[0][0]]) if parts and start is None else start
    for a, b in parts:
        level = float(r[a])
        jump = level - float(previous) if previous is not None else math.nan
        y_part = y[a:b]
        overshoot = (
            100.0 * max(0.0, float(np.max(np.sign(jump) * (y_part - level)))) / abs(jump)
            if jump and math.isfinite(jump)
            else math.nan
        )
        outside = np.flatnonzero(np.abs(y_part - level) > width)
        if outside.size == 0:
            settling = 0.0
        elif outside[-1] == y_part.shape[0] - 1:
            settling = math.nan
        else:
            settling = float(outside[-1] + 1) * step_s
        rows.append(
            {
                "level": level,
                "step": jump,
                "overshoot_percent": overshoot,
                "settling_time_s": settling,
            }
        )
        previous = level
    return pd.DataFrame(rows, columns=["level", "step", "overshoot_percent", "settling_time_s"])
