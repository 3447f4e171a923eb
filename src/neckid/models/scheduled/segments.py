"""Where the operating points of the scheduled model lie in a record: dwells, bins or segments.

The seed paper (section IV) identifies ``G(z) = N / (z − P)`` by CFF-RLS while the neck is held
at one inclination. In a log nobody marked where it was held, so
:class:`~neckid.models.scheduled.model.GainScheduledModel` finds the operating points itself
(``segments="dwell"``, its default):

1. **Smooth** the inclination with the estimator's own memory (:func:`smooth_inclination`): a
   first-order low-pass whose pole is the forgetting factor ``λ``, run forward and backward so
   that it does not delay the edges. CFF-RLS weighs the past by ``λ^k``, so this is the
   inclination the estimate belongs to; an excitation faster than that memory (the stair logs'
   ±1° dither, the 3 rad/s sine of their first 20 s) is the persistent excitation of a point, not
   a move to another one.
2. **Dwells** (:func:`find_dwells`): from the first sample on, a run grows while its smoothed
   inclination stays inside a band of :data:`DWELL_BAND` = 2° (largest minus smallest); when
   the next sample would leave the band the run ends and the next one starts there. A run of at
   least :data:`DWELL_MEMORIES` = 4 memories of the estimator (``4 / (1 − λ)`` samples: 200 at
   ``λ = 0.98``, 5 s at the bench's 0.025 s) is trimmed at its ends to the samples within ±1°
   (half the band) of its median, since it may begin on the tail of a ramp; it joins the
   previous dwell when the two together (and what lies between) still span at most the band
   (one stair cut in two), and is a dwell, one operating point, when it still holds four
   memories. Why these values: the band is under half the 5° between the seed paper's
   operating points (5°, 10°, …, 35°), so two neighbouring points never merge into one dwell,
   and it is wider than what the smoothed closed loop wanders while held; four memories leave
   two for the estimate to forget its start and two to average and check its convergence over
   (the default ``window`` is half a segment).
3. **Bins** (:func:`inclination_bins`), when fewer dwells than the lines need (``degree + 1``)
   were found, e.g. a record that sweeps the inclination without holding it: the samples are
   sorted by their smoothed inclination into bins of equal sample count, as many as the band
   fits into the smoothed range (its width over :data:`DWELL_BAND`, rounded up), at least
   ``degree + 1`` and at most as many as hold four memories each. One bin is one operating
   point, made of every stretch of the record that passes through it (CFF-RLS runs over them
   one after the other, carrying its estimate over, no regressor straddling two).

``segments`` may also be ``"bins"`` (bins only), a number of equal parts per record, or
boundaries in seconds (see :func:`operating_segments`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData
from neckid.utils.checks import check_number, check_time_vector, check_vector
from neckid.utils.types import FloatArray

__all__ = [
    "DWELL_BAND",
    "DWELL_MEMORIES",
    "SEGMENTATIONS",
    "OperatingSegment",
    "estimator_memory",
    "find_dwells",
    "inclination_bins",
    "operating_segments",
    "smooth_inclination",
]

#: Largest spread [deg] of the smoothed inclination over one dwell (largest minus smallest).
DWELL_BAND = 2.0

#: Shortest dwell, and fewest samples of a bin, in memories of the estimator (``1 / (1 − λ)``).
DWELL_MEMORIES = 4

#: The rules found by name: ``"dwell"`` (dwells, else bins) and ``"bins"`` (bins only).
SEGMENTATIONS = ("dwell", "bins")

#: Shortest stretch of a bin kept [samples]: a first-order regressor on the rate needs three.
_SHORTEST_RUN = 3


class OperatingSegment(NamedTuple):
    """Where one operating point lies: one or more stretches of one record.

    ``runs`` are the stretches (one for a dwell, a segment or a whole record; those of a bin);
    ``experiment`` indexes the record (``-1`` for a bin over several records); ``kind`` is
    ``"dwell"``, ``"bin"``, ``"segment"`` or ``"experiment"``.
    """

    runs: tuple[IOData, ...]
    experiment: int
    kind: str

    @property
    def n_samples(self) -> int:
        """Samples in all its stretches."""
        return sum(run.n_samples for run in self.runs)

    @property
    def span(self) -> tuple[float, float]:
        """First and last time stamp [s] of its stretches."""
        return float(self.runs[0].time[0]), float(self.runs[-1].time[-1])


def estimator_memory(forgetting_factor: float) -> int:
    """Samples CFF-RLS remembers, ``1 / (1 − λ)`` (50 at ``λ = 0.98``; 100 when ``λ = 1``).

    Examples
    --------
    >>> estimator_memory(0.98), estimator_memory(1.0)
    (50, 100)
    """
    lam = check_number(forgetting_factor, "forgetting_factor", low=0, high=1, closed="right")
    if lam >= 1.0:
        return 100  # ordinary RLS remembers everything: one fifth of its default window
    return max(2, round(1.0 / (1.0 - lam)))


def smooth_inclination(inclination: ArrayLike, forgetting_factor: float = 0.98) -> FloatArray:
    """The inclination as CFF-RLS weighs it: a zero-phase first-order low-pass of pole ``λ``.

    ``s(t) = λ s(t−1) + (1 − λ) i(t)`` run forward, then the same backward over the result, each
    pass starting in steady state at the first sample it sees (no transient at the ends). The
    pole is ``1 − 1 / memory`` (:func:`estimator_memory`): ``λ`` itself, 0.99 when ``λ = 1``.

    Parameters
    ----------
    inclination : array_like, shape (n_samples,)
        Inclination [deg].
    forgetting_factor : float, default 0.98
        ``λ`` of the estimator.

    Returns
    -------
    ndarray, shape (n_samples,)
        The smoothed inclination [deg].

    Examples
    --------
    >>> s = smooth_inclination(np.r_[np.zeros(300), np.ones(300)])
    >>> round(float(s[0]), 6), round(float(s[299]), 2), round(float(s[-1]), 6)
    (0.0, 0.5, 1.0)
    """
    from scipy.signal import lfilter

    values = check_vector(inclination, "inclination")
    if values.size == 0:
        return values
    pole = 1.0 - 1.0 / estimator_memory(forgetting_factor)
    b, a = [1.0 - pole], [1.0, -pole]
    forward = lfilter(b, a, values, zi=[pole * values[0]])[0]
    backward = lfilter(b, a, forward[::-1], zi=[pole * forward[-1]])[0]
    return np.ascontiguousarray(backward[::-1], dtype=np.float64)


def find_dwells(
    inclination: ArrayLike,
    *,
    forgetting_factor: float = 0.98,
    band: float = DWELL_BAND,
    min_samples: int | None = None,
) -> list[tuple[int, int]]:
    """Stretches where the smoothed inclination stays inside a band: the record's dwells.

    From the first sample on, a run grows while the largest minus the smallest smoothed
    inclination (:func:`smooth_inclination`) over it is at most ``band``; the sample that would
    widen it past ``band`` starts the next run. A run of at least ``min_samples`` is trimmed at
    both ends to the samples within ``band / 2`` of its median (it may begin on a ramp), joins
    the previous dwell when both together, and what lies between, span at most ``band``, and
    is a dwell when it still holds ``min_samples``.

    Parameters
    ----------
    inclination : array_like, shape (n_samples,)
        Inclination [deg].
    forgetting_factor : float, default 0.98
        ``λ`` of the estimator: it sets the smoothing and the default ``min_samples``.
    band : float, default :data:`DWELL_BAND` (2 deg)
        Largest spread of the smoothed inclination over a dwell [deg].
    min_samples : int, optional
        Shortest dwell [samples]; default :data:`DWELL_MEMORIES` memories of the estimator,
        ``4 / (1 − λ)`` (200 at ``λ = 0.98``).

    Returns
    -------
    list of (int, int)
        ``(start, stop)`` sample indices of each dwell (``stop`` excluded), in time order.

    Examples
    --------
    Three stairs of 10 s at 50 Hz with a ±1° dither, one 0.4 s ramp between them:

    >>> rng = np.random.default_rng(0)
    >>> stairs = np.concatenate([np.full(500, 10.0), np.linspace(10, 15, 20), np.full(500, 15.0),
    ...                          np.linspace(15, 20, 20), np.full(500, 20.0)])
    >>> dwells = find_dwells(stairs + rng.uniform(-1, 1, stairs.size))
    >>> [round(float(np.mean(stairs[a:b])), 1) for a, b in dwells]
    [10.0, 15.0, 20.0]
    """
    smooth = smooth_inclination(inclination, forgetting_factor)
    width = check_number(band, "band", low=0, closed="neither")
    if min_samples is None:
        shortest = DWELL_MEMORIES * estimator_memory(forgetting_factor)
    else:
        shortest = check_number(min_samples, "min_samples", low=1, integer=True)
    return _dwells(smooth, width, shortest)


def _dwells(smooth: FloatArray, band: float, shortest: int) -> list[tuple[int, int]]:
    """The dwells of :func:`find_dwells` on an already smoothed inclination."""
    runs: list[tuple[int, int]] = []
    n = smooth.size
    start = 0
    while start < n:  # greedy runs of spread <= band
        low = high = smooth[start]
        stop = start + 1
        while stop < n:
            value = smooth[stop]
            if max(high, value) - min(low, value) > band:
                break
            low, high = min(low, value), max(high, value)
            stop += 1
        runs.append((start, stop))
        start = stop
    half = 0.5 * band
    dwells: list[tuple[int, int]] = []
    for start, stop in runs:
        if stop - start < shortest:
            continue
        # trim the ends outside ±band/2 of the run's median (a run may begin on a ramp)
        inside = np.abs(smooth[start:stop] - np.median(smooth[start:stop])) <= half
        start, stop = start + int(np.argmax(inside)), stop - int(np.argmax(inside[::-1]))
        if dwells and np.ptp(smooth[dwells[-1][0] : stop]) <= band:
            dwells[-1] = (dwells[-1][0], stop)  # the same level as the previous dwell: one
        elif stop - start >= shortest:
            dwells.append((start, stop))
    return dwells


def inclination_bins(
    smoothed: Sequence[FloatArray], n_bins: int
) -> list[list[tuple[int, int, int]]]:
    """Stretches of each record in each of ``n_bins`` bins of equal sample count.

    Parameters
    ----------
    smoothed : sequence of ndarray
        The smoothed inclination of each record [deg] (:func:`smooth_inclination`).
    n_bins : int
        Number of bins; their edges are quantiles of all the records' samples together.

    Returns
    -------
    list of list of (int, int, int)
        Per bin, from low to high inclination, ``(record, start, stop)`` of each stretch of
        at least three samples whose smoothed inclination lies in the bin, in time order.

    Examples
    --------
    >>> ramp = np.linspace(0.0, 10.0, 100)
    >>> inclination_bins([ramp], 2)
    [[(0, 0, 50)], [(0, 50, 100)]]
    """
    count = check_number(n_bins, "n_bins", low=1, integer=True)
    pooled = np.concatenate([np.asarray(s, dtype=np.float64) for s in smoothed])
    edges = np.quantile(pooled, np.linspace(0.0, 1.0, count + 1))
    bins: list[list[tuple[int, int, int]]] = [[] for _ in range(count)]
    for record, values in enumerate(smoothed):
        # bin index of every sample: the last edge belongs to the last bin
        index = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, count - 1)
        changes = np.flatnonzero(np.diff(index)) + 1
        for start, stop in itertools.pairwise([0, *changes.tolist(), index.size]):
            if stop - start >= _SHORTEST_RUN:
                bins[int(index[start])].append((record, int(start), int(stop)))
    return bins


def _bin_segments(
    experiments: Sequence[IOData], smoothed: list[FloatArray], degree: int, memory: int
) -> list[OperatingSegment]:
    """One segment per bin of the smoothed inclination (see the module's rule 3)."""
    pooled = np.concatenate(smoothed)
    spread = float(pooled.max() - pooled.min())
    most = pooled.size // (DWELL_MEMORIES * memory)
    wanted = max(degree + 1, math.ceil(spread / DWELL_BAND))
    n_bins = max(1, min(wanted, most))
    segments = []
    for stretches in inclination_bins(smoothed, n_bins):
        runs = tuple(experiments[r][a:b] for r, a, b in stretches)
        if sum(run.n_samples for run in runs) >= DWELL_MEMORIES * memory:
            records = {r for r, _, _ in stretches}
            segments.append(
                OperatingSegment(runs, records.pop() if len(records) == 1 else -1, "bin")
            )
    return segments


def _split(data: IOData, segments: Any, index: int) -> list[OperatingSegment]:
    """A record cut into ``segments`` equal parts (an int) or at boundaries in seconds."""
    if isinstance(segments, int | np.integer):
        bounds = np.linspace(0, data.n_samples, int(segments) + 1).round().astype(int)
        whole = int(segments) == 1
        return [
            OperatingSegment((data[a:b],), index, "experiment" if whole else "segment")
            for a, b in itertools.pairwise(bounds)
            if b > a
        ]
    edges = check_time_vector(segments, "segments", increasing=True)
    pieces = []
    for start, stop in itertools.pairwise(edges):
        if data.t0 + start >= data.time[-1]:
            break
        piece = data.time_slice(data.t0 + start, data.t0 + stop)
        # a segment cut short by the end of the record counts if half of it is there
        if piece.n_samples * data.ts >= 0.5 * (stop - start):
            pieces.append(OperatingSegment((piece,), index, "segment"))
    return pieces


def operating_segments(
    experiments: Sequence[IOData],
    segments: Any,
    *,
    forgetting_factor: float = 0.98,
    degree: int = 1,
) -> tuple[list[OperatingSegment], str]:
    """Where the operating points lie in the records, and by which rule they were found.

    Parameters
    ----------
    experiments : sequence of IOData
        The records; the inclination is the first output.
    segments : {"dwell", "bins"}, int, array_like of float or None
        ``"dwell"`` (or ``None``): the dwells of every record (:func:`find_dwells`), or bins
        when they give fewer than ``degree + 1`` points; ``"bins"``: bins only; an int ``n``:
        ``n`` equal parts of every record (``1``: one point per record); an array: boundaries
        in seconds from each record's start, a last segment cut short by the end of a record
        kept when half of it is there.
    forgetting_factor : float, default 0.98
        ``λ`` of the estimator (smoothing, shortest dwell, fewest samples per bin).
    degree : int, default 1
        Degree of the lines: dwells fall back to bins below ``degree + 1`` points.

    Returns
    -------
    (list of OperatingSegment, str)
        The segments and the rule that gave them: ``"dwell"``, ``"bins"``, ``"equal"`` or
        ``"edges"``.

    Raises
    ------
    ValueError
        If bins are needed and the records are too short for ``degree + 1`` of them.
    """
    if segments is not None and not isinstance(segments, str):
        rule = "equal" if isinstance(segments, int | np.integer) else "edges"
        return [s for k, d in enumerate(experiments) for s in _split(d, segments, k)], rule
    memory = estimator_memory(forgetting_factor)
    smoothed = [smooth_inclination(d.y[:, 0], forgetting_factor) for d in experiments]
    if segments in (None, "dwell"):
        found = [
            OperatingSegment((data[a:b],), k, "dwell")
            for k, (data, smooth) in enumerate(zip(experiments, smoothed, strict=True))
            for a, b in _dwells(smooth, DWELL_BAND, DWELL_MEMORIES * memory)
        ]
        if len(found) >= degree + 1:
            return found, "dwell"
    found = _bin_segments(experiments, smoothed, int(degree), memory)
    if len(found) < degree + 1:
        total = sum(d.n_samples for d in experiments)
        raise ValueError(
            f"the records hold {f'fewer than {degree + 1} dwells and ' if segments != 'bins' else ''}"
            "too few samples for"
            f" {degree + 1} inclination bins of four memories of the estimator"
            f" ({DWELL_MEMORIES * memory} samples) each: {total} samples; give longer records that"
            " visit more inclinations, or segments=N (--set segments=N: N equal parts of every"
            " record)"
        )
    return found, "bins"
