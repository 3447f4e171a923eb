"""Tests of GainScheduledModel: line recovery, simulation, simulator, transfer function, files."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import control
import numpy as np
import pytest

from neckid import IOData
from neckid.models.base import NotFittedError
from neckid.models.io import load_model
from neckid.models.scheduled import (
    PAPER_GAIN_COEFFICIENTS,
    PAPER_POLE_COEFFICIENTS,
    GainScheduledModel,
)
from neckid.report.scheduled_plots import plot_gain_schedule

INCLINATIONS = np.array([5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0])


def test_recovers_the_paper_lines_from_exact_points() -> None:
    n = np.polyval(PAPER_GAIN_COEFFICIENTS, INCLINATIONS)
    p = np.polyval(PAPER_POLE_COEFFICIENTS, INCLINATIONS)
    model = GainScheduledModel(ts=0.02).fit(INCLINATIONS, n, p)
    np.testing.assert_allclose(model.gain_coefficients_, PAPER_GAIN_COEFFICIENTS, rtol=1e-10)
    np.testing.assert_allclose(model.pole_coefficients_, PAPER_POLE_COEFFICIENTS, rtol=1e-10)
    assert model.gain_rmse_ < 1e-12 and model.pole_rmse_ < 1e-12


def test_recovers_lines_from_noisy_points() -> None:
    rng = np.random.default_rng(0)
    i = np.repeat(INCLINATIONS, 20)
    n = -0.05 * i + 1.8 + 0.02 * rng.normal(size=i.size)
    p = 0.012 * i - 0.5 + 0.01 * rng.normal(size=i.size)
    model = GainScheduledModel(ts=0.02).fit(i, n, p)
    assert abs(model.gain_coefficients_[0] + 0.05) < 1e-3
    assert abs(model.gain_coefficients_[1] - 1.8) < 0.02
    assert abs(model.pole_coefficients_[0] - 0.012) < 1e-3
    assert abs(model.pole_coefficients_[1] + 0.5) < 0.01
    assert 0.01 < model.gain_rmse_ < 0.03


def test_polynomial_degree_option() -> None:
    n = 0.001 * INCLINATIONS**2 - 0.05 * INCLINATIONS + 1.5
    p = 0.01 * INCLINATIONS
    model = GainScheduledModel(degree=2, ts=0.02).fit(INCLINATIONS, n, p)
    np.testing.assert_allclose(model.gain_coefficients_, [0.001, -0.05, 1.5], atol=1e-10)
    np.testing.assert_allclose(model.pole_coefficients_, [0.0, 0.01, 0.0], atol=1e-10)
    np.testing.assert_allclose(model.gain(12.0), 0.001 * 144 - 0.6 + 1.5)


def reference_loop(model: GainScheduledModel, u: np.ndarray, y0: float) -> np.ndarray:
    """The model's equations written out plainly."""
    ts = model.ts_
    incl, rate = np.empty(u.size), 0.0
    incl[0] = y0
    for t in range(1, u.size):
        n = np.polyval(model.gain_coefficients_, incl[t - 1])
        p = np.polyval(model.pole_coefficients_, incl[t - 1])
        rate = p * rate + n * u[t - 1]
        incl[t] = incl[t - 1] + ts * rate
    return incl


def test_simulate_follows_its_own_inclination() -> None:
    model = GainScheduledModel.from_coefficients([-0.02, 1.5], [0.01, 0.3], ts=0.02)
    u = np.random.default_rng(1).normal(size=400)
    result = model.simulate(u, y0=15.0)
    assert result.kind == "simulation" and result.n_initial == 1
    np.testing.assert_allclose(result.y[:, 0], reference_loop(model, u, 15.0), rtol=1e-12)
    np.testing.assert_allclose(result.extras["gain"][1:], model.gain(result.y[:-1, 0]), rtol=1e-12)
    # Scheduling matters: a frozen model at the initial inclination gives another answer.
    frozen = GainScheduledModel.from_coefficients([1.2], [0.45], ts=0.02)
    assert not np.allclose(frozen.simulate(u, y0=15.0).y, result.y, atol=1e-3)


