"""Tests of GainScheduledModel: line recovery, simulation, simulator, transfer function, files,
the operating points found with its defaults (dwells, bins), its errors and ``neckid info``."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import functools
from pathlib import Path

import control
import numpy as np
import pytest

from neckid import IOData, Lags
from neckid.models.base import NotFittedError
from neckid.models.io import load_model
from neckid.models.scheduled.model import (
    PAPER_GAIN_COEFFICIENTS,
    PAPER_POLE_COEFFICIENTS,
    GainScheduledModel,
)
from neckid.report.scheduled_plots import plot_gain_schedule

INCLINATIONS = np.array([5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0])


def commands(u: np.ndarray, ts: float = 0.02) -> IOData:
    """A velocity-command record [rad/s] without measured output."""
    return IOData(u, ts=ts, input_names=["velocity_command"], input_units=["rad/s"])


def test_recovers_the_paper_lines_from_exact_points() -> None:
    n = np.polyval(PAPER_GAIN_COEFFICIENTS, INCLINATIONS)
    p = np.polyval(PAPER_POLE_COEFFICIENTS, INCLINATIONS)
    model = GainScheduledModel.from_points(INCLINATIONS, n, p, ts=0.02)
    np.testing.assert_allclose(model.gain_coefficients_, PAPER_GAIN_COEFFICIENTS, rtol=1e-10)
    np.testing.assert_allclose(model.pole_coefficients_, PAPER_POLE_COEFFICIENTS, rtol=1e-10)
    assert model.gain_rmse_ < 1e-12 and model.pole_rmse_ < 1e-12


def test_recovers_lines_from_noisy_points() -> None:
    rng = np.random.default_rng(0)
    i = np.repeat(INCLINATIONS, 20)
    n = -0.05 * i + 1.8 + 0.02 * rng.normal(size=i.size)
    p = 0.012 * i - 0.5 + 0.01 * rng.normal(size=i.size)
    model = GainScheduledModel.from_points(i, n, p, ts=0.02)
    assert abs(model.gain_coefficients_[0] + 0.05) < 1e-3
    assert abs(model.gain_coefficients_[1] - 1.8) < 0.02
    assert abs(model.pole_coefficients_[0] - 0.012) < 1e-3
    assert abs(model.pole_coefficients_[1] + 0.5) < 0.01
    assert 0.01 < model.gain_rmse_ < 0.03


def test_polynomial_degree_option() -> None:
    n = 0.001 * INCLINATIONS**2 - 0.05 * INCLINATIONS + 1.5
    p = 0.01 * INCLINATIONS
    model = GainScheduledModel.from_points(INCLINATIONS, n, p, ts=0.02, degree=2)
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
    result = model.simulate(commands(u), initial=15.0)
    assert result.kind == "simulation" and result.n_initial == 1
    np.testing.assert_allclose(result.y[:, 0], reference_loop(model, u, 15.0), rtol=1e-12)
    np.testing.assert_allclose(result.extras["gain"][1:], model.gain(result.y[:-1, 0]), rtol=1e-12)
    # Scheduling matters: a frozen model at the initial inclination gives another answer.
    frozen = GainScheduledModel.from_coefficients([1.2], [0.45], ts=0.02)
    assert not np.allclose(frozen.simulate(commands(u), initial=15.0).y, result.y, atol=1e-3)


def test_constant_gain_model_matches_transfer_function() -> None:
    """With N and P constant the model is LTI: python-control gives the same response."""
    model = GainScheduledModel.from_coefficients([0.8], [0.6], ts=0.05)
    u = np.random.default_rng(2).normal(size=200)
    sim = model.simulate(commands(u, ts=0.05), initial=0.0).y[:, 0]
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
    expected = model.simulate(commands(u), initial=5.0).y[:, 0]
    sim = model.simulator()
    sim.reset(y0=5.0, u0=u[0])
    out = [sim.step(value)[0] for value in u]
    # step(u(t)) returns y(t), which depends on commands up to t - 1 only (as SoftNeck.step).
    np.testing.assert_allclose(out, expected, rtol=1e-12)


def test_simulate_an_iodata_log() -> None:
    model = GainScheduledModel.from_coefficients([-0.02, 1.5], [0.01, 0.3], ts=0.02)
    u = np.random.default_rng(3).normal(size=100)
    truth = model.simulate(commands(u), initial=12.0).y[:, 0]
    log = IOData(
        np.column_stack([np.full(100, 12.0), u]),
        truth,
        ts=0.02,
        input_names=["reference", "velocity_command"],
        output_names=["inclination"],
    )
    with_reference = GainScheduledModel.from_coefficients([-0.02, 1.5], [0.01, 0.3], ts=0.02)
    with_reference._bind_channels(0.02, 1, "velocity_command", "inclination", "deg")
    result = model.simulate(log.select(inputs=["velocity_command"]))
    np.testing.assert_allclose(result.y[:, 0], truth)
    assert result.output_names == ("inclination",)
    assert result.fit_percent(log)[0] > 99.999
    with pytest.raises(ValueError, match=r"data has inputs \['reference', 'velocity_command'\]"):
        model.simulate(log)


def test_save_load_round_trip(tmp_path) -> None:  # type: ignore[no-untyped-def]
    n = np.polyval(PAPER_GAIN_COEFFICIENTS, INCLINATIONS)
    p = np.polyval(PAPER_POLE_COEFFICIENTS, INCLINATIONS)
    model = GainScheduledModel.from_points(INCLINATIONS, n, p, ts=0.02, input_name="cmd")
    loaded = load_model(model.save(tmp_path / "schedule.npz"))
    assert loaded.input_names_ == ("cmd",)
    assert isinstance(loaded, GainScheduledModel)
    params = {k: v for k, v in model.get_params().items() if k != "lags"}
    assert {k: v for k, v in loaded.get_params().items() if k != "lags"} == params
    assert loaded.lags_.to_dict() == model.lags_.to_dict()
    np.testing.assert_array_equal(loaded.gain_coefficients_, model.gain_coefficients_)
    np.testing.assert_array_equal(loaded.inclinations_, model.inclinations_)
    u = IOData(np.ones(50), ts=0.02, input_names=["cmd"])
    np.testing.assert_array_equal(
        loaded.simulate(u, initial=1.0).y, model.simulate(u, initial=1.0).y
    )


def test_plot_gain_schedule() -> None:
    n = np.polyval(PAPER_GAIN_COEFFICIENTS, INCLINATIONS)
    p = np.polyval(PAPER_POLE_COEFFICIENTS, INCLINATIONS)
    model = GainScheduledModel.from_points(INCLINATIONS, n, p, ts=0.02)
    fig = plot_gain_schedule(model, title="Fig. 6")
    gain_ax, pole_ax = fig.axes  # one panel for N, one for P
    np.testing.assert_allclose(gain_ax.collections[0].get_offsets()[:, 1], n)
    np.testing.assert_allclose(pole_ax.collections[0].get_offsets()[:, 1], p)
    import matplotlib.pyplot as plt

    _, own = plt.subplots()
    assert plot_gain_schedule(model, ax=own) is own.figure
    plt.close("all")


def test_not_fitted_and_bad_input() -> None:
    with pytest.raises(NotFittedError):
        GainScheduledModel(Lags.arx(1, 1)).simulate(commands(np.ones(3)), initial=0.0)
    with pytest.raises(ValueError, match="needs at least 2 distinct inclinations; got 1"):
        GainScheduledModel.from_points([10.0, 10.0], [1.0, 1.1], [0.1, 0.2], ts=0.02)
    with pytest.raises(ValueError, match="same length; got 3, 2 and 3"):
        GainScheduledModel.from_points([1.0, 2.0, 3.0], [1.0, 2.0], [1.0, 2.0, 3.0], ts=0.02)
    with pytest.raises(ValueError, match=r"inclinations.*non-finite value .*nan.* at row 1"):
        GainScheduledModel.from_points([1.0, np.nan], [1.0, 2.0], [1.0, 2.0], ts=0.02)
    with pytest.raises(ValueError, match="degree must be a whole number >= 0; got -1"):
        GainScheduledModel.from_points([1.0, 2.0], [1.0, 2.0], [1.0, 2.0], ts=0.02, degree=-1)
    with pytest.raises(ValueError, match=r"ts must be a positive number of seconds; got -0\.1"):
        GainScheduledModel.from_points([1.0, 2.0], [1.0, 2.0], [1.0, 2.0], ts=-0.1)
    with pytest.raises(ValueError, match="first order in one output"):
        GainScheduledModel(Lags.arx(2, 1)).fit(staircase_log())
    # Without lags on two inputs: both names and how to choose, in CLI and Python words.
    with pytest.raises(
        ValueError,
        match=r"2 inputs \['velocity_command', 'unused'\]: on the command line keep one with"
        r" --inputs \(e\.g\. --inputs velocity_command\) and give --lags 1/D; in Python give"
        r" lags=Lags\(outputs=\[1\], inputs=\{'velocity_command': \[D\]\}\)",
    ):
        GainScheduledModel().fit(staircase_log())
    fitted = GainScheduledModel.from_coefficients()
    with pytest.raises(ValueError, match="initial"):
        fitted.simulate(commands(np.ones(5)))
    with pytest.raises(ValueError, match="to must be 'rate' or 'inclination'"):
        fitted.transfer_function(10.0, to="angle")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="non-finite"):
        fitted.simulator().step(np.inf)


def staircase_log(n_stairs: int = 6, per_stair: int = 600, seed: int = 0) -> IOData:
    """A rig held at rising inclinations, PRBS on the command, true N(i) = 2 - 0.03 i, P(i) = 0.2 + 0.01 i."""
    rng = np.random.default_rng(seed)
    ts = 0.02
    n = n_stairs * per_stair
    u = rng.choice([-1.0, 1.0], size=n)
    incl = np.zeros(n)
    rate = 0.0
    incl[0] = 5.0
    for t in range(1, n):
        level = 5.0 + 5.0 * (t // per_stair)
        gain = 2.0 - 0.03 * incl[t - 1]
        pole = 0.2 + 0.01 * incl[t - 1]
        # the excitation rides on a slow pull towards the stair's level
        rate = pole * rate + gain * u[t - 1] + 2.0 * (level - incl[t - 1])
        incl[t] = incl[t - 1] + ts * rate
    return IOData(
        np.column_stack([u, rng.normal(size=n)]),
        incl,
        ts=ts,
        input_names=["velocity_command", "unused"],
        output_names=["inclination"],
        input_units=["rad/s", "V"],
        output_units=["deg"],
    )


def test_fit_from_a_staircase_log_recovers_the_schedule() -> None:
    log = staircase_log()
    lags = Lags(outputs=[1], inputs={"velocity_command": [1]})
    model = GainScheduledModel(lags, segments=6, skip=100, window=200, form="rate").fit(log)
    assert len(model.points_) == 6 and model.delay_ == 1
    # The stairs sit near 5, 10, ..., 30 deg.
    np.testing.assert_allclose(np.sort(model.inclinations_), 5.0 + 5.0 * np.arange(6), atol=1.5)
    # The pull towards the level biases the pole estimate; the gain line is recovered closely.
    assert abs(model.gain_coefficients_[0] + 0.03) < 0.01
    assert abs(model.gain_coefficients_[1] - 2.0) < 0.15
    edges = GainScheduledModel(
        lags, segments=[0.0, 12.0, 24.0, 36.0, 48.0, 60.0, 72.0], skip=100, window=200, form="rate"
    ).fit(log)
    np.testing.assert_allclose(edges.gains_, model.gains_, rtol=0.05)
    one_per_log = GainScheduledModel(lags, segments=1, skip=100, window=200, form="rate").fit(
        [log[k * 600 : (k + 1) * 600] for k in range(6)]
    )
    np.testing.assert_allclose(one_per_log.gains_, model.gains_, rtol=1e-12)
    # Simulating needs the same inputs; the unused one is carried along.
    assert model.simulate(log).y.shape == (log.n_samples, 1)
    with pytest.raises(ValueError, match=r"operating point 0 .* needs at least window \+ 3"):
        GainScheduledModel(lags, segments=6, window=700, form="rate").fit(log)


@pytest.mark.parametrize("delay", [1, 2, 4])
def test_delay_shifts_the_response_and_matches_the_transfer_function(delay: int) -> None:
    model = GainScheduledModel.from_points(
        [10.0, 20.0], [1.5, 1.5], [0.6, 0.6], ts=0.02, delay=delay, degree=0
    )
    u = np.zeros(60)
    u[5:] = 1.0
    y = model.simulate(commands(u), initial=0.0).y[:, 0]
    # r(t) = P r(t-1) + N u(t-d): the first sample to move is t = 5 + d
    assert np.all(y[: 5 + delay] == 0.0)
    assert y[5 + delay] > 0.0
    tf = model.transfer_function(15.0, to="inclination")
    assert len(tf.den[0][0]) == 3 + (delay - 1)
    _, expected = control.forced_response(tf, T=np.arange(60) * 0.02, U=u)
    np.testing.assert_allclose(y, expected, atol=1e-12)


def test_delay_comes_from_the_operating_points_and_survives_save_load(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from neckid.loops.operating_points import operating_points_from_logs

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
    with pytest.raises((TypeError, ValueError), match="delay must be a whole number"):
        GainScheduledModel.from_points([1.0, 2.0], [1.0, 1.0], [0.5, 0.5], ts=0.02, delay=delay)  # type: ignore[arg-type]


# ------------------------------------------------------------------ divergence, the position form
def unclipped_loop(model: GainScheduledModel, u: np.ndarray, y0: float) -> np.ndarray:
    """The rate form with the lines extrapolated and the pole unbounded (the former behaviour)."""
    ts = model.ts_
    incl, rate = np.full(u.size, np.nan), 0.0
    incl[0] = y0
    with np.errstate(over="ignore", invalid="ignore"):
        for t in range(1, u.size):
            n = np.polyval(model.gain_coefficients_, incl[t - 1])
            p = np.polyval(model.pole_coefficients_, incl[t - 1])
            rate = p * rate + n * u[t - 1]
            incl[t] = incl[t - 1] + ts * rate
    return incl


def test_clipped_schedule_keeps_a_run_finite_where_the_extrapolated_lines_overflow() -> None:
    # Points at 10-30 deg with a gain rising in i and a pole line that crosses 1 at 45 deg: a
    # command that carries the inclination past the points made the former model overflow.
    i = np.array([10.0, 20.0, 30.0])
    model = GainScheduledModel.from_points(i, 0.2 * i, 0.02 * i + 0.1, ts=0.02)
    u = np.ones(1500)
    assert not np.isfinite(unclipped_loop(model, u, 20.0)).all()
    result = model.simulate(commands(u), initial=20.0)
    assert np.isfinite(result.y).all()
    np.testing.assert_array_equal(model.schedule_range_, [10.0, 30.0])
    # Past 30 deg the lines are held at their end values, N = 6 and P = 0.7.
    far = result.y[:-1, 0] > 30.0  # gain[t] is N at y[t - 1]
    assert far.any()
    np.testing.assert_allclose(result.extras["gain"][1:][far], 6.0)
    np.testing.assert_allclose(model.pole([50.0, 200.0]), [0.7, 0.7])
    # With the same schedule written out plainly (clipped), the run is the same.
    clipped = GainScheduledModel.from_coefficients(
        model.gain_coefficients_, model.pole_coefficients_, ts=0.02, schedule_range=[10.0, 30.0]
    )
    np.testing.assert_allclose(clipped.simulate(commands(u), initial=20.0).y, result.y)


def test_pole_is_held_inside_the_unit_circle() -> None:
    model = GainScheduledModel.from_points([10.0, 30.0], [1.0, 1.0], [0.9, 1.05], ts=0.02)
    np.testing.assert_allclose(model.pole([10.0, 29.0, 30.0, 60.0]), [0.9, 0.99, 0.99, 0.99])
    model.set_params(pole_bound=0.95)
    np.testing.assert_allclose(model.pole(30.0), 0.95)
    assert np.all(np.abs(model.transfer_function(30.0).poles()) < 1.0)
    with pytest.raises(ValueError, match=r"pole_bound must be a number in \(0, 1\); got 1\.0"):
        GainScheduledModel(Lags.arx(1, 1), pole_bound=1.0).fit(staircase_log())


def position_staircase(noise: float = 0.0, seed: int = 0) -> IOData:
    """Motor position held in stairs under a ±0.2 rad dither; i(t) = P(i) i(t-1) + N(i) x(t-1).

    True N(i) = 1.5 − 0.01 i [deg/rad], P(i) = 0.8 − 0.002 i; the stairs sit at 5, 10, ..., 30 deg.
    """
    rng = np.random.default_rng(seed)
    targets = 5.0 + 5.0 * np.arange(6)
    levels = targets * (1.0 - (0.8 - 0.002 * targets)) / (1.5 - 0.01 * targets)
    x = np.repeat(levels, 600) + 0.2 * rng.choice([-1.0, 1.0], size=3600)
    incl = np.empty(x.size)
    incl[0] = targets[0]
    for t in range(1, x.size):
        previous = incl[t - 1]
        incl[t] = (0.8 - 0.002 * previous) * previous + (1.5 - 0.01 * previous) * x[t - 1]
    return IOData(
        x,
        incl + noise * rng.normal(size=x.size),
        ts=0.02,
        input_names=["motor_position"],
        output_names=["inclination"],
        input_units=["rad"],
        output_units=["deg"],
    )


def test_position_form_recovers_the_schedule_and_simulates_its_equations() -> None:
    log = position_staircase()
    model = GainScheduledModel(Lags.arx(1, 1), segments=6, skip=100, window=200, form="position")
    model.fit(log)
    np.testing.assert_allclose(model.inclinations_, 5.0 + 5.0 * np.arange(6), atol=0.5)
    # Each point is the local linearisation of P(i) i: close to the true lines, not on them.
    (gain_slope, gain_0), (pole_slope, pole_0) = model.gain_coefficients_, model.pole_coefficients_
    assert abs(gain_slope + 0.01) < 0.003 and abs(gain_0 - 1.5) < 0.02
    assert abs(pole_slope + 0.002) < 0.001 and abs(pole_0 - 0.8) < 0.01
    result = model.simulate(log)
    assert result.fit_percent(log)[0] > 95.0
    # The free run is i(t) = P(s) i(t-1) + N(s) x(t-1), s = i(t-1) clipped to the points' range.
    x, expected = log.u[:, 0], np.empty(log.n_samples)
    expected[0] = log.y[0, 0]
    for t in range(1, log.n_samples):
        s = np.clip(expected[t - 1], *model.schedule_range_)
        p = np.polyval(model.pole_coefficients_, s)
        expected[t] = p * expected[t - 1] + np.polyval(model.gain_coefficients_, s) * x[t - 1]
    np.testing.assert_allclose(result.y[:, 0], expected, rtol=1e-12)
    np.testing.assert_allclose(result.extras["rate"][1:], np.diff(expected) / 0.02, rtol=1e-9)
    # One step ahead uses the measured inclination in the same equation.
    measured = log.y[:, 0]
    one_step = model.pole(measured[:-1]) * measured[:-1] + model.gain(measured[:-1]) * x[:-1]
    np.testing.assert_allclose(model.predict(log).y[1:, 0], one_step, rtol=1e-12)
    # The rate form on the same log is another model.
    rate = GainScheduledModel(
        Lags.arx(1, 1), segments=6, skip=100, window=200, converged_only=False, form="rate"
    )
    assert not np.allclose(rate.fit(log).gains_, model.gains_)


@pytest.mark.parametrize("delay", [1, 3])
def test_position_form_transfer_functions(delay: int) -> None:
    model = GainScheduledModel.from_points(
        [10.0, 20.0], [1.5, 1.5], [0.6, 0.6], ts=0.02, delay=delay, degree=0, form="position"
    )
    u = np.random.default_rng(4).normal(size=80)
    u[:5] = 0.0  # at rest before the record, as the transfer function assumes
    y = model.simulate(commands(u), initial=0.0).y[:, 0]
    t = np.arange(80) * 0.02
    _, expected = control.forced_response(model.transfer_function(15.0, to="inclination"), t, u)
    np.testing.assert_allclose(y, expected, atol=1e-12)
    _, rate = control.forced_response(model.transfer_function(15.0, to="rate"), t, u)
    np.testing.assert_allclose(rate[1:], np.diff(y) / 0.02, atol=1e-9)
    assert control.dcgain(model.transfer_function(15.0, to="inclination")) == pytest.approx(3.75)


def test_position_form_and_schedule_range_survive_save_load(tmp_path) -> None:  # type: ignore[no-untyped-def]
    model = GainScheduledModel(
        Lags.arx(1, 1, 2),
        segments=6,
        skip=100,
        window=200,
        converged_only=False,
        pole_bound=0.9,
        form="position",
    )
    model.fit(position_staircase(noise=0.02))
    loaded = load_model(model.save(tmp_path / "position.npz"))
    assert (loaded.form, loaded.pole_bound, loaded.delay_) == ("position", 0.9, 2)
    np.testing.assert_array_equal(loaded.schedule_range_, model.schedule_range_)
    log = position_staircase(seed=1)
    np.testing.assert_array_equal(loaded.simulate(log).y, model.simulate(log).y)


def test_files_without_form_or_schedule_range_load_as_the_rate_form() -> None:
    model = GainScheduledModel.from_points(
        INCLINATIONS, INCLINATIONS / 10, INCLINATIONS / 100, ts=0.02
    )
    arrays, meta = model._get_state()
    old_arrays = {k: v for k, v in arrays.items() if k != "schedule_range"}
    old_params = {k: v for k, v in meta["params"].items() if k not in ("form", "pole_bound")}
    old = GainScheduledModel._from_state(old_arrays, {**meta, "params": old_params})
    old._check_state()
    assert old.form == "rate" and old.pole_bound == 0.99
    np.testing.assert_array_equal(old.schedule_range_, [5.0, 35.0])
    bad = GainScheduledModel._from_state({**arrays, "schedule_range": np.array([30.0, 10.0])}, meta)
    with pytest.raises(
        ValueError, match=r"schedule_range must be \[low, high\].*got \[30\.0, 10\.0\]"
    ):
        bad._check_state()
    wrong_form = GainScheduledModel._from_state(
        arrays, {**meta, "params": {**meta["params"], "form": "angle"}}
    )
    with pytest.raises(ValueError, match="form must be one of 'rate', 'position'; got 'angle'"):
        wrong_form._check_state()


def test_a_segment_cut_short_by_the_end_of_the_record_is_left_out() -> None:
    # Boundaries written for a longer staircase: the last segment holds 5 samples of its 600;
    # it used to fail the fit ("needs at least window + 3").
    log = position_staircase()
    edges = [0.0, 12.0, 24.0, 36.0, 48.0, 60.0, 71.9, 83.9]
    model = GainScheduledModel(
        Lags.arx(1, 1), segments=edges, skip=100, window=200, form="position"
    )
    assert len(model.fit(log).points_) == 6


def test_plot_shows_the_position_form_units() -> None:
    model = GainScheduledModel.from_points(
        INCLINATIONS, INCLINATIONS / 10, INCLINATIONS / 100, ts=0.02, form="position"
    )
    fig = plot_gain_schedule(model, inclination_range=(0.0, 50.0))
    assert fig.axes[0].get_ylabel() == "gain N [deg/rad]"
    line = fig.axes[0].get_lines()[-1]
    # Held at the end values outside the points' range.
    assert line.get_ydata()[0] == pytest.approx(0.5) and line.get_ydata()[-1] == pytest.approx(3.5)
    import matplotlib.pyplot as plt

    plt.close("all")


# ------------------------------------------------------------------ the real soft-neck logs
SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
SOFTNECK_STAIRS = SHARED_DATA / "softneck" / "stair"


def _stair_log(name: str) -> IOData:
    from neckid.datasets import load_softneck_log
    from neckid.experiments.benchmark.datasets import softneck_protocol

    return softneck_protocol(load_softneck_log(SOFTNECK_STAIRS / f"{name}response.csv"))


@pytest.mark.skipif(
    not SOFTNECK_STAIRS.is_dir(),
    reason=f"the real soft-neck logs are not at {SOFTNECK_STAIRS} (the shared data folder)",
)
def test_cross_run_free_run_on_the_real_soft_neck_stays_finite_and_fits() -> None:
    """Train on payloads 000 and 600 g, free-run 200 and 400 g, all three controllers.

    The settings (position form on the motor displacement, d = 4, 8 segments per log) are the
    best mean leave-one-log-out fit on the six training logs; the test logs were not used.
    """
    import warnings

    controllers = ("ada", "fra", "int")
    train = [_stair_log(f"{c}{p}") for c in controllers for p in ("000", "600")]
    test = [_stair_log(f"{c}{p}") for c in controllers for p in ("200", "400")]
    settings = {"segments": 8, "skip": 40, "window": 100, "converged_only": False}
    model = GainScheduledModel(
        Lags(outputs=[1], inputs={"motor_displacement": [4]}), form="position", **settings
    ).fit(train)
    # The seed paper's rate form on the motor velocity used to overflow on every one of them.
    paper = GainScheduledModel(
        Lags(outputs=[1], inputs={"motor_velocity": [1]}), form="rate", **settings
    ).fit(train)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the logs leave the training ranges a little
        fits = [model.simulate(log).fit_percent(log)[0] for log in test]
        for log in test:
            assert np.isfinite(paper.simulate(log).y).all()
    assert np.all(np.isfinite(fits))
    assert np.mean(fits) >= 50.0, fits


# ------------------------------------------------------------------ operating points found by default
@functools.cache
def closed_loop_staircase(targets: tuple[float, ...] = (10.0, 20.0, 30.0, 20.0)) -> IOData:
    """A known plant (the rate-form lines TRUE_*) held at each target for 12 s, P control + PRBS.

    Returns the velocity command [rad/s] and the inclination [deg] only.
    """
    from neckid.plant import closed_loop
    from neckid.signals import random_binary

    class Proportional:
        def reset(self) -> None:
            pass

        def step(self, reference: float, measurement: np.ndarray) -> np.ndarray:
            return np.array([1.0 * (reference - float(np.ravel(measurement)[0]))])

    plant = GainScheduledModel.from_coefficients(TRUE_GAIN, TRUE_POLE, ts=0.02).simulator()
    reference = np.repeat(np.asarray(targets), 600)
    excitation = random_binary(reference.size, 1.0, 5, seed=np.random.default_rng(0))
    record = closed_loop(plant, Proportional(), reference, 0.02, excitation=excitation[:, None])
    return record.select(inputs=["velocity_command"], outputs=[record.output_names[0]])


TRUE_GAIN, TRUE_POLE = (-0.02, 1.5), (0.01, 0.3)


def test_defaults_find_the_stairs_and_recover_the_lines() -> None:
    log = closed_loop_staircase()
    model = GainScheduledModel().fit(log)  # no lags, no segments: one input, its dwells
    assert model.lags is None and model.lags_.to_lags() == Lags.arx(1, 1, 1).resolve(log).to_lags()
    assert model.segmentation_ == "dwell" and model.n_samples_ == log.n_samples
    table = model.operating_points_
    assert list(table["kind"]) == ["dwell"] * 4 and table["converged"].all()
    np.testing.assert_allclose(table["inclination"], [10.0, 20.0, 30.0, 20.0], atol=0.5)
    # each dwell lies inside its 12 s stair, its start after the step
    starts, stops = table["start_s"].to_numpy(), table["stop_s"].to_numpy()
    assert np.all(starts > 12.0 * np.arange(4)) and np.all(stops < 12.0 * np.arange(1, 5))
    np.testing.assert_allclose(model.gains_, np.polyval(TRUE_GAIN, model.inclinations_), atol=0.05)
    np.testing.assert_allclose(model.poles_, np.polyval(TRUE_POLE, model.inclinations_), atol=0.03)
    assert abs(model.gain_coefficients_[0] - TRUE_GAIN[0]) < 0.005


def test_defaults_give_a_model_on_the_simulated_neck_in_both_forms() -> None:
    from neckid.plant import InclinationController, SoftNeck, closed_loop
    from neckid.signals import random_binary

    reference = np.repeat([10.0, 15.0, 20.0, 25.0, 20.0], 500)
    excitation = random_binary(reference.size, 1.0, 5, seed=np.random.default_rng(0))
    record = closed_loop(
        SoftNeck(configuration="planar", ts=0.02, seed=0),
        InclinationController(ts=0.02),
        reference,
        0.02,
        excitation=excitation[:, None],
    )
    for form, command in (("rate", "velocity_command"), ("position", "motor_position")):
        log = record.select(inputs=[command], outputs=["inclination"])
        model = GainScheduledModel(form=form).fit(log)
        assert model.segmentation_ == "dwell" and len(model.operating_points_) >= 5, form
        # every stair holds a point (the first one may hold two: its start is the rise)
        levels = np.unique(np.round(model.operating_points_["inclination"] / 5.0) * 5.0)
        np.testing.assert_array_equal(levels, [10.0, 15.0, 20.0, 25.0])
        assert np.isfinite(model.simulate(log).y).all()
    assert model.simulate(log).fit_percent(log)[0] > 90.0  # the position form, free run


def stairs_with_ramps(seed: int = 0) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """Stairs of 10 s at 50 Hz (10, 15, 20, 15 deg) with a ±1 deg white dither, 1 s ramps."""
    rng = np.random.default_rng(seed)
    pieces, stairs, start = [], [], 0
    for k, level in enumerate((10.0, 15.0, 20.0, 15.0)):
        if k:
            pieces.append(np.linspace(pieces[-1][-1], level, 50))
            start += 50
        pieces.append(np.full(500, level))
        stairs.append((start, start + 500))
        start += 500
    clean = np.concatenate(pieces)
    return clean + rng.uniform(-1.0, 1.0, clean.size), stairs


def test_find_dwells_finds_the_stairs_and_leaves_the_ramps_out() -> None:
    from neckid.models.scheduled.segments import find_dwells, smooth_inclination

    inclination, stairs = stairs_with_ramps()
    dwells = find_dwells(inclination)
    assert len(dwells) == 4
    for (start, stop), (first, last) in zip(dwells, stairs, strict=True):
        # inside its stair but for the smoothing's reach (a memory, 50 samples), most of it
        assert first - 50 <= start < stop <= last + 50 and stop - start >= 300
    levels = [float(np.mean(inclination[a:b])) for a, b in dwells]
    np.testing.assert_allclose(levels, [10.0, 15.0, 20.0, 15.0], atol=0.3)
    # the smoothing is the estimator's weighting run both ways: on a sine of ω rad/sample its
    # gain is |H|² with H = (1 − λ) / (1 − λ e^{−jω}), and it does not shift the phase
    n = np.arange(4000)
    smooth = smooth_inclination(np.sin(0.05 * n), 0.98)[1000:3000]
    gain = abs(0.02 / (1.0 - 0.98 * np.exp(-0.05j))) ** 2
    np.testing.assert_allclose(smooth, gain * np.sin(0.05 * n[1000:3000]), atol=1e-6)
    # a dwell must hold min_samples, by default four memories: 200 samples at λ = 0.98, 800 at
    # λ = 0.995 (longer than these 500-sample stairs)
    assert find_dwells(inclination, min_samples=501) == []
    assert find_dwells(inclination, forgetting_factor=0.995) == []
    # a band narrower than the dithered level's wander finds fewer or none
    assert len(find_dwells(inclination, band=0.05)) < 4
    with pytest.raises(ValueError, match="band must be"):
        find_dwells(inclination, band=0.0)


def sweep_log(n: int = 3000, seed: int = 0) -> IOData:
    """Position form, i(t) = P(i) i(t-1) + N(i) x(t-1), the command two ramps of 0 to 6 rad.

    True N(i) = 1.5 − 0.01 i [deg/rad], P(i) = 0.8 − 0.002 i; the inclination sweeps 0 to 27 deg
    twice, about 1 deg/s, never dwelling.
    """
    rng = np.random.default_rng(seed)
    x = np.tile(np.linspace(0.0, 6.0, n // 2), 2) + 0.2 * rng.choice([-1.0, 1.0], n)
    incl = np.empty(n)
    incl[0] = 0.0
    for t in range(1, n):
        p = incl[t - 1]
        incl[t] = (0.8 - 0.002 * p) * p + (1.5 - 0.01 * p) * x[t - 1]
    return IOData(x, incl, ts=0.02, input_names=["motor_position"], output_names=["inclination"])


def test_a_record_without_dwells_falls_back_to_inclination_bins() -> None:
    from neckid.models.scheduled.segments import find_dwells

    log = sweep_log()
    assert find_dwells(log.y[:, 0]) == []
    model = GainScheduledModel(form="position").fit(log)
    table = model.operating_points_
    assert model.segmentation_ == "bins" and set(table["kind"]) == {"bin"}
    # as many bins as the 2 deg band fits into the range, each holding four memories or more
    spread = np.ptp(log.y[:, 0])
    assert int(np.ceil(spread / 2.0)) - 2 <= len(table) <= int(np.ceil(spread / 2.0))
    assert (table["n_samples"] >= 195).all()
    assert np.all(np.diff(table["inclination"]) > 0)  # from low to high
    # a bin gathers both sweeps: its stretches span more than one of them (30 s)
    middle = table.iloc[len(table) // 2]
    assert middle["stop_s"] - middle["start_s"] > 30.0
    # the local models are near the true lines' linearisation
    assert abs(model.pole_coefficients_[1] - 0.8) < 0.05
    # asked for by name on a staircase too
    steps = closed_loop_staircase()
    assert GainScheduledModel(segments="bins").fit(steps).segmentation_ == "bins"
    # too short for two bins of four memories (200 samples) each: says so, and what to do
    with pytest.raises(
        ValueError,
        match=r"fewer than 2 dwells and too few samples for 2 inclination bins of four memories"
        r" of the estimator \(200 samples\) each: 300 samples; .*--set segments=N",
    ):
        GainScheduledModel(form="position").fit(log[:300])


def test_too_few_converged_points_take_every_point_and_say_how_many_converged() -> None:
    rng = np.random.default_rng(1)
    # the inclination dwells at three levels but moves at random: no estimate settles
    levels = np.repeat([10.0, 20.0, 30.0], 400)
    log = IOData(
        rng.normal(size=levels.size),
        levels + rng.normal(scale=3.0, size=levels.size),
        ts=0.02,
        input_names=["velocity_command"],
        output_names=["inclination"],
    )
    with pytest.warns(UserWarning, match=r"0 of 3 operating points converged.* all 3 points"):
        model = GainScheduledModel(segments=3).fit(log)
    table = model.operating_points_
    assert not table["converged"].any() and table["used"].all() and model.inclinations_.size == 3
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        GainScheduledModel(segments=3, converged_only=False).fit(log)


def test_lags_errors_say_the_command_line_and_the_python_way() -> None:
    log = closed_loop_staircase()
    with pytest.raises(ValueError) as error:
        GainScheduledModel(Lags.arx(2, 1)).fit(log)
    message = str(error.value)
    assert "first order in one output and one command" in message
    assert "--lags 1/D" in message and "--inputs" in message and "Lags.arx(1, 1, D)" in message
    assert "got Lags(" in message and "['velocity_command']" in message
    with pytest.raises(ValueError, match=r"needs a command among the inputs.* --inputs"):
        GainScheduledModel().fit(IOData(np.zeros((log.n_samples, 0)), log.y, ts=0.02))
    with pytest.raises(ValueError, match=r"segments must be None or one of 'dwell', 'bins'"):
        GainScheduledModel(segments="stairs").fit(log)  # type: ignore[arg-type]


def test_the_schedule_points_and_counts_survive_the_file(tmp_path: Path) -> None:
    log = closed_loop_staircase()
    model = GainScheduledModel().fit(log)
    loaded = load_model(model.save(tmp_path / "defaults.npz"))
    assert (loaded.segmentation_, loaded.n_samples_, loaded.command_unit_) == (
        "dwell",
        log.n_samples,
        "rad/s",
    )
    assert loaded.segments == "dwell" and loaded.lags_.to_lags() == model.lags_.to_lags()
    import pandas as pd

    pd.testing.assert_frame_equal(loaded.operating_points_, model.operating_points_)
    assert loaded.describe_schedule() == model.describe_schedule()


def test_describe_schedule_has_the_lines_units_range_and_points() -> None:
    model = GainScheduledModel(form="position").fit(position_staircase())
    schedule = model.describe_schedule()
    assert schedule["form"] == "position" and schedule["command"] == "motor_position"
    assert schedule["gain"]["unit"] == "deg/rad" and schedule["pole"]["unit"] == "-"
    slope, intercept = model.gain_coefficients_
    assert schedule["gain"]["text"] == f"N(i) = {slope:.4g} i + {intercept:.4g}".replace(
        "+ -", "- "
    )
    assert schedule["schedule_range_deg"] == model.schedule_range_.tolist()
    assert [p["inclination_deg"] for p in schedule["points"]] == model.inclinations_.tolist()
    assert all(p["converged"] is True and p["kind"] == "dwell" for p in schedule["points"])
    rate = GainScheduledModel().fit(closed_loop_staircase())
    assert rate.describe_schedule()["gain"]["unit"] == "(deg/s)/(rad/s)"


def test_info_shows_the_schedule_and_the_training_samples(tmp_path: Path) -> None:
    import json
    import re

    from typer.testing import CliRunner

    from neckid.cli import app

    model = GainScheduledModel(form="position").fit(position_staircase())
    path = model.save(tmp_path / "position.npz")
    runner = CliRunner()
    result = runner.invoke(app, ["info", str(path)], env={"COLUMNS": "120"})
    assert result.exit_code == 0, result.output
    text = re.sub(r"\s+", " ", result.output)
    assert f"training_samples │ {position_staircase().n_samples}" in text
    assert "schedule (position form)" in text and "points found by │ dwell" in text
    assert re.search(r"N\(i\) = -0\.0\d+ i \+ 1\.\d+ \[deg/rad\], i in deg", text), text
    assert re.search(r"P\(i\) = -0\.00\d+ i \+ 0\.\d+ \[-\], held in ±0\.99", text), text
    assert "operating points: 6, 6 converged, 6 in the lines" in text
    low, high = model.schedule_range_
    assert f"{low:.4g} .. {high:.4g} deg" in text
    result = runner.invoke(app, ["info", str(path), "--json"])
    described = json.loads(result.output)
    assert described["training_samples"] == position_staircase().n_samples
    assert described["schedule"]["gain"]["coefficients"] == model.gain_coefficients_.tolist()
    assert len(described["schedule"]["points"]) == 6
    # a file written before the table: the points of the lines, convergence unknown
    arrays, meta = model._get_state()
    old = {k: v for k, v in arrays.items() if not k.startswith("points_")}
    legacy = GainScheduledModel._from_state(old, {**meta, "point_kinds": None})
    assert legacy.operating_points_["converged"].isna().all()
    assert legacy.describe_schedule()["points"][0]["converged"] is None


SOFTNECK_ID = SHARED_DATA / "softneck" / "id" / "id000response.csv"


@pytest.mark.skipif(
    not (SOFTNECK_STAIRS.is_dir() and SOFTNECK_ID.is_file()),
    reason=f"the real soft-neck logs are not at {SHARED_DATA / 'softneck'} (the shared data folder)",
)
def test_defaults_give_a_model_on_every_real_stair_log_and_the_id_log() -> None:
    """What ``neckid identify LOG --method scheduled[-position]`` fits with no settings.

    The position form on the motor displacement, the rate form on the velocity command (the
    3-column ``000response.csv`` has none); the measured table is in the scheduled model's docs.
    """
    import warnings

    from neckid.data.preprocess import Relative
    from neckid.datasets import load_softneck_log

    logs = sorted(SOFTNECK_STAIRS.glob("*response.csv"))
    assert len(logs) == 13
    fits = {}
    for path in [*logs, SOFTNECK_ID]:
        log = load_softneck_log(path)
        output = "inclination" if "inclination" in log.output_names else "inclination_filtered"
        position = Relative("motor_position").apply(
            log.select(inputs=["motor_position"], outputs=[output])
        )
        model = GainScheduledModel(form="position").fit(position)
        assert model.segmentation_ == "dwell" and model.inclinations_.size >= 2, path.name
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # ExtrapolationWarning: the first seconds lie below
            fits[path.name] = model.simulate(position).fit_percent(position)[0]
        if "velocity_command" in log.input_names:
            rate = log.select(inputs=["velocity_command"], outputs=[output])
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # most rate-form points do not converge
                model = GainScheduledModel().fit(rate)
            assert model.segmentation_ == "dwell" and model.inclinations_.size >= 2, path.name
    assert min(fits.values()) > 50.0, fits
    assert np.median(list(fits.values())) > 80.0, fits
