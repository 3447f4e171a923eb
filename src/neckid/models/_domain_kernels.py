"""The compiled pass behind the training-box shares of :mod:`neckid.models.domain`."""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from neckid._typing import FloatArray

__all__ = ["box_counts"]


@numba.njit(cache=True, nogil=True)
def box_counts(
    y: FloatArray,
    u: FloatArray,
    source: NDArray[np.int64],
    channel: NDArray[np.int64],
    lag: NDArray[np.int64],
    low: FloatArray,
    high: FloatArray,
    start: int,
) -> tuple[NDArray[np.int64], int]:  # pragma: no cover - compiled; tested against regressor_domain
    """Rows ``t >= start`` whose regressor term ``j`` is outside ``[low_j, high_j]``, and any term.

    Term ``j`` at row ``t`` is ``y`` (source 0) or ``u`` at ``[t − lag_j, channel_j]``, as
    :meth:`~neckid.regressors.ResolvedLags.build_one` puts it in the regressor, without building
    the regressor matrix.
    """
    n_rows = y.shape[0] - start
    counts = np.zeros(lag.shape[0], np.int64)
    for j in range(lag.shape[0]):
        column = (y if source[j] == 0 else u)[start - lag[j] : y.shape[0] - lag[j], channel[j]]
        lo, hi = low[j], high[j]
        count = 0
        for t in range(n_rows):
            count += (column[t] < lo) | (column[t] > hi)
        counts[j] = count
    if np.count_nonzero(counts) < 2:  # no term outside, or one: no union to count
        return counts, int(counts.sum())
    rows = 0
    for t in range(n_rows):
        for j in range(lag.shape[0]):
            v = (
                y[start + t - lag[j], channel[j]]
                if source[j] == 0
                else u[t + start - lag[j], channel[j]]
            )
            if v < low[j] or v > high[j]:
                rows += 1
                break
    return counts, rows