def test_constant_gain_model_matches_transfer_function() -> None:
    """With N and P constant the model is LTI: python-control gives the same response."""
    model = GainScheduledModel.from_coefficients([0.8], [0.6], ts=0.05)
    u = np.random.default_rng(2).normal(size=200)
    sim = model.simulate(u, y0=0.0).y[:, 0]
    tf = model.transfer_function(10.0, to="inclination")
    assert tf.dt == 0.05
    response = control.forced_response(tf, U=u).outputs
    np.testing.assert_allclose(sim, response, atol=1e-10)
    rate_tf = model.transfer_function(10.0)
    np.testing.assert_allclose(rate_tf.poles(), [0.6])
    np.testing.assert_allclose(control.dcgain(rate_tf), 0.8 / (1 - 0.6))


def test_simulator_matches_simulate_and_closed_loop_conventions() -> None:
    model = GainScheduledModel.from_coefficients([-0.02, 1.5], [0.01, 0.3], ts=0.02)
    u = np.sin(np.linspace(0, 10, 300))
    expected = model.simulate(u, y0=5.0).y[:, 0]
    sim = model.simulator()
    sim.reset(y0=5.0)
    out = [sim.step(value)[0] for value in u]
    # step(u(t)) returns y(t), which depends on commands up to t - 1 only (as SoftNeck.step).
    np.testing.assert_allclose(out, expected, rtol=1e-12)


def test_simulate_an_iodata_log() -> None:
    model = GainScheduledModel.from_coefficients([-0.02, 1.5], [0.01, 0.3], ts=0.02)
    u = np.random.default_rng(3).normal(size=100)
    truth = model.simulate(u, y0=12.0).y[:, 0]
    log = IOData(
        np.column_stack([np.full(100, 12.0), u]),
        truth,
        ts=0.02,
        input_names=["reference", "velocity_command"],
        output_names=["inclination"],
    )
    result = model.simulate(log)
    np.testing.assert_allclose(result.y[:, 0], truth)
    assert result.output_names == ("inclination",)
    assert result.fit_percent(log)[0] > 99.999
    with pytest.raises(KeyError, match="no input named 'cmd'"):
        GainScheduledModel.from_coefficients(input="cmd").simulate(log)


def test_save_load_round_trip(tmp_path) -> None:  # type: ignore[no-untyped-def]
    n = np.polyval(PAPER_GAIN_COEFFICIENTS, INCLINATIONS)
    p = np.polyval(PAPER_POLE_COEFFICIENTS, INCLINATIONS)
    model = GainScheduledModel(ts=0.02, input="cmd").fit(INCLINATIONS, n, p)
    loaded = load_model(model.save(tmp_path / "schedule.npz"))
    assert isinstance(loaded, GainScheduledModel)
    assert loaded.get_params() == model.get_params()
    np.testing.assert_array_equal(loaded.gain_coefficients_, model.gain_coefficients_)
    np.testing.assert_array_equal(loaded.inclinations_, model.inclinations_)
    u = np.ones(50)
    np.testing.assert_array_equal(loaded.simulate(u, y0=1.0).y, model.simulate(u, y0=1.0).y)


def test_plot_gain_schedule() -> None:
    n = np.polyval(PAPER_GAIN_COEFFICIENTS, INCLINATIONS)
    p = np.polyval(PAPER_POLE_COEFFICIENTS, INCLINATIONS)
    model = GainScheduledModel(ts=0.02).fit(INCLINATIONS, n, p)
    fig = plot_gain_schedule(model, title="Fig. 6")
    ax = fig.axes[0]
    assert len(ax.collections) == 2  # the points of N and of P
    np.testing.assert_allclose(ax.collections[0].get_offsets()[:, 1], n)
    import matplotlib.pyplot as plt

    _, own = plt.subplots()
    assert plot_gain_schedule(model, ax=own) is own.figure
    plt.close("all")


