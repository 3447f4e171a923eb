"""Tests of the simulated soft neck, its controller and the closed loop."""

import numpy as np
import pytest

from neckid.data.iodata import IOData
from neckid.plant import InclinationController, SoftNeck, SoftNeckParameters, _kernels, closed_loop
from neckid.plant.calibration import (
    PAPER_BANDWIDTH,
    REAL_STATIC_SLOPE,
    chirp_bandwidth,
    operating_point_models,
    static_map,
)

QUIET = SoftNeckParameters(sensor_noise=0.0)


# ----------------------------------------------------------------------------- physics sanity
def test_at_rest_with_zero_command_stays_at_rest():
    neck = SoftNeck(QUIET)
    data = neck.run(np.zeros(200))
    assert np.all(data.y == 0.0)
    assert np.all(data.channel("motor_position") == 0.0)
    assert neck.inclination == 0.0
    assert np.all(neck.tendon_force == 0.0)


def test_pulling_raises_and_releasing_comes_back_but_not_below_zero():
    neck = SoftNeck(QUIET)
    pull = np.full(50, 2.0)  # 1 s winding at 2 rad/s: 2 rad, about 14 deg
    data = neck.run(np.r_[pull, np.zeros(50), -pull, np.zeros(300)])
    y = data.channel("inclination")
    assert np.all(np.diff(y[5:50]) > 0)  # rises while the tendon winds
    assert 12.0 < y[100] < 16.0
    assert y[-1] < 1.0  # back near upright once the motor is unwound
    assert y.min() >= 0.0
    assert neck.inclination >= 0.0


def _time_10_90(segment):
    start, end = segment[0], segment[-1]
    sign = np.sign(end - start)
    first = np.argmax(sign * (segment - (start + 0.1 * (end - start))) >= 0)
    last = np.argmax(sign * (segment - (start + 0.9 * (end - start))) >= 0)
    return last - first


def test_return_is_slower_than_rise_and_driven_by_elasticity():
    neck = SoftNeck(QUIET)
    top_speed = np.full(25, 4.0)  # the speed limit, 0.5 s
    y = neck.run(np.r_[top_speed, np.zeros(75)]).channel("inclination")
    neck_down = SoftNeck(QUIET)
    neck_down.run(np.r_[top_speed, np.zeros(75), -top_speed[:12]])
    assert neck_down.tendon_force[0] == 0.0  # unwinding at full speed: the tendon runs slack
    y_all = SoftNeck(QUIET).run(np.r_[top_speed, np.zeros(75), -top_speed, np.zeros(125)])
    fall = _time_10_90(y_all.channel("inclination")[100:])
    rise = _time_10_90(y)
    assert fall > 1.2 * rise


def test_slack_tendon_transmits_no_force():
    neck = SoftNeck(QUIET)
    neck.run(np.full(25, -2.0))  # unwind: the tendon goes slack, the neck stays upright
    assert neck.tendon_stretch[0] < 0.0
    assert neck.tendon_force[0] == 0.0
    assert neck.inclination < 1e-12


def test_pulling_tendon_carries_force():
    neck = SoftNeck(QUIET)
    neck.run(np.r_[np.full(50, 2.0), np.zeros(50)])
    assert neck.tendon_force[0] > 1.0


def test_determinism_for_a_seed_and_run_equals_steps():
    commands = np.r_[np.full(40, 2.0), np.zeros(40), np.full(40, -1.0)]
    first = SoftNeck(seed=7).run(commands)
    assert first == SoftNeck(seed=7).run(commands)
    assert not np.array_equal(first.y, SoftNeck(seed=8).run(commands).y)
    neck = SoftNeck(seed=7)
    neck.reset()
    stepped = np.array([neck.step([u]) for u in commands])
    np.testing.assert_array_equal(stepped, first.y)


def test_hysteresis_loop_area_positive_under_slow_triangle():
    neck = SoftNeck(QUIET)
    n = 1500  # 30 s up, 30 s down at 0.15 rad/s
    data = neck.run(np.r_[np.full(n, 0.15), np.full(n, -0.15)])
    q = data.channel("motor_position")
    y = data.channel("inclination")
    area = 0.5 * abs(np.sum(q[:-1] * y[1:] - q[1:] * y[:-1]))  # shoelace, deg * rad
    assert area > 0.05


