"""What a single-output ``LinearARX.simulate`` reads of the fitted model, worked out once.

Every free run of a fitted single-output ARX needs the same things of the model before it
reads the log: the FIR and all-pole filters of its coefficients, the regressor terms and
channels with a training range as the compiled checks read them, and the divergence envelope
for inputs inside their training ranges. At 20,000 samples building them took about as long
as the filter itself. :func:`plan_of` builds them once into an :class:`ArxPlan` kept on the
model (``model._simulation_plan``), and builds them again whenever what they were built from
has changed: a refit, ``partial_fit``, a loaded model, or an attribute set or changed in place
(the plan holds a copy of the coefficients' bytes and of the ranges, compared on every call).
The plan is per model, never shared, and never written to a model file.

The arithmetic is the one the run had before (:func:`filter_coefficients`,
:func:`filter_state`): the same floats, bit for bit.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.models.domain import channel_terms, regressor_terms
from neckid.models.linear._arx_kernels import MAX_FIR_TAPS
from neckid.regressors import ResolvedLags
from neckid.utils.types import FloatArray, IntArray

__all__ = ["ArxPlan", "filter_coefficients", "filter_state", "plan_of"]

#: ``(names, terms (k, 3), bounds (k, 2))`` as :func:`~neckid.models.domain.regressor_terms`.
Terms = tuple[list[str], IntArray, FloatArray]

#: No envelope: a model without a training range for its output.
_UNBOUNDED = (-np.inf, np.inf)


class Filters:
    """The single-output ARX map as filters (see :func:`filter_coefficients`)."""

    __slots__ = ("channels", "denominator", "numerator", "order", "taps", "value")

    def __init__(
        self,
        channels: IntArray,
        numerator: FloatArray,
        taps: dict[int, int],
        denominator: FloatArray,
        value: float,
    ) -> None:
        self.channels, self.numerator, self.taps = channels, numerator, taps
        self.denominator, self.order, self.value = denominator, denominator.shape[0] - 1, value

    def fir(self, u: FloatArray, n: int, m: int) -> tuple[IntArray, FloatArray, FloatArray, float]:
        """``(channels, numerator, forcing, intercept)`` of ``checked_free_run`` on inputs ``u``.

        With more than ``MAX_FIR_TAPS`` taps on an input the FIRs are convolved here
        (``np.convolve``, as ``lfilter`` does) into the ``forcing``.
        """
        if self.numerator.shape[1] <= MAX_FIR_TAPS:
            return self.channels, self.numerator, np.empty(0), self.value
        forcing = np.full(n - m, self.value)
        for row, channel in zip(self.numerator, self.channels.tolist(), strict=True):
            # what lfilter(row, [1.0], u) computes for an FIR filter, without its overhead
            forcing += np.convolve(row[: self.taps[channel]], u[:, channel])[m:n]
        return self.channels[:0], self.numerator[:0], forcing, self.value


def filter_coefficients(resolved: ResolvedLags, coef: FloatArray, intercept: Any) -> Filters:
    """The FIR of each input and the all-pole filter of a single-output ARX map.

    The FIR of each input (its coefficients by lag, a row of the padded ``numerator``) and the
    all-pole ``denominator`` ``1 − Σ_l a_l z^{-l}``; ``coef`` of shape ``(n_terms, 1)``.
    """
    value = float(np.asarray(intercept, dtype=np.float64).reshape(()))
    columns = (resolved.source.tolist(), resolved.channel.tolist(), resolved.lag.tolist())
    terms = list(zip(*columns, strict=True))
    weights = coef[:, 0].tolist()
    taps: dict[int, int] = {}  # input channel -> its FIR's length
    for source, channel, lag in terms:
        if source == 1:
            taps[channel] = max(taps.get(channel, 0), lag + 1)
    row_of = {channel: row for row, channel in enumerate(sorted(taps))}
    order = max((lag for source, _, lag in terms if source == 0), default=0)
    numerator = np.zeros((len(taps), max(taps.values(), default=1)))
    denominator = np.zeros(order + 1)
    denominator[0] = 1.0
    for (source, channel, lag), weight in zip(terms, weights, strict=True):
        if source == 1:
            numerator[row_of[channel], lag] += weight  # what np.add.at gave: 0.0 + weight
        else:
            denominator[lag] -= weight
    channels = np.array(sorted(taps), dtype=np.int64)
    return Filters(channels, numerator, taps, denominator, value)


def filter_state(denominator: FloatArray, y: FloatArray, m: int) -> FloatArray:
    """The all-pole filter's initial state from the initial outputs ``y[:m, 0]``.

    ``signal.lfiltic([1.0], denominator, past)``, its arithmetic without its checks, ``past``
    being ``y(m − 1), y(m − 2), ..., y(m − order)``.
    """
    order = denominator.shape[0] - 1
    if 1 <= order <= 2:  # the same floats in Python's arithmetic, without NumPy's call overhead
        # NumPy sums two products as d1·p0 + d2·p1 (the sum of one is the product); the sign
        # of a zero may differ inside the sum, never in 0.0 − sum (tested)
        d, p = denominator.tolist(), y[m - order : m, 0].tolist()[::-1]
        if order == 1:
            return np.array([0.0 - d[1] * p[0]])
        return np.array([0.0 - (d[1] * p[0] + d[2] * p[1]), 0.0 - d[2] * p[0]])
    past = y[m - order : m, 0][::-1]
    state = np.zeros(order)
    for k in range(order):
        state[k] -= (denominator[k + 1 :] * past[: order - k]).sum()
    return state


def _key(model: Any) -> tuple[Any, ...]:
    """What a plan is built from, by value (the lags by identity: a refit makes new ones)."""
    coef = np.asarray(model.coef_, dtype=np.float64)
    intercept = np.asarray(model.intercept_, dtype=np.float64)
    return (
        coef.shape,
        coef.tobytes(),
        intercept.shape,
        intercept.tobytes(),
        dict(getattr(model, "training_ranges_", {})),
        dict(getattr(model, "regressor_ranges_", {})),
        model.input_names_,
        model.output_names_,
        model.max_lag_,
    )


class ArxPlan:
    """What a fitted single-output LinearARX's free run reads of the model (see the module)."""

    __slots__ = (
        "channels",
        "envelope",
        "filters",
        "gains",
        "key",
        "lags",
        "reach_high",
        "reach_index",
        "reach_low",
        "terms",
    )

    def __init__(self, model: Any, key: tuple[Any, ...]) -> None:
        self.key, self.lags = key, model.lags_
        self.gains: FloatArray | None = None  # ||h||_1, computed when first needed
        self.filters: Filters | None = None
        if model.n_outputs_ != 1:
            return
        coef = np.asarray(model.coef_, dtype=np.float64).reshape(model.lags_.n_terms, 1)
        self.filters = filter_coefficients(model.lags_, coef, model.intercept_)
        names, terms, bounds = regressor_terms(model)
        self.terms: Terms | None = (names, terms, bounds) if model.regressor_ranges_ else None
        self.channels: dict[bool, Terms] = {}  # by whether the log has its outputs
        self.envelope = np.array(
            model.divergence_envelope().get(model.output_names_[0], _UNBOUNDED), np.float64
        )
        ranges = getattr(model, "training_ranges_", {})
        index = [j for j, name in enumerate(model.input_names_) if name in ranges]
        if model.output_names_[0] not in ranges:
            index = []  # no envelope to widen
        self.reach_index = np.array(index, dtype=np.intp)
        self.reach_low = np.array([ranges[model.input_names_[j]][0] for j in index])
        self.reach_high = np.array([ranges[model.input_names_[j]][1] for j in index])

    def channel_terms(self, model: Any, data: Any) -> Terms:
        """:func:`~neckid.models.domain.channel_terms` of a log the model accepted.

        ``_check_inputs`` has made its input names the model's, and its output names too
        when it has outputs: the terms depend on the log only through that.
        """
        measured = data.n_outputs > 0
        found = self.channels.get(measured)
        if found is None:
            found = self.channels[measured] = channel_terms(model, data)
        return found

    def divergence_envelope(self, model: Any, data: Any, u: FloatArray) -> FloatArray:
        """``model.divergence_envelope(data=data)`` of the output, as ``(low, high)``.

        The envelope for inputs inside their training ranges unless an input of ``u`` leaves
        its range (or is not finite): then the full computation, which widens it.
        """
        index = self.reach_index
        if index.size:
            columns = u if index.size == u.shape[1] and index[-1] == index.size - 1 else u[:, index]
            lowest, highest = columns.min(axis=0), columns.max(axis=0)
            if not ((lowest >= self.reach_low).all() and (highest <= self.reach_high).all()):
                envelope = model.divergence_envelope(data=data)
                return np.array(envelope.get(model.output_names_[0], _UNBOUNDED), np.float64)
        return self.envelope


def plan_of(model: Any) -> ArxPlan:
    """The model's :class:`ArxPlan`, built again if anything it was built from has changed."""
    plan: ArxPlan | None = getattr(model, "_simulation_plan", None)
    key = _key(model)
    if plan is None or plan.lags is not model.lags_ or plan.key != key:
        plan = model._simulation_plan = ArxPlan(model, key)
    return plan
