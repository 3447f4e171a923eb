"""Model in the loop: a model (or the true plant) behind the controller of a measured record."""

from __future__ import annotations

import numpy as np
import pytest

import neckid
from neckid import GainScheduledModel, IOData, Lags, LinearARX
from neckid.loops.model_in_loop import (
    LoopComparison,
    ModelPlant,
    VelocityDrive,
    model_in_the_loop,
)
from neckid.plant import InclinationController, SoftNeck, closed_loop
from neckid.signals import multisine, sine, step

TS = 0.02
SEED = 7


@pytest.fixture(scope="module", autouse=True)
def _one_numba_thread():
    """Set Membership is stepped one regressor at a time: keep numba's thread wake-ups out."""
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(before)


def _test_record(kind: str, duration: float = 12.0) -> IOData:
    """The demo's closed-loop tests 1 and 3 on the simulated neck."""
    t = np.arange(round(duration / TS)) * TS
    reference = (
        sine(t, amplitude=5.0, omega=2.0, offset=15.0)
        if kind == "sine"
        else step(t, amplitude=20.0, step_time=1.0)
    )
    return closed_loop(SoftNeck(seed=SEED), InclinationController(ts=TS), reference, TS)


@pytest.fixture(scope="module")
def sine_record() -> IOData:
    return _test_record("sine")


@pytest.fixture(scope="module")
def position_view() -> IOData:
    """Open-loop identification record as in the demo: motor position -> inclination."""
    n = round(60.0 / TS)
    position = 2.5 + 2.5 * multisine(
        n, TS, band=(0.05, 4.0), amplitude=1.0, phases="random", seed=1
    )
    n_ramp = round(3.0 / TS)
    ramp = np.full(n_ramp, position[0] / (n_ramp * TS))
    velocity = np.concatenate([ramp, np.diff(position, prepend=position[0]) / TS])
    record = SoftNeck(seed=1).run(velocity)[n_ramp:]
    return record.select(inputs=["motor_position"], outputs=["inclination"])


def test_the_true_plant_in_the_loop_reproduces_the_measured_record(sine_record: IOData) -> None:
    comparison = model_in_the_loop(SoftNeck(seed=SEED), InclinationController(ts=TS), sine_record)
    assert isinstance(comparison, LoopComparison)
    np.testing.assert_array_equal(comparison.loop.y, sine_record.y)
    np.testing.assert_array_equal(comparison.loop.u, sine_record.u)
    assert comparison.n_initial == 0
    assert comparison.output_fit[0] == 100.0 and comparison.output_rmse[0] == 0.0
    assert comparison.command_fit[0] == 100.0 and comparison.command_rmse[0] == 0.0
    assert comparison.lower is None and np.isnan(comparison.scores()["band_coverage"])
    # Another neck (other noise) is not the same experiment: the check can fail.
    other = model_in_the_loop(SoftNeck(seed=SEED + 1), InclinationController(ts=TS), sine_record)
    assert other.output_rmse[0] > 0.0


@pytest.mark.parametrize("kind", ["sine", "step"])
def test_the_drive_integrates_commands_as_the_simulated_neck_does(kind: str) -> None:
    record = _test_record(kind, duration=6.0)
    drive = VelocityDrive.from_parameters(ts=TS)
    positions = [drive.step([c])[0] for c in record.channel("velocity_command")]
    logged = record.channel("motor_position")
    # The neck integrates the same law with Runge-Kutta 4 (its acceleration limit is a kink).
    np.testing.assert_allclose(positions, logged, rtol=0, atol=1e-5)
    # The plain integrator q(k+1) = q(k) + ts u(k) lags by about ts_m * u: 0.06 rad at 4 rad/s.
    integrator = np.r_[0.0, np.cumsum(TS * record.channel("velocity_command"))[:-1]]
    assert np.max(np.abs(integrator - logged)) > 0.03