def test_compiled_kernel_agrees_with_numpy_reference():
    for configuration, n_motors in (("planar", 1), ("three_tendon", 3)):
        rng = np.random.default_rng(3)
        commands = rng.uniform(-3.0, 4.0, size=(120, n_motors))
        commands[:40] = np.abs(commands[:40])
        results = []
        for compiled in (True, False):
            neck = SoftNeck(configuration=configuration, seed=1)
            noise = np.random.default_rng(5).standard_normal((120, 1 if n_motors == 1 else 2))
            out = neck._advance(commands, noise, compiled=compiled)
            results.append((neck._state.copy(), *out))
        np.testing.assert_allclose(results[0][0], results[1][0], rtol=1e-9, atol=1e-12)
        for a, b in zip(results[0][1:], results[1][1:], strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=0.0100001)


def test_derivatives_reference_matches_compiled_on_random_states():
    neck = SoftNeck(configuration="three_tendon")
    rng = np.random.default_rng(0)
    dx = np.empty(12)
    for _ in range(20):
        x = rng.normal(scale=[3, 3, 3, 2, 2, 2, 0.3, 0.3, 1, 1, 0.01, 0.01])
        u = rng.normal(scale=3.0, size=3)
        _kernels._derivatives(x, u, neck._packed, neck._directions, 3, 2, dx[None, :], 0)
        ref = _kernels.derivatives_reference(x, u, neck._packed, neck._directions)
        np.testing.assert_allclose(dx, ref, rtol=1e-10, atol=1e-9)


def test_shape_functions_series_and_closed_forms_agree_with_the_reference():
    # The kernel uses 12-term series in theta^2 below pi/2 and the closed forms above; the
    # reference uses short series below 0.01 rad and the closed forms above (whose cancellation
    # costs it about 1e-11 just above 0.01).
    limit = np.sqrt(_kernels.SERIES_LIMIT)
    thetas = np.r_[
        0.0, 1e-9, 1e-4, 0.0099, 0.0101, np.linspace(0.02, 3.0, 400), limit, limit * 1.0001
    ]
    for theta in thetas:
        ours = _kernels._shape_functions(theta, theta * theta)
        reference = _kernels._shape_functions_reference(theta)
        np.testing.assert_allclose(ours, reference, rtol=1e-10, atol=1e-15, err_msg=f"{theta=}")


# ----------------------------------------------------------------------------- three tendons
@pytest.mark.parametrize("tendon", [0, 1, 2])
def test_three_tendon_orientation_follows_the_pulling_tendon(tendon):
    neck = SoftNeck(configuration="three_tendon", seed=2)
    commands = np.zeros((100, 3))
    commands[:50, tendon] = 2.0
    commands[:50, [k for k in range(3) if k != tendon]] = -1.5  # release the other two
    data = neck.run(commands)
    incl, orient = data.y[-1]
    assert incl > 10.0
    expected = 120.0 * tendon
    assert abs((orient - expected + 180.0) % 360.0 - 180.0) < 2.0
    others = [k for k in range(3) if k != tendon]
    assert np.all(neck.tendon_force[others] == 0.0)  # the other two are slack


# ----------------------------------------------------------------------------- calibration
@pytest.fixture(scope="module")
def neck():
    return SoftNeck()


def test_static_map_within_20_percent_of_real(neck):
    result = static_map(neck, levels=(10.0, 15.0, 20.0, 25.0, 30.0, 25.0, 20.0), hold=6.0)
    assert abs(result.slope - REAL_STATIC_SLOPE) < 0.2 * REAL_STATIC_SLOPE
    # a little hysteresis: same inclination, different motor position up and down (real: 0.02-0.03)
    assert 0.002 < abs(result.up_down[20.0]) < 0.06


def test_chirp_bandwidth_same_order_as_paper(neck):
    result, *_ = chirp_bandwidth(neck)
    assert result.status == "found"
    assert PAPER_BANDWIDTH / 2 < result.bandwidth < PAPER_BANDWIDTH * 2


