r"""Online protocols: a model identified on other runs, adapted to a new run while it goes on.

The real soft neck changes between runs (payload, tendon slack, controller), so a model identified
on some runs misses a new one by an offset and a little dynamics. Two protocols measure how much
of that an adaptation on the new run's own first data wins back:

- :func:`adaptive_free_run`: adapt a copy of the model on the first ``warmup_s`` seconds of a
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
from typing import Any, Literal

import numpy as np

from neckid.data.iodata import IOData
from neckid.models.base import ModelResult, check_is_fitted
from neckid.models.kstep import predict_ahead
from neckid.models.online import estimate_offset, simulate_with_offset
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

Adapt = Literal["none", "offset", "update", "both"]

#: The adaptations of :func:`adaptive_free_run`.
ADAPT_MODES: tuple[str, ...] = ("none", "offset", "update", "both")

#: Default chunk of :func:`streaming_ahead`, in seconds of data between two updates.
DEFAULT_UPDATE_SECONDS = 1.0


@dataclass(frozen=True)
class AdaptiveRun:
    """The result of :func:`adaptive_free_run`.

    Attributes
    ----------
    result : ModelResult
        Free run over :attr:`scored` (``kind="simulation"``); its first ``n_initial`` rows are the
        measured outputs at the end of the warm-up (the initial conditions).
    fit : ndarray, shape (n_outputs,)
        NRMSE fit [%] per output on the samples after the warm-up (``result.fit_percent(scored)``).
    scored : IOData
        The part of the run after the warm-up, with the initial-condition samples before it.
    model : estimator
        The adapted copy (the given model itself when ``adapt`` is ``"none"`` or ``"offset"``,
        which leave it as it is).
    offset : ndarray, shape (n_outputs,)
        The output offset added (zeros without offset adaptation), output units.
    adapt : str
        Which adaptation ran.
    warmup_samples : int
        Samples of the warm-up.
    """

    result: ModelResult
    fit: FloatArray
    scored: IOData
    model: Any
    offset: FloatArray
    adapt: str
    warmup_samples: int


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


def _shift_outputs(data: IOData, shift: FloatArray) -> IOData:
    """``data`` with ``shift`` added to every output sample (everything else kept)."""
    if not np.any(shift):
        return data
    return data.replace(y=data.y + shift)


def _warmup_samples(data: IOData, warmup_s: float) -> int:
    """Number of samples with ``t < t0 + warmup_s``."""
    seconds = check_number(warmup_s, "warmup_s", low=0, closed="neither")
    return int(np.searchsorted(data.time, data.t0 + seconds - 1e-9 * data.ts, side="left"))


def adaptive_free_run(
    model: Any,
    data: IOData,
    warmup_s: float = 5.0,
    *,
    adapt: Adapt = "update",
    update_options: Mapping[str, Any] | None = None,
) -> AdaptiveRun:
    r"""Adapt a copy of ``model`` on the first ``warmup_s`` seconds of ``data``, free-run the rest.

    Parameters
    ----------
    model : fitted estimator
        Any registered model (it is not changed).
    data : IOData
        A new run: inputs and measured outputs.
    warmup_s : float, default 5.0
        Seconds from the start of ``data`` that the adaptation may use (the issue's 5 s).
    adapt : {"update", "offset", "both", "none"}, default "update"
        ``"update"``: ``partial_fit`` of the copy on the warm-up; ``"offset"``: a constant
        output offset estimated on the warm-up (:func:`~neckid.models.online.estimate_offset`)
        and added to the free run (:func:`~neckid.models.online.simulate_with_offset`);
        ``"both"``: the offset of the given model, then the update on the warm-up with that
        offset taken off its outputs, the free run with the offset (the update learns what the
        offset does not explain); ``"none"``: neither, the baseline (the same scored samples).
    update_options : mapping, optional
        Keyword arguments of the model's ``partial_fit`` (``prior="keep"``, ``epochs=5``, ...).

    Returns
    -------
    AdaptiveRun
        The free run from the measured outputs at the warm-up's end and its fit on the samples
        after the warm-up only.

    Raises
    ------
    NotFittedError
        If ``model`` is not fitted.
    ValueError
        For an unknown ``adapt``, a warm-up not longer than the model's ``max_lag_`` or one that
        leaves nothing to score; what the model's ``partial_fit`` raises.
    DivergenceError
        If the free run after the warm-up diverges.

    Notes
    -----
    The scored run starts at the first sample after the warm-up, ``t_w``; its initial
    conditions are the ``max_lag_`` measured outputs before ``t_w`` (part of the warm-up), so
    adaptation and baseline are scored on exactly the same samples.

    Why ``"both"`` takes the offset first: a model that interpolates its data (Set Membership)
    reproduces the warm-up it was just updated on, so an offset measured after the update
    would be about zero whatever the run's offset; measured before, it is the run's offset,
    and the update then adds warm-up points consistent with the old ones up to it.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=1000)
    >>> y = np.zeros(1000)
    >>> for t in range(1, 1000):
    ...     y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    >>> model = LinearARX(Lags.arx(1, 1)).fit(IOData(u[:500], y[:500], ts=0.1))
    >>> shifted = IOData(u[500:], y[500:] + 1.0, ts=0.1)  # a sensor offset in the new run
    >>> runs = {a: adaptive_free_run(model, shifted, 10.0, adapt=a) for a in ("none", "offset")}
    >>> bool(runs["offset"].fit[0] > runs["none"].fit[0] + 20), runs["none"].model is model
    (True, True)
    """
    check_is_fitted(model)
    if adapt not in ADAPT_MODES:
        raise ValueError(f"adapt must be one of {list(ADAPT_MODES)}; got {adapt!r}")
    n_warmup = _warmup_samples(data, warmup_s)
    m = int(model.max_lag_)
    if n_warmup <= m or n_warmup >= data.n_samples:
        raise ValueError(
            f"warmup_s = {warmup_s!r} s gives {n_warmup} warm-up samples of {data.n_samples}: it"
            f" must hold more than max_lag = {m} samples and leave some to score"
        )
    warmup = data[:n_warmup]
    scored = data[n_warmup - m :]
    offset = np.zeros(int(model.n_outputs_))
    if adapt in ("offset", "both"):
        offset = estimate_offset(model, warmup)
    adapted = model
    if adapt in ("update", "both"):
        adapted = copy.deepcopy(model)
        adapted.partial_fit(_shift_outputs(warmup, -offset), **dict(update_options or {}))
    if adapt in ("offset", "both"):
        result = simulate_with_offset(adapted, scored, offset)
    else:
        result = adapted.simulate(scored)
    return AdaptiveRun(
        result, result.fit_percent(scored), scored, adapted, offset, str(adapt), n_warmup
    )


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
