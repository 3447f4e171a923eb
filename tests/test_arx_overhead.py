"""LinearARX.simulate without its overhead (issue 33): the same floats and the same checks as before.

The single-output free run used to call ``scipy.signal.lfilter`` twice (the FIR of each input,
then the all-pole filter from ``lfiltic``'s state), and the result's checks each made a pass of
their own over the samples. Now one compiled pass (``neckid.models.linear._arx_kernels``) sums
the FIR of each input tap by tap and runs the all-pole filter in ``lfilter``'s direct form II
transposed, and counts what the checks look for.

Two kinds of reference, two kinds of assertion (issue 39):

* **bit for bit** against references this file computes itself in a fixed order
  (:func:`reference_fir`, elementwise NumPy operations, each one correctly rounded on every
  CPU; :func:`reference_all_pole`, a Python loop): the kernels' arithmetic, on any machine;
* **a bound in units of the last place** against other libraries whose summation order depends
  on the CPU or on the BLAS: ``np.convolve`` (OpenBLAS's ``ddot`` adds short vectors one by one
  on some cores and in SIMD blocks on others: AVX-512 from 12 taps) and ``lfilter``. The bound
  is the textbook one for a sum of ``n`` products in any order (Higham, *Accuracy and Stability
  of Numerical Algorithms*, 2nd ed., §3.1): ``|error| ≤ γ_n · Σ|products|``,
  ``γ_n = n·u / (1 − n·u)``, ``u = 2⁻⁵³``, once for each of the two sums compared.

``make test`` runs this file a second time with NumPy's SIMD dispatch narrowed to its baseline
and OpenBLAS forced to another core (``make pytest-narrow``), so that a CPU-dependent assertion
fails on any machine rather than only on the one whose CPU differs.
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
from neckid.models.linear._arx_plan import filter_state
from neckid.models.linear.arx import _linear_free_run, linear_free_run
from neckid.models.results import ModelResult
from neckid.regressors import ResolvedLags

pytestmark = pytest.mark.cpu_dependent

UNIT_ROUNDOFF = 2.0**-53


def gamma(n: int) -> float:
    """Higham's γ_n: the relative error bound of a sum of ``n`` products in any order."""
    return n * UNIT_ROUNDOFF / (1.0 - n * UNIT_ROUNDOFF)


