"""Ljung's residual tests (neckid.selection.residuals): their level, their power, per channel."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.signal import lfilter

from neckid import IOData
from neckid.metrics import residual_autocorrelation, residual_input_correlation
from neckid.models.linear import LinearARX
from neckid.regressors import Lags
from neckid.selection.residuals import ONE_STEP, OUTPUT_ERROR, residual_tests

#: Seeds of the level check: at 1 % per test, 100 runs of a true model reject it at most 6 times
#: with probability 0.9999 (the binomial quantile below); a test at 3 % would pass this bound
#: with probability 0.03 only, and the uncorrected cross-correlation statistic (17 % on a
#: coloured input) never.
LEVEL_SEEDS = range(100)
MAX_REJECTIONS = int(stats.binom.ppf(0.9999, len(LEVEL_SEEDS), 0.01))


def arx_data(n: int, seed: int) -> IOData:
    """y = (q^-1 + 0.5 q^-2) / A u + e / A, A = 1 - 1.5 q^-1 + 0.7 q^-2: an ARX(2, 2, 1)."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=n)
    e = 0.2 * rng.normal(size=n)
    a = [1.0, -1.5, 0.7]
    y = lfilter([0.0, 1.0, 0.5], a, u) + lfilter([1.0], a, e)
    return IOData(u, y, ts=0.02, input_names=["cmd"], output_names=["incl"], output_units=["deg"])


def _arx(order: int, data: IOData) -> LinearARX:
    lags = list(range(1, order + 1))
    return LinearARX(Lags(outputs=lags, inputs=lags)).fit(data)


def test_the_true_order_is_rejected_at_the_stated_rate() -> None:
    """ARX(2, 2) on ARX(2, 2) data: each test rejects at most ~1 % of 100 seeds (99 % confidence)."""
    whiteness = independence = 0
    for seed in LEVEL_SEEDS:
        data = arx_data(2000, seed)
        tests = residual_tests(_arx(2, data), data, max_lag=25, confidence=0.99)
        whiteness += not tests.whiteness[0].passed
        independence += not tests.independence[0][0].passed
    assert MAX_REJECTIONS == 6
    assert whiteness <= MAX_REJECTIONS
    assert independence <= MAX_REJECTIONS


def test_one_order_too_low_fails_on_every_seed() -> None:
    """ARX(1, 1) on the ARX(2, 2) data: both tests reject it, every seed, and so does the verdict."""
    for seed in range(10):
        data = arx_data(2000, seed)
        low = residual_tests(_arx(1, data), data)
        assert not low.whiteness[0].passed
        assert not low.independence[0][0].passed
        assert not low.passed
        assert low.lines()[-1].startswith("verdict: failed")


def test_the_cross_correlation_statistic_accounts_for_a_coloured_input() -> None:
    """White residuals and an AR(1) input (pole 0.9): N r' R_u^-1 r keeps its 1 % level, while
    N sum r^2 (right for a white input only) would reject far more often."""
    corrected = naive = 0
    for seed in LEVEL_SEEDS:
        rng = np.random.default_rng(seed)
        u = lfilter([1.0], [1.0, -0.9], rng.normal(size=2000))
        test = residual_input_correlation(rng.normal(size=2000), u, max_lag=25)
        corrected += not test.passed
        naive += 2000 * np.sum(test.correlation**2) > test.threshold
    assert corrected <= MAX_REJECTIONS
    assert naive >= 10  # about 17 of 100 (measured over 400 seeds: 17.5 %)


def test_a_white_input_reduces_the_statistic_to_the_sum_of_squares() -> None:
    rng = np.random.default_rng(4)
    u, e = rng.normal(size=5000), rng.normal(size=5000)
    test = residual_input_correlation(e, u, max_lag=10)
    assert test.degrees_of_freedom == 21
    assert test.statistic == pytest.approx(5000 * np.sum(test.correlation**2), rel=0.1)
    assert test.threshold == pytest.approx(stats.chi2.ppf(0.99, 21))


def test_the_whiteness_statistic_is_the_portmanteau_sum() -> None:
    e = np.random.default_rng(5).normal(size=1000)
    test = residual_autocorrelation(e, max_lag=15)
    assert test.statistic == pytest.approx(1000 * np.sum(test.correlation[1:] ** 2))
    assert test.degrees_of_freedom == 15
    assert test.outside == int(np.sum(np.abs(test.correlation[1:]) > test.bound))


