"""The compiled passes behind :mod:`neckid.models.domain`: values outside a box, counted by term.

A *term* is a channel of a log read at a lag, one row ``(source, channel, lag)`` of an integer
array: at sample ``t`` it reads ``outputs[channel, t − lag]`` (source 0) or
``inputs[channel, t − lag]`` (source 1), as :meth:`~neckid.regressors.ResolvedLags.build_one`
puts ``y[t − lag, channel]`` or ``u[t − lag, channel]`` in the regressor; a channel's own range is
a term of lag 0. Its box is one row ``(low, high)`` of a float array; a value is outside when
``value < low or value > high``.

The passes take the log channel by channel, ``outputs = y.T`` and ``inputs = u.T`` made
C-contiguous (:func:`channels_of`; no copy for a log of one channel), so that every loop runs
over a contiguous row and vectorises. They go over the samples a block of :data:`BLOCK` at a
time, so that the compiled free run of :mod:`neckid.models.linear._arx_kernels` counts a block
while it is still in the cache.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.utils.types import BoolArray, FloatArray

__all__ = ["BLOCK", "box_block", "box_counts", "channels_of", "count_outside", "count_term"]

#: Samples per block (a few arrays of this many float64 fit in a core's first-level cache).
BLOCK = 1024


def channels_of(values: ArrayLike) -> FloatArray:
    """``values`` (time down the rows) channel by channel: the C-contiguous transpose, read-only.

    No copy for one channel; the compiled passes are compiled for read-only arrays only.
    """
    channels = np.ascontiguousarray(np.asarray(values, dtype=np.float64).T).view()
    channels.flags.writeable = False
    return channels


@numba.njit(cache=True, nogil=True)
def count_term(
    outputs: FloatArray,
    inputs: FloatArray,
    term: NDArray[np.int64],
    low: float,
    high: float,
    start: int,
    stop: int,
) -> int:  # pragma: no cover - compiled; tested against regressor_domain and extrapolation
    """The samples ``start <= t < stop`` where ``term`` (source, channel, lag) is outside the box.

    The loop runs over a slice from 0 up: indices that cannot be negative let it vectorise.
    """
    rows = (outputs if term[0] == 0 else inputs)[term[1], start - term[2] : stop - term[2]]
    count = 0
    for t in range(rows.shape[0]):
        count += (rows[t] < low) | (rows[t] > high)
    return count


@numba.njit(cache=True, nogil=True)
def count_outside(
    outputs: FloatArray,
    inputs: FloatArray,
    terms: NDArray[np.int64],
    bounds: FloatArray,
    start: int,
    stop: int,
    counts: NDArray[np.int64],
) -> None:  # pragma: no cover - compiled; tested against regressor_domain and extrapolation
    """Add to ``counts[j]`` the samples ``start <= t < stop`` where term ``j`` is outside its box."""
    for j in range(terms.shape[0]):
        counts[j] += count_term(outputs, inputs, terms[j], bounds[j, 0], bounds[j, 1], start, stop)


@numba.njit(cache=True, nogil=True)
def box_block(
    outputs: FloatArray,
    inputs: FloatArray,
    terms: NDArray[np.int64],
    bounds: FloatArray,
    start: int,
    stop: int,
    counts: NDArray[np.int64],
    flags: BoolArray,
) -> int:  # pragma: no cover - compiled; tested against regressor_domain
    """:func:`count_outside` on samples ``start <= t < stop``, and how many have any term outside.

    ``flags`` is scratch space for at least ``stop − start`` samples; the union is only walked
    when two terms or more are outside somewhere in the block (otherwise it is the one term's
    count).
    """
    outside_terms = 0
    total = 0
    for j in range(terms.shape[0]):
        added = count_term(outputs, inputs, terms[j], bounds[j, 0], bounds[j, 1], start, stop)
        counts[j] += added
        total += added
        outside_terms += added > 0
    if outside_terms < 2:
        return total
    for t in range(stop - start):  # loops rather than slice assignments: quicker to compile
        flags[t] = False
    for j in range(terms.shape[0]):
        source, channel, lag = terms[j, 0], terms[j, 1], terms[j, 2]
        rows = (outputs if source == 0 else inputs)[channel, start - lag : stop - lag]
        low, high = bounds[j, 0], bounds[j, 1]
        for t in range(rows.shape[0]):
            flags[t] |= (rows[t] < low) | (rows[t] > high)
    union = 0
    for t in range(stop - start):
        union += flags[t]
    return union


@numba.njit(cache=True, nogil=True)
def box_counts(
    outputs: FloatArray,
    inputs: FloatArray,
    terms: NDArray[np.int64],
    bounds: FloatArray,
    start: int,
) -> tuple[NDArray[np.int64], int]:  # pragma: no cover - compiled; tested against regressor_domain
    """Samples ``t >= start`` where term ``j`` is outside its box, and where any term is.

    The regressor-box shares of a log without building its regressor matrix, block by block.
    """
    counts = np.zeros(terms.shape[0], np.int64)
    flags = np.empty(BLOCK, np.bool_)
    rows = 0
    n = inputs.shape[1]
    for begin in range(start, n, BLOCK):
        stop = min(begin + BLOCK, n)
        rows += box_block(outputs, inputs, terms, bounds, begin, stop, counts, flags)
    return counts, rows
