"""PolynomialNARX: monomial tables, compiled free run and sensitivities, the simulation fit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import neckid
from neckid import IOData, Lags, PolynomialNARX
from neckid.models.base import _free_run
from neckid.models.polynomial import narx as polynomial
from neckid.models.polynomial._kernels import poly_free_run, poly_sensitivity
from neckid.models.polynomial.monomials import monomial_tables


def _cubic_system(n: int, seed: int, output_noise: float = 0.0) -> tuple[IOData, np.ndarray]:
    """A Duffing-like system y(t) = 1.5 y(t-1) - 0.7 y(t-2) - 0.1 y(t-1)^3 + 0.4 u(t-1)."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1.0, 1.0, n // 5 + 1), 5)[:n]
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = 1.5 * y[t - 1] - 0.7 * y[t - 2] - 0.1 * y[t - 1] ** 3 + 0.4 * u[t - 1]
    measured = y + output_noise * rng.normal(size=n)
    return IOData(u, measured, ts=0.01, name=f"cubic-{seed}"), y


@given(st.integers(1, 5), st.integers(1, 4))
@settings(max_examples=30, deadline=None)
def test_monomial_tables_build_every_monomial_once(n_terms: int, degree: int) -> None:
    powers, parent, var, lower = monomial_tables(n_terms, degree)
    assert powers.shape == (math.comb(n_terms + degree, degree), n_terms)
    assert len({tuple(p) for p in powers}) == powers.shape[0]
    assert powers.sum(axis=1).max() == degree
    for m in range(1, powers.shape[0]):
        step = np.zeros(n_terms, dtype=int)
        step[var[m]] = 1
        np.testing.assert_array_equal(powers[m], powers[parent[m]] + step)
        for j in range(n_terms):
            if powers[m, j]:
                step = np.zeros(n_terms, dtype=int)
                step[j] = 1
                np.testing.assert_array_equal(powers[lower[m, j]], powers[m] - step)
            else:
                assert lower[m, j] == -1


def test_least_squares_recovers_a_polynomial_system_exactly() -> None:
    data, _ = _cubic_system(1500, 0)
    model = PolynomialNARX(Lags.arx(2, 1), degree=3, fit_for="prediction").fit(data)
    np.testing.assert_allclose(model.predict(data).y, data.y, atol=1e-9)
    np.testing.assert_allclose(model.simulate(data).y, data.y, atol=1e-7)


def test_the_compiled_free_run_is_the_generic_narx_loop() -> None:
    data, _ = _cubic_system(800, 1, output_noise=0.01)
    model = PolynomialNARX(Lags.arx(2, 2), degree=3, max_iter=5).fit(data)
    reference = _free_run(model.lags_, model._predict_rows, data.u, np.array(data.y))
    np.testing.assert_allclose(model.simulate(data).y, reference, rtol=1e-10, atol=1e-12)
    stepper = model.simulator()
    m = model.max_lag_
    stepper.reset(y0=data.y[:m], u0=data.u[:m])
    stepped = np.array([stepper.step(u) for u in data.u[m:]])
    np.testing.assert_allclose(stepped, reference[m:], rtol=1e-9, atol=1e-12)


def test_sensitivities_are_the_derivatives_of_the_free_run() -> None:
    rng = np.random.default_rng(3)
    n, n_out = 120, 2
    u = rng.uniform(-1, 1, (n, 2))
    lags = Lags(outputs=[1, 2], inputs=[1])
    y0 = rng.normal(scale=0.1, size=(n, n_out))
    data = IOData(u, y0, ts=0.1)
    resolved = lags.resolve([data])
    powers, parent, var, lower = monomial_tables(resolved.n_terms, 2)
    coef = rng.normal(scale=0.05, size=(powers.shape[0], n_out))
    center, scale = rng.normal(scale=0.1, size=resolved.n_terms), np.full(resolved.n_terms, 0.7)
    m = resolved.max_lag
    wide = np.full(n_out, 1e6)
    box = np.full(resolved.n_terms, 1e6)
    tables = (
        resolved.source,
        resolved.channel,
        resolved.lag,
        center,
        scale,
        -box,
        box,
        parent,
        var,
    )

    def simulate(c: np.ndarray) -> np.ndarray:
        y = y0.copy()
        poly_free_run(u, y, *tables, c.reshape(coef.shape), m, -wide, wide)
        return y[m:]

    jacobian = np.zeros((n - m, n_out, coef.size))
    y = y0.copy()
    poly_sensitivity(u, y, *tables, powers, lower, coef, m, -wide, wide, jacobian)
    np.testing.assert_allclose(y[m:], simulate(coef.ravel()), rtol=1e-12)
    h = 1e-6
    for p in range(coef.size):
        step = np.zeros(coef.size)
        step[p] = h
        numeric = (simulate(coef.ravel() + step) - simulate(coef.ravel() - step)) / (2 * h)
        np.testing.assert_allclose(jacobian[:, :, p], numeric, rtol=1e-5, atol=1e-8)


def test_fitting_for_simulation_beats_least_squares_under_output_noise() -> None:
    # Output (not equation) noise biases one-step least squares; the free-run fit is the
    # criterion that matches the noise, and must simulate a clean validation run better.
    train, _ = _cubic_system(3000, 4, output_noise=0.05)
    validation, clean = _cubic_system(2000, 5)
    lags = Lags.arx(2, 1)
    ls = PolynomialNARX(lags, degree=3, fit_for="prediction").fit(train)
    oe = PolynomialNARX(lags, degree=3).fit(train)
    assert oe.fit_report_["rmse"][0] <= oe.fit_report_["rmse_start"][0]
    error_ls = np.sqrt(np.mean((ls.simulate(validation).y[:, 0] - clean) ** 2))
    error_oe = np.sqrt(np.mean((oe.simulate(validation).y[:, 0] - clean) ** 2))
    assert error_oe < 0.5 * error_ls