def test_operating_point_gain_falls_and_pole_rises_with_inclination(neck):
    models = operating_point_models(neck, inclinations=(5.0, 20.0, 35.0), duration=40.0)
    gain_slope, pole_slope = models.trend()
    assert gain_slope < 0.0  # paper: -0.059 per degree
    assert pole_slope > 0.0  # paper: +0.01175 per degree
    assert np.all(np.abs(models.pole) < 1.0)


def test_payload_slows_and_sags():
    light = SoftNeck(QUIET).run(np.r_[np.full(50, 2.0), np.zeros(50)])
    heavy = SoftNeck(SoftNeckParameters(sensor_noise=0.0, payload=0.6)).run(
        np.r_[np.full(50, 2.0), np.zeros(50)]
    )
    assert heavy.y[-1, 0] > light.y[-1, 0]  # gravity helps the tendon bend further


# ----------------------------------------------------------------------------- closed loop
def test_closed_loop_reaches_the_reference():
    data = closed_loop(SoftNeck(), InclinationController(), np.full(400, 20.0), ts=0.02)
    assert isinstance(data, IOData)
    assert abs(data.y[-50:, 0].mean() - 20.0) < 0.3
    assert np.all(np.abs(data.channel("velocity_command")) <= 4.0 + 1e-12)


def test_closed_loop_three_tendons():
    ref = np.column_stack([np.full(500, 15.0), np.full(500, 120.0)])
    ctrl = InclinationController(configuration="three_tendon")
    data = closed_loop(SoftNeck(configuration="three_tendon"), ctrl, ref, ts=0.02)
    assert data.input_names[:2] == ("reference_inclination", "reference_orientation")
    assert "motor_position_3" in data.input_names
    assert abs(data.y[-50:, 0].mean() - 15.0) < 1.0
    assert abs(data.y[-50:, 1].mean() - 120.0) < 5.0


class FirstOrder:
    """A plain object with reset/step, like an identified model's simulator()."""

    def __init__(self):
        self.reset()

    def reset(self):
        self.y = 0.0
        self.u = 0.0

    def step(self, u):
        self.y = self.y + 0.02 * 7.0 * self.u  # integrator: 7 deg per rad
        self.u = float(np.asarray(u).ravel()[0])
        return np.array([self.y])


def test_closed_loop_accepts_any_reset_step_object():
    ex = 0.1 * np.sign(np.sin(np.arange(300)))
    data = closed_loop(FirstOrder(), InclinationController(), np.full(300, 5.0), 0.02, ex)
    assert data.input_names == ("reference", "velocity_command")
    assert data.output_names == ("inclination",)
    assert abs(data.y[-20:, 0].mean() - 5.0) < 0.5


class SteppedNeck(SoftNeck):
    """A SoftNeck that closed_loop steps from Python (not the exact class: no compiled loop)."""


class SteppedController(InclinationController):
    """An InclinationController that closed_loop steps from Python."""


@pytest.mark.parametrize("configuration", ["planar", "three_tendon"])
def test_compiled_closed_loop_equals_the_stepped_loop(configuration):
    n = 600
    t = np.arange(n) * 0.02
    excitation = 0.3 * np.sign(np.sin(3.1 * t))
    if configuration == "planar":
        # a reference that saturates the command (anti-windup) and one that reverses it
        reference = np.where(t < 4.0, 35.0, 10.0 + 5.0 * np.sin(2.0 * t))
    else:
        reference = np.column_stack([np.where(t < 4.0, 30.0, 12.0), (45.0 * t) % 360.0])
        excitation = excitation[:, None] * np.array([1.0, -0.5, 0.25])
    pairs = []
    for neck_class, controller_class in ((SoftNeck, InclinationController),
                                         (SteppedNeck, SteppedController)):  # fmt: skip
        neck = neck_class(configuration=configuration, seed=4)
        controller = controller_class(ki=1.5, configuration=configuration)
        log = closed_loop(neck, controller, reference, 0.02, excitation)
        pairs.append((log, neck, controller))
    (fast, fast_neck, fast_pi), (slow, slow_neck, slow_pi) = pairs
    assert fast.input_names == slow.input_names
    assert fast.output_names == slow.output_names
    np.testing.assert_array_equal(fast.u, slow.u)
    np.testing.assert_array_equal(fast.y, slow.y)
    first_command = next(name for name in fast.input_names if name.startswith("velocity_command"))
    assert np.any(np.abs(fast.channel(first_command)) > 4.0)  # saturated, plus the excitation
    # the objects are left alike: neck state, sensor buffer, noise generator, PI integral
    np.testing.assert_array_equal(fast_neck._state, slow_neck._state)
    np.testing.assert_array_equal(fast_neck._buffer, slow_neck._buffer)
    assert fast_neck._rng.standard_normal() == slow_neck._rng.standard_normal()
    np.testing.assert_array_equal(fast_pi._integral, slow_pi._integral)
    np.testing.assert_array_equal(fast_neck.step([1.0] * fast_neck.n_motors),
                                  slow_neck.step([1.0] * slow_neck.n_motors))  # fmt: skip


