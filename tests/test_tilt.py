"""The tilt representations of the 3-D neck (neckid.data.tilt): round trips, wrap and zero inclination."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from neckid import IOData
from neckid.data.tilt import from_pitch_roll, from_tilt, polar_log, tilt_log, to_pitch_roll, to_tilt

inclinations = st.floats(0.0, 80.0, allow_nan=False)
orientations = st.floats(-720.0, 720.0, allow_nan=False)


def _circular_gap(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs((a - b + 180.0) % 360.0 - 180.0)


@settings(max_examples=200, deadline=None)
@given(inclinations, orientations)
def test_tilt_vector_round_trip(inclination: float, orientation: float) -> None:
    x, y = to_tilt([inclination], [orientation])
    back_incl, back_orient = from_tilt(x, y)
    assert back_incl[0] == pytest.approx(inclination, abs=1e-9)
    assert 0.0 <= back_orient[0] < 360.0
    if inclination > 1e-6:
        assert _circular_gap(back_orient, np.array([orientation]))[0] < 1e-6


@settings(max_examples=200, deadline=None)
@given(st.floats(0.0, 80.0), orientations)
def test_pitch_roll_round_trip(inclination: float, orientation: float) -> None:
    pitch, roll = to_pitch_roll([inclination], [orientation])
    back_incl, back_orient = from_pitch_roll(pitch, roll)
    assert back_incl[0] == pytest.approx(inclination, abs=1e-7)
    assert 0.0 <= back_orient[0] < 360.0
    if inclination > 1e-4:
        assert _circular_gap(back_orient, np.array([orientation]))[0] < 1e-5


@settings(max_examples=100, deadline=None)
@given(st.floats(1.0, 60.0), st.floats(0.0, 360.0))
def test_pitch_roll_match_the_tilt_vector_for_small_and_axis_tilts(inclination, orientation):
    # Along the x axis pitch is the inclination; along y roll is minus it.
    pitch, roll = to_pitch_roll([inclination, inclination], [0.0, 90.0])
    assert pitch[0] == pytest.approx(inclination) and roll[0] == pytest.approx(0.0, abs=1e-12)
    assert pitch[1] == pytest.approx(0.0, abs=1e-12) and roll[1] == pytest.approx(-inclination)
    small = inclination / 100.0
    x, y = to_tilt([small], [orientation])
    p, r = to_pitch_roll([small], [orientation])
    assert p[0] == pytest.approx(x[0], rel=1e-4, abs=1e-9)
    assert r[0] == pytest.approx(-y[0], rel=1e-4, abs=1e-9)


def test_orientation_wrap_and_zero_inclination_make_no_jump() -> None:
    """A neck leaning 10° while its orientation wraps 359° → 1°, then passing upright."""
    t = np.linspace(0.0, 1.0, 201)
    orientation = np.mod(350.0 + 20.0 * t, 360.0)  # wraps at t = 0.5
    wrap_x, wrap_y = to_tilt(np.full_like(t, 10.0), orientation)
    assert np.max(np.abs(np.diff(orientation))) > 300.0  # the raw signal jumps
    assert np.max(np.hypot(np.diff(wrap_x), np.diff(wrap_y))) < 0.02  # 10° * 0.1° in rad
    # Through upright along a line: the orientation flips by 180° (and is 0 at zero),
    # the tilt vector moves smoothly through the origin.
    line = np.linspace(-5.0, 5.0, 101)
    incl, orient = from_tilt(line, np.full_like(line, 0.5))
    x, y = to_tilt(incl, orient)
    assert np.allclose(x, line) and np.allclose(y, 0.5)
    incl0, orient0 = from_tilt([0.0], [0.0])
    assert incl0[0] == 0.0 and orient0[0] == 0.0


def test_the_log_helpers_convert_both_ways_and_keep_other_channels() -> None:
    rng = np.random.default_rng(0)
    incl = rng.uniform(0.0, 30.0, 50)
    orient = rng.uniform(0.0, 360.0, 50)
    log = IOData(
        rng.normal(size=(50, 3)),
        np.column_stack([incl, orient, rng.normal(size=50)]),
        ts=0.02,
        output_names=["inclination", "orientation", "temperature"],
        output_units=["deg", "deg", "degC"],
        conditions={"payload": 0.2},
        name="imu",
    )
    for representation, names in (
        ("vector", ("tilt_x", "tilt_y")),
        ("pitch_roll", ("pitch", "roll")),
    ):
        tilted = log.with_tilt(representation)
        assert tilted.output_names == (*names, "temperature")
        assert tilted.output_units == ("deg", "deg", "degC")
        assert tilted.conditions == log.conditions and tilted.name == "imu"
        np.testing.assert_array_equal(tilted.u, log.u)
        back = tilted.with_polar(representation)
        assert back.output_names == ("inclination", "orientation", "temperature")
        np.testing.assert_allclose(back.y[:, 0], incl, atol=1e-9)
        assert np.max(_circular_gap(back.y[:, 1], orient)) < 1e-7
        np.testing.assert_array_equal(back.y[:, 2], log.y[:, 2])
    assert tilt_log(log, representation="vector").output_names[0] == "tilt_x"
    assert polar_log(log.with_tilt()).output_names[0] == "inclination"


def test_bad_input_is_named() -> None:
    log = IOData(np.zeros(3), np.zeros((3, 2)), ts=0.1, output_names=["incl", "orientation"])
    with pytest.raises(KeyError, match="inclination output 'inclination' not in the log"):
        log.with_tilt()
    assert log.with_tilt(inclination="incl").output_names == ("tilt_x", "tilt_y")
    with pytest.raises(ValueError, match="representation must be"):
        log.with_tilt("polar", inclination="incl")
    with pytest.raises(ValueError, match="same shape"):
        to_tilt([1.0, 2.0], [0.0])
    with pytest.raises(ValueError, match="orientation"):
        to_tilt([1.0], [np.nan])
    with pytest.raises(KeyError, match="'tilt_x' not in the log"):
        log.with_polar()
