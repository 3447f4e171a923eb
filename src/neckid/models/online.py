r"""Online use of fitted models: the checks every ``partial_fit`` shares, and offset adaptation.

Every registered model has ``partial_fit(data, **options)``: it takes new measurements (one
:class:`~neckid.IOData` or a list) into a *fitted* model and returns it, updated. What an update
means is the model's own (see each class): an exact least-squares update for
:class:`~neckid.LinearARX`, the CFF-RLS recursion continued for :class:`~neckid.RecursiveARX`,
more data points for the Set Membership models, a few more epochs for
:class:`~neckid.NeuralNARX`, one more operating point for :class:`~neckid.GainScheduledModel`.
The name is scikit-learn's for incremental learning; ``RecursiveARX.update(y, u)`` keeps its
per-sample meaning.

Offset adaptation works on any model, without changing it: :func:`estimate_offset` measures the
mean error of the model's free run over a stretch of a new run (the first seconds of a test),
and :func:`simulate_with_offset` runs the model as the output-offset model

.. math:: y(t) = \tilde y(t) + c, \qquad \tilde y(t) = f(\tilde y(t-1), …, u(…)),

i.e. the model's own dynamics, seen through a constant measurement offset ``c`` (a sensor zero or
a tendon slack that differs between runs).
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import ModelResult, check_is_fitted
from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = [
    "ADAPT_MODES",
    "AdaptiveRun",
    "adaptive_free_run",
    "estimate_offset",
    "extend_training_ranges",
    "simulate_with_offset",
    "update_experiments",
    "update_rows",
]


def update_experiments(model: Any, data: IOData | Sequence[IOData]) -> list[IOData]:
    """The checks at the door of every ``partial_fit``; returns the experiments, conditions added.

    Raises
    ------
    NotFittedError
        If ``model`` is not fitted (an update needs something to update).
    ValueError
        If an experiment has other channels or another sampling period than the model, holds no
        outputs, or is not longer than the model's ``max_lag_``.
    """
    check_is_fitted(model)
    experiments = as_experiments(model._with_conditions(data))
    for i, experiment in enumerate(experiments):
        if experiment.n_outputs == 0:
            raise ValueError(
                f"partial_fit needs measured outputs; data[{i}] holds inputs only"
                f" ({list(experiment.input_names)})"
            )
        model._check_inputs(experiment)
        if experiment.n_samples <= model.max_lag_:
            raise ValueError(
                f"data[{i}] has {experiment.n_samples} samples, too few for lags up to"
                f" {model.max_lag_}: an update needs at least {model.max_lag_ + 1}"
            )
    return experiments


def update_rows(model: Any, experiments: Sequence[IOData]) -> tuple[FloatArray, FloatArray]:
    """Regressor rows and targets of ``experiments`` on the model's ``lags_`` (none straddles two)."""
    parts = [model.lags_.build_one(d) for d in experiments]
    return np.vstack([p[0] for p in parts]), np.vstack([p[1] for p in parts])


def extend_training_ranges(model: Any, experiments: Sequence[IOData]) -> None:
    """Widen ``training_ranges_`` and ``regressor_ranges_`` (``Estimator.domain``) to the new data."""
    ranges: dict[str, tuple[float, float]] = dict(getattr(model, "training_ranges_", {}))
    for d in experiments:
        for names, values in ((d.input_names, d.u), (d.output_names, d.y)):
            for j, name in enumerate(names):
                low, high = float(values[:, j].min()), float(values[:, j].max())
                old = ranges.get(name, (low, high))
                ranges[name] = (min(old[0], low), max(old[1], high))
    model.training_ranges_ = ranges
    terms: dict[str, tuple[float, float]] = dict(getattr(model, "regressor_ranges_", {}) or {})
    lags = getattr(model, "lags_", None)
    if terms and lags is not None:
        for d in experiments:
            x, _ = lags.build_one(model._with_conditions(d))
            if x.shape[0] == 0:
                continue
            for j, name in enumerate(lags.names):
                old = terms.get(name, (float(x[:, j].min()), float(x[:, j].max())))
                terms[name] = (min(old[0], float(x[:, j].min())), max(old[1], float(x[:, j].max())))
        model.regressor_ranges_ = terms


