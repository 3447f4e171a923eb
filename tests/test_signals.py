"""Tests of neckid.signals: analytic checks, spectra, autocorrelation, bandwidth, bad input."""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal as sps

from neckid import signals
from neckid.report.signal_plots import plot_bandwidth
from neckid.signals import (
    BandwidthResult,
    bandwidth_from_chirp,
    chirp,
    chirp_frequency,
    multisine,
    multisine_frequencies,
    paper_chirp,
    paper_chirp_frequency,
    prbs,
    random_binary,
    sine,
    staircase,
    step,
)

TS = 0.01


def numerical_frequency(t: np.ndarray, phase: np.ndarray) -> np.ndarray:
    return np.gradient(phase, t)


# ------------------------------------------------------------------------------- paper chirp
def test_paper_chirp_is_eq_14_15() -> None:
    t = np.linspace(0.0, 50.0, 5001)
    expected = 5.0 + 4.0 * np.sin(0.1 * t * t)
    np.testing.assert_allclose(paper_chirp(t), expected, rtol=0, atol=1e-12)
    assert paper_chirp(t).min() >= 1.0 - 1e-12
    assert paper_chirp(t).max() <= 9.0 + 1e-12


def zero_crossing_frequency(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frequency measured on the signal itself: half a period between zero crossings.

    Crossings are located by linear interpolation; between crossings k and k+1 the phase advances
    by pi, so omega = pi / (t_{k+1} - t_k) at the midpoint.
    """
    i = np.flatnonzero(np.diff(np.signbit(x)))
    crossings = t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    return 0.5 * (crossings[1:] + crossings[:-1]), math.pi / np.diff(crossings)


def test_paper_chirp_instantaneous_frequency_is_twice_the_rate() -> None:
    # The phase of sin(0.1 t^2) is 0.1 t^2; its derivative is 0.2 t, not 0.1 t. Measured on the
    # generated signal from its zero crossings (sqrt(k pi / 0.1)).
    rate = 0.1
    t = np.arange(0.0, 60.0, 1e-3)
    mid, omega = zero_crossing_frequency(t, paper_chirp(t) - 5.0)
    np.testing.assert_allclose(omega[3:], paper_chirp_frequency(mid[3:], rate), rtol=2e-3)
    np.testing.assert_allclose(paper_chirp_frequency(t), 0.2 * t, atol=1e-12)
    assert not np.allclose(omega[3:], 0.1 * mid[3:], rtol=0.1)


def test_paper_chirp_parameters() -> None:
    t = np.array([1.0, 2.0])
    np.testing.assert_allclose(
        paper_chirp(t, offset=1.0, amplitude=2.0, rate=0.3), 1.0 + 2.0 * np.sin(0.3 * t**2)
    )
    assert paper_chirp(0.0).shape == (1,)


# ------------------------------------------------------------------------------ general chirp
@settings(max_examples=30, deadline=None)
@given(
    omega_start=st.floats(0.0, 20.0),
    omega_end=st.floats(0.0, 20.0),
    duration=st.floats(1.0, 30.0),
)
def test_chirp_phase_derivative_is_the_instantaneous_frequency(
    omega_start: float, omega_end: float, duration: float
) -> None:
    t = np.linspace(0.0, duration, 20001)
    # Recover the phase from the signal: x = sin(phi) with phi(0) = 0, compare d phi / dt.
    phase = omega_start * t + 0.5 * (omega_end - omega_start) / duration * t**2
    np.testing.assert_allclose(chirp(t, omega_start, omega_end), np.sin(phase), atol=1e-9)
    np.testing.assert_allclose(
        np.gradient(phase, t)[1:-1],
        chirp_frequency(t, omega_start, omega_end)[1:-1],
        atol=1e-6 * (1 + max(omega_start, omega_end)),
    )
    assert chirp_frequency(t, omega_start, omega_end)[-1] == pytest.approx(omega_end)


@pytest.mark.parametrize(("omega_start", "omega_end"), [(2.0, 10.0), (12.0, 3.0)])
def test_chirp_zero_crossing_frequency(omega_start: float, omega_end: float) -> None:
    t = np.arange(0.0, 40.0, 1e-3)
    x = chirp(t, omega_start, omega_end, amplitude=3.0, offset=1.0)
    mid, omega = zero_crossing_frequency(t, x - 1.0)
    np.testing.assert_allclose(omega, chirp_frequency(mid, omega_start, omega_end, 40.0), rtol=2e-3)


def test_chirp_matches_paper_chirp_and_down_chirp() -> None:
    t = np.linspace(0.0, 30.0, 3001)
    np.testing.assert_allclose(
        chirp(t, 0.0, 6.0, duration=30.0, amplitude=4.0, offset=5.0), paper_chirp(t), atol=1e-12
    )
    down = chirp_frequency(t, 5.0, 1.0, duration=30.0)
    assert down[0] == 5.0 and down[-1] == pytest.approx(1.0)


# ----------------------------------------------------------------------- simple signals
def test_sine_step_staircase_values() -> None:
    t = np.array([0.0, 0.25, 0.5, 0.75])
    np.testing.assert_allclose(
        sine(t, amplitude=2.0, omega=2 * np.pi, offset=1.0, phase=np.pi / 2),
        1.0 + 2.0 * np.cos(2 * np.pi * t),
        atol=1e-12,
    )
    np.testing.assert_array_equal(step(t, 3.0, step_time=0.5, initial=-1.0), [-1, -1, 2, 2])


def test_staircase_is_the_papers_five_degrees_every_three_seconds() -> None:
    t = np.arange(0.0, 30.0, 0.02)
    x = staircase(t)
    # Level k is held on [3k, 3k + 3): value 5 (k + 1).
    expected = 5.0 * (np.floor(np.round(t / 0.02) * 0.02 / 3.0 + 1e-9) + 1.0)
    np.testing.assert_allclose(x, expected)
    changes = t[1:][np.diff(x) != 0]
    np.testing.assert_allclose(changes, np.arange(3.0, 30.0, 3.0), atol=1e-9)
    assert set(np.diff(x)) <= {0.0, 5.0}


def test_staircase_options() -> None:
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0])
    np.testing.assert_allclose(
        staircase(t, step=2.0, step_duration=1.0, start_time=2.0, initial=10.0, maximum=13.0),
        [10.0, 10.0, 12.0, 13.0, 13.0, 13.0],
    )
    np.testing.assert_allclose(
        staircase(t, step=-1.0, step_duration=2.0, maximum=-2.0), [-1, -1, -2, -2, -2, -2]
    )


# ---------------------------------------------------------------------------------- multisine
@pytest.mark.parametrize("phases", ["schroeder", "random"])
@pytest.mark.parametrize("n_periods", [1, 3])
def test_multisine_spectrum_only_inside_band(phases: str, n_periods: int) -> None:
    period, ts, band = 1000, 0.01, (3.0, 25.0)
    x = multisine(
        period * n_periods, ts, band, amplitude=2.0, n_periods=n_periods, phases=phases, seed=1
    )
    assert np.abs(x).max() == pytest.approx(2.0)
    spectrum = np.abs(np.fft.rfft(x))
    omega = 2 * np.pi * np.fft.rfftfreq(x.size, ts)
    inside = (omega >= band[0]) & (omega <= band[1])
    excited = spectrum > 1e-9 * spectrum.max()
    # Energy only inside the band, on the DFT lines of one period, all with the same amplitude.
    assert not np.any(excited & ~inside)
    lines, omegas = multisine_frequencies(period, ts, band)
    np.testing.assert_allclose(omega[excited], omegas)
    np.testing.assert_allclose(spectrum[excited], spectrum[excited][0], rtol=1e-9)
    assert np.all(np.abs(np.fft.rfft(x)[lines * n_periods]) > 0)


def test_multisine_periods_and_crest_factor(rng: np.random.Generator) -> None:
    x = multisine(3500, 0.01, (1.0, 150.0), period=1000)
    np.testing.assert_allclose(x[:1000], x[1000:2000])
    np.testing.assert_allclose(x[3000:], x[:500])
    crest = np.abs(x).max() / np.sqrt(np.mean(x[:1000] ** 2))
    random_crests = [
        np.abs(y).max() / np.sqrt(np.mean(y**2))
        for y in (multisine(1000, 0.01, (1.0, 150.0), phases="random", seed=rng) for _ in range(10))
    ]
    # Schroeder phases: crest factor near sqrt(2) ~ 1.41..1.8; random phases are worse on average.
    assert crest < 2.0
    assert crest < np.mean(random_crests)


def test_multisine_random_phases_reproducible() -> None:
    a = multisine(500, 0.01, (1.0, 50.0), phases="random", seed=7)
    b = multisine(500, 0.01, (1.0, 50.0), phases="random", seed=7)
    c = multisine(500, 0.01, (1.0, 50.0), phases="random", seed=8)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)


# --------------------------------------------------------------------------------------- PRBS
@pytest.mark.parametrize("order", [3, 5, 7, 9])
def test_prbs_autocorrelation_is_two_valued(order: int) -> None:
    n = 2**order - 1
    x = prbs(n, ts=0.1, clock_period=0.1, order=order)
    assert set(np.unique(x)) == {-1.0, 1.0}
    assert np.sum(x == 1.0) == (n + 1) // 2
    circular = np.array([np.dot(x, np.roll(x, k)) for k in range(n)])
    assert circular[0] == n
    np.testing.assert_array_equal(circular[1:], -1.0)


def test_prbs_clock_levels_and_default_order() -> None:
    x = prbs(1000, ts=0.02, clock_period=0.1, levels=(2.0, 7.0))
    assert set(np.unique(x)) == {2.0, 7.0}
    # Held for 5 samples: every change happens at a multiple of 5.
    changes = np.flatnonzero(np.diff(x)) + 1
    assert np.all(changes % 5 == 0)
    # 200 bits need order 8 (255 bits): no repetition; the bit sequence is scipy's m-sequence.
    bits = x[::5] == 7.0
    expected = sps.max_len_seq(8, length=200)[0].astype(bool)
    np.testing.assert_array_equal(bits, expected)


def test_prbs_seed_shifts_the_sequence() -> None:
    a = prbs(127, 1.0, 1.0, order=7, seed=3)
    b = prbs(127, 1.0, 1.0, order=7)
    np.testing.assert_array_equal(a, prbs(127, 1.0, 1.0, order=7, seed=3))
    # A different initial state is a circular shift of the same m-sequence.
    assert any(np.array_equal(np.roll(b, k), a) for k in range(127))


# ------------------------------------------------------------------------------ random binary
def test_random_binary_levels_clock_and_seed() -> None:
    x = random_binary(1000, 0.7, clock=4, seed=3)
    assert x.shape == (1000,) and x.dtype == np.float64
    assert set(np.unique(x)) == {-0.7, 0.7}
    assert np.all(x.reshape(-1, 4) == x[::4, None])
    np.testing.assert_array_equal(x, random_binary(1000, 0.7, clock=4, seed=3))
    assert not np.array_equal(x, random_binary(1000, 0.7, clock=4, seed=4))
    assert abs(x.mean()) < 0.1


def test_random_binary_draws_one_fair_coin_per_clock_period() -> None:
    # The levels are Generator.integers(0, 2) flips, one per started clock period, cut at n_samples.
    flips = np.random.default_rng(5).integers(0, 2, size=4)
    expected = np.repeat(2.0 * flips - 1.0, 3)[:10]
    np.testing.assert_array_equal(random_binary(10, 1.0, clock=3, seed=5), expected)
    # A Generator is drawn from and advanced, so successive segments differ.
    rng = np.random.default_rng(0)
    first, second = random_binary(64, 1.0, seed=rng), random_binary(64, 1.0, seed=rng)
    assert not np.array_equal(first, second)
    assert random_binary(0, 1.0).shape == (0,)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"clock": 0}, ValueError, r"clock must be a whole number >= 1; got 0"),
        ({"clock": 2.0}, TypeError, r"clock must be a whole number >= 1; got 2.0"),
        ({"n_samples": -1}, ValueError, r"n_samples must be a whole number >= 0; got -1"),
        ({"amplitude": np.nan}, ValueError, r"amplitude must be a finite number; got nan"),
    ],
)
def test_random_binary_bad_input(kwargs: dict, error: type, match: str) -> None:
    arguments = {"n_samples": 10, "amplitude": 1.0, **kwargs}
    with pytest.raises(error, match=match):
        random_binary(**arguments)


# ---------------------------------------------------------------------------------- bandwidth
def first_order_response(
    t: np.ndarray, command: np.ndarray, tau: float, *, at_rest: bool = False
) -> np.ndarray:
    """Response of ``1 / (tau s + 1)``, starting in steady state at the first command (or at 0).

    ``lsim`` realises it as ``x' = -x / tau + u``, ``y = x / tau``: steady state is
    ``x = tau * u``.
    """
    x0 = 0.0 if at_rest else tau * command[0]
    _, y, _ = sps.lsim(([1.0], [tau, 1.0]), command, t, X0=[x0])
    return y


@pytest.mark.parametrize("tau", [0.05, 0.1, 0.2])
@pytest.mark.parametrize("given_frequency", [True, False])
def test_bandwidth_of_first_order_lag(tau: float, given_frequency: bool) -> None:
    t = np.arange(0.0, 70.0, TS)
    command = paper_chirp(t)
    response = first_order_response(t, command, tau)
    expected = math.sqrt(1.0 / 0.81 - 1.0) / tau
    result = bandwidth_from_chirp(
        t, command, response, frequency=paper_chirp_frequency if given_frequency else None
    )
    assert isinstance(result, BandwidthResult)
    assert result.status == "found"
    assert result.bandwidth == pytest.approx(expected, rel=0.05)
    assert result.omega == result.bandwidth
    assert result.bandwidth_hz == pytest.approx(result.bandwidth / (2 * math.pi))
    # The envelopes: command amplitude is 4 everywhere; response follows |G(j omega)|. The
    # Hilbert phase estimate (no frequency given) ripples by a few per cent.
    tolerance = 0.005 if given_frequency else 0.03
    inner = slice(2, -2)
    np.testing.assert_allclose(result.command_amplitude[inner], 4.0, rtol=tolerance)
    gain = 1.0 / np.sqrt(1.0 + (result.frequency * tau) ** 2)
    np.testing.assert_allclose(result.ratio[inner], gain[inner], atol=tolerance)
    n = result.time.size
    assert result.frequency.shape == result.ratio.shape == result.response_amplitude.shape == (n,)
    assert np.all(result.ratio[result.crossing_index :] < 0.9)
    assert result.ratio[result.crossing_index - 1] >= 0.9


def test_bandwidth_with_offset_drift_and_noise(rng: np.random.Generator) -> None:
    tau = 0.05
    t = np.arange(0.0, 70.0, TS)
    command = paper_chirp(t)
    response = first_order_response(t, command, tau) + 0.02 * t  # slow drift
    response = response + rng.normal(0.0, 0.1, t.size)
    result = bandwidth_from_chirp(
        t, command, response, frequency=paper_chirp_frequency(t), cycles_per_window=4
    )
    assert result.bandwidth == pytest.approx(math.sqrt(1 / 0.81 - 1) / tau, rel=0.05)


def test_bandwidth_general_chirp_and_threshold() -> None:
    tau = 0.2
    t = np.arange(0.0, 200.0, 0.02)
    command = chirp(t, 0.5, 10.0, amplitude=2.0)
    response = first_order_response(t, command, tau)
    result = bandwidth_from_chirp(
        t, command, response, threshold=0.7, frequency=lambda s: chirp_frequency(s, 0.5, 10.0)
    )
    expected = math.sqrt(1.0 / 0.49 - 1.0) / tau
    assert result.bandwidth == pytest.approx(expected, rel=0.03)


def test_bandwidth_uses_the_last_crossing() -> None:
    # A response whose ratio dips below 0.9, comes back to 1, and then falls for good.
    t = np.arange(0.0, 60.0, TS)
    omega = paper_chirp_frequency(t)
    gain = np.where(omega < 3.0, 1.0, np.where(omega < 4.0, 0.8, np.where(omega < 6.0, 1.0, 0.5)))
    command = paper_chirp(t)
    response = 5.0 + 4.0 * gain * np.sin(0.1 * t**2)
    result = bandwidth_from_chirp(t, command, response, frequency=omega)
    assert result.status == "found"
    assert 5.5 < result.bandwidth < 6.5


def test_bandwidth_not_reached_and_below_at_start() -> None:
    t = np.arange(0.0, 30.0, TS)
    command = paper_chirp(t)
    with pytest.warns(UserWarning, match="not stayed below"):
        result = bandwidth_from_chirp(t, command, command, frequency=paper_chirp_frequency)
    assert result.status == "not_reached" and math.isnan(result.bandwidth)
    with pytest.warns(UserWarning, match="below threshold"):
        low = bandwidth_from_chirp(t, command, 5.0 + 0.5 * (command - 5.0))
    assert low.status == "below_at_start" and math.isnan(low.bandwidth)


SLOW_LAG_TAU = 0.5  # 1 / (0.5 s + 1): |G| = 0.9 at 0.9686 rad/s
SLOW_LAG_BANDWIDTH = math.sqrt(1.0 / 0.81 - 1.0) / SLOW_LAG_TAU


def _advice(reason: str) -> tuple[float, float]:
    found = re.search(
        r"start the chirp at or below ([0-9.]+) rad/s and sweep it no faster than ([0-9.e-]+)"
        r" rad/s\^2",
        reason,
    )
    assert found is not None, reason
    return float(found[1]), float(found[2])


@pytest.mark.parametrize("given_frequency", [True, False])
def test_bandwidth_below_the_first_measured_window_is_explained_and_the_advice_measures_it(
    given_frequency: bool,
) -> None:
    # The paper's chirp passes 0.97 rad/s after 4.8 s, less than half a cycle (phase 0.1 t^2 =
    # 2.3 rad): its first window spans 0 .. 1.6 rad/s. No amplitude at 0.97 rad/s is in the
    # record, so no bandwidth is reported, and the result says why and which chirp measures it.
    t = np.arange(0.0, 70.0, TS)
    command = paper_chirp(t)
    response = first_order_response(t, command, SLOW_LAG_TAU)
    with pytest.warns(UserWarning, match="below threshold=0.9 in every measured window"):
        result = bandwidth_from_chirp(
            t, command, response, frequency=paper_chirp_frequency if given_frequency else None
        )
    assert result.status == "below_at_start" and math.isnan(result.bandwidth)
    first = result.first_measured
    assert first >= 1 and result.crossing_index == first
    assert np.all(result.ratio[first:] < 0.9)
    # What the reason claims is true: the bandwidth lies below the first measured frequency.
    assert result.frequency[first] > SLOW_LAG_BANDWIDTH
    assert f"below about {result.frequency[first]:.3g} rad/s" in result.reason
    assert "the first window" in result.reason and "start transient" in result.reason
    start, rate = _advice(result.reason)
    assert start == pytest.approx(result.frequency[first] / 3, rel=0.01)
    assert start < SLOW_LAG_BANDWIDTH
    # Following the advice measures it within 5 %.
    end = 3.0
    duration = (end - start) / rate
    t = np.arange(0.0, duration, TS)
    command = chirp(t, start, end, duration, amplitude=4.0, offset=5.0)
    advised = bandwidth_from_chirp(
        t,
        command,
        first_order_response(t, command, SLOW_LAG_TAU),
        frequency=(lambda s: chirp_frequency(s, start, end, duration)) if given_frequency else None,
    )
    assert advised.status == "found", advised.reason
    assert advised.bandwidth == pytest.approx(SLOW_LAG_BANDWIDTH, rel=0.05)


def test_start_transient_does_not_make_a_bandwidth() -> None:
    # The lag starts at rest while the command starts at 5: in the first window the response
    # rises by 5, which the first-harmonic fit reads as a ratio of 1.8. That window used to be
    # the last one above 0.9, giving "found" at 1.46 rad/s for a 0.97 rad/s bandwidth.
    t = np.arange(0.0, 70.0, TS)
    command = paper_chirp(t)
    response = first_order_response(t, command, SLOW_LAG_TAU, at_rest=True)
    with pytest.warns(UserWarning, match="below threshold"):
        result = bandwidth_from_chirp(t, command, response, frequency=paper_chirp_frequency)
    assert result.ratio[0] > 1.0  # the transient
    assert result.status == "below_at_start"


def test_every_result_says_how_it_was_reached() -> None:
    t = np.arange(0.0, 70.0, TS)
    command = paper_chirp(t)
    found = bandwidth_from_chirp(
        t, command, first_order_response(t, command, 0.1), frequency=paper_chirp_frequency
    )
    assert found.status == "found"
    assert f"at {found.bandwidth:.4g} rad/s by linear interpolation" in found.reason
    assert found.first_measured == 1  # the first window, the start transient, is not used
    with pytest.warns(UserWarning) as record:
        short = bandwidth_from_chirp(t[:3000], command[:3000], command[:3000])
    assert short.status == "not_reached"
    assert str(record[0].message) == short.reason
    assert "use a longer or faster chirp" in short.reason


def test_bandwidth_does_not_mutate_inputs() -> None:
    t = np.arange(0.0, 40.0, TS)
    command = paper_chirp(t)
    response = first_order_response(t, command, 0.1)
    copies = [a.copy() for a in (t, command, response)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bandwidth_from_chirp(t, command, response)
    for a, b in zip((t, command, response), copies, strict=True):
        np.testing.assert_array_equal(a, b)


def test_plot_bandwidth_returns_figure_without_showing() -> None:
    import matplotlib.pyplot as plt

    t = np.arange(0.0, 70.0, TS)
    command = paper_chirp(t)
    result = bandwidth_from_chirp(
        t, command, first_order_response(t, command, 0.05), frequency=paper_chirp_frequency
    )
    fig = plot_bandwidth(result)
    assert len(fig.axes) == 1
    ax = fig.axes[0]
    assert len(ax.lines) == 4  # command, threshold, response, bandwidth
    assert ax.get_xlabel() == "frequency [rad/s]"
    assert ax.get_ylabel() == "amplitude [unit of the command]"
    assert len(ax.patches) == 1  # the windows not measured
    _, other = plt.subplots()
    assert plot_bandwidth(result, ax=other, unit="deg") is other.figure
    assert other.get_ylabel() == "amplitude [deg]"
    with pytest.raises(TypeError, match="BandwidthResult"):
        plot_bandwidth("nope")  # type: ignore[arg-type]


def test_plot_bandwidth_marks_where_the_bandwidth_lies_below() -> None:
    t = np.arange(0.0, 70.0, TS)
    command = paper_chirp(t)
    with pytest.warns(UserWarning):
        result = bandwidth_from_chirp(
            t,
            command,
            first_order_response(t, command, SLOW_LAG_TAU),
            frequency=paper_chirp_frequency,
        )
    ax = plot_bandwidth(result).axes[0]
    below = ax.lines[-1]
    assert below.get_linestyle() == ":"
    assert below.get_xdata()[0] == result.frequency[result.first_measured]
    assert "no bandwidth" in ax.get_title()


# --------------------------------------------------------------------------------- bad input
T = np.arange(0.0, 10.0, 0.1)
C = paper_chirp(T)

BAD_CALLS = [
    (lambda: paper_chirp([0.0, np.nan, 1.0]), ValueError, r"t has a non-finite value nan at row 1"),
    (lambda: paper_chirp(T, rate=np.inf), ValueError, r"rate must be a finite number; got inf"),
    (
        lambda: paper_chirp(T, amplitude="big"),
        TypeError,
        r"amplitude must be a finite number; got 'big'",
    ),
    (lambda: paper_chirp(np.zeros((2, 2))), ValueError, r"t must be 1-D.*\(2, 2\)"),
    (lambda: sine(T, 1.0, omega=np.nan), ValueError, r"omega must be a finite number; got nan"),
    (lambda: step(T, amplitude=None), TypeError, r"amplitude must be a finite number; got None"),
    (
        lambda: staircase(T, step_duration=0.0),
        ValueError,
        r"step_duration must be a number > 0; got 0.0",
    ),
    (
        lambda: staircase(T, step=5.0, initial=3.0, maximum=1.0),
        ValueError,
        r"maximum must lie beyond initial=3.0.*got 1.0",
    ),
    (lambda: chirp(T, -1.0, 2.0), ValueError, r"omega_start must be >= 0 rad/s; got -1.0"),
    (
        lambda: chirp(np.zeros(3), 1.0, 2.0),
        ValueError,
        r"duration is None.*last time stamp.*got 0.0",
    ),
    (
        lambda: chirp(T, 1.0, 2.0, duration=-3.0),
        ValueError,
        r"duration must be a number > 0; got -3.0",
    ),
    (
        lambda: multisine(100, 0.0, (1.0, 2.0)),
        ValueError,
        r"ts must be a positive number of seconds; got 0.0",
    ),
    (
        lambda: multisine(100, -0.1, (1.0, 2.0)),
        ValueError,
        r"ts must be a positive number of seconds; got -0.1",
    ),
    (
        lambda: multisine(100, 0.01, (5.0, 1.0)),
        ValueError,
        r"band must satisfy 0 <= omega_low < omega_high.*\(5.0, 1.0\)",
    ),
    (
        lambda: multisine(100, 0.01, (1.0, 400.0)),
        ValueError,
        r"band\[1\]=400.0 rad/s is above the Nyquist",
    ),
    (lambda: multisine(100, 0.01, (1.0, 2.0)), ValueError, r"holds no DFT line.*6.283 rad/s apart"),
    (lambda: multisine(100, 0.01, 3.0), TypeError, r"band must be a pair"),
    (
        lambda: multisine(101, 0.01, (1.0, 100.0), n_periods=2),
        ValueError,
        r"n_samples=101 is not a multiple of n_periods=2",
    ),
    (
        lambda: multisine(300, 0.01, (1.0, 100.0), n_periods=2, period=100),
        ValueError,
        r"n_periods=2 periods of period=100",
    ),
    (
        lambda: multisine(100, 0.01, (10.0, 100.0), phases="flat"),
        ValueError,
        r"phases must be 'schroeder' or 'random'; got 'flat'",
    ),
    (
        lambda: multisine(2.5, 0.01, (1.0, 2.0)),
        TypeError,
        r"n_samples must be a whole number >= 1; got 2.5",
    ),
    (
        lambda: multisine(100, 0.01, (10.0, 100.0), amplitude=0.0),
        ValueError,
        r"amplitude must be a number > 0; got 0.0",
    ),
    (
        lambda: prbs(100, 0.02, clock_period=0.03),
        ValueError,
        r"clock_period must be a whole multiple of ts=0.02 s; got 0.03",
    ),
    (
        lambda: prbs(100, 0.02, 0.02, levels=(1.0, 1.0)),
        ValueError,
        r"levels must be two different values; got \(1.0, 1.0\)",
    ),
    (
        lambda: prbs(100, 0.02, 0.02, order=1),
        ValueError,
        r"order must be a whole number in \[2, 32\]; got 1",
    ),
    (
        lambda: prbs(100, 0.02, 0.02, order=40),
        ValueError,
        r"order must be a whole number in \[2, 32\]; got 40",
    ),
    (lambda: prbs(0, 0.02, 0.02), ValueError, r"n_samples must be a whole number >= 1; got 0"),
    (lambda: bandwidth_from_chirp(T, C, C[:-1]), ValueError, r"same length; got 100, 100 and 99"),
    (
        lambda: bandwidth_from_chirp(T, C, np.where(T[7] == T, np.nan, C)),
        ValueError,
        r"response has a non-finite value nan at row 7",
    ),
    (
        lambda: bandwidth_from_chirp(T, np.where(T[3] == T, np.inf, C), C),
        ValueError,
        r"command has a non-finite value inf at row 3",
    ),
    (
        lambda: bandwidth_from_chirp(T[::-1], C, C),
        ValueError,
        r"time column 't' is not sorted: row 1",
    ),
    (
        lambda: bandwidth_from_chirp(np.r_[T[:5], T[4], T[6:]], C, C),
        ValueError,
        r"repeats the time stamp 0.4 at rows 4 and 5",
    ),
    (
        lambda: bandwidth_from_chirp(T, C, C, threshold=0.0),
        ValueError,
        r"threshold must be a number > 0; got 0.0",
    ),
    (
        lambda: bandwidth_from_chirp(T, C, C, frequency=-np.ones(100)),
        ValueError,
        r"frequency must be >= 0 rad/s; got -1.0 at row 0",
    ),
    (
        lambda: bandwidth_from_chirp(T, C, C, frequency=np.ones(5)),
        ValueError,
        r"one value per time stamp \(100\); got 5",
    ),
    (lambda: bandwidth_from_chirp(T, np.ones(100), C), ValueError, r"command is constant"),
    (
        lambda: bandwidth_from_chirp(T[:20], C[:20], C[:20], frequency=paper_chirp_frequency),
        ValueError,
        r"holds 0.06 cycles",
    ),
    (
        lambda: bandwidth_from_chirp(T, C, C, cycles_per_window=0),
        ValueError,
        r"cycles_per_window must be a whole number >= 1; got 0",
    ),
]


@pytest.mark.parametrize(("call", "error", "message"), BAD_CALLS)
def test_bad_input_is_refused_with_a_clear_message(call, error, message) -> None:
    with pytest.raises(error, match=message):
        call()


def test_public_names_are_documented() -> None:
    for name in signals.__all__:
        obj = getattr(signals, name)
        assert (obj.__doc__ and "Examples" in obj.__doc__) or name == "BandwidthResult", name