def test_a_two_by_two_model_is_tested_per_output_and_per_pair() -> None:
    """Output 0 depends on both inputs; a model that leaves out input 1 fails that pair only."""
    rng = np.random.default_rng(6)
    n = 3000
    u = rng.normal(size=(n, 2))
    e = 0.1 * rng.normal(size=(n, 2))  # equation error: ARX(1, 1) per output
    y0 = lfilter([0.0, 1.0], [1.0, -0.5], u[:, 0] + 0.8 * u[:, 1]) + lfilter(
        [1.0], [1.0, -0.5], e[:, 0]
    )
    y1 = lfilter([0.0, 0.6], [1.0, -0.3], u[:, 0]) + lfilter([1.0], [1.0, -0.3], e[:, 1])
    y = np.column_stack([y0, y1])
    data = IOData(u, y, ts=0.01, input_names=["a", "b"], output_names=["p", "q"])
    full = LinearARX(Lags(outputs=[1], inputs=[1])).fit(data)
    tests = residual_tests(full, data, max_lag=20)
    assert tests.residual == ONE_STEP
    assert len(tests.whiteness) == 2 and len(tests.independence) == 2
    assert all(len(row) == 2 for row in tests.independence)
    assert tests.passed, tests.lines()
    only_a = LinearARX(Lags(outputs=[1], inputs={"a": [1], "b": []})).fit(data)
    tests = residual_tests(only_a, data.select(inputs=["a", "b"]), max_lag=20)
    assert not tests.independence[0][1].passed  # p's residual still holds b
    assert tests.independence[0][0].passed
    assert tests.independence[1][0].passed and tests.independence[1][1].passed
    document = tests.to_dict()
    assert [o["output"] for o in document["outputs"]] == ["p", "q"]
    assert set(document["outputs"][0]["independence"]) == {"a", "b"}
    assert document["outputs"][0]["independence"]["b"]["passed"] is False
    assert document["outputs"][0]["whiteness"]["lag_seconds"][1] == pytest.approx(0.01)


def test_an_output_error_model_says_its_residual_is_the_free_run() -> None:
    from neckid.models.pnlss import PolynomialStateSpace

    data = arx_data(800, 1)
    model = PolynomialStateSpace(order=2, degree=2, max_iter=3).fit(data)
    tests = residual_tests(model, data, max_lag=10)
    assert tests.residual == OUTPUT_ERROR


BAD = [
    ({"max_lag": 0}, ValueError, r"max_lag must be"),
    ({"max_lag": 1000}, ValueError, r"max_lag=1000 is too large .* give max_lag <= 99"),
    ({"confidence": 1.0}, ValueError, r"confidence"),
]


@pytest.mark.parametrize(("options", "error", "match"), BAD)
def test_bad_settings_are_refused(options: dict, error: type, match: str) -> None:
    data = arx_data(202, 0)
    with pytest.raises(error, match=match):
        residual_tests(_arx(2, data), data, **options)


def test_a_constant_input_is_not_tested_and_said_so() -> None:
    data = arx_data(1000, 2)
    flat = IOData(
        np.column_stack([data.u[:, 0], np.ones(1000)]),
        data.y,
        ts=0.02,
        input_names=["cmd", "payload"],
        output_names=["incl"],
    )
    model = LinearARX(Lags(outputs=[1, 2], inputs={"cmd": [1, 2], "payload": []})).fit(flat)
    tests = residual_tests(model, flat, max_lag=10)
    assert tests.independence[0][1] is None
    assert "not tested: the input is constant" in "\n".join(tests.lines())


def test_the_figure_has_a_panel_per_test_with_units() -> None:
    import matplotlib.pyplot as plt

    from neckid.report.residual_plots import plot_residual_tests

    data = arx_data(1000, 3)
    fig = plot_residual_tests(residual_tests(_arx(1, data), data, max_lag=15))
    try:
        panels = [ax for ax in fig.axes if ax.get_xlabel() == "lag [samples]"]
        assert len(panels) == 2
        assert {ax.get_ylabel() for ax in panels} == {"correlation [-]"}
        assert "FAILED" in panels[0].get_title() and "FAILED" in panels[1].get_title()
        seconds = [c for ax in panels for c in ax.child_axes if c.get_xlabel() == "lag [s]"]
        assert len(seconds) == 2
    finally:
        plt.close(fig)


@pytest.mark.parametrize("pole", [0.0, 0.9, 0.99])
def test_the_cross_correlation_statistic_is_the_quadratic_form(pole: float) -> None:
    """Levinson's solve gives N r' R_u^-1 r as a dense solve does (to 1e-8 relative)."""
    rng = np.random.default_rng(7)
    u = lfilter([1.0], [1.0, -pole], rng.normal(size=3000))
    e = rng.normal(size=3000) + 0.1 * np.roll(u, 2)
    test = residual_input_correlation(e, u, max_lag=12)
    centred = u - u.mean()
    r_u = [np.dot(centred[k:], centred[: 3000 - k]) / (3000 * centred.var()) for k in range(25)]
    matrix = np.array([[r_u[abs(i - j)] for j in range(25)] for i in range(25)])
    expected = 3000 * test.correlation @ np.linalg.solve(matrix, test.correlation)
    assert test.degrees_of_freedom == 25
    assert test.statistic == pytest.approx(expected, rel=1e-8)


def test_the_eigen_fallback_gives_the_same_statistic(monkeypatch: pytest.MonkeyPatch) -> None:
    """When Levinson's recursion fails (a singular matrix), the eigen-decomposition takes over."""
    import neckid.metrics

    rng = np.random.default_rng(9)
    u = lfilter([1.0], [1.0, -0.8], rng.normal(size=2000))
    e = rng.normal(size=2000)
    direct = residual_input_correlation(e, u, max_lag=10)

    def singular(*args: object, **kwargs: object) -> None:
        raise np.linalg.LinAlgError("singular")

    monkeypatch.setattr(neckid.metrics.linalg, "solve_toeplitz", singular)
    fallback = residual_input_correlation(e, u, max_lag=10)
    assert fallback.degrees_of_freedom == direct.degrees_of_freedom == 21
    assert fallback.statistic == pytest.approx(direct.statistic, rel=1e-8)
