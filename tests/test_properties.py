"""Properties of the public estimators, with Hypothesis.

- Set Membership: whenever the prior assumptions hold (the noise is bounded by ``epsilon`` and
  the true function is Lipschitz with a constant at most ``gamma`` in the model's metric), the
  fit accepts the prior and the bounds contain the noise-free true function, at new regressors
  (:meth:`SetMembership.bounds`) and along new data (:meth:`SetMembership.predict`). Milanese &
  Novara (2004), Theorem 1: the true function belongs to the feasible set, and ``f_l``/``f_u``
  are the lower and upper envelopes of that set.
- Every registered method: a saved and loaded model simulates and predicts what the original
  does (to 1e-12), and its step-by-step simulator reproduces ``simulate`` (to 1e-10). A case
  Hypothesis found for ``sm-linear`` (``SM_LINEAR_ORDER_BUG``: the two paths summed the linear
  part in different orders) stays pinned with ``@example``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import neckid
from neckid import IOData, Lags, SetMembership

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


# ============================================================ Set Membership: bounds contain f_o
class TanhSystem(NamedTuple):
    """``y(t) = f(y(t-1), u(t-1)) + e(t)`` with ``|e(t)| <= noise_bound`` (uniform), white input.

    ``f(y1, u1) = pole*y1 + gain*tanh(slope*u1)``: its gradient is known, so is its Lipschitz
    constant in any weighted Euclidean norm.
    """

    pole: float
    gain: float
    slope: float
    noise_bound: float
    seed: int

    def f(self, y1: np.ndarray, u1: np.ndarray) -> np.ndarray:
        return self.pole * y1 + self.gain * np.tanh(self.slope * u1)

    def gradients(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """The gradient of ``f`` over ``(y1, u1)`` lies in the box with these corners."""
        return (self.pole, self.pole), (0.0, self.gain * self.slope)

    def record(self, n_samples: int, seed_offset: int = 0) -> IOData:
        rng = np.random.default_rng([self.seed, seed_offset])
        u = rng.uniform(-1.0, 1.0, n_samples)
        e = rng.uniform(-self.noise_bound, self.noise_bound, n_samples)
        y = np.zeros(n_samples)
        for t in range(1, n_samples):
            y[t] = self.f(y[t - 1], u[t - 1]) + e[t]
        return IOData(u, y, ts=0.1)


@st.composite
def tanh_systems(draw: st.DrawFn) -> TanhSystem:
    return TanhSystem(
        pole=draw(st.floats(-0.9, 0.9)),
        gain=draw(st.sampled_from([-1.0, 1.0])) * draw(st.floats(0.1, 2.0)),
        slope=draw(st.floats(0.1, 3.0)),
        noise_bound=draw(st.floats(0.0, 0.1)),
        seed=draw(SEEDS),
    )


LAGS = Lags.arx(1, 1)  # regressor columns: y(t-1), u(t-1)
N_TRAIN = st.integers(min_value=30, max_value=250)
MARGINS = st.floats(min_value=1.0, max_value=4.0)
SM_SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _lipschitz(system: TanhSystem, coef: np.ndarray, weights: np.ndarray) -> float:
    """Lipschitz constant of ``f(w) − coefᵀw`` in the norm ``‖weights ⊙ w‖``.

    The gradient of ``f`` lies in a box, so the residual's gradient in the scaled coordinates
    ``z = weights ⊙ w`` is ``(∇f − coef) / weights``; its largest norm is at a corner of the box.
    """
    (g_y_low, g_y_high), (g_u_low, g_u_high) = system.gradients()
    worst = [
        max(abs(g_y_low - coef[0]), abs(g_y_high - coef[0])) / weights[0],
        max(abs(g_u_low - coef[1]), abs(g_u_high - coef[1])) / weights[1],
    ]
    return float(np.hypot(*worst))


def _assert_contains(lower: np.ndarray, truth: np.ndarray, upper: np.ndarray) -> None:
    tolerance = 1e-9 * (1.0 + np.abs(truth))
    below = truth < lower - tolerance
    above = truth > upper + tolerance
    assert not below.any(), f"f_o below f_l by {np.max((lower - truth)[below]):.3g}"
    assert not above.any(), f"f_o above f_u by {np.max((truth - upper)[above]):.3g}"


def _check_bounds_contain_truth(model: SetMembership, system: TanhSystem, train: IOData) -> None:
    # The training regressors, where the bounds are tightest (at most 2 epsilon apart), and new
    # ones, beyond the training range too: the guarantee holds everywhere.
    assert model.lags_.names == ("y(t-1)", "u(t-1)")  # the column order used below and in f
    rng = np.random.default_rng([system.seed, 2])
    low, high = train.y.min() - 1.0, train.y.max() + 1.0
    new = np.column_stack([rng.uniform(low, high, 200), rng.uniform(-2.0, 2.0, 200)])
    w = np.vstack([np.column_stack([train.y[:-1, 0], train.u[:-1, 0]]), new])
    bounds = model.bounds(w)
    _assert_contains(bounds.lower[:, 0], system.f(w[:, 0], w[:, 1]), bounds.upper[:, 0])
    # Along a new record, one step ahead: at the measured regressors.
    test = system.record(200, seed_offset=1)
    result = model.predict(test)
    assert result.lower is not None and result.upper is not None
    truth = system.f(test.y[:-1, 0], test.u[:-1, 0])
    _assert_contains(result.lower[1:, 0], truth, result.upper[1:, 0])


@SM_SETTINGS
@given(system=tanh_systems(), n_train=N_TRAIN, margin=MARGINS)
def test_set_membership_bounds_contain_true_function_unscaled(
    system: TanhSystem, n_train: int, margin: float
) -> None:
    train = system.record(n_train)
    gamma = margin * _lipschitz(system, np.zeros(2), np.ones(2))
    model = SetMembership(LAGS, epsilon=system.noise_bound, gamma=gamma, scaling="none")
    model.fit(train)  # the prior holds, so the fit must accept it
    assert model.prior_valid_.all()
    _check_bounds_contain_truth(model, system, train)


@SM_SETTINGS
@given(system=tanh_systems(), n_train=N_TRAIN, margin=MARGINS)
def test_set_membership_bounds_contain_true_function_scaled_with_linear_part(
    system: TanhSystem, n_train: int, margin: float
) -> None:
    train = system.record(n_train)
    # The metric (1/std weights) and the linear part come from the data: read them off a first
    # fit with a gamma far above any constant, then give the residual's true constant.
    probe = SetMembership(
        LAGS, epsilon=system.noise_bound, gamma=1e9, scaling="std", linear_part=True
    ).fit(train)
    gamma = margin * _lipschitz(system, probe.coef_[:, 0], probe.weights_)
    model = SetMembership(
        LAGS, epsilon=system.noise_bound, gamma=gamma, scaling="std", linear_part=True
    ).fit(train)
    np.testing.assert_array_equal(model.weights_, probe.weights_)
    np.testing.assert_array_equal(model.coef_, probe.coef_)
    _check_bounds_contain_truth(model, system, train)


# ============================================================ every method: files and simulators
METHODS = neckid.methods()


class FirstOrderSystem(NamedTuple):
    """Slow ``y(t) = pole*y(t-1) + gain*u(t-delay) + curvature*tanh(y(t-1)) + e(t)``, white input.

    White input keeps every stretch of the record exciting, so the scheduled method's CFF-RLS
    settles at each of its operating points (dwells or inclination bins).
    """

    pole: float
    gain: float
    curvature: float
    delay: int
    noise: float
    seed: int

    def record(self, n_samples: int, seed_offset: int = 0) -> IOData:
        rng = np.random.default_rng([self.seed, seed_offset])
        u = rng.uniform(-1.0, 1.0, n_samples)
        e = self.noise * rng.normal(size=n_samples)
        y = np.zeros(n_samples)
        for t in range(self.delay, n_samples):
            y[t] = (
                self.pole * y[t - 1]
                + self.gain * u[t - self.delay]
                + self.curvature * np.tanh(y[t - 1])
                + e[t]
            )
        return IOData(u, y, ts=0.02)


@st.composite
def first_order_systems(draw: st.DrawFn) -> FirstOrderSystem:
    return FirstOrderSystem(
        pole=draw(st.floats(0.8, 0.95)),
        gain=draw(st.floats(0.1, 1.0)),
        curvature=draw(st.floats(-0.04, 0.04)),
        delay=draw(st.integers(1, 2)),
        noise=draw(st.floats(0.002, 0.02)),
        seed=draw(SEEDS),
    )


LAG_ORDERS = st.tuples(st.integers(1, 2), st.integers(1, 2))  # (na, nb)
FILE_SETTINGS = settings(
    max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)


def _fitted(name: str, system: FirstOrderSystem, orders: tuple[int, int]):
    # The scheduled model is first order by construction: Lags.arx(1, 1, d) only.
    na, nb = (1, 1) if name.startswith("scheduled") else orders
    lags = Lags.arx(na, nb, system.delay)
    return METHODS[name].make(lags, quick=True).fit(system.record(800))


def _assert_same_result(got: neckid.ModelResult, expected: neckid.ModelResult) -> None:
    assert got.kind == expected.kind
    np.testing.assert_allclose(got.y, expected.y, rtol=1e-12, atol=1e-12)
    for band in ("lower", "upper"):
        a, b = getattr(got, band), getattr(expected, band)
        assert (a is None) == (b is None), band
        if a is not None:
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12, err_msg=band)


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
@pytest.mark.parametrize("name", list(METHODS))
@FILE_SETTINGS
@given(system=first_order_systems(), orders=LAG_ORDERS)
def test_saved_and_loaded_model_reproduces_simulate_and_predict(
    name: str, system: FirstOrderSystem, orders: tuple[int, int]
) -> None:
    model = _fitted(name, system, orders)
    test = system.record(200, seed_offset=1)
    with tempfile.TemporaryDirectory() as folder:
        loaded = neckid.load_model(model.save(Path(folder) / "model"))
    assert type(loaded) is type(model)
    _assert_same_result(loaded.simulate(test), model.simulate(test))
    _assert_same_result(loaded.predict(test), model.predict(test))


#: Found by Hypothesis: the compiled free run of SetMembership (``_sm_kernels._free_run_kernel``)
#: summed the linear part as ``intercept + Σ w_k coef_k``, the simulator (``_bounds_rows``) as
#: ``x @ coef + intercept``; the last-bit difference was amplified by the SM map (gamma * weight
#: of y(t-1) is about 30 here) to 1.8e-10 at sample 164. Both now sum in the kernel's order.
SM_LINEAR_ORDER_BUG = FirstOrderSystem(
    pole=0.8125, gain=0.125, curvature=0.0, delay=1, noise=0.015625, seed=1
)


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
@pytest.mark.parametrize(
    "name",
    METHODS,
)
@FILE_SETTINGS
@example(system=SM_LINEAR_ORDER_BUG, orders=(1, 1))
@given(system=first_order_systems(), orders=LAG_ORDERS)
def test_simulator_steps_reproduce_simulate(
    name: str, system: FirstOrderSystem, orders: tuple[int, int]
) -> None:
    model = _fitted(name, system, orders)
    test = system.record(200, seed_offset=1)
    simulation = model.simulate(test)
    m = model.max_lag_
    simulator = model.simulator()
    simulator.reset(y0=test.y[:m], u0=test.u[:m])
    stepped = np.array([simulator.step(u) for u in test.u[m:]])
    np.testing.assert_allclose(stepped, simulation.y[m:], rtol=1e-10, atol=1e-10)