def test_not_fitted_and_bad_input() -> None:
    with pytest.raises(NotFittedError):
        GainScheduledModel().simulate(np.ones(3), y0=0.0)
    model = GainScheduledModel(ts=0.02)
    with pytest.raises(ValueError, match="needs at least 2 distinct inclinations; got 1"):
        model.fit([10.0, 10.0], [1.0, 1.1], [0.1, 0.2])
    with pytest.raises(ValueError, match="same length; got 3, 2 and 3"):
        model.fit([1.0, 2.0, 3.0], [1.0, 2.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"inclinations.*non-finite value .*nan.* at row 1"):
        model.fit([1.0, np.nan], [1.0, 2.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="degree must be a whole number >= 0; got -1"):
        GainScheduledModel(degree=-1, ts=0.02).fit([1.0, 2.0], [1.0, 2.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="ts is required"):
        GainScheduledModel().fit([1.0, 2.0], [1.0, 2.0], [1.0, 2.0])
    with pytest.raises(ValueError, match=r"ts must be a positive number of seconds; got -0\.1"):
        GainScheduledModel(ts=-0.1).fit([1.0, 2.0], [1.0, 2.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="gains and poles are required"):
        model.fit([1.0, 2.0])
    fitted = GainScheduledModel.from_coefficients()
    with pytest.raises(ValueError, match="y0"):
        fitted.simulate(np.ones(5))
    with pytest.raises(ValueError, match="to must be 'rate' or 'inclination'"):
        fitted.transfer_function(10.0, to="angle")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="non-finite"):
        fitted.simulator().step(np.inf)


@pytest.mark.parametrize("delay", [1, 2, 4])
def test_delay_shifts_the_response_and_matches_the_transfer_function(delay: int) -> None:
    model = GainScheduledModel(degree=0, ts=0.02, delay=delay).fit(
        [10.0, 20.0], [1.5, 1.5], [0.6, 0.6]
    )
    u = np.zeros(60)
    u[5:] = 1.0
    y = model.simulate(u, y0=0.0).y[:, 0]
    # r(t) = P r(t-1) + N u(t-d): the first sample to move is t = 5 + d
    assert np.all(y[: 5 + delay] == 0.0)
    assert y[5 + delay] > 0.0
    tf = model.transfer_function(15.0, to="inclination")
    assert len(tf.den[0][0]) == 3 + (delay - 1)
    _, expected = control.forced_response(tf, T=np.arange(60) * 0.02, U=u)
    np.testing.assert_allclose(y, expected, atol=1e-12)


def test_delay_comes_from_the_operating_points_and_survives_save_load(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from neckid.experiments.operating_points import operating_points_from_logs

    rng = np.random.default_rng(0)
    logs = []
    for target in (10.0, 20.0, 30.0):
        u = rng.choice([-1.0, 1.0], size=800)
        rate = np.zeros(800)
        for t in range(3, 800):
            rate[t] = 0.7 * rate[t - 1] + (2.0 - 0.02 * target) * u[t - 3]
        incl = target + np.cumsum(rate) * 0.02
        logs.append(
            IOData(u, incl, ts=0.02, input_names=["velocity_command"], output_names=["inclination"])
        )
    points = operating_points_from_logs(
        logs, input="velocity_command", output="inclination", delay=3
    )
    model = points.fit_schedule(converged_only=False)
    assert model.delay_ == 3
    np.testing.assert_allclose(model.gains_, [1.8, 1.6, 1.4], atol=0.02)
    again = load_model(model.save(tmp_path / "sched.npz"))
    assert again.delay_ == 3


@pytest.mark.parametrize("delay", [0, -1, 1.5, True])
def test_bad_delay_is_refused(delay: object) -> None:
    with pytest.raises(ValueError, match="delay must be a whole number"):
        GainScheduledModel(ts=0.02, delay=delay).fit([1.0, 2.0], [1.0, 1.0], [0.5, 0.5])  # type: ignore[arg-type]
