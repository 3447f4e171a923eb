r"""Online protocols: a model identified on other runs, adapted to a new run while it goes on.

The real soft neck changes between runs (payload, tendon slack, controller), so a model identified
on some runs misses a new one by an offset and a little dynamics. Two protocols measure how much
of that an adaptation on the new run's own first data wins back:

- :func:`adaptive_free_run` (defined in :mod:`neckid.models.online`, where the selection's
  folds reach it too): adapt a copy of the model on the first ``warmup_s`` seconds of a
  test run (``partial_fit``, a constant output offset, both or neither), then free-run the rest
  from the measured outputs at the warm-up's end and score that rest only.
- :func:`streaming_ahead`: ``k``-step-ahead prediction over a whole run while the model is
  updated, chunk after chunk, on what it has seen; every prediction uses only the model as it
  stood at the prediction's anchor time.

Neither changes the model it is given: each works on a ``copy.deepcopy`` of it (scikit-learn's
``clone`` would return it unfitted).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from neckid.data.iodata import IOData
from neckid.models.base import ModelResult, check_is_fitted
from neckid.models.kstep import predict_ahead
from neckid.models.online import ADAPT_MODES, AdaptiveRun, adaptive_free_run
from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = [
    "ADAPT_MODES",
    "DEFAULT_UPDATE_SECONDS",
    "AdaptiveRun",
    "StreamingRun",
    "adaptive_free_run",
    "streaming_ahead",
]

#: Default chunk of :func:`streaming_ahead`, in seconds of data between two updates.
DEFAULT_UPDATE_SECONDS = 1.0


@dataclass(frozen=True)
class StreamingRun:
    """The result of :func:`streaming_ahead`.

    Attributes
    ----------
    result : ModelResult
        ``kind="prediction"``: row ``s`` is the prediction of ``y(s)`` made at ``s − steps``
        by the model updated on the samples up to the last chunk boundary at or before that
        time; ``n_initial = max_lag_ + steps − 1``; ``extras`` holds ``"steps"`` and
        ``"update_every"``.
    fit : ndarray, shape (n_outputs,)
        NRMSE fit [%] of those predictions per output, skipping ``n_initial``.
    model : estimator
        The copy after the last update.
    n_updates : int
        How many updates ran.
    """

    result: ModelResult
    fit: FloatArray
    model: Any
    n_updates: int


def streaming_ahead(
    model: Any,
    data: IOData,
    steps: int = 1,
    update_every: int | None = None,
    *,
    update_options: Mapping[str, Any] | None = None,
) -> StreamingRun:
    r"""``steps``-ahead prediction over ``data`` while a copy of ``model`` learns from it in chunks.

    Parameters
    ----------
    model : fitted estimator
        Any registered model (it is not changed).
    data : IOData
        A run: inputs and measured outputs.
    steps : int, default 1
        Horizon ``k`` [samples] (:func:`~neckid.models.conformal.predict_ahead`).
    update_every : int, optional
        Samples per chunk: the copy is updated (``partial_fit``) on each chunk once it has been
        seen. Default: :data:`DEFAULT_UPDATE_SECONDS` (1 s) of samples, 40 at the soft neck's
        40 Hz: a per-sample loop would rebuild a Set Membership tree or re-solve a least-squares
        problem 40 times a second, and one second is short next to the drifts it follows.
    update_options : mapping, optional
        Keyword arguments of the model's ``partial_fit``.

    Returns
    -------
    StreamingRun

    Raises
    ------
    NotFittedError
        If ``model`` is not fitted.
    ValueError
        For ``steps`` or ``update_every`` below 1, or ``data`` too short for one prediction.

    Notes
    -----
    With chunk boundaries ``c_j = j · update_every``, the model after update ``j`` has seen the
    samples before ``c_j``; the prediction of ``y(s)`` made at ``t = s − k`` may use it when
    ``c_j − 1 <= t``, so it predicts the samples ``c_j + k − 1 <= s < c_{j+1} + k − 1``. The
    update ``j + 1`` takes the chunk ``[c_j, c_{j+1})`` with the ``max_lag_`` samples before it
    as initial conditions, so every regressor of the run enters the model once: for
    :class:`~neckid.LinearARX` the model after the last chunk is the refit on the training data
    and the whole run. (A direct multi-step model loses the ``k − 1`` targets at each chunk
    start from its ``k``-step predictor's update.)
    """
    check_is_fitted(model)
    k = int(check_number(steps, "steps", low=1, integer=True))
    m = int(model.max_lag_)
    chunk = (
        max(1, round(DEFAULT_UPDATE_SECONDS / data.ts))
        if update_every is None
        else int(check_number(update_every, "update_every", low=1, integer=True))
    )
    n = data.n_samples
    first = m + k - 1
    if n <= first:
        raise ValueError(
            f"data has {n} samples, too few for a {k}-step prediction with lags up to {m}: it"
            f" needs at least {first + 1}"
        )
    learner = copy.deepcopy(model)
    options = dict(update_options or {})
    y = np.array(data.y, dtype=np.float64)
    lower = upper = None
    n_updates = 0
    for start in range(0, n, chunk):
        stop = min(start + chunk, n)
        low, high = max(first, start + k - 1), min(n, stop + k - 1)
        if low < high:
            ahead = predict_ahead(learner, data[low - first : high], k)
            y[low:high] = ahead.y[first:]
            if ahead.lower is not None and ahead.upper is not None:
                if lower is None or upper is None:
                    lower, upper = np.full(y.shape, np.nan), np.full(y.shape, np.nan)
                lower[low:high], upper[low:high] = ahead.lower[first:], ahead.upper[first:]
        if stop < n and stop - max(start - m, 0) > m:
            learner.partial_fit(data[max(start - m, 0) : stop], **options)
            n_updates += 1
    result = ModelResult.from_data(
        "prediction",
        data,
        y,
        first,
        learner.output_names_,
        learner.output_units_,
        lower,
        upper,
        {"steps": k, "update_every": chunk},
    )
    return StreamingRun(result, result.fit_percent(data), learner, n_updates)