def estimate_offset(model: Any, data: IOData, initial: ArrayLike | None = None) -> FloatArray:
    r"""The constant output offset of a model on ``data``: mean of measured − free-run output.

    Parameters
    ----------
    model : fitted estimator
        Any model with ``simulate``.
    data : IOData
        Measured inputs and outputs (e.g. the first seconds of a new run); the free run starts
        from its first ``max_lag_`` outputs, or from ``initial``.
    initial : array_like, optional
        Initial outputs of the free run, as for ``simulate``.

    Returns
    -------
    ndarray, shape (n_outputs,)
        ``c = mean_t (y(t) − ŷ(t))`` over the samples after the initial ones, output units.

    Notes
    -----
    ``c`` is the least-squares estimate of a constant added to the model's free run. It is the
    offset of :func:`simulate_with_offset` (where the model's state starts at ``y − c``); the
    estimate uses the plain free run from the measured initial outputs, whose transient from a
    wrong initial state lasts a few time constants of the model.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> u = np.random.default_rng(0).normal(size=300)
    >>> y = np.zeros(300)
    >>> for t in range(1, 300):
    ...     y[t] = 0.5 * y[t - 1] + u[t - 1]
    >>> model = LinearARX(Lags.arx(1, 1), fit_intercept=False).fit(IOData(u, y, ts=0.1))
    >>> shifted = IOData(u, y + 2.0, ts=0.1)
    >>> c = estimate_offset(model, shifted[:100], initial=y[:1])
    >>> np.round(c, 6)
    array([2.])
    """
    check_is_fitted(model)
    result = model.simulate(data, initial=initial)
    start = result.n_initial
    if data.n_samples <= start:
        raise ValueError(
            f"data has {data.n_samples} samples; estimating an offset needs more than the"
            f" {start} initial ones"
        )
    error = data.y[start:] - result.y[start:]
    return np.asarray(error.mean(axis=0), dtype=np.float64)


def simulate_with_offset(model: Any, data: IOData, offset: ArrayLike) -> ModelResult:
    r"""Free run of the output-offset model ``y = ỹ + c`` (see the module docstring).

    The model's state starts at the measured initial outputs minus ``c``; the result is the
    model's free run plus ``c`` (bounds too, when the model has them), and its first
    ``n_initial`` rows are the measured outputs again.

    Parameters
    ----------
    model : fitted estimator
        Any model with ``simulate(data, initial=...)``.
    data : IOData
        Inputs and the measured initial outputs (its first ``max_lag_`` rows).
    offset : array_like, shape (n_outputs,)
        ``c``, output units (:func:`estimate_offset`).

    Returns
    -------
    ModelResult
        ``kind="simulation"``; ``extras["offset"]`` holds ``c``.
    """
    check_is_fitted(model)
    c = np.asarray(offset, dtype=np.float64).reshape(-1)
    if c.shape != (model.n_outputs_,) or not np.all(np.isfinite(c)):
        raise ValueError(
            f"offset must be {model.n_outputs_} finite value(s), one per output; got {offset!r}"
        )
    m = max(int(model.max_lag_), 1)
    if data.n_outputs == 0 or data.n_samples <= m:
        raise ValueError(
            f"data must hold the measured outputs and more than {m} samples; got"
            f" {data.n_samples} samples and {data.n_outputs} outputs"
        )
    result = model.simulate(data, initial=data.y[:m] - c)
    y = result.y + c
    y[: result.n_initial] = data.y[: result.n_initial]
    lower = None if result.lower is None else result.lower + c
    upper = None if result.upper is None else result.upper + c
    extras = {**result.extras, "offset": c.copy()}
    return dataclasses.replace(result, y=y, lower=lower, upper=upper, extras=extras)


Adapt = Literal["none", "offset", "update", "both"]

#: The adaptations of :func:`adaptive_free_run`.
ADAPT_MODES: tuple[str, ...] = ("none", "offset", "update", "both")


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
