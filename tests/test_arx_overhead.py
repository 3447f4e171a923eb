"""LinearARX.simulate without its overhead (issue 33): the same floats and the same checks as before.

The single-output free run used to call ``scipy.signal.lfilter`` twice (the FIR of each input,
then the all-pole filter from ``lfiltic``'s state), and the result's checks each made a pass of
their own over the samples. Now one compiled pass (``neckid.models.linear._arx_kernels``) runs
the FIR with ``np.convolve``'s arithmetic, the all-pole filter with ``lfilter``'s, and counts what
the checks look for. The references below: the previous filter, kept verbatim, and the general
path every other model takes (``Estimator._result`` making its own passes).
"""

from __future__ import annotations

import copy
import dataclasses
import warnings
from typing import Any

import numpy as np
import pytest
from scipy import signal

from neckid import IOData, Lags, LinearARX
from neckid.models._domain_kernels import BLOCK, channels_of
from neckid.models.base import DivergenceError
from neckid.models.domain import regressor_domain
from neckid.models.linear._arx_kernels import MAX_FIR_TAPS, all_pole_block, fir_block
from neckid.models.linear.arx import _linear_free_run, linear_free_run
from neckid.models.results import ModelResult
from neckid.regressors import ResolvedLags


def previous_free_run(resolved: ResolvedLags, coef, intercept, u, y_initial) -> np.ndarray:
    """The single-output branch of ``linear_free_run`` before issue 33."""
    u_arr = np.asarray(u, dtype=np.float64)
    y = np.array(y_initial, dtype=np.float64, order="C", ndmin=2)
    coef_arr = np.asarray(coef, dtype=np.float64).reshape(resolved.n_terms, -1)
    n = y.shape[0]
    m = resolved.max_lag
    outputs = np.flatnonzero(resolved.source == 0)
    forcing = np.full(n - m, float(np.asarray(intercept, dtype=np.float64).reshape(())))
    for channel in np.unique(resolved.channel[resolved.source == 1]):
        terms = np.flatnonzero((resolved.source == 1) & (resolved.channel == channel))
        numerator = np.zeros(int(resolved.lag[terms].max()) + 1)
        np.add.at(numerator, resolved.lag[terms], coef_arr[terms, 0])
        forcing += signal.lfilter(numerator, [1.0], u_arr[:, channel])[m:]
    if outputs.size == 0:
        y[m:, 0] = forcing
        return y
    order = int(resolved.lag[outputs].max())
    denominator = np.zeros(order + 1)
    denominator[0] = 1.0
    np.subtract.at(denominator, resolved.lag[outputs], coef_arr[outputs, 0])
    past = y[m - order : m, 0][::-1]
    state = signal.lfiltic([1.0], denominator, past)
    y[m:, 0] = signal.lfilter([1.0], denominator, forcing, zi=state)[0]
    return y


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def random_filter(
    rng: np.random.Generator, lags: Lags, n: int, n_inputs: int
) -> tuple[ResolvedLags, IOData, np.ndarray, np.ndarray, np.ndarray]:
    """A log and the coefficients of a stable-ish filter scaled over decades."""
    data = IOData(rng.normal(size=(n, n_inputs)), rng.normal(size=n), ts=0.1)
    resolved = lags.resolve(data)
    coef = rng.normal(size=(resolved.n_terms, 1)) * 10.0 ** rng.uniform(-3, 1)
    coef[resolved.source == 0] *= 0.3 / max(1, int(np.sum(resolved.source == 0)))
    return resolved, data, coef, rng.normal(size=1), data.y * 10.0 ** rng.uniform(-2, 2)


