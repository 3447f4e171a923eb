"""Tests of the figures of merit and residual tests."""

from __future__ import annotations

import numpy as np
import pytest

from neckid.metrics import (
    fit_percent,
    mae,
    max_abs_error,
    residual_autocorrelation,
    residual_input_correlation,
    rmse,
)


def test_fit_percent_formula_per_output_and_skip(rng: np.random.Generator) -> None:
    y = rng.normal(size=(200, 2))
    y_hat = y + rng.normal(scale=0.1, size=(200, 2))
    y_hat[:5] = 100.0  # initial conditions, skipped
    expected = 100 * (
        1
        - np.linalg.norm(y[5:] - y_hat[5:], axis=0) / np.linalg.norm(y[5:] - y[5:].mean(0), axis=0)
    )
    np.testing.assert_allclose(fit_percent(y, y_hat, skip=5), expected)
    np.testing.assert_allclose(fit_percent(y, y), [100.0, 100.0])
    np.testing.assert_allclose(fit_percent(y, np.tile(y.mean(0), (200, 1))), [0.0, 0.0], atol=1e-12)
    assert fit_percent(y[:, 0], -y[:, 0])[0] < 0


def test_error_measures() -> None:
    y = np.array([0.0, 1.0, 2.0, 3.0])
    y_hat = np.array([0.0, 2.0, 2.0, 1.0])
    assert rmse(y, y_hat)[0] == pytest.approx(np.sqrt(5 / 4))
    assert mae(y, y_hat)[0] == pytest.approx(3 / 4)
    assert max_abs_error(y, y_hat)[0] == 2.0
    assert rmse(y, y_hat, skip=3)[0] == pytest.approx(2.0)
    assert rmse(y[:, None], y_hat).shape == (1,)


def test_white_residuals_pass_and_coloured_fail(rng: np.random.Generator) -> None:
    e = rng.normal(size=4000)
    white = residual_autocorrelation(e, max_lag=20, confidence=0.999)
    assert white.correlation[0] == pytest.approx(1.0)
    assert white.bound == pytest.approx(3.2905 / np.sqrt(4000), rel=1e-4)
    assert white.passed
    coloured = np.convolve(e, [1.0, 0.9], mode="same")
    test = residual_autocorrelation(coloured, max_lag=5)
    assert not test.passed
    assert test.correlation[1] == pytest.approx(0.9 / 1.81, abs=0.05)


def test_residual_input_correlation_finds_missed_dynamics(rng: np.random.Generator) -> None:
    u = rng.normal(size=3000)
    e_ok = rng.normal(size=3000)
    assert residual_input_correlation(e_ok, u, max_lag=10, confidence=0.999).passed
    e_bad = e_ok + 0.5 * np.roll(u, 3)
    test = residual_input_correlation(e_bad, u, max_lag=10)
    assert not test.passed
    assert test.lags[np.argmax(np.abs(test.correlation))] == 3


BAD = [
    (
        lambda: fit_percent([1.0, 1.0, 1.0], [1.0, 2.0, 3.0]),
        ValueError,
        r"fit_percent is undefined for output 0: the measured output is constant \(1.0\) over the 3 samples",
    ),
    (
        lambda: fit_percent([[0.0, 1.0], [1.0, 1.0], [2.0, 1.0]], np.zeros((3, 2))),
        ValueError,
        r"undefined for output 1",
    ),
    (
        lambda: fit_percent([0.0, 1.0, 2.0], [0.0, 1.0]),
        ValueError,
        r"same shape; got \(3, 1\) and \(2, 1\)",
    ),
    (
        lambda: fit_percent([0.0, np.nan, 2.0], [0.0, 1.0, 2.0]),
        ValueError,
        r"y_true has a non-finite value nan at row 1, output 0",
    ),
    (
        lambda: rmse([0.0, 1.0, 2.0], [0.0, 1.0, np.inf], skip=1),
        ValueError,
        r"y_pred has a non-finite value inf at row 2, output 0",
    ),
    (lambda: mae([0.0, 1.0], [0.0, 1.0], skip=2), ValueError, r"skip=2 leaves no sample of 2"),
    (
        lambda: mae([0.0, 1.0], [0.0, 1.0], skip=-1),
        ValueError,
        r"skip must be a whole number >= 0; got -1",
    ),
    (
        lambda: mae([0.0, 1.0], [0.0, 1.0], skip=1.0),
        TypeError,
        r"skip must be a whole number >= 0; got 1.0",
    ),
    (
        lambda: residual_autocorrelation(np.ones((5, 2))),
        ValueError,
        r"residuals must be 1-D .*got shape \(5, 2\)",
    ),
    (
        lambda: residual_autocorrelation([0.0, 1.0, np.nan, 2.0]),
        ValueError,
        r"residuals has a non-finite value nan at row 2",
    ),
    (lambda: residual_autocorrelation(np.zeros(10), max_lag=3), ValueError, r"constant"),
    (
        lambda: residual_autocorrelation(np.arange(10.0), max_lag=10),
        ValueError,
        r"max_lag must be a whole number in \[1, 9\]; got 10",
    ),
    (
        lambda: residual_autocorrelation(np.arange(10.0), max_lag=2, confidence=1.5),
        ValueError,
        r"confidence must be a number in \(0, 1\); got 1.5",
    ),
    (
        lambda: residual_input_correlation(np.arange(10.0), np.arange(9.0)),
        ValueError,
        r"same length; got 10 and 9",
    ),
]


@pytest.mark.parametrize(("call", "error", "message"), BAD)
def test_bad_input_is_refused(call, error, message) -> None:
    with pytest.raises(error, match=message):
        call()
