"""Tests of the operating-point protocol (CFF-RLS at each inclination, then the scheduled lines)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from neckid import IOData
from neckid.loops.operating_points import (
    OperatingPointResult,
    identify_operating_points,
    operating_points_from_logs,
)
from neckid.models.scheduled.model import GainScheduledModel
from neckid.signals import random_binary

TRUE_GAIN = (-0.02, 1.5)
TRUE_POLE = (0.01, 0.3)


class ProportionalController:
    """Stand-in controller: command = kp * (reference - inclination)."""

    def __init__(self, kp: float = 1.0) -> None:
        self.kp = kp

    def reset(self) -> None:
        pass

    def step(self, reference: float, measurement: np.ndarray) -> np.ndarray:
        return np.array([self.kp * (reference - float(np.ravel(measurement)[0]))])


def stand_in_plant():  # type: ignore[no-untyped-def]
    """A noise-free plant whose local first-order models are known: the scheduled model itself."""
    return GainScheduledModel.from_coefficients(TRUE_GAIN, TRUE_POLE, ts=0.02).simulator()


@pytest.fixture(scope="module")
def stand_in_result() -> OperatingPointResult:
    return identify_operating_points(
        stand_in_plant(), ProportionalController(), hold_time=10.0, settle_time=3.0, seed=0
    )


def test_recovers_local_models_and_lines_of_a_known_plant(
    stand_in_result: OperatingPointResult,
) -> None:
    table = stand_in_result.table
    assert list(table["target"]) == [5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0]
    assert table["converged"].all()
    np.testing.assert_allclose(table["inclination"], table["target"], atol=0.6)
    np.testing.assert_allclose(
        stand_in_result.gains, np.polyval(TRUE_GAIN, stand_in_result.inclinations), atol=0.02
    )
    np.testing.assert_allclose(
        stand_in_result.poles, np.polyval(TRUE_POLE, stand_in_result.inclinations), atol=0.01
    )
    schedule = stand_in_result.fit_schedule()
    assert abs(schedule.gain_coefficients_[0] - TRUE_GAIN[0]) < 1e-3
    assert abs(schedule.gain_coefficients_[1] - TRUE_GAIN[1]) < 0.02
    assert abs(schedule.pole_coefficients_[0] - TRUE_POLE[0]) < 1e-3
    assert abs(schedule.pole_coefficients_[1] - TRUE_POLE[1]) < 0.01
    assert schedule.ts_ == 0.02


def test_logs_carry_the_closed_loop_channels(stand_in_result: OperatingPointResult) -> None:
    log = stand_in_result.logs[0]
    assert log.n_samples == 500
    assert "velocity_command" in log.input_names and log.output_names == ("inclination",)
    assert log.name == "operating point 5 deg"
    # The excitation is on: the command takes many values around the controller's.
    assert np.std(log.channel("velocity_command")) > 0.5


def test_from_logs_gives_the_same_table(stand_in_result: OperatingPointResult) -> None:
    again = operating_points_from_logs(list(stand_in_result.logs))
    np.testing.assert_allclose(again.gains, stand_in_result.gains)
    np.testing.assert_allclose(again.poles, stand_in_result.poles)
    # Targets read from the logs' reference channel.
    np.testing.assert_allclose(again.table["target"], stand_in_result.table["target"])


def test_fit_schedule_uses_converged_points_only(stand_in_result: OperatingPointResult) -> None:
    table = stand_in_result.table.copy()
    table.loc[0, "gain"] = 100.0  # an outlier, flagged as not converged
    table.loc[0, "converged"] = False
    edited = OperatingPointResult(
        table, stand_in_result.logs, stand_in_result.models, stand_in_result.ts
    )
    schedule = edited.fit_schedule()
    assert isinstance(schedule, GainScheduledModel)
    assert abs(schedule.gain_coefficients_[1] - TRUE_GAIN[1]) < 0.05
    everything = edited.fit_schedule(converged_only=False)
    assert everything.gain_coefficients_[1] > 10


def test_on_the_simulated_neck() -> None:
    from neckid.plant import InclinationController, SoftNeck

    result = identify_operating_points(
        SoftNeck(configuration="planar", ts=0.02, seed=0),
        InclinationController(ts=0.02),
        inclinations=(10.0, 20.0, 30.0),
        hold_time=10.0,
        seed=0,
    )
    table = result.table
    np.testing.assert_allclose(table["inclination"], table["target"], atol=0.5)
    assert np.all(np.isfinite(result.gains)) and np.all(np.isfinite(result.poles))
    assert np.all(result.gains > 0)  # more velocity command, more inclination rate
    assert np.all(np.abs(result.poles) < 1)  # stable local models
    assert result.logs[0].input_names[:2] == ("reference", "velocity_command")


def test_excitation_is_random_binary_drawn_point_after_point(monkeypatch) -> None:
    """With a controller that commands nothing, the logged command is the excitation itself."""
    import neckid.loops.operating_points as protocol

    class Silent:
        def reset(self) -> None:
            pass

        def step(self, reference: float, measurement: np.ndarray) -> np.ndarray:
            return np.zeros(1)

    def logs_only(logs, **options) -> OperatingPointResult:  # skip the identification
        return OperatingPointResult(pd.DataFrame(), tuple(logs), (), logs[0].ts)

    monkeypatch.setattr(protocol, "operating_points_from_logs", logs_only)
    result = identify_operating_points(
        stand_in_plant(),
        Silent(),
        [10.0, 20.0],
        settle_time=1.0,
        hold_time=2.0,
        excitation_amplitude=0.5,
        excitation_clock=3,
        seed=11,
    )
    rng = np.random.default_rng(11)
    for log in result.logs:
        expected = random_binary(100, 0.5, 3, seed=rng)
        np.testing.assert_array_equal(log.channel("velocity_command"), expected)


def test_bad_input_refused() -> None:
    plant, ctrl = stand_in_plant(), ProportionalController()
    with pytest.raises(ValueError, match="inclinations is empty"):
        identify_operating_points(plant, ctrl, [])
    with pytest.raises(ValueError, match="inclinations must be finite"):
        identify_operating_points(plant, ctrl, [10.0, np.nan])
    with pytest.raises(ValueError, match="hold_time must be a number > 0; got -1"):
        identify_operating_points(plant, ctrl, [10.0], hold_time=-1)
    with pytest.raises(ValueError, match=r"ts must be a positive number of seconds; got 0\.0"):
        identify_operating_points(plant, ctrl, [10.0], ts=0.0)
    with pytest.raises(ValueError, match="clock must be a whole number >= 1; got 0"):
        identify_operating_points(plant, ctrl, [10.0], excitation_clock=0)
    with pytest.raises(ValueError, match="motor must index one of the 1 motor"):
        identify_operating_points(plant, ctrl, [10.0], motor=2)
    log = IOData(np.ones(50), np.arange(50.0), ts=0.02, input_names=["cmd"], output_names=["incl"])
    with pytest.raises(KeyError, match=r"set input=\.\.\. and output=\.\.\."):
        operating_points_from_logs([log])
    with pytest.raises(ValueError, match="has 50 samples; the protocol needs at least"):
        operating_points_from_logs([log], input="cmd", output="incl")
    with pytest.raises(ValueError, match="targets has 2 values for 1 logs"):
        operating_points_from_logs([log], input="cmd", output="incl", targets=[1, 2], window=10)
    with pytest.raises(ValueError, match=r"forgetting_factor must be a number in \(0, 1\]"):
        operating_points_from_logs([log], input="cmd", output="incl", forgetting_factor=2.0)


def test_the_model_with_its_defaults_finds_the_protocols_points(
    stand_in_result: OperatingPointResult,
) -> None:
    """Each excited hold is one dwell; the model's default window is the protocol's (250)."""
    logs = [
        log.select(inputs=["velocity_command"], outputs=[log.output_names[0]])
        for log in stand_in_result.logs
    ]
    model = GainScheduledModel().fit(logs)
    table = model.operating_points_
    assert model.segmentation_ == "dwell" and list(table["experiment"]) == list(range(7))
    for column in ("inclination", "gain", "pole", "converged"):
        np.testing.assert_array_equal(table[column], stand_in_result.table[column], err_msg=column)