def test_the_drive_without_dynamics_is_the_integrator() -> None:
    drive = VelocityDrive(ts=TS, time_constant=0.0, speed_limit=None, acceleration_limit=None)
    commands = np.random.default_rng(0).normal(size=50)
    positions = [drive.step([c])[0] for c in commands]
    np.testing.assert_allclose(positions, np.r_[0.0, np.cumsum(TS * commands)[:-1]], atol=1e-12)
    limited = VelocityDrive(ts=TS, time_constant=0.0, speed_limit=1.0, acceleration_limit=None)
    assert [float(limited.step([5.0])[0]) for _ in range(3)] == pytest.approx([0.0, 0.02, 0.04])


def test_an_identified_arx_in_the_loop_tracks_the_sine_test(
    position_view: IOData, sine_record: IOData
) -> None:
    model = LinearARX(Lags(outputs=[1, 2], inputs=[3, 4])).fit(position_view)
    comparison = model_in_the_loop(model, InclinationController(ts=TS), sine_record)
    scores = comparison.scores()
    assert comparison.n_initial == model.max_lag_
    assert scores["output_fit"] > 90.0
    assert scores["command_fit"] > 85.0
    assert scores["output_rmse"] < 0.5  # degrees
    # The loop fed the model the drive's positions, close to the ones the neck logged.
    position_error = comparison.loop.channel("motor_position") - sine_record.channel(
        "motor_position"
    )
    assert np.max(np.abs(position_error)) < 0.2
    frame = comparison.to_frame()
    assert {"inclination_measured", "inclination_loop", "velocity_command_loop"} <= set(frame)


def test_set_membership_in_the_loop_carries_its_band(position_view: IOData) -> None:
    record = _test_record("sine", duration=3.0)
    model = neckid.methods()["sm-linear"].make(Lags(outputs=[1, 2], inputs=[3, 4]))
    model.fit(position_view[:1500])
    comparison = model_in_the_loop(model, InclinationController(ts=TS), record)
    assert comparison.lower is not None and comparison.upper is not None
    m = model.max_lag_
    y = comparison.loop.y[m:, 0]
    assert np.all(comparison.lower[m:, 0] <= y) and np.all(y <= comparison.upper[m:, 0])
    assert comparison.band_coverage is not None and 0.0 <= comparison.band_coverage[0] <= 1.0
    assert comparison.scores()["band_coverage"] == comparison.band_coverage[0]


def test_a_velocity_model_takes_the_command_itself() -> None:
    record = _test_record("step", duration=4.0)
    i = np.array([5.0, 15.0, 25.0, 35.0])
    model = GainScheduledModel.from_points(
        i, -0.059 * i + 1.857, 0.01175 * i - 0.4797, ts=TS, delay=3
    )
    comparison = model_in_the_loop(model, InclinationController(ts=TS), record)
    assert np.isfinite(comparison.output_rmse[0]) and comparison.n_initial == 1
    # The plant of the loop is the model: closing it by hand gives the same log.
    plant = ModelPlant(model, y0=record.y[0])
    log = closed_loop(plant, InclinationController(ts=TS), record.channel("reference"), TS)
    np.testing.assert_array_equal(log.y, comparison.loop.y)


def test_refusals_name_what_is_wrong(position_view: IOData, sine_record: IOData) -> None:
    model = LinearARX(Lags.arx(1, 1)).fit(position_view[:200])
    renamed = LinearARX(Lags.arx(1, 1)).fit(
        IOData(
            position_view.u[:200],
            position_view.y[:200],
            ts=TS,
            input_names=["tendon"],
            output_names=["inclination"],
        )
    )
    with pytest.raises(ValueError, match="input 'tendon' cannot be fed from the loop"):
        model_in_the_loop(renamed, InclinationController(ts=TS), sine_record)
    with pytest.raises(ValueError, match="reference: the record has no channel 'target'"):
        model_in_the_loop(model, InclinationController(ts=TS), sine_record, reference="target")
    with pytest.raises(ValueError, match=r"controller runs at ts=0\.01"):
        model_in_the_loop(model, InclinationController(ts=0.01), sine_record)
    with pytest.raises(ValueError, match="time_constant must be"):
        VelocityDrive(time_constant=-1.0)
