"""Folds that test the next run, and the one-standard-error rule: what every selection shares.

:func:`~neckid.select_lags`, :func:`~neckid.select_safely` and :func:`~neckid.compare` choose on
the training logs only, by one rule:

1. **Folds over runs.** With two or more training experiments each fold holds one out; with one,
   the record is cut into ``n_blocks >= 3`` contiguous time blocks (:func:`time_blocks`) and each
   fold holds one block out, so that some fold tests the edges of the range. A record whose
   input repeats exactly (a periodic excitation, :func:`input_period`) is first averaged over
   its periods (:func:`period_average`) and the blocks cut from one period: blocks of the raw
   record would hold out samples the other periods already show.
2. **No runaway.** A candidate that fails or whose free run diverges in any fold is out.
3. **One standard error toward the simpler candidate** (:func:`one_standard_error`): among the
   rest, the best mean fold fit ``m*`` and its standard error ``s*`` set the bar ``m* − s*``; the
   simplest candidate above the bar is chosen.

References
----------
T. Hastie, R. Tibshirani and J. Friedman, *The Elements of Statistical Learning*, 2nd ed.,
Springer, 2009, §7.10 (the one-standard-error rule).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData

__all__ = [
    "MIN_BLOCKS",
    "fold_records",
    "fold_statistics",
    "input_period",
    "one_standard_error",
    "period_average",
    "time_blocks",
]

#: Fewest contiguous blocks a single training record is cut into.
MIN_BLOCKS = 3


def time_blocks(data: IOData, n_blocks: int = MIN_BLOCKS) -> list[IOData]:
    """``data`` cut into ``n_blocks`` contiguous blocks of (nearly) equal length, in order.

    Examples
    --------
    >>> import numpy as np
    >>> blocks = time_blocks(IOData(np.zeros(10), np.arange(10.0), ts=0.1, name="run"), 3)
    >>> [b.n_samples for b in blocks], blocks[0].name
    ([4, 3, 3], 'run [block 1/3]')
    """
    if isinstance(n_blocks, bool) or not isinstance(n_blocks, int) or n_blocks < MIN_BLOCKS:
        raise ValueError(f"n_blocks must be an integer >= {MIN_BLOCKS}; got {n_blocks!r}")
    if data.n_samples < 2 * n_blocks:
        raise ValueError(
            f"{data.name or 'the log'} has {data.n_samples} samples, too few for {n_blocks}"
            " time blocks; give a longer log or several logs"
        )
    edges = np.linspace(0, data.n_samples, n_blocks + 1)
    starts = np.ceil(edges).astype(int)
    return [
        data[int(starts[i]) : int(starts[i + 1])].renamed(
            f"{data.name or 'log'} [block {i + 1}/{n_blocks}]"
        )
        for i in range(n_blocks)
    ]


def input_period(data: IOData, tolerance: float = 1e-9) -> int | None:
    """The period [samples] of an input that repeats exactly, at least twice; ``None`` if none.

    Candidates are the 5 highest peaks of the inputs' autocorrelation (computed with the FFT)
    at lags from 2 to half the record; the smallest lag ``P`` with
    ``max |u(t + P) − u(t)| <= tolerance · range(u)`` on every input is the period.

    Examples
    --------
    >>> import numpy as np
    >>> u = np.tile(np.sin(np.arange(50) / 3.0), 4)
    >>> input_period(IOData(u, np.zeros(200), ts=0.1)), input_period(IOData(np.arange(9.0), ts=0.1))
    (50, None)
    """
    u = data.u
    n = u.shape[0]
    if n < 8 or u.shape[1] == 0:
        return None
    centred = u - u.mean(axis=0)
    spectrum = np.fft.rfft(centred, 2 * n, axis=0)
    correlation = np.fft.irfft(np.abs(spectrum) ** 2, axis=0)[:n].sum(axis=1)
    lags = np.arange(2, n // 2 + 1)
    if lags.size == 0:
        return None
    order = lags[np.argsort(-correlation[lags], kind="stable")[:5]]
    scale = np.ptp(u, axis=0)
    for lag in sorted(int(v) for v in order):
        difference = np.max(np.abs(u[lag:] - u[:-lag]), axis=0)
        if np.all(difference <= tolerance * np.where(scale > 0, scale, 1.0)):
            return lag
    return None


def period_average(data: IOData, period: int) -> IOData:
    """One period of ``data``: its complete periods averaged sample by sample (noise down by √P).

    Examples
    --------
    >>> import numpy as np
    >>> y = np.array([1.0, 2.0, 3.0, 3.0, 4.0, 5.0])
    >>> period_average(IOData(np.tile([0.0, 1.0, 2.0], 2), y, ts=0.1, name="run"), 3).y[:, 0]
    array([2., 3., 4.])
    """
    count = data.n_samples // period
    if count < 1:
        raise ValueError(
            f"period must be at most the record's length {data.n_samples}; got {period}"
        )
    used = data[: count * period]
    u = used.u.reshape(count, period, -1).mean(axis=0)
    y = used.y.reshape(count, period, -1).mean(axis=0)
    first = used[:period]
    return first.replace(u=u, y=y).renamed(f"{data.name or 'log'} (mean of {count} periods)")


def fold_records(train: Sequence[IOData], n_blocks: int = MIN_BLOCKS) -> tuple[list[IOData], str]:
    """The records each fold holds out, and the scheme's name.

    Several experiments: themselves (``"leave-one-experiment-out"``). One: its time blocks
    (``"time-blocks"``), or, when its input repeats with a period of at least ``2 n_blocks``
    samples, the time blocks of its period average (``"time-blocks of one period"``).
    """
    if len(train) >= 2:
        return list(train), "leave-one-experiment-out"
    record = train[0]
    period = input_period(record)
    if period is not None and period >= 2 * n_blocks:
        return time_blocks(period_average(record, period), n_blocks), "time-blocks of one period"
    return time_blocks(record, n_blocks), "time-blocks"


def fold_statistics(fits: ArrayLike) -> tuple[float, float, float]:
    """``(mean, standard error, worst)`` of one candidate's fold fits [%].

    The standard error is ``std(fits, ddof=1) / sqrt(k)`` over ``k`` folds (0 for one fold). A
    fold that is not finite (a failed or diverged fit) makes the mean ``-inf``.

    Examples
    --------
    >>> fold_statistics([80.0, 90.0, 85.0])
    (85.0, 2.886751345948129, 80.0)
    >>> fold_statistics([80.0, float("-inf")])[0]
    -inf
    """
    values = np.asarray(fits, dtype=np.float64).reshape(-1)
    if values.size == 0:
        raise ValueError("fold_statistics needs at least one fold fit; got none")
    worst = float(np.min(values))
    if not np.all(np.isfinite(values)):
        return -np.inf, 0.0, worst
    se = float(np.std(values, ddof=1) / np.sqrt(values.size)) if values.size > 1 else 0.0
    return float(np.mean(values)), se, worst


def one_standard_error(
    means: Sequence[float],
    standard_errors: Sequence[float],
    simplicity: Sequence[Any],
    accepted: Sequence[bool],
) -> tuple[int, float]:
    """The simplest accepted candidate within one standard error of the best; and the bar.

    Parameters
    ----------
    means, standard_errors : sequence of float
        Each candidate's mean fold fit [%] and its standard error [points].
    simplicity : sequence
        A sort key per candidate, smaller is simpler (a tuple such as ``(rank, n_terms)``);
        ties go to the better mean fit.
    accepted : sequence of bool
        ``False`` for a candidate that is out (failed, ran away).

    Returns
    -------
    index : int
        The chosen candidate.
    bar : float
        ``m* − s*``: the best accepted mean fit minus its standard error.

    Raises
    ------
    ValueError
        If no candidate is accepted.

    Examples
    --------
    >>> one_standard_error([90.0, 89.5, 70.0], [1.0, 0.2, 0.1], [3, 1, 0], [True, True, True])
    (1, 89.0)
    """
    kept = [i for i, ok in enumerate(accepted) if ok and np.isfinite(means[i])]
    if not kept:
        raise ValueError("no candidate is accepted: every one failed or ran away in a fold")
    best = max(kept, key=lambda i: float(means[i]))
    bar = float(means[best]) - float(standard_errors[best])
    eligible = [i for i in kept if float(means[i]) >= bar]
    pick = min(eligible, key=lambda i: (simplicity[i], -float(means[i])))
    return pick, bar
