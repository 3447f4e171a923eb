r"""k-step-ahead prediction of any fitted model: ``y(t + k)`` from the data up to ``t``.

:func:`predict_ahead` is the generic k-step predictor beside the one-step prediction
(``predict``) and the free run (``simulate``) of :mod:`neckid.models.base`: a model with its own
``predict_ahead`` (the multi-step Set Membership model) uses it, a NARX model iterates its
one-step map ``k`` times from every anchor (all anchors at once), any other model runs its
``simulator()`` ``k`` steps from every anchor. :func:`neckid.models.conformal.calibrate` puts a
split-conformal band around it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.data.iodata import IOData
from neckid.models.base import ModelResult, NarxModel, check_is_fitted
from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = ["predict_ahead"]


def predict_ahead(model: Any, data: IOData, steps: int) -> ModelResult:
    r"""``steps``-ahead prediction of any fitted model: ``y(t + k)`` from the data up to ``t``.

    Row ``s`` is the prediction of ``y(s)`` made at ``t = s − k`` from the measured outputs up
    to ``t`` and the inputs up to ``s`` (the first ``max_lag_ + k − 1`` rows are the measured
    outputs).

    Parameters
    ----------
    model : fitted estimator
        A model with ``predict_ahead`` (:class:`~neckid.models.set_membership.multistep.MultiStepSetMembership`,
        its direct predictor is used), a NARX model (its one-step map iterated ``k`` times from
        every anchor, all anchors at once), or any model with a ``simulator()`` (run ``k`` steps
        from every anchor).
    data : IOData
        Measured inputs and outputs.
    steps : int
        The horizon ``k >= 1``, samples.

    Returns
    -------
    ModelResult
        ``kind="prediction"``, ``n_initial = max_lag_ + steps − 1``, ``extras["steps"]``.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> u = np.random.default_rng(0).normal(size=200)
    >>> y = np.zeros(200)
    >>> for t in range(1, 200):
    ...     y[t] = 0.5 * y[t - 1] + u[t - 1]
    >>> data = IOData(u, y, ts=0.1)
    >>> model = LinearARX(Lags.arx(1, 1)).fit(data)
    >>> ahead = predict_ahead(model, data, steps=3)
    >>> ahead.n_initial, bool(np.allclose(ahead.y[:, 0], y))
    (3, True)
    """
    check_is_fitted(model)
    k = check_number(steps, "steps", low=1, integer=True)
    if data.n_outputs == 0:
        raise ValueError("predict_ahead needs measured outputs; data holds inputs only")
    if hasattr(model, "predict_ahead"):
        result: ModelResult = model.predict_ahead(data, steps=k)
        return result
    data = model._with_conditions(data)
    model._check_inputs(data)
    m = int(model.max_lag_)
    n = data.n_samples
    start = m + k - 1
    if n <= start:
        raise ValueError(
            f"data has {n} samples, too few for a {k}-step prediction with lags up to {m}: it"
            f" needs at least {start + 1}"
        )
    if isinstance(model, NarxModel) and not model.predicts_by_simulation:
        y_hat = _iterate_map(model, data, k)
    else:
        y_hat = _iterate_simulator(model, data, k)
    y = np.array(data.y, dtype=np.float64)
    y[start:] = y_hat[start:]
    return ModelResult.from_data(
        "prediction",
        data,
        y,
        start,
        model.output_names_,
        model.output_units_,
        extras={"steps": k},
    )


def _iterate_map(model: NarxModel, data: IOData, steps: int) -> FloatArray:
    """``steps`` iterations of the one-step map from every anchor, vectorised over anchors.

    ``ahead[j][t]`` is the prediction of ``y(t)`` from the anchor ``t − j``: its output term of
    lag ``l`` is the measurement ``y(t − l)`` when ``l >= j`` and ``ahead[j − l][t − l]``
    (same anchor) otherwise.
    """
    lags = model.lags_
    m = lags.max_lag
    n = data.n_samples
    y, u = data.y, data.u
    ahead: dict[int, FloatArray] = {}
    for j in range(1, steps + 1):
        rows = np.arange(m + j - 1, n)
        x = np.empty((rows.size, lags.n_terms))
        for term in range(lags.n_terms):
            lag, channel = int(lags.lag[term]), int(lags.channel[term])
            if lags.source[term] == 1:
                x[:, term] = u[rows - lag, channel]
            elif lag >= j:
                x[:, term] = y[rows - lag, channel]
            else:
                x[:, term] = ahead[j - lag][rows - lag, channel]
        full = np.full(y.shape, np.nan)
        full[rows] = model._predict_rows(np.ascontiguousarray(x))
        ahead[j] = full
    return ahead[steps]


def _iterate_simulator(model: Any, data: IOData, steps: int) -> FloatArray:
    """``steps`` steps of the model's simulator from every anchor (any model; slow)."""
    m = int(model.max_lag_)
    history = max(m, 1)
    out = np.full(data.y.shape, np.nan)
    simulator = model.simulator()
    for anchor in range(m - 1, data.n_samples - steps):
        first = anchor - history + 1
        simulator.reset(y0=data.y[first : anchor + 1], u0=data.u[first : anchor + 1])
        for t in range(anchor + 1, anchor + steps + 1):
            y_now = simulator.step(data.u[t])
        out[anchor + steps] = y_now
    return out