def test_a_condition_with_two_values_drops_its_square() -> None:
    runs = []
    for payload in (0.0, 0.6):
        data, _ = _cubic_system(600, int(10 * payload))
        runs.append(data.with_conditions(payload=payload))
    model = PolynomialNARX(Lags([1], [1], conditions=["payload"]), degree=2).fit(runs)
    square = [list(p) for p in model.powers_].index([0, 0, 2])
    assert not model.active_[square] and model.coef_[square, 0] == 0.0
    assert model.active_.sum() == model.powers_.shape[0] - 1


def test_a_jacobian_too_large_is_refused_with_what_to_do(monkeypatch) -> None:
    data, _ = _cubic_system(500, 6)
    monkeypatch.setattr(polynomial, "MAX_JACOBIAN_BYTES", 1000)
    with pytest.raises(ValueError, match="fit_for='prediction'"):
        PolynomialNARX(Lags.arx(2, 1)).fit(data)


def test_too_few_rows_for_the_monomials_is_refused() -> None:
    data, _ = _cubic_system(30, 7)
    with pytest.raises(ValueError, match="monomials"):
        PolynomialNARX(Lags.arx(4, 4), degree=3).fit(data)


def test_a_model_file_with_other_powers_is_refused(tmp_path) -> None:
    data, _ = _cubic_system(600, 8)
    model = PolynomialNARX(Lags.arx(2, 1), degree=2, max_iter=3).fit(data)
    path = model.save(tmp_path / "poly")
    loaded = neckid.load_model(path)
    np.testing.assert_array_equal(loaded.simulate(data).y, model.simulate(data).y)
    with np.load(path) as stored:
        arrays = {k: stored[k] for k in stored.files}
    key = next(k for k in arrays if k.endswith("powers"))
    arrays[key] = arrays[key][::-1].copy()
    np.savez(path, **arrays)
    with pytest.raises(ValueError, match="powers"):
        neckid.load_model(path)


def test_partial_fit_for_prediction_equals_the_refit() -> None:
    a, _ = _cubic_system(700, 9, output_noise=0.01)
    b, _ = _cubic_system(700, 10, output_noise=0.01)
    lags = Lags.arx(2, 1)
    updated = PolynomialNARX(lags, degree=3, fit_for="prediction").fit(a).partial_fit(b)
    refit = PolynomialNARX(lags, degree=3, fit_for="prediction").fit([a, b])
    # the standardisation stays that of the first fit: compare the maps, not the coefficients
    np.testing.assert_allclose(updated.predict(b).y, refit.predict(b).y, atol=1e-8)


def test_outside_the_training_range_only_the_linear_terms_grow() -> None:
    data, _ = _cubic_system(1500, 11)
    model = PolynomialNARX(Lags.arx(2, 1), degree=3, fit_for="prediction", hold_margin=0.1).fit(
        data
    )
    np.testing.assert_allclose(
        model.high_ - model.low_,
        1.2 * (np.ptp((model.lags_.build_one(data)[0] - model.center_) / model.scale_, axis=0)),
    )
    corner = model.center_ + model.scale_ * model.high_
    for step in ([3.0, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 40.0]):
        beyond = corner + model.scale_ * np.array(step)
        linear = model.coef_[1:4, 0] @ np.array(step)  # per standardised unit
        np.testing.assert_allclose(
            model._predict_rows(beyond[None, :])[0, 0] - model._predict_rows(corner[None, :])[0, 0],
            linear, rtol=1e-9, atol=1e-12,
        )  # fmt: skip
    wild = IOData(np.full(400, 50.0), np.zeros(400), ts=0.01)  # 50x the training input
    # The run stays finite (the monomials are held) and follows its inputs beyond the training
    # range: an extrapolation, not a runaway, since the divergence envelope widens with the
    # inputs' reach (issue 40; neckid.models.envelope). A recursion that grows by itself is
    # still stopped (tests/test_envelope_reach.py).
    result = model.simulate(wild)
    assert np.all(np.isfinite(result.y))
    assert result.extras["outside_domain"] > 0.9


def test_a_second_fit_on_the_same_data_and_parameters_is_taken_from_the_cache(monkeypatch) -> None:
    data, _ = _cubic_system(400, 5, output_noise=0.01)
    first = PolynomialNARX(Lags.arx(2, 2, 1), degree=2).fit(data)

    def refit(*args, **kwargs):
        raise AssertionError("the simulation fit ran again")

    monkeypatch.setattr(PolynomialNARX, "_fit_simulation", refit)
    again = PolynomialNARX(Lags.arx(2, 2, 1), degree=2).fit(data)
    np.testing.assert_array_equal(again.coef_, first.coef_)
    assert again.coef_ is not first.coef_  # a copy: updating one leaves the other
    assert again.fit_report_ == first.fit_report_
    # Other data, or other parameters, fit again.
    for model, other in (
        (PolynomialNARX(Lags.arx(2, 2, 1), degree=2), data[:300]),
        (PolynomialNARX(Lags.arx(2, 2, 1), degree=2, hold_margin=0.2), data),
        (PolynomialNARX(Lags.arx(2, 2, 1), degree=2), data.with_conditions(payload=0.2)),
    ):
        with pytest.raises(AssertionError, match="ran again"):
            model.fit(other)