def reference_fir(numerator: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``np.convolve(numerator, u)[: len(u)]`` summed tap by tap from the highest lag.

    ``Σ_k u[t − (width − 1) + k] · numerator[width − 1 − k]`` for ``k = 0 … width − 1``, each
    step an elementwise product and sum (correctly rounded, so the same floats on every CPU),
    starting from ``+0.0``: the order of :func:`fir_block`.
    """
    width = numerator.shape[0]
    padded = np.r_[np.zeros(width - 1), u]
    total = np.zeros(u.shape[0])
    for k in range(width):
        total = total + padded[k : k + u.shape[0]] * numerator[width - 1 - k]
    return total


def fir_magnitude(numerator: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``Σ|products|`` of each output of :func:`reference_fir` (the scale of its rounding)."""
    return np.convolve(np.abs(numerator), np.abs(u))[: u.shape[0]]


def reference_all_pole(
    denominator: np.ndarray, x: np.ndarray, state: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``lfilter([1.0], denominator, x, zi=state)`` in SciPy's direct form II transposed.

    Term by term in the order of SciPy's ``_linear_filter`` (and of :func:`all_pole_block`),
    the products with the padded numerator's zeros included; a Python loop, so a fixed order.
    """
    order = denominator.shape[0] - 1
    z = [float(v) for v in state]
    d = [float(v) for v in denominator]
    out = np.empty(x.shape[0])
    for k, xn in enumerate(x.tolist()):
        yn = z[0] + 1.0 * xn if order else xn
        for i in range(order - 1):
            z[i] = z[i + 1] + xn * 0.0 - yn * d[i + 1]
        if order:
            z[order - 1] = xn * 0.0 - yn * d[order]
        out[k] = yn
    return out, np.array(z)


def previous_free_run(
    resolved: ResolvedLags, coef, intercept, u, y_initial, fir=reference_fir, all_pole=None
) -> np.ndarray:
    """The single-output branch of ``linear_free_run`` before issue 33, FIR and IIR swappable.

    With the defaults the sums are this file's fixed-order references (what the kernels must
    give bit for bit); with ``fir=np.convolve``-based and ``all_pole=lfilter`` it is the
    previous code verbatim (what the kernels must give to within rounding).
    """
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
        forcing += fir(numerator, u_arr[:, channel])[m:]
    if outputs.size == 0:
        y[m:, 0] = forcing
        return y
    order = int(resolved.lag[outputs].max())
    denominator = np.zeros(order + 1)
    denominator[0] = 1.0
    np.subtract.at(denominator, resolved.lag[outputs], coef_arr[outputs, 0])
    past = y[m - order : m, 0][::-1]
    state = signal.lfiltic([1.0], denominator, past)
    if all_pole is None:
        y[m:, 0] = reference_all_pole(denominator, forcing, state)[0]
    else:
        y[m:, 0] = all_pole(denominator, forcing, state)
    return y


def scipy_fir(numerator: np.ndarray, u: np.ndarray) -> np.ndarray:
    return signal.lfilter(numerator, [1.0], u)  # np.convolve inside: a CPU-dependent order


def scipy_all_pole(denominator: np.ndarray, x: np.ndarray, state: np.ndarray) -> np.ndarray:
    return signal.lfilter([1.0], denominator, x, zi=state)[0]


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


def longest_fir(resolved: ResolvedLags) -> int:
    inputs = resolved.source == 1
    return int(resolved.lag[inputs].max()) + 1 if np.any(inputs) else 0


def free_run_bound(resolved: ResolvedLags, coef, intercept, u, y_initial) -> np.ndarray:
    """What two free runs that sum the same terms in different orders may differ by, per row.

    First order in the rounding: each FIR output may differ by ``2·γ_w · Σ|products|`` (both
    sums rounded, ``w`` taps), each recursion step adds ``2·γ_(p+2) · (|x| + Σ|d_i||y|)`` (the
    direct form's ``p + 2`` terms), and the recursion carries both through its impulse
    response: bounded by the ℓ1 norm of the filter run on the magnitudes.
    """
    u_arr = np.asarray(u, dtype=np.float64)
    coef_arr = np.asarray(coef, dtype=np.float64).reshape(resolved.n_terms, -1)
    y0 = np.asarray(y_initial, dtype=np.float64).reshape(-1)
    m = resolved.max_lag
    local = np.full(u_arr.shape[0] - m, abs(float(np.asarray(intercept).reshape(()))))
    forcing_error = np.zeros_like(local)
    for channel in np.unique(resolved.channel[resolved.source == 1]):
        terms = np.flatnonzero((resolved.source == 1) & (resolved.channel == channel))
        numerator = np.zeros(int(resolved.lag[terms].max()) + 1)
        np.add.at(numerator, resolved.lag[terms], coef_arr[terms, 0])
        magnitude = fir_magnitude(numerator, u_arr[:, channel])[m:]
        local += magnitude
        forcing_error += 2.0 * gamma(numerator.shape[0] + 1) * magnitude
    outputs = np.flatnonzero(resolved.source == 0)
    order = int(resolved.lag[outputs].max()) if outputs.size else 0
    poles = np.zeros(order + 1)
    np.add.at(poles, resolved.lag[outputs], np.abs(coef_arr[outputs, 0]))
    # |y| run on magnitudes bounds every |y(t)|; the local rounding of each step scales with it
    magnitude_run = np.empty_like(local)
    past = list(np.abs(y0[m - order : m][::-1])) if order else []
    for t in range(local.shape[0]):
        value = local[t] + sum(poles[i + 1] * past[i] for i in range(order))
        magnitude_run[t] = value
        past = [value, *past[:-1]] if order else []
    step_error = forcing_error + 2.0 * gamma(order + 2) * 2.0 * magnitude_run
    propagated = np.empty_like(step_error)
    past = [0.0] * order
    for t in range(step_error.shape[0]):
        value = step_error[t] + sum(poles[i + 1] * past[i] for i in range(order))
        propagated[t] = value
        past = [value, *past[:-1]] if order else []
    bound = np.zeros(u_arr.shape[0])
    bound[m:] = propagated
    return bound


def assert_within(new: np.ndarray, other: np.ndarray, bound: np.ndarray) -> None:
    new, other = np.asarray(new).reshape(-1), np.asarray(other).reshape(-1)
    finite = np.isfinite(other)
    assert np.array_equal(np.isfinite(new), finite)
    excess = np.abs(new[finite] - other[finite]) - bound.reshape(-1)[finite]
    assert np.all(excess <= 0.0), f"beyond the rounding bound by {excess.max():.3g}"


def random_case(seed: int) -> tuple[ResolvedLags, IOData, np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    n_inputs = int(rng.integers(1, 4))
    outputs = sorted(set(rng.integers(1, 7, size=int(rng.integers(0, 5))).tolist()))
    inputs = sorted(set(rng.integers(0, 6, size=int(rng.integers(1, 5))).tolist()))
    n = int(rng.integers(20, 2 * BLOCK + 400))
    return random_filter(rng, Lags(outputs=outputs, inputs=inputs), n, n_inputs)


@pytest.mark.parametrize("seed", range(40))
def test_single_output_free_run_is_bit_for_bit_the_fixed_order_reference(seed: int) -> None:
    resolved, data, coef, intercept, y0 = random_case(seed)
    with np.errstate(over="ignore", invalid="ignore"):
        new = linear_free_run(resolved, coef, intercept, data.u, y0)
        old = previous_free_run(resolved, coef, intercept, data.u, y0)
    np.testing.assert_array_equal(bits(new), bits(old))


@pytest.mark.parametrize("seed", range(40))
def test_single_output_free_run_is_the_previous_lfilter_one_to_rounding(seed: int) -> None:
    resolved, data, coef, intercept, y0 = random_case(seed)
    with np.errstate(over="ignore", invalid="ignore"):
        new = linear_free_run(resolved, coef, intercept, data.u, y0)
        old = previous_free_run(resolved, coef, intercept, data.u, y0, scipy_fir, scipy_all_pole)
        bound = free_run_bound(resolved, coef, intercept, data.u, y0)
    assert_within(new, old, bound)


@pytest.mark.parametrize("longest", [MAX_FIR_TAPS - 2, MAX_FIR_TAPS - 1, MAX_FIR_TAPS, 16, 23])
def test_long_input_filters(longest: int) -> None:
    """Up to MAX_FIR_TAPS taps the compiled sum (bit for bit the fixed-order reference), from
    16 on ``np.convolve`` itself (bit for bit the previous code on the same machine); both
    within the rounding bound of the previous code."""
    rng = np.random.default_rng(longest)
    lags = Lags(outputs=[1, 2], inputs={"u1": [0, 3, longest - 1], "u2": [1, 2]})
    resolved, data, coef, intercept, y0 = random_filter(rng, lags, 2 * BLOCK + 77, 2)
    new = linear_free_run(resolved, coef, intercept, data.u, y0)
    assert longest_fir(resolved) == longest
    if longest <= MAX_FIR_TAPS:
        same = previous_free_run(resolved, coef, intercept, data.u, y0)
    else:
        same = previous_free_run(resolved, coef, intercept, data.u, y0, scipy_fir)
    np.testing.assert_array_equal(bits(new), bits(same))
    previous = previous_free_run(resolved, coef, intercept, data.u, y0, scipy_fir, scipy_all_pole)
    assert_within(new, previous, free_run_bound(resolved, coef, intercept, data.u, y0))


@pytest.mark.parametrize("width", range(1, MAX_FIR_TAPS + 1))
@pytest.mark.parametrize("n_inputs", [1, 3])
def test_fir_block_sums_in_a_fixed_order(width: int, n_inputs: int) -> None:
    """One input and three (taken channel by channel), rows padded at the high lags: bit for
    bit the fixed-order reference, and ``np.convolve`` to within 2·γ_w · Σ|products|."""
    rng = np.random.default_rng(width)
    u = rng.normal(size=(600, n_inputs)) * 10.0 ** rng.uniform(-3, 3, size=(600, n_inputs))
    numerator = np.zeros((n_inputs, MAX_FIR_TAPS))
    numerator[:, :width] = rng.normal(size=(n_inputs, width)) * 10.0 ** rng.uniform(-3, 3, width)
    channel = np.arange(n_inputs, dtype=np.int64)
    start, begin = MAX_FIR_TAPS, 100
    x, partial = np.empty(300), np.empty(BLOCK)
    fir_block(channels_of(u), channel, numerator, np.empty(0), 0.25, start, begin, x, partial)
    fixed = np.full(300, 0.25)
    convolved = np.full(300, 0.25)
    bound = np.zeros(300)
    for c in range(n_inputs):
        window = slice(begin, begin + 300)
        fixed = fixed + reference_fir(numerator[c], u[:, c])[window]
        convolved = convolved + np.convolve(numerator[c, :width], u[:, c])[window]
        bound += 2.0 * gamma(MAX_FIR_TAPS + 1) * fir_magnitude(numerator[c], u[:, c])[window]
    bound += 2.0 * gamma(n_inputs + 1) * (0.25 + bound / (2.0 * gamma(MAX_FIR_TAPS + 1)))
    np.testing.assert_array_equal(bits(x), bits(fixed))
    assert_within(x, convolved, bound)


@pytest.mark.parametrize("order", [0, 1, 2, 3, 4, 5, 8])
def test_all_pole_block_is_the_fixed_order_direct_form(order: int) -> None:
    """Block by block, the state carried over: bit for bit the Python direct form, and one
    ``lfilter`` call to within the recursion's rounding bound."""
    rng = np.random.default_rng(order)
    denominator = np.r_[1.0, 0.4 * rng.normal(size=order) / max(order, 1)]
    x = rng.normal(size=5000) * 10.0 ** rng.uniform(-3, 3, size=5000)
    state = signal.lfiltic([1.0], denominator, rng.normal(size=order)) if order else np.empty(0)
    expected, expected_state = reference_all_pole(denominator, x, state)
    out = np.empty_like(x)
    moving = state.copy()
    for begin, stop in ((0, 1), (1, 8), (8, 8 + BLOCK), (8 + BLOCK, 5000)):
        all_pole_block(denominator, x[begin:stop], moving, out, begin)
    np.testing.assert_array_equal(bits(out), bits(expected))
    np.testing.assert_array_equal(bits(moving), bits(expected_state))
    if order:
        # the recursion on magnitudes bounds |y|; its impulse response's ℓ1 norm carries the
        # local rounding 2·γ_(p+2)·(|x| + Σ|d||y|) of each step
        magnitude = signal.lfilter([1.0], np.r_[1.0, -np.abs(denominator[1:])], np.abs(x))
        local = 2.0 * gamma(order + 2) * (np.abs(x) + 2.0 * magnitude + np.abs(state).sum())
        bound = signal.lfilter([1.0], np.r_[1.0, -np.abs(denominator[1:])], local)
        assert_within(out, signal.lfilter([1.0], denominator, x, zi=state)[0], bound)


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


def test_blocks_screened_before_counting_count_the_same() -> None:
    """Values outside their box in a few blocks only, one at a block's edge: the same counts.

    The run screens each block channel by channel and counts term by term only where the
    screen finds a value outside; a lagged term reads the rows before its block, so a spike in
    the last row of a block is outside for ``u(t-1)`` and ``u(t-2)`` in the next one.
    """
    training = siso(4 * BLOCK + 100, 2)
    model = LinearARX(Lags.arx(2, 2, 1)).fit(training)  # the log is inside but for the spikes
    u, y = np.array(training.u), np.array(training.y)
    # the blocks start at max_lag = 2: row 2 * BLOCK + 1 ends block 1 (block 2's lags read it)
    u[2 * BLOCK + 1, 1] = 40.0
    u[BLOCK + 7, 0] = -40.0
    y[3 * BLOCK + 11] = 1e3  # a measured output beyond its range, in block 3
    data = log_like(training, u, y)
    general = copy.deepcopy(model)
    general.__class__ = GeneralPathARX
    fast, fast_error, fast_warnings = outcome(model, data, None)
    slow, slow_error, slow_warnings = outcome(general, data, None)
    assert_same_result(fast, slow)
    assert (fast_error, fast_warnings) == (slow_error, slow_warnings)
    assert 0 < fast.extras["outside_domain"] < 0.01  # not vacuous: a few rows counted
    assert fast.extras["extrapolation"]["u1"] == 1 / data.n_samples


@pytest.mark.parametrize("order", [0, 1, 2, 3])
def test_filter_state_is_lfiltics_arithmetic(order: int) -> None:
    """Up to order 2 in Python floats, the same bits as the NumPy sums (zeros, inf, NaN too)."""
    rng = np.random.default_rng(order)
    special = [0.0, -0.0, 1e-300, -1e-300, 1e308, -1e308, np.inf, -np.inf, np.nan, 1.0, -0.3]
    for trial in range(3000):
        if trial % 2:
            d, y = rng.choice(special, order), rng.choice(special, (order, 1))
        else:
            d, y = (
                rng.normal(size=order) * 10.0 ** rng.integers(-8, 8, order),
                rng.normal(size=(order, 1)),
            )
        denominator = np.r_[1.0, d]
        past = y[:, 0][::-1]
        expected = np.zeros(order)
        with np.errstate(all="ignore"):
            for k in range(order):  # what filter_state computed for every order before issue 42
                expected[k] -= (denominator[k + 1 :] * past[: order - k]).sum()
            state = filter_state(denominator, y, order)
        np.testing.assert_array_equal(bits(state), bits(expected))
        if trial % 2 == 0 and order:
            lfiltic = signal.lfiltic([1.0], denominator, past)
            np.testing.assert_allclose(state, lfiltic, rtol=1e-14, atol=1e-300)


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
