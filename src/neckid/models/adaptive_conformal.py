r"""Adaptive conformal bands: coverage that survives a change of run (Gibbs & Candès, 2021).

A split-conformal band (:mod:`neckid.models.conformal`) covers a new sample with its nominal
probability only if the new run is exchangeable with the calibration run; a new payload or
controller breaks that. Adaptive conformal inference (ACI) reads the log as it comes and steers
the level of the band by its own misses: with nominal miss rate ``α`` and step ``γ``,

.. math::

    α_{t+1} = α_t + γ \left(α − \mathrm{err}_t\right), \qquad
    \mathrm{err}_t = 1 \text{ if } y_t \notin \left[\hat y_t − q_t, \hat y_t + q_t\right]

where ``q_t`` is the ``⌈(n + 1)(1 − α_t)⌉``-th smallest of the ``n`` most recent scores
``|y_s − \hat y_s|`` known when the prediction of ``y_t`` is made (a k-step prediction is made
``k`` samples earlier, so only scores up to ``t − k`` are used; a free run's band uses scores up
to ``t − 1``). A miss widens the next bands, a hit narrows them; whatever the data, the long-run
miss rate satisfies ``|mean(err) − α| <= (max(α_1, 1 − α_1) + γ) / (γ T)`` over ``T`` samples
(Gibbs & Candès 2021, Proposition 4.1). It is a statement about the *running* coverage of this
log, not a probability for each sample.

References
----------
I. Gibbs and E. J. Candès, "Adaptive conformal inference under distribution shift", Advances in
Neural Information Processing Systems 34, 2021.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from neckid.data.iodata import IOData
from neckid.models.base import ModelResult, check_is_fitted
from neckid.models.kstep import predict_ahead
from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = ["adaptive_band", "band_around"]


def _level_quantile(window: FloatArray, level: float) -> float:
    """The ``⌈(n + 1) level⌉``-th smallest of ``window`` (``inf`` beyond ``n``, 0 for level <= 0)."""
    n = window.size
    if level <= 0.0:
        return 0.0
    rank = math.ceil((n + 1) * min(level, 1.0) * (1 - 1e-12))
    if rank > n or n == 0:
        return math.inf
    return float(np.partition(window, rank - 1)[rank - 1])


def _aci(
    y: FloatArray,
    y_hat: FloatArray,
    start: int,
    delay: int,
    coverage: float,
    step: float,
    window: int,
    warmup: FloatArray | None,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Half-widths, misses and the level α_t per sample and output (NaN before ``start``)."""
    n, n_out = y.shape
    alpha = 1.0 - coverage
    half = np.full((n, n_out), np.nan)
    missed = np.full((n, n_out), np.nan)
    levels = np.full((n, n_out), np.nan)
    scores = np.abs(y - y_hat)
    for c in range(n_out):
        a_t = alpha
        history = [] if warmup is None else list(np.asarray(warmup[:, c], dtype=np.float64))
        for t in range(start, n):
            known = t - delay  # the last sample whose score is known when y_t is predicted
            if known >= start:
                history.append(float(scores[known, c]))
            recent = np.asarray(history[-window:], dtype=np.float64)
            q = _level_quantile(recent, 1.0 - a_t)
            half[t, c], levels[t, c] = q, a_t
            miss = float(scores[t, c] > q)
            missed[t, c] = miss
            a_t = a_t + step * (alpha - miss)
    return half, missed, levels