@pytest.mark.parametrize("seed", range(40))
def test_single_output_free_run_is_bit_for_bit_the_previous_one(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n_inputs = int(rng.integers(1, 4))
    outputs = sorted(set(rng.integers(1, 7, size=int(rng.integers(0, 5))).tolist()))
    inputs = sorted(set(rng.integers(0, 6, size=int(rng.integers(1, 5))).tolist()))
    n = int(rng.integers(20, 2 * BLOCK + 400))
    resolved, data, coef, intercept, y0 = random_filter(
        rng, Lags(outputs=outputs, inputs=inputs), n, n_inputs
    )
    with np.errstate(over="ignore", invalid="ignore"):
        new = linear_free_run(resolved, coef, intercept, data.u, y0)
        old = previous_free_run(resolved, coef, intercept, data.u, y0)
    np.testing.assert_array_equal(bits(new), bits(old))


@pytest.mark.parametrize("longest", [MAX_FIR_TAPS - 2, MAX_FIR_TAPS - 1, MAX_FIR_TAPS, 16, 23])
def test_long_input_filters_are_bit_for_bit_the_previous_one(longest: int) -> None:
    """Up to MAX_FIR_TAPS taps the compiled sum, from 16 on ``np.convolve``: the same floats."""
    rng = np.random.default_rng(longest)
    lags = Lags(outputs=[1, 2], inputs={"u1": [0, 3, longest - 1], "u2": [1, 2]})
    resolved, data, coef, intercept, y0 = random_filter(rng, lags, 2 * BLOCK + 77, 2)
    new = linear_free_run(resolved, coef, intercept, data.u, y0)
    np.testing.assert_array_equal(
        bits(new), bits(previous_free_run(resolved, coef, intercept, data.u, y0))
    )


@pytest.mark.parametrize("width", range(1, MAX_FIR_TAPS + 1))
@pytest.mark.parametrize("n_inputs", [1, 3])
def test_fir_block_is_np_convolve_bit_for_bit(width: int, n_inputs: int) -> None:
    """One input and three (taken channel by channel), rows padded at the high lags."""
    rng = np.random.default_rng(width)
    u = rng.normal(size=(600, n_inputs)) * 10.0 ** rng.uniform(-3, 3, size=(600, n_inputs))
    numerator = np.zeros((n_inputs, MAX_FIR_TAPS))
    numerator[:, :width] = rng.normal(size=(n_inputs, width)) * 10.0 ** rng.uniform(-3, 3, width)
    channel = np.arange(n_inputs, dtype=np.int64)
    start, begin = MAX_FIR_TAPS, 100
    x, partial = np.empty(300), np.empty(BLOCK)
    fir_block(channels_of(u), channel, numerator, np.empty(0), 0.25, start, begin, x, partial)
    expected = np.full(300, 0.25)
    for c in range(n_inputs):
        expected += np.convolve(numerator[c, :width], u[:, c])[begin : begin + 300]
    np.testing.assert_array_equal(bits(x), bits(expected))


@pytest.mark.parametrize("order", [1, 2, 3, 4, 5, 8])
def test_all_pole_block_is_lfilter_bit_for_bit(order: int) -> None:
    """Block by block, the state carried over, against one ``lfilter`` call."""
    rng = np.random.default_rng(order)
    denominator = np.r_[1.0, 0.4 * rng.normal(size=order) / order]
    x = rng.normal(size=5000) * 10.0 ** rng.uniform(-3, 3, size=5000)
    state = signal.lfiltic([1.0], denominator, rng.normal(size=order))
    expected = signal.lfilter([1.0], denominator, x, zi=state)[0]
    out = np.empty_like(x)
    moving = state.copy()
    for begin, stop in ((0, 1), (1, 8), (8, 8 + BLOCK), (8 + BLOCK, 5000)):
        all_pole_block(denominator, x[begin:stop], moving, out, begin)
    np.testing.assert_array_equal(bits(out), bits(expected))
    np.testing.assert_array_equal(
        bits(moving), bits(signal.lfilter([1.0], denominator, x, zi=state)[1])
    )


class GeneralPathARX(LinearARX):
    """``LinearARX.simulate`` through the checks every other model makes, pass by pass."""

    def simulate(self, data: IOData, initial: Any = None) -> ModelResult:
        data = self._with_conditions(data)
        y = self._initial_outputs(data, initial)
        with np.errstate(over="ignore", invalid="ignore"):
            y = _linear_free_run(self.lags_, self.coef_, self.intercept_, data.u, y)
        return self._result("simulation", data, y)


def outcome(model: LinearARX, data: IOData, initial: Any) -> tuple[Any, ...]:
    """The result (or the error and its result) and the warnings of one free run."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result, error = model.simulate(data, initial=initial), ""
        except DivergenceError as raised:
            result, error = raised.result, str(raised)
    shown = [(str(w.message), w.category, w.filename, w.lineno) for w in caught]
    name = type(model).__name__  # the messages name the class: both paths as LinearARX
    shown = [(text.replace(name, "LinearARX"), *rest) for text, *rest in shown]
    return result, error.replace(name, "LinearARX"), shown


def assert_same_result(fast: ModelResult, general: ModelResult) -> None:
    for field in dataclasses.fields(ModelResult):
        mine, theirs = getattr(fast, field.name), getattr(general, field.name)
        if isinstance(mine, np.ndarray):
            np.testing.assert_array_equal(bits(mine), bits(theirs), err_msg=field.name)
        else:
            assert mine == theirs, field.name


def siso(n: int, n_inputs: int, seed: int = 0) -> IOData:
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, n_inputs))
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = 0.7 * y[t - 1] - 0.2 * y[t - 2] + u[t - 1] @ np.linspace(0.5, -0.3, n_inputs)
    names = [f"u{j}" for j in range(n_inputs)]
    return IOData(u, y, ts=0.02, input_names=names, output_names=["incl"], output_units=["deg"])


def unstable(model: LinearARX, pole: float) -> LinearARX:
    """The model with the one pole ``pole`` (``y(t-1)``'s coefficient; ``y(t-2)``'s zero)."""
    changed = copy.deepcopy(model)
    changed.coef_[:2, 0] = pole, 0.0
    return changed


def old_file(model: LinearARX) -> LinearARX:
    """The model as read from a file written before the training ranges were recorded."""
    changed = copy.deepcopy(model)
    changed.training_ranges_, changed.regressor_ranges_ = {}, {}
    return changed


def with_payload(data: IOData, payload: float) -> IOData:
    return data.with_conditions(payload=payload)


def log_like(data: IOData, u: np.ndarray, y: np.ndarray | None, t0: float = 0.0) -> IOData:
    names = {"input_names": data.input_names, "output_names": ["incl"] if y is not None else None}
    return IOData(u, y, ts=data.ts, t0=t0, **names)


LOGS = {
    "training": lambda d: (d, None),
    "wider": lambda d: (log_like(d, 1.5 * d.u, 2.0 * d.y), None),
    "outputs-shifted": lambda d: (log_like(d, d.u, d.y + 3.0), None),
    "inputs-only": lambda d: (log_like(d, 2.0 * d.u, None, t0=12.345), [[0.2], [-0.1]]),
    "t0-and-initial": lambda d: (log_like(d, d.u, d.y, t0=-7.5), [[5.0], [9.0]]),
}

MODELS = {
    "as-fitted": lambda m: m,
    "old-file": old_file,
    "runaway": lambda m: unstable(m, 1.02),
    "overflow": lambda m: unstable(m, 1e200),
}


@pytest.mark.parametrize("n_inputs", [1, 3])
@pytest.mark.parametrize("log", sorted(LOGS))
@pytest.mark.parametrize("variant", sorted(MODELS))
def test_checks_counted_in_the_run_are_those_of_the_general_path(
    variant: str, log: str, n_inputs: int
) -> None:
    """The same result, extras, warning (text and place) and divergence error, bit for bit."""
    training = siso(2 * BLOCK + 300, n_inputs)
    fitted = LinearARX(Lags.arx(2, 2, 1)).fit(training[: BLOCK + 100])
    model = MODELS[variant](fitted)
    general = copy.deepcopy(model)
    general.__class__ = GeneralPathARX
    data, initial = LOGS[log](training)
    fast, fast_error, fast_warnings = outcome(model, data, initial)
    slow, slow_error, slow_warnings = outcome(general, data, initial)
    assert_same_result(fast, slow)
    assert fast_error == slow_error
    assert fast_warnings == slow_warnings
    if variant in ("runaway", "overflow"):  # not vacuous: the errors are there
        assert "ran away" in fast_error or "diverged" in fast_error
    if log == "wider" and variant == "as-fitted":
        assert "regressor terms outside" in fast_warnings[0][0]
        assert fast.extras["outside_domain"] > 0.1


def test_conditions_are_checked_as_inputs() -> None:
    training = with_payload(siso(BLOCK + 500, 2), 0.4)
    model = LinearARX(Lags(outputs=2, inputs=[1, 2], conditions=["payload"])).fit(training)
    general = copy.deepcopy(model)
    general.__class__ = GeneralPathARX
    heavier = with_payload(training, 0.5)
    fast, _, fast_warnings = outcome(model, heavier, None)
    slow, _, slow_warnings = outcome(general, heavier, None)
    assert_same_result(fast, slow)
    assert fast_warnings == slow_warnings
    assert fast.extras["extrapolation"]["payload"] == 1.0


def test_domain_shares_are_those_of_regressor_domain() -> None:
    rng = np.random.default_rng(5)
    u = rng.normal(size=(3000, 2))
    y = np.convolve(u[:, 0] - 0.5 * u[:, 1], [0.0, 0.5, 0.25])[:3000]
    data = IOData(u, y, ts=0.1)
    model = LinearARX(Lags.arx(2, 2, 1)).fit(data[:1000])
    for log in (data, data[:1500], IOData(1.5 * u, 2.0 * y, ts=0.1), IOData(u, 3.0 * y, ts=0.1)):
        found = regressor_domain(model, log, nearest=False)
        share, by_term = model._domain_shares(log)
        assert share == found.share
        assert by_term == found.by_term
    wider = IOData(2.0 * u, 2.0 * y, ts=0.1)
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        result = model.simulate(wider)
    assert result.extras["outside_domain"] == regressor_domain(model, wider, nearest=False).share
    assert 0.0 < result.extras["outside_domain"] < 1.0
