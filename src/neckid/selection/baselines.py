"""The naive references a user checks first: the training outputs' mean and their replay.

Every selection (:func:`~neckid.select_lags`, :func:`~neckid.compare`) scores them on the same
folds as the candidates (:func:`baseline_candidates`), and says so in one line when the
recommended model does not beat them (:func:`baseline_warnings`):

- :class:`TrainingMean`: the mean of the training outputs, for every sample. Its fit on a
  held-out record is at most 0 % (0 % when the means agree): a model below it has not learnt
  more than the level of the output.
- :class:`Replay`: where a training log was driven by the same input trajectory as the record
  (the same motor commands, another payload), that log's outputs, replayed in time. It is a
  candidate only where such a log exists; elsewhere it fails and is left out.

Both have ``fit`` and ``simulate`` as every neckid model has, so they are scored by
:func:`~neckid.selection.lags.score_candidates` exactly as the candidates are.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator

from neckid.data.iodata import IOData, as_experiments
from neckid.models.results import ModelResult

__all__ = [
    "BASELINES",
    "REPLAY_TOLERANCE",
    "Replay",
    "TrainingMean",
    "baseline_candidates",
    "baseline_warnings",
]

#: A replayed log matches when the RMS difference of every input is at most this share of
#: that input's training range.
REPLAY_TOLERANCE = 0.02


class _Baseline(BaseEstimator):
    """What both references share: no lags, a free run that is one array."""

    def __sklearn_is_fitted__(self) -> bool:
        return hasattr(self, "max_lag_")

    def _result(self, data: IOData, y: np.ndarray) -> ModelResult:
        return ModelResult(
            kind="simulation",
            time=data.time,
            y=np.ascontiguousarray(y, dtype=np.float64),
            output_names=tuple(data.output_names),
            n_initial=0,
            output_units=tuple(data.output_units),
        )

    def predict(self, data: IOData) -> ModelResult:
        """The same as :meth:`simulate`: a reference reads no past output."""
        return self.simulate(data)

    def simulate(self, data: IOData) -> ModelResult:  # pragma: no cover - overridden
        raise NotImplementedError


class TrainingMean(_Baseline):
    """Every output is the mean of the training outputs.

    Examples
    --------
    >>> import numpy as np
    >>> train = IOData(np.zeros(4), np.array([1.0, 2.0, 3.0, 6.0]), ts=0.1)
    >>> TrainingMean().fit(train).simulate(train).y[:2, 0]
    array([3., 3.])
    """

    def fit(self, data: IOData | Sequence[IOData]) -> TrainingMean:
        """Store the mean of every output over all training records."""
        records = as_experiments(data, "data")
        self.mean_ = np.vstack([d.y for d in records]).mean(axis=0)
        self.max_lag_ = 0
        return self

    def simulate(self, data: IOData) -> ModelResult:
        """The training mean for every sample of ``data``."""
        if not hasattr(self, "mean_"):
            raise AttributeError("TrainingMean is not fitted; call fit first")
        return self._result(data, np.tile(self.mean_, (data.n_samples, 1)))


class Replay(_Baseline):
    """The outputs of the training log driven by the same inputs, replayed in time.

    Parameters
    ----------
    tolerance : float, default REPLAY_TOLERANCE
        Largest RMS input difference, as a share of each input's training range, for a
        training log (at the best time offset) to count as the same trajectory.

    Examples
    --------
    >>> import numpy as np
    >>> u = np.repeat([0.0, 1.0, 0.0, 2.0], 25)
    >>> a = IOData(u, 2.0 * u, ts=0.1, name="a")
    >>> b = IOData(u[30:70], 2.1 * u[30:70], ts=0.1, name="b")
    >>> float(Replay().fit(a).simulate(b).y[0, 0])
    2.0
    """

    def __init__(self, tolerance: float = REPLAY_TOLERANCE) -> None:
        self.tolerance = tolerance

    def fit(self, data: IOData | Sequence[IOData]) -> Replay:
        """Keep the training logs and their inputs' ranges."""
        records = as_experiments(data, "data")
        self.records_ = tuple(records)
        u = np.vstack([d.u for d in records])
        self.input_range_ = np.ptp(u, axis=0)
        self.max_lag_ = 0
        return self

    def simulate(self, data: IOData) -> ModelResult:
        """The matching training log's outputs; ``ValueError`` when no log matches."""
        if not hasattr(self, "records_"):
            raise AttributeError("Replay is not fitted; call fit first")
        scale = np.where(self.input_range_ > 0, self.input_range_, 1.0)
        best: tuple[float, Any] = (np.inf, None)
        for record in self.records_:
            found = _best_offset(record.u / scale, data.u / scale)
            if found is not None and found[0] < best[0]:
                best = (found[0], record.y[found[1] : found[1] + data.n_samples])
        if best[1] is None or best[0] > float(self.tolerance):
            raise ValueError(
                f"no training log has the input trajectory of {data.name or 'the record'}"
                f" (closest RMS difference {best[0]:.3g} of the input range, tolerance"
                f" {float(self.tolerance):g}): replay does not apply"
            )
        return self._result(data, best[1])


def _best_offset(long: np.ndarray, short: np.ndarray) -> tuple[float, int] | None:
    """The smallest RMS difference of ``short`` against every window of ``long``, and where."""
    n, m = short.shape[0], long.shape[0]
    if n == 0 or m < n:
        return None
    size = 1 << int(np.ceil(np.log2(m + n)))
    cross = np.zeros(m - n + 1)
    for j in range(short.shape[1]):
        spectrum = np.fft.rfft(long[:, j], size) * np.conj(np.fft.rfft(short[:, j], size))
        cross += np.fft.irfft(spectrum, size)[: m - n + 1]
    energy = np.concatenate([[0.0], np.cumsum(np.sum(long**2, axis=1))])
    windows = energy[n:] - energy[:-n]
    squared = np.maximum(windows - 2.0 * cross + np.sum(short**2), 0.0)
    offset = int(np.argmin(squared))
    return float(np.sqrt(squared[offset] / (n * short.shape[1]))), offset


#: The references, by the name the tables and warnings use.
BASELINES = {"training mean": TrainingMean, "replay": Replay}


def baseline_candidates() -> list[tuple[str, Any]]:
    """``(name, estimator)`` of every reference, ready for ``score_candidates``."""
    return [(f"baseline: {name}", make()) for name, make in BASELINES.items()]


def baseline_warnings(
    name: str, mean_fit: float, baselines: dict[str, float], what: str = "mean fold fit"
) -> list[str]:
    """One line when the recommended ``name`` is below 0 % or below a reference (else none).

    ``baselines``: reference name -> its mean fold fit [%] (a reference that did not apply is
    left out).

    Examples
    --------
    >>> baseline_warnings("arx", -19.9, {"training mean": -3.2})
    ['no model is good: the recommended arx has mean fold fit -19.9 %, below 0 % and below the baseline training mean (-3.2 %)']
    >>> baseline_warnings("sm", 61.0, {"training mean": -3.2})
    []
    """
    below = {b: v for b, v in baselines.items() if np.isfinite(v) and mean_fit < v}
    if mean_fit >= 0 and not below:
        return []
    parts = ["below 0 %"] if mean_fit < 0 else []
    parts += [f"below the baseline {b} ({v:.1f} %)" for b, v in below.items()]
    return [
        f"no model is good: the recommended {name} has {what} {mean_fit:.1f} %, "
        + " and ".join(parts)
    ]
