"""The logs of a selection, checked once: the training runs, their folds, their ranges, the tests.

:func:`neckid.compare` and :func:`neckid.select_safely` take the user's logs in whatever form
they come (one :class:`~neckid.IOData` or a list); :meth:`TrainingSet.of` turns them into one
object at the entry, so that nothing further down normalises them again or cuts other folds:

- ``experiments``: the training runs, checked to share channels and sampling period
  (:func:`~neckid.data.iodata.as_experiments`);
- ``plan``: the folds every candidate is scored on (:func:`~neckid.data.folds.fold_plan`);
- ``ranges``: every channel's range over all training runs, a property of the data, the same for
  every method (:meth:`TrainingSet.outside_range`, :meth:`TrainingSet.input_reach`);
- ``tests``: the test logs, if any, checked against the training runs and refused when they
  hold a neck at rest (:func:`~neckid.data.folds.refuse_resting_runs`).

Examples
--------
>>> import numpy as np
>>> from neckid import IOData
>>> runs = [IOData(np.linspace(-1, 1, 600), np.zeros(600), ts=0.1, name=f"run{i}") for i in range(2)]
>>> wide = IOData(np.linspace(-1.5, 1.0, 600), np.linspace(0, 1, 600), ts=0.1, name="wide")
>>> logs = TrainingSet.of(runs, tests=[wide])
>>> logs.plan.scheme, logs.plan.n_folds, logs.input_reach(logs.tests)
('experiments × time-blocks', 6, 0.5)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from neckid.data.folds import MIN_BLOCKS, FoldPlan, fold_plan, refuse_resting_runs
from neckid.data.iodata import IOData, as_experiments

__all__ = ["TrainingSet"]


@dataclass(frozen=True)
class TrainingSet:
    """The training runs of a selection with their folds and ranges, and the test logs.

    Build it with :meth:`of`.

    Attributes
    ----------
    experiments : tuple of IOData
        The training runs (regressors are never built across two of them).
    plan : FoldPlan
        Every fit and fold a candidate is scored on.
    ranges : mapping of str to (float, float)
        ``{channel: (low, high)}`` of every input and output over all training runs.
    tests : tuple of IOData
        The test logs (empty when none were given).
    """

    experiments: tuple[IOData, ...]
    plan: FoldPlan
    ranges: Mapping[str, tuple[float, float]] = field(repr=False)
    tests: tuple[IOData, ...] = ()

    @classmethod
    def of(
        cls,
        train: IOData | Sequence[IOData],
        n_blocks: int = MIN_BLOCKS,
        *,
        tests: IOData | Sequence[IOData] | None = None,
    ) -> TrainingSet:
        """Check the logs once, cut the folds, take the ranges.

        Parameters
        ----------
        train : IOData or list of IOData
            The training runs (several: each held out in turn; one: its time blocks).
        n_blocks : int, default 3
            Blocks of a single training run (:func:`~neckid.data.folds.fold_plan`).
        tests : IOData or list of IOData, optional
            Test logs, with the channels and sampling period of ``train``.

        Raises
        ------
        TypeError, ValueError
            As :func:`~neckid.data.iodata.as_experiments` and
            :func:`~neckid.data.folds.fold_plan`; a test log that holds the neck at rest.
        """
        experiments = as_experiments(train, "train")
        held: list[IOData] = []
        if tests is not None:
            held = as_experiments(tests, "test")
            refuse_resting_runs(held, "test log")
            as_experiments([experiments[0], held[0]], "[train[0], test[0]]")
        first = experiments[0]
        ranges = {}
        for name in (*first.input_names, *first.output_names):
            values = np.concatenate([d.channel(name) for d in experiments])
            ranges[name] = (float(values.min()), float(values.max()))
        return cls(
            tuple(experiments),
            fold_plan(experiments, n_blocks),
            MappingProxyType(ranges),
            tuple(held),
        )

    @property
    def output_names(self) -> tuple[str, ...]:
        """The training runs' output channels."""
        return tuple(self.experiments[0].output_names)

    def fit_data(self) -> IOData | list[IOData]:
        """What a model is fitted on: the one run, or the list of runs."""
        return self.experiments[0] if len(self.experiments) == 1 else list(self.experiments)

    def outside_range(self, record: IOData) -> float:
        """Share of ``record``'s samples at which some channel lies outside its training range.

        Examples
        --------
        >>> train = IOData(np.linspace(0.0, 1.0, 10), np.linspace(0.0, 2.0, 10), ts=0.1)
        >>> logs = TrainingSet.of(train)
        >>> logs.outside_range(IOData(np.linspace(0.5, 1.5, 10), np.ones(10), ts=0.1))
        0.4
        """
        outside = np.zeros(record.n_samples, dtype=bool)
        for name in (*record.input_names, *record.output_names):
            low, high = self.ranges[name]
            seen = record.channel(name)
            outside |= (seen < low) | (seen > high)
        return float(outside.mean()) if record.n_samples else 0.0

    def input_reach(self, records: Sequence[IOData]) -> float:
        """How far ``records``' inputs go beyond the training inputs' range, as a share of its half-width.

        0 when every input stays inside; 0.5 when one goes half the half-width beyond an end
        (the ``stress`` of :func:`neckid.selection.comparison.stretched` that reaches it). A
        constant training input is left out.
        """
        names = self.experiments[0].input_names
        low = np.array([self.ranges[n][0] for n in names])
        high = np.array([self.ranges[n][1] for n in names])
        middle, half = 0.5 * (low + high), 0.5 * (high - low)
        varied = half > 0
        reach = 0.0
        for record in records:
            if not record.n_samples or not varied.any():
                continue
            extent = np.abs(record.u - middle).max(axis=0)
            reach = max(reach, float(np.max(extent[varied] / half[varied] - 1.0)))
        return reach