def adaptive_band(
    model: Any,
    data: IOData,
    *,
    steps: int | None = None,
    coverage: float = 0.95,
    step: float = 0.005,
    window: int = 500,
    calibration: IOData | None = None,
) -> ModelResult:
    """A band around a model's k-step or free-run output, adapted online as ``data`` is read.

    Parameters
    ----------
    model : fitted estimator
        Any neckid model.
    data : IOData
        The log, read in time order (inputs and measured outputs).
    steps : int, optional
        The horizon in samples (``predict_ahead``); ``None`` is the free run (``simulate``).
    coverage : float, default 0.95
        The nominal level ``1 − α`` in (0, 1).
    step : float, default 0.005
        ACI's step ``γ`` (> 0): larger adapts faster and wobbles more.
    window : int, default 500
        How many of the most recent scores the quantile reads.
    calibration : IOData, optional
        A log whose scores (same horizon) start the window; without one, the first samples have
        infinite bands until enough scores are known.

    Returns
    -------
    ModelResult
        The model's result with ``lower``, ``upper`` and ``extras``: ``"band"`` (``"adaptive"``),
        ``"coverage"`` (nominal), ``"running_coverage"`` (per output: the share of samples so
        far inside their band, an array over time), ``"miss_level"`` (``α_t``), ``"steps"``.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, 3000)
    >>> y = np.zeros(3000)
    >>> for t in range(1, 3000):
    ...     y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1] + 0.05 * rng.normal()
    >>> model = LinearARX(Lags.arx(1, 1)).fit(IOData(u[:1000], y[:1000], ts=0.02))
    >>> shifted = IOData(u[1000:], y[1000:] + np.linspace(0, 0.5, 2000), ts=0.02)  # a drift
    >>> band = adaptive_band(model, shifted, steps=5)
    >>> bool(abs(band.extras["running_coverage"][-1, 0] - 0.95) < 0.02)
    True
    """
    check_is_fitted(model)
    level = check_number(coverage, "coverage", low=0, high=1, closed="neither")
    gamma = check_number(step, "step", low=0, high=1, closed="right")
    if isinstance(window, bool) or not isinstance(window, int) or window < 1:
        raise ValueError(f"window must be an integer >= 1; got {window!r}")
    if steps is not None and (isinstance(steps, bool) or not isinstance(steps, int) or steps < 1):
        raise ValueError(f"steps must be an integer >= 1 or None (the free run); got {steps!r}")

    def run(log: IOData) -> ModelResult:
        return model.simulate(log) if steps is None else predict_ahead(model, log, steps)

    warmup = None
    if calibration is not None:
        calibrated = run(calibration)
        warmup = np.abs(calibration.y - calibrated.y)[calibrated.n_initial :]
    return band_around(
        run(data), data, steps=steps, coverage=level, step=gamma, window=window, scores=warmup
    )


def band_around(
    result: ModelResult,
    data: IOData,
    *,
    steps: int | None = None,
    coverage: float = 0.95,
    step: float = 0.005,
    window: int = 500,
    scores: FloatArray | None = None,
) -> ModelResult:
    """:func:`adaptive_band` around a result already computed (an adapted run, say).

    Parameters
    ----------
    result : ModelResult
        A free run (``steps=None``) or ``steps``-ahead prediction of ``data``'s outputs.
    data : IOData
        The log, read in time order.
    steps, coverage, step, window
        As in :func:`adaptive_band`.
    scores : ndarray, shape (n, n_outputs), optional
        Absolute residuals known before ``data`` starts (a calibration log, or the warm-up
        an adaptation read), the first contents of the window.

    Returns
    -------
    ModelResult
        As :func:`adaptive_band` returns it.
    """
    level = check_number(coverage, "coverage", low=0, high=1, closed="neither")
    gamma = check_number(step, "step", low=0, high=1, closed="right")
    if isinstance(window, bool) or not isinstance(window, int) or window < 1:
        raise ValueError(f"window must be an integer >= 1; got {window!r}")
    start = result.n_initial
    delay = 1 if steps is None else int(steps)
    half, missed, levels = _aci(data.y, result.y, start, delay, level, gamma, window, scores)
    counted = np.nan_to_num(1.0 - missed, nan=0.0).cumsum(axis=0)
    seen = np.maximum(np.arange(data.n_samples) - start + 1, 1)[:, None]
    running = np.where(np.isnan(missed), np.nan, counted / seen)
    extras = {
        **result.extras,
        "band": "adaptive",
        "coverage": level,
        "running_coverage": running,
        "miss_level": levels,
        "steps": steps,
    }
    return dataclasses.replace(result, lower=result.y - half, upper=result.y + half, extras=extras)
