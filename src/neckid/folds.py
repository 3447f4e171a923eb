"""Folds that test the next run, and the one-standard-error rule: what every selection shares.

:func:`~neckid.select_lags`, :func:`~neckid.select_safely` and :func:`~neckid.compare` choose on
the training logs only, by one rule:

1. **Folds over runs.** With two or more training experiments each fold holds one out; with one,
   the record is cut into ``n_blocks >= 3`` contiguous time blocks (:func:`time_blocks`) and each
   fold holds one block out, so that some fold tests the edges of the range.
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

__all__ = ["MIN_BLOCKS", "fold_statistics", "one_standard_error", "time_blocks"]

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
