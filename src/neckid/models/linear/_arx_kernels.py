"""The compiled single-output free run of :mod:`neckid.models.linear.arx`, checks included.

One pass over the samples, a block of :data:`~neckid.models._domain_kernels.BLOCK` rows at a
time: the FIR part of each input (summed tap by tap, a fixed order), the all-pole part
(``scipy.signal.lfilter``'s direct form II transposed), and, while the block is in the cache,
what every free run checks (the time stamps of the result, the channels and regressor terms
outside their training ranges, the first non-finite output, the first output outside the
divergence envelope). The Python wrapper (:func:`neckid.models.linear.arx.linear_free_run` and
``LinearARX.simulate``) validates, allocates and turns counts into shares.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from neckid.models._domain_kernels import BLOCK, box_block, count_outside
from neckid.utils.types import FloatArray

__all__ = ["MAX_FIR_TAPS", "all_pole_block", "checked_free_run", "fir_block"]

#: Most taps of one input's FIR filter the compiled run sums itself, in a fixed order (the same
#: floats on every CPU). ``np.convolve`` takes each output as a dot product (OpenBLAS's
#: ``ddot``), whose order depends on the core: one by one for short vectors on some, SIMD
#: blocks from 12 products on AVX-512. The two agree to rounding (tested with the bound in
#: ``tests/test_arx_overhead.py``); with more taps the caller convolves.
MAX_FIR_TAPS = 15


@numba.njit(cache=True, nogil=True)
def fir_block(
    inputs: FloatArray,
    channel: NDArray[np.int64],
    numerator: FloatArray,
    forcing: FloatArray,
    intercept: float,
    start: int,
    begin: int,
    x: FloatArray,
    partial: FloatArray,
) -> None:  # pragma: no cover - compiled; tested against a fixed-order reference and np.convolve
    """``x[k]`` for ``t = begin + k``: ``forcing[t − start]`` (or ``intercept``) plus each FIR.

    Input ``i`` adds ``Σ_k inputs[channel_i, t − width + 1 + k] · numerator[i, width − 1 − k]``,
    summed in ``partial`` from ``k = 0`` up, a fixed order: ``np.convolve(numerator[i],
    u[:, channel_i])[t]`` to rounding (bit for bit where its ``ddot`` adds one by one). Rows
    padded with zeros at the high lags give the same floats: the sum starts at ``+0.0`` and
    stays there until the first real tap.
    """
    count, width = x.shape[0], numerator.shape[1]
    for j in range(count):  # loops rather than slice assignments: quicker to compile
        x[j] = forcing[begin - start + j] if forcing.shape[0] else intercept
    for i in range(channel.shape[0]):
        for j in range(count):
            partial[j] = 0.0
        for k in range(width):
            tap = numerator[i, width - 1 - k]
            first = begin - width + 1 + k
            rows = inputs[channel[i], first : first + count]
            for j in range(count):
                partial[j] += rows[j] * tap
        for j in range(count):
            x[j] += partial[j]


@numba.njit(cache=True, nogil=True)
def all_pole_block(
    denominator: FloatArray, x: FloatArray, state: FloatArray, out: FloatArray, begin: int
) -> None:  # pragma: no cover - compiled; tested bit for bit against lfilter
    """``rows[k] = lfilter([1.0], denominator, x, zi=state)[0][k]``; ``state`` moves on.

    The direct form II transposed of SciPy's ``_linear_filter`` with the numerator ``[1, 0, ...]``
    padded to the denominator's length, term by term in its order (the products with the
    numerator's zeros included), ``denominator[0] = 1``. Up to order 3 the state is held in
    locals (registers), which takes a store and a load off the recursion's critical path; the
    arithmetic is the same. Order 0 (no output lag) copies ``x``.
    """
    order = denominator.shape[0] - 1
    rows = out[begin : begin + x.shape[0]]
    if order == 0:
        for k in range(x.shape[0]):
            rows[k] = x[k]
    elif order == 1:
        z0, d1 = state[0], denominator[1]
        for k in range(x.shape[0]):
            xn = x[k]
            yn = z0 + 1.0 * xn
            z0 = xn * 0.0 - yn * d1
            rows[k] = yn
        state[0] = z0
    elif order == 2:
        z0, z1, d1, d2 = state[0], state[1], denominator[1], denominator[2]
        for k in range(x.shape[0]):
            xn = x[k]
            yn = z0 + 1.0 * xn
            z0 = z1 + xn * 0.0 - yn * d1
            z1 = xn * 0.0 - yn * d2
            rows[k] = yn
        state[0], state[1] = z0, z1
    elif order == 3:
        z0, z1, z2 = state[0], state[1], state[2]
        d1, d2, d3 = denominator[1], denominator[2], denominator[3]
        for k in range(x.shape[0]):
            xn = x[k]
            yn = z0 + 1.0 * xn
            z0 = z1 + xn * 0.0 - yn * d1
            z1 = z2 + xn * 0.0 - yn * d2
            z2 = xn * 0.0 - yn * d3
            rows[k] = yn
        state[0], state[1], state[2] = z0, z1, z2
    else:
        for k in range(x.shape[0]):
            xn = x[k]
            yn = state[0] + 1.0 * xn
            for i in range(order - 1):
                state[i] = state[i + 1] + xn * 0.0 - yn * denominator[i + 1]
            state[order - 1] = xn * 0.0 - yn * denominator[order]
            rows[k] = yn


@numba.njit(cache=True, nogil=True)
def _first_flags(
    out: FloatArray, begin: int, stop: int, envelope: FloatArray, non_finite: int, runaway: int
) -> tuple[int, int]:  # pragma: no cover - compiled; tested against Estimator.first_runaway
    """The first row of ``out[begin:stop]`` not finite, and outside ``envelope`` (if not yet found).

    NaN is never outside the envelope (as ``Estimator.first_runaway`` counts); -1 for none.
    """
    low, high = envelope[0], envelope[1]
    rows = out[begin:stop]
    suspect = False
    for k in range(rows.shape[0]):
        suspect |= (not np.isfinite(rows[k])) | (rows[k] < low) | (rows[k] > high)
    if not suspect:
        return non_finite, runaway
    for k in range(rows.shape[0]):
        if non_finite < 0 and not np.isfinite(rows[k]):
            non_finite = begin + k
        if runaway < 0 and (rows[k] < low or rows[k] > high):
            runaway = begin + k
    return non_finite, runaway


@numba.njit(cache=True, nogil=True)
def _fill_time(
    time: FloatArray, t0: float, ts: float, begin: int, stop: int
) -> None:  # pragma: no cover - compiled; tested bit for bit against IOData.time
    """``time[t] = t0 + ts · t`` (``IOData.time``'s arithmetic); nothing for an empty ``time``."""
    if time.shape[0]:
        rows = time[begin:stop]
        for k in range(rows.shape[0]):
            rows[k] = t0 + ts * (begin + k)


@numba.njit(cache=True, nogil=True)
def _screens(
    n_channels: int,
    source: int,
    groups: tuple[NDArray[np.int64], NDArray[np.int64]],
    bounds: tuple[FloatArray, FloatArray],
) -> FloatArray:  # pragma: no cover - compiled; tested through checked_free_run's counts
    """Per channel of ``source`` (0 outputs, 1 inputs): ``(used, deepest lag, low, high)``.

    Over the terms of both ``groups`` on the channel (their bounds in ``bounds``): the highest
    lag and the intersection of their boxes. A block whose rows of the channel, from
    ``begin − lag`` to ``stop``, are all inside it has no term of the channel outside its own.
    """
    screens = np.zeros((n_channels, 4))
    screens[:, 2], screens[:, 3] = -np.inf, np.inf
    for g in range(2):
        terms, box = groups[g], bounds[g]
        for j in range(terms.shape[0]):
            if terms[j, 0] == source:
                row = screens[terms[j, 1]]
                row[0] = 1.0
                row[1] = max(row[1], float(terms[j, 2]))
                row[2] = max(row[2], box[j, 0])
                row[3] = min(row[3], box[j, 1])
    return screens


@numba.njit(cache=True, nogil=True)
def _inside(
    values: FloatArray, screens: FloatArray, begin: int, stop: int
) -> bool:  # pragma: no cover - compiled; tested through checked_free_run's counts
    """Whether every screened channel of ``values`` is inside its screen's box over the block.

    NaN is inside (``count_term`` never counts it as outside): the test is ``v < low or v >
    high``, OR-ed over the rows (a reduction that vectorises).
    """
    for c in range(screens.shape[0]):
        if screens[c, 0] == 0.0:
            continue
        low, high = screens[c, 2], screens[c, 3]
        rows = values[c, begin - int(screens[c, 1]) : stop]
        outside = False
        for t in range(rows.shape[0]):
            outside |= (rows[t] < low) | (rows[t] > high)
        if outside:
            return False
    return True


@numba.njit(cache=True, nogil=True)
def checked_free_run(
    inputs: FloatArray,
    outputs: FloatArray,
    fir: tuple[NDArray[np.int64], FloatArray, FloatArray, float],
    denominator: FloatArray,
    state: FloatArray,
    out: FloatArray,
    time: tuple[FloatArray, float, float],
    channels: tuple[NDArray[np.int64], FloatArray],
    box: tuple[NDArray[np.int64], FloatArray],
    envelope: FloatArray,
    start: int,
) -> tuple[NDArray[np.int64], NDArray[np.int64], int, int, int]:  # pragma: no cover - compiled
    """The single-output free run ``out[start:]`` and its checks, one block of rows at a time.

    Parameters
    ----------
    inputs, outputs : ndarray, shape (n_inputs, n_samples) and (n_outputs, n_samples)
        The log channel by channel (``u.T`` and ``y.T``, C-contiguous:
        :func:`~neckid.models._domain_kernels.channels_of`): the inputs (the filter and the
        checks read them) and the measured outputs (the checks).
    fir : (channel, numerator, forcing, intercept)
        Input ``channel[i]`` filtered by ``numerator[i]`` (:func:`fir_block`), added to
        ``forcing`` (``n_samples − start`` values, or none: then ``intercept``).
    denominator, state : ndarray
        The all-pole filter and its initial state (:func:`all_pole_block`); ``state`` moves on.
    out : ndarray, shape (n_samples,)
        The output (contiguous); rows ``start`` on are written.
    time : (array, t0, ts)
        The time stamps to write, ``n_samples`` of them (or none).
    channels, box : (terms, bounds)
        Terms counted outside their box (:mod:`neckid.models._domain_kernels`): ``channels``
        over every row, ``box`` over the rows from ``start`` on, with the union of its terms.
        A block is first screened channel by channel against the intersection of the boxes of
        its terms (:func:`_screens`); only a block with a value outside it is counted term by
        term (the same counts: inside the intersection no term is outside its own box).
    envelope : ndarray, shape (2,)
        ``(low, high)`` of the divergence envelope (infinite for none).
    start : int
        The first simulated row (``max_lag``).

    Returns
    -------
    channel_counts, box_counts, box_rows, first_non_finite, first_runaway
        The counts; the first row not finite, and the first outside the envelope (-1 for none).
    """
    fir_channel, numerator, forcing, intercept = fir
    terms, bounds = channels
    n = out.shape[0]
    x, partial = np.empty(BLOCK), np.empty(BLOCK)
    flags = np.empty(BLOCK, np.bool_)
    channel_counts = np.zeros(terms.shape[0], np.int64)
    box_counts = np.zeros(box[0].shape[0], np.int64)
    box_rows, non_finite, runaway = 0, -1, -1
    _fill_time(time[0], time[1], time[2], 0, start)
    count_outside(outputs, inputs, terms, bounds, 0, start, channel_counts)
    groups, boxes = (terms, box[0]), (bounds, box[1])
    input_screens = _screens(inputs.shape[0], 1, groups, boxes)
    output_screens = _screens(outputs.shape[0], 0, groups, boxes)
    for begin in range(start, n, BLOCK):
        stop = min(begin + BLOCK, n)
        block = x[: stop - begin]
        fir_block(inputs, fir_channel, numerator, forcing, intercept, start, begin, block, partial)
        all_pole_block(denominator, block, state, out, begin)
        _fill_time(time[0], time[1], time[2], begin, stop)
        if non_finite < 0 or runaway < 0:
            non_finite, runaway = _first_flags(out, begin, stop, envelope, non_finite, runaway)
        if _inside(inputs, input_screens, begin, stop) and _inside(
            outputs, output_screens, begin, stop
        ):
            continue  # no channel nor term outside its box in this block: nothing to count
        count_outside(outputs, inputs, terms, bounds, begin, stop, channel_counts)
        box_rows += box_block(outputs, inputs, box[0], box[1], begin, stop, box_counts, flags)
    return channel_counts, box_counts, box_rows, non_finite, runaway
