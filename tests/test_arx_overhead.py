"""LinearARX.simulate without its overhead (issue 33): the same floats as before, bit for bit.

The single-output free run used to call ``scipy.signal.lfilter`` twice (the FIR of each input,
then the all-pole filter from ``lfiltic``'s state) and the extrapolation warning built the whole
regressor matrix (:func:`~neckid.models.domain.regressor_domain`). Now the FIR is the
``np.convolve`` that ``lfilter`` runs for it, the all-pole filter a compiled loop with the same
arithmetic, and the training-box shares are counted in one compiled pass. The reference below is
the previous implementation, kept verbatim.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import signal

from neckid import IOData, Lags, LinearARX
from neckid.models.domain import regressor_domain
from neckid.models.linear.arx import _all_pole_filter, linear_free_run
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


@pytest.mark.parametrize("seed", range(40))
def test_single_output_free_run_is_bit_for_bit_the_previous_one(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n_inputs = int(rng.integers(1, 4))
    outputs = sorted(set(rng.integers(1, 7, size=int(rng.integers(0, 5))).tolist()))
    inputs = sorted(set(rng.integers(0, 6, size=int(rng.integers(1, 5))).tolist()))
    lags = Lags(outputs=outputs, inputs=inputs)
    n = int(rng.integers(20, 400))
    data = IOData(rng.normal(size=(n, n_inputs)), rng.normal(size=n), ts=0.1)
    resolved = lags.resolve(data)
    # coefficients of a stable-ish filter, scaled over decades (rounding shows at every scale)
    coef = rng.normal(size=(resolved.n_terms, 1)) * 10.0 ** rng.uniform(-3, 1)
    coef[resolved.source == 0] *= 0.3 / max(1, int(np.sum(resolved.source == 0)))
    intercept = rng.normal(size=1)
    y0 = data.y * 10.0 ** rng.uniform(-2, 2)
    with np.errstate(over="ignore", invalid="ignore"):
        new = linear_free_run(resolved, coef, intercept, data.u, y0)
        old = previous_free_run(resolved, coef, intercept, data.u, y0)
    np.testing.assert_array_equal(bits(new), bits(old))


@pytest.mark.parametrize("order", [1, 2, 3, 5, 8])
def test_all_pole_filter_is_lfilter_bit_for_bit(order: int) -> None:
    rng = np.random.default_rng(order)
    denominator = np.r_[1.0, 0.4 * rng.normal(size=order) / order]
    x = rng.normal(size=5000) * 10.0 ** rng.uniform(-3, 3, size=5000)
    state = signal.lfiltic([1.0], denominator, rng.normal(size=order))
    out = np.empty_like(x)
    _all_pole_filter(denominator, x, state, out)
    expected = signal.lfilter([1.0], denominator, x, zi=state)[0]
    np.testing.assert_array_equal(bits(out), bits(expected))


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
