"""Folds that test the next run, and the ranking every selection applies to them.

:func:`~neckid.select_lags`, :func:`~neckid.select_safely`, :func:`~neckid.compare`, the
multi-step SM settings and the benchmark's candidates are chosen on the training logs only, by
one engine (:func:`rank_candidates`, here beside the folds because the model families, which
must not import :mod:`neckid.selection`, choose with it too):

1. **Folds over runs** (:func:`fold_plan`). With two or more training experiments each fold
   holds one out and fits on the others; when there are fewer than :data:`MIN_FOLDS` (6) logs,
   each held-out log is also cut into ``ceil(6 / k)`` contiguous time blocks
   (:func:`blocks_per_log`, each at least :data:`MIN_BLOCK_SAMPLES` samples) scored one by one:
   a fold is one block of one held-out log, the model is fitted on the *other logs only* (never
   on another block of the held-out run), and no fold mixes time from two blocks. With one
   record, it is cut into ``n_blocks >= 3`` contiguous time blocks (:func:`time_blocks`) and
   each fold holds one block out, so that some fold tests the edges of the range. A record
   whose input repeats exactly (a periodic excitation, :func:`input_period`) is first averaged
   over its periods (:func:`period_average`) and the blocks cut from one period: blocks of the
   raw record would hold out samples the other periods already show.
2. **No runaway.** A candidate that fails or whose free run diverges in any fold is out.
3. **Paired one standard error toward the simpler candidate** (:func:`rank_candidates`): every
   candidate is scored on the same folds; candidate ``j`` is eligible when its mean per-fold
   difference to the best, ``d̄_j``, is within one standard error of that difference (or
   within :data:`MIN_GAIN`, half a point); the simplest eligible candidate is chosen. The unpaired rule of earlier versions
   (:func:`one_standard_error`: ``m_j >= m* − s*`` with ``s*`` the spread between folds) is
   kept for comparison.

References
----------
T. Hastie, R. Tibshirani and J. Friedman, *The Elements of Statistical Learning*, 2nd ed.,
Springer, 2009, §7.10 (the one-standard-error rule; here on paired differences).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData, as_experiments
from neckid.utils.types import BoolArray, FloatArray

__all__ = [
    "MIN_BLOCKS",
    "MIN_BLOCK_SAMPLES",
    "MIN_FOLDS",
    "MIN_GAIN",
    "RULES",
    "FoldPlan",
    "Ranking",
    "Split",
    "blocks_per_log",
    "fold_plan",
    "fold_records",
    "fold_statistics",
    "holdout_plan",
    "input_period",
    "one_standard_error",
    "period_average",
    "rank_candidates",
    "refuse_resting_runs",
    "time_blocks",
]

#: Fewest contiguous blocks a single training record is cut into.
MIN_BLOCKS = 3

#: Fewest folds :func:`fold_plan` makes from several logs (logs × time blocks below it).
MIN_FOLDS = 6

#: Fewest samples of a time block when held-out logs are cut into blocks.
MIN_BLOCK_SAMPLES = 100


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


def blocks_per_log(
    train: Sequence[IOData], min_folds: int = MIN_FOLDS, min_samples: int = MIN_BLOCK_SAMPLES
) -> int:
    """Time blocks each held-out log is cut into: ``ceil(min_folds / k)`` for ``k`` logs.

    At most as many as leave every block of the shortest log ``min_samples`` samples; at
    least 1 (plain leave-one-experiment-out, the case from :data:`MIN_FOLDS` logs on).

    Examples
    --------
    >>> import numpy as np
    >>> logs = [IOData(np.zeros(900), np.zeros(900), ts=0.1) for _ in range(3)]
    >>> blocks_per_log(logs), blocks_per_log(logs[:2]), blocks_per_log(logs * 2)
    (2, 3, 1)
    """
    if not train:
        raise ValueError("blocks_per_log needs at least one log; got none")
    wanted = math.ceil(int(min_folds) / len(train))
    room = min(d.n_samples for d in train) // max(int(min_samples), 1)
    return max(1, min(wanted, room))


@dataclass(frozen=True)
class Split:
    """One fit and the folds it is scored on.

    Attributes
    ----------
    fit_on : tuple of IOData
        The records the model of this split is fitted on.
    folds : tuple of tuple of IOData
        The held-out records of each fold this fit is scored on (one score per fold).
    """

    fit_on: tuple[IOData, ...]
    folds: tuple[tuple[IOData, ...], ...]


@dataclass(frozen=True)
class FoldPlan:
    """Every fit and fold of a selection (:func:`fold_plan`).

    Attributes
    ----------
    splits : tuple of Split
        The fits, each with the folds it is scored on, in fold order.
    names : list of list of str
        The held-out records of each fold, by name.
    scheme : str
        ``"leave-one-experiment-out"``, ``"experiments × time-blocks"``, ``"time-blocks"`` or
        ``"time-blocks of one period"``.
    """

    splits: tuple[Split, ...]
    names: list[list[str]]
    scheme: str

    @property
    def n_folds(self) -> int:
        """Folds in all (scores per candidate)."""
        return len(self.names)


def fold_plan(
    train: Sequence[IOData],
    n_blocks: int = MIN_BLOCKS,
    min_folds: int = MIN_FOLDS,
    *,
    blocks: int | None = None,
) -> FoldPlan:
    """The folds every candidate of a selection is scored on (the module's rule 1).

    Several logs: each held out in turn, fitted on the others, and cut into
    :func:`blocks_per_log` time blocks scored one by one when there are fewer than
    ``min_folds`` logs (``"experiments × time-blocks"``; with ``min_folds=0``, plain
    ``"leave-one-experiment-out"``); ``blocks`` (an int >= 1) sets the blocks per log instead.
    One log: :func:`fold_records` (``n_blocks`` blocks).

    Examples
    --------
    >>> import numpy as np
    >>> logs = [IOData(np.zeros(600), np.zeros(600), ts=0.1, name=f"run{i}") for i in range(3)]
    >>> plan = fold_plan(logs)
    >>> plan.scheme, plan.n_folds, plan.names[1]
    ('experiments × time-blocks', 6, ['run0 [block 2/2]'])
    """
    experiments = list(train)
    if len(experiments) < 2:
        records, scheme = fold_records(experiments, n_blocks)
        splits = tuple(
            Split(tuple(r for j, r in enumerate(records) if j != i), ((held,),))
            for i, held in enumerate(records)
        )
        return FoldPlan(splits, [[r.name or f"block {i}"] for i, r in enumerate(records)], scheme)
    if blocks is None:
        blocks = blocks_per_log(experiments, min_folds) if min_folds > 0 else 1
    elif isinstance(blocks, bool) or not isinstance(blocks, int) or blocks < 1:
        raise ValueError(f"blocks must be an int >= 1 or None; got {blocks!r}")
    splits_list: list[Split] = []
    names: list[list[str]] = []
    for i, held in enumerate(experiments):
        parts = [held] if blocks < 2 else _blocks_of(held, blocks)
        others = tuple(r for j, r in enumerate(experiments) if j != i)
        splits_list.append(Split(others, tuple((p,) for p in parts)))
        names.extend([p.name or f"train[{i}]"] for p in parts)
    scheme = "leave-one-experiment-out" if blocks < 2 else "experiments × time-blocks"
    return FoldPlan(tuple(splits_list), names, scheme)


def _experiment_folds(n: int, folds: int | None) -> tuple[list[list[int]], str]:
    """The held-out experiments of every fold: experiment ``i`` is held out in fold ``i mod k``."""
    if n < 2:
        raise ValueError(
            "validation is None, so the candidates are scored on held-out experiments"
            " (leave-one-experiment-out), which needs train to be a list of at least 2"
            f" experiments; got {n}. Give validation records, or train as a list of experiments"
        )
    if folds is None:
        k = n
    elif isinstance(folds, bool) or not isinstance(folds, int | np.integer):
        raise TypeError(f"folds must be an int or None; got {folds!r}")
    elif not 2 <= folds <= n:
        raise ValueError(
            f"folds must be in [2, {n}] (the number of experiments in train), or None for"
            f" leave-one-experiment-out; got {folds}"
        )
    else:
        k = int(folds)
    held_out = [list(range(j, n, k)) for j in range(k)]
    return held_out, "leave-one-experiment-out" if k == n else "grouped-k-fold"


def holdout_plan(
    train: list[IOData],
    validation: IOData | Sequence[IOData] | None,
    folds: int | None,
    blocks: int | None = 1,
) -> FoldPlan:
    """The folds of :func:`neckid.selection.lags.score_candidates`: every fit, its folds, the scheme.

    ``validation`` given: one fold, fitted on ``train`` and scored on ``validation``
    (``"validation"``). Otherwise held-out experiments of ``train``: fold ``j`` of ``folds``
    (default one per experiment) holds out the experiments ``i`` with ``i mod folds == j``
    (``"leave-one-experiment-out"`` or ``"grouped-k-fold"``); ``blocks`` other than 1 (and
    ``folds=None``) scores every held-out experiment in time blocks (:func:`fold_plan`; ``None``:
    its rule).

    Examples
    --------
    >>> import numpy as np
    >>> logs = [IOData(np.zeros(60), np.zeros(60), ts=0.1, name=f"run{i}") for i in range(4)]
    >>> plan = holdout_plan(logs, None, 2)
    >>> plan.scheme, plan.names
    ('grouped-k-fold', [['run0', 'run2'], ['run1', 'run3']])
    """
    if validation is None:
        if folds is None and len(train) >= 2 and blocks != 1:
            return fold_plan(train, blocks=blocks)
        held_out, scheme = _experiment_folds(len(train), folds)
        splits = tuple(
            Split(
                tuple(d for i, d in enumerate(train) if i not in fold),
                (tuple(train[i] for i in fold),),
            )
            for fold in held_out
        )
        held_names = [[train[i].name or f"train[{i}]" for i in f] for f in held_out]
        return FoldPlan(splits, held_names, scheme)
    if folds is not None:
        raise ValueError(
            f"folds applies only when validation is None; got folds={folds!r} and validation"
            " records: drop one of them"
        )
    records = as_experiments(validation, "validation")
    as_experiments([train[0], records[0]], "[train[0], validation[0]]")
    names = [d.name or f"validation[{i}]" for i, d in enumerate(records)]
    return FoldPlan((Split(tuple(train), (tuple(records),)),), [names], "validation")


def _blocks_of(record: IOData, blocks: int) -> list[IOData]:
    """``record`` in ``blocks`` contiguous parts (2 allowed here: the fit is on other logs)."""
    edges = np.ceil(np.linspace(0, record.n_samples, blocks + 1)).astype(int)
    return [
        record[int(edges[b]) : int(edges[b + 1])].renamed(
            f"{record.name or 'log'} [block {b + 1}/{blocks}]"
        )
        for b in range(blocks)
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

    The *unpaired* rule (``m_j >= m* − s*``, ``s*`` the spread between folds of the best), kept
    for the subspace model's order choice and for comparison; every selection of candidates
    ranks with :func:`rank_candidates` (the paired rule).

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


#: Rules :func:`rank_candidates` applies: the paired one-standard-error rule (the default of
#: every selection), the unpaired one of earlier versions, or the top mean fold fit.
RULES = ("paired", "unpaired", "best")


@dataclass(frozen=True)
class Ranking:
    """What :func:`rank_candidates` chose and why.

    Attributes
    ----------
    chosen : int
        The chosen candidate (its position in the fold fits given).
    best : int
        The candidate with the best mean fold fit (among the accepted ones).
    rule : {"paired", "unpaired", "best"}
        The rule applied.
    means : ndarray, shape (n_candidates,)
        Mean fold fit [%] of every candidate (``-inf`` for a rejected one).
    standard_errors : ndarray, shape (n_candidates,)
        Standard error of each candidate's mean fold fit [points] (the spread between folds).
    differences : ndarray, shape (n_candidates, n_folds)
        Each candidate's fold fit minus the best candidate's on the same fold [points].
    difference_means, difference_errors : ndarray, shape (n_candidates,)
        The mean of those differences and its standard error
        ``std(d, ddof=1) / sqrt(n_folds)`` [points].
    bars : ndarray, shape (n_candidates,)
        The mean fold fit a candidate needed to be eligible: ``m* − max(SE(d_j), min_gain)`` (paired),
        ``m* − s*`` (unpaired, the same for all), ``m*`` (best).
    eligible : ndarray of bool, shape (n_candidates,)
        The candidates the rule let through; the simplest of them is chosen.
    """

    chosen: int
    best: int
    rule: str
    means: FloatArray
    standard_errors: FloatArray
    differences: FloatArray
    difference_means: FloatArray
    difference_errors: FloatArray
    bars: FloatArray
    eligible: BoolArray

    @property
    def bar(self) -> float:
        """The bar the chosen candidate cleared (mean fold fit, %)."""
        return float(self.bars[self.chosen])

    @property
    def n_folds(self) -> int:
        """Folds every candidate was scored on."""
        return int(self.differences.shape[1])

    def explain(self, names: Sequence[str]) -> str:
        """One sentence: the best, the chosen, the rule and the bar, in the candidates' names."""
        best, chosen = names[self.best], names[self.chosen]
        head = f"best {best} (mean fold fit {self.means[self.best]:.1f} %)"
        if self.chosen == self.best:
            return f"{head}, chosen: no simpler candidate is within the {RULE_WORDS[self.rule]}"
        return (
            f"{head}; chosen {chosen} ({self.means[self.chosen]:.1f} %): the simplest within the"
            f" {RULE_WORDS[self.rule]} (bar {self.bar:.1f} %; mean difference to the best"
            f" {self.difference_means[self.chosen]:+.1f} ± {self.difference_errors[self.chosen]:.1f}"
            f" points over {self.n_folds} folds)"
        )


#: How each rule reads in a sentence.
RULE_WORDS = {
    "paired": "paired one-standard-error rule",
    "unpaired": "unpaired one-standard-error rule",
    "best": "best-mean rule",
}


#: Points of mean fold fit a simpler candidate may always give up under the paired rule: a
#: gain smaller than this is not worth a more complex model, however consistent it is.
MIN_GAIN = 0.5


def rank_candidates(
    fold_fits: ArrayLike,
    simplicity: Sequence[Any] | None = None,
    accepted: Sequence[bool] | None = None,
    rule: str = "paired",
    min_gain: float = MIN_GAIN,
) -> Ranking:
    """Choose among candidates scored on the same folds: the one ranking every selection uses.

    Parameters
    ----------
    fold_fits : array_like, shape (n_candidates, n_folds)
        Each candidate's fit [%] (higher is better) on each fold, every candidate on the same
        folds. A fold that is not finite (a failed or diverged fit) puts the candidate out.
    simplicity : sequence, optional
        A sort key per candidate, smaller is simpler (``(rank, n_terms)``); ties go to the
        better mean, then the earlier candidate. Default: all equal.
    accepted : sequence of bool, optional
        ``False`` for a candidate that is out for another reason (a stress check).
    rule : {"paired", "unpaired", "best"}, default "paired"
        ``"paired"``: candidate ``j`` is eligible when its mean difference to the best,
        ``d̄_j = mean_f(fit_jf − fit_*f)``, is within one standard error of that difference, or
        within ``min_gain``: ``d̄_j >= −max(SE(d_j), min_gain)``,
        ``SE(d_j) = std_f(d_j, ddof=1) / sqrt(k)``. ``"unpaired"``: within
        one standard error of the best mean, ``m_j >= m* − s*`` (the rule of earlier versions).
        ``"best"``: the best mean (ties: the simplest).
    min_gain : float, default MIN_GAIN (0.5)
        Points of fit below which a consistent gain is not worth a more complex model (paired
        rule only; 0 for the pure paired test).

    Returns
    -------
    Ranking

    Raises
    ------
    ValueError
        If no candidate is accepted, the shapes disagree, or ``rule`` is unknown.

    Notes
    -----
    The paired rule is Hastie, Tibshirani & Friedman's one-standard-error rule (§7.10) applied
    to paired differences: every candidate is scored on the same folds, so what makes one fold
    hard for all of them (a run with its own gain, a short block) cancels in ``fit_jf − fit_*f``
    and only how the candidates differ is left. Its standard error is that of a paired t-test;
    the rule keeps a simpler candidate when the test could not tell it from the best at
    ``t >= −1`` (not a significance level: a tolerance of one standard error, as in §7.10);
    a gain under ``min_gain`` points never outweighs simplicity. The
    unpaired rule compares the mean to the best mean minus the *between-fold* spread: with
    three folds of different runs that spread is large, and a model better on every fold by a
    few points is lost in it (the simplest candidate wins almost always). With one fold both
    standard errors are 0 and the rules choose the best.

    Examples
    --------
    >>> fits = [[60.0, 80.0, 100.0], [62.0, 82.0, 102.0]]  # the second better on every fold
    >>> rank_candidates(fits, [0, 1]).chosen, rank_candidates(fits, [0, 1], rule="unpaired").chosen
    (1, 0)
    """
    if rule not in RULES:
        raise ValueError(f"rule must be one of {RULES}; got {rule!r}")
    fits = np.atleast_2d(np.asarray(fold_fits, dtype=np.float64))
    n = fits.shape[0]
    if fits.ndim != 2 or fits.shape[1] == 0:
        raise ValueError(f"fold_fits must be (n_candidates, n_folds >= 1); got {fits.shape}")
    keys = list(simplicity) if simplicity is not None else [0] * n
    flags = list(accepted) if accepted is not None else [True] * n
    if len(keys) != n or len(flags) != n:
        raise ValueError(
            f"simplicity and accepted need one entry per candidate ({n}); got {len(keys)}"
            f" and {len(flags)}"
        )
    finite = np.all(np.isfinite(fits), axis=1) & np.asarray(flags, dtype=bool)
    if not finite.any():
        raise ValueError("no candidate is accepted: every one failed or ran away in a fold")
    statistics = [fold_statistics(row) for row in fits]
    means = np.where(finite, [s[0] for s in statistics], -np.inf)
    errors = np.array([s[1] for s in statistics])
    kept = np.flatnonzero(finite)
    best = int(kept[np.argmax(means[kept])])
    with np.errstate(invalid="ignore"):
        differences = fits - fits[best]
    k = fits.shape[1]
    with np.errstate(invalid="ignore"):
        d_means = np.where(finite, differences.mean(axis=1), -np.inf)
        spread = differences.std(axis=1, ddof=1) / np.sqrt(k) if k > 1 else np.zeros(n)
    d_errors = np.where(finite, spread, np.nan)
    if rule == "paired":
        bars = means[best] - np.maximum(np.nan_to_num(d_errors, nan=np.inf), float(min_gain))
    elif rule == "unpaired":
        bars = np.full(n, means[best] - errors[best])
    else:
        bars = np.full(n, means[best])
    # A tolerance of 1e-9 points: the best is always eligible, rounding never decides.
    eligible = finite & (means >= bars - 1e-9)
    pick = min(np.flatnonzero(eligible), key=lambda i: (keys[i], -means[i], i))
    return Ranking(
        chosen=int(pick),
        best=best,
        rule=rule,
        means=means,
        standard_errors=errors,
        differences=differences,
        difference_means=d_means,
        difference_errors=d_errors,
        bars=bars,
        eligible=eligible,
    )


def refuse_resting_runs(runs: Sequence[IOData], role: str) -> None:
    """Refuse, before any fit, a run whose output never moves (a neck at rest), naming it.

    A fit % divides by the output's spread: on such a run it is undefined, so a fold that
    scores on it (a test log of ``compare``, a held-out log of ``select``) cannot rank the
    candidates. ``role`` names the runs in the message (``"test log"``, ``"training log"``).
    """
    for k, data in enumerate(runs):
        for j, name in enumerate(data.output_names):
            column = data.y[:, j]
            if column.size and float(np.ptp(column)) == 0.0:
                label = data.name or f"{role}[{k}]"
                raise ValueError(
                    f"{role} {label}: its output {name!r} is constant ({column[0]:g} throughout:"
                    " a neck at rest?), so a fit % on it is undefined and the candidates cannot"
                    " be ranked on it: drop it from the logs, or check a model on it with neckid"
                    " validate (its RMSE is defined)"
                )