def test_compiled_closed_loop_reports_a_non_finite_state():
    from neckid.plant.control import _compiled_loop

    neck = SoftNeck()
    neck._state[2] = np.nan  # the bending
    with pytest.raises(FloatingPointError, match="diverged"):
        _compiled_loop(neck, InclinationController(), np.full((5, 1), 10.0), np.zeros((5, 1)))


def test_anti_windup_limits_the_integral():
    ctrl = InclinationController(kp=0.1, ki=5.0, command_limit=1.0)
    for _ in range(500):
        ctrl.step(40.0, 0.0)  # saturated for 10 s
    # once the error reverses, the command leaves saturation at once (no wound-up integral)
    assert ctrl.step(0.0, 10.0)[0] < 1.0


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"bending_stiffness": -1.0}, "bending_stiffness must be > 0.*-1.0"),
        ({"payload": -0.1}, r"payload must be in \[0, 1\] kg; got -0.1"),
        ({"payload": 2.0}, "payload"),
        ({"tendon_stiffness": 0.0}, "tendon_stiffness"),
        ({"sensor_noise": -0.01}, "sensor_noise must be >= 0"),
        ({"link_length": float("nan")}, "link_length must be finite"),
        ({"hysteresis_shape": 1.5}, "hysteresis_shape"),
        ({"bending_stiffness": 0.5, "payload": 1.0}, "gravity"),
    ],
)
def test_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SoftNeckParameters(**kwargs)


def test_bad_commands_and_ts():
    neck = SoftNeck()
    with pytest.raises(ValueError, match="non-finite value nan at row 2"):
        neck.run([0.0, 1.0, np.nan])
    with pytest.raises(ValueError, match="inf"):
        neck.step([np.inf])
    with pytest.raises(ValueError, match=r"shape \(n_samples, 1\)"):
        neck.run(np.zeros((10, 3)))
    with pytest.raises(ValueError, match="3 value"):
        SoftNeck(configuration="three_tendon").step([1.0])
    with pytest.raises(ValueError, match="ts must be a positive"):
        neck.run(np.zeros(5), ts=0.0)
    with pytest.raises(ValueError, match="ts must be a positive"):
        SoftNeck(ts=-0.02)
    with pytest.raises(ValueError, match="configuration"):
        SoftNeck(configuration="spherical")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"kp must be a number >= 0; got -1\.0"):
        InclinationController(kp=-1.0)
    with pytest.raises(TypeError, match=r"ki must be a number >= 0; got '0\.6'"):
        InclinationController(ki="0.6")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"command_limit must be a number > 0; got 0"):
        InclinationController(command_limit=0)
    with pytest.raises(ValueError, match=r"ts is 0\.01 s but the plant runs at ts=0\.02"):
        closed_loop(SoftNeck(), InclinationController(ts=0.01), np.zeros(5), ts=0.01)
    with pytest.raises(ValueError, match="reference"):
        closed_loop(SoftNeck(), InclinationController(), np.zeros((5, 2)), ts=0.02)
    with pytest.raises(TypeError, match="reset"):
        closed_loop(object(), InclinationController(), np.zeros(5), ts=0.02)


def test_run_with_other_ts_keeps_delay_in_seconds():
    neck = SoftNeck(QUIET)
    neck.run(np.zeros(3), ts=0.01)
    assert neck.ts == 0.01
    assert neck.delay_samples == 4
