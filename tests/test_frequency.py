"""The frequency-domain core against systems whose answer is known (issue 43's figures).

- A Wiener-Hammerstein system (two known filters around ``x + a x^3``), M = 8 x P = 4: the
  robust BLA inside its own 95 % band at >= 90 % of the excited lines against the analytic BLA
  (Bussgang: ``G1 G2 (1 + 3 a sigma_x^2)``), and the distortion variance within 1.5 dB of its
  Monte-Carlo value over 200 noise-free realisations (vectorised: one ``lfilter`` call over a
  (2N, 200) array), on average over the excited lines.
- A linear system with 1 % output noise: no distortion detected (99 % F test) at >= 95 % of lines.
- The kind: a squarer shows at the even lines only, a cuber at the non-excited odd lines only.
- A closed loop of the simulated neck with sensor noise fed back: the indirect estimate through
  the reference holds the open-loop plant within its 95 % band at >= 90 % of the frequencies in
  the loop's bandwidth; the direct one does not (it is pulled toward -1/C).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal as sps

from neckid.frequency import etfe, indirect_frf, robust_bla, smoothed_frf
from neckid.signals import multisine_plan

PERIOD = 512
FIRST = sps.cheby1(2, 1, 0.3)  # G1: (b, a), ts = 1 s
SECOND = sps.butter(2, 0.5)  # G2
CUBIC = 0.3


def _response(filter_ba: tuple, omega: np.ndarray) -> np.ndarray:
    return sps.freqz(*filter_ba, worN=omega)[1]


def _wiener_hammerstein(u: np.ndarray) -> np.ndarray:
    x = sps.lfilter(*FIRST, u, axis=0)
    return sps.lfilter(*SECOND, x + CUBIC * x**3, axis=0)


def _plan(seed: int, **settings):
    options = {"n_realisations": 8, "n_periods": 4, **settings}
    return multisine_plan(PERIOD, 1.0, (1e-9, 0.8 * math.pi), seed=seed, **options)


def _bla(plan, y):
    return robust_bla(
        plan.signal,
        y[:, None],
        1.0,
        period=PERIOD,
        n_realisations=plan.n_realisations,
        n_periods=plan.n_periods,
        excited=plan.excited_lines,
    )


def _line_amplitude(plan) -> float:
    one = plan.signal[plan.period_index == 0][:PERIOD, 0]
    return float(np.abs(np.fft.rfft(one)[plan.excited_lines[0]]) * 2 / PERIOD)


def _monte_carlo_distortion(plan, realisations: int, seed: int) -> np.ndarray:
    """Variance over noise-free realisations of Y/U at the plan's excited lines."""
    lines, amplitude = plan.excited_lines, _line_amplitude(plan)
    phases = np.random.default_rng(seed).uniform(0, 2 * math.pi, (realisations, lines.size))
    spectrum = np.zeros((realisations, PERIOD // 2 + 1), complex)
    spectrum[:, lines] = amplitude * PERIOD / 2 * np.exp(1j * phases)
    one = np.fft.irfft(spectrum, n=PERIOD, axis=1).T
    u = np.vstack([one, one])  # a transient period, then the measured one
    y = _wiener_hammerstein(u)
    frf = np.fft.rfft(y[PERIOD:], axis=0)[lines] / np.fft.rfft(u[PERIOD:], axis=0)[lines]
    return np.var(frf, axis=1, ddof=1)


@pytest.fixture(scope="module")
def wiener_hammerstein():
    plan = _plan(seed=0)
    rng = np.random.default_rng(100)
    y = _wiener_hammerstein(plan.signal[:, 0])
    y = y + 0.01 * rng.standard_normal(y.shape)
    return plan, _bla(plan, y)


def test_bla_of_wiener_hammerstein_holds_the_bussgang_bla(wiener_hammerstein) -> None:
    plan, bla = wiener_hammerstein
    omega = bla.omega
    amplitude = _line_amplitude(plan)
    variance_x = np.sum(np.abs(_response(FIRST, omega)) ** 2 * amplitude**2 / 2)
    analytic = _response(FIRST, omega) * _response(SECOND, omega) * (1 + 3 * CUBIC * variance_x)
    inside = np.abs(bla.frf[:, 0, 0] - analytic) <= bla.band_radius(0.95)[:, 0, 0]
    assert inside.mean() >= 0.90, inside.mean()
    # and a wrong constant (the linear part alone) is far outside
    linear_only = _response(FIRST, omega) * _response(SECOND, omega)
    assert (np.abs(bla.frf[:, 0, 0] - linear_only) <= bla.band_radius()[:, 0, 0]).mean() < 0.5


def test_distortion_variance_matches_monte_carlo(wiener_hammerstein) -> None:
    plan, bla = wiener_hammerstein
    reference = _monte_carlo_distortion(plan, 200, seed=7)
    estimate = bla.distortion_variance[:, 0, 0]
    difference_db = 10 * np.log10(estimate / reference)
    assert abs(difference_db.mean()) <= 1.5, difference_db.mean()
    assert abs(10 * np.log10(estimate.mean() / reference.mean())) <= 1.5
    # the noise (1e-2 on the output) is far below the distortions here
    assert np.median(bla.nl_variance / bla.noise_variance) > 100


def test_linear_system_shows_no_distortion() -> None:
    plan = _plan(seed=3)
    rng = np.random.default_rng(4)
    clean = sps.lfilter(*FIRST, plan.signal[:, 0])
    y = clean + 0.01 * clean.std() * rng.standard_normal(clean.shape)
    bla = _bla(plan, y)
    assert 1 - bla.nonlinear_detected(0.99).mean() >= 0.95
    assert bla.levels.kind_detected("even") is False
    assert bla.levels.kind_detected("odd") is False
    truth = _response(FIRST, bla.omega)
    assert (np.abs(bla.frf[:, 0, 0] - truth) <= bla.band_radius()[:, 0, 0]).mean() >= 0.9
    assert "no nonlinear distortion" in bla.verdict()


@pytest.mark.parametrize(
    ("power", "even", "odd"), [(2, True, False), (3, False, True)], ids=["squarer", "cuber"]
)
def test_kind_of_nonlinearity(power: int, even: bool, odd: bool) -> None:
    plan = _plan(seed=5)
    rng = np.random.default_rng(6)
    x = sps.lfilter(*SECOND, plan.signal[:, 0])
    clean = sps.lfilter(*SECOND, x + 0.2 * x**power)
    bla = _bla(plan, clean + 0.01 * clean.std() * rng.standard_normal(clean.shape))
    assert bla.levels.kind_detected("even") is even
    assert bla.levels.kind_detected("odd") is odd
    assert f"{'even' if even else 'odd'} nonlinearity detected" in bla.verdict()


def test_mimo_bla_recovers_each_pair() -> None:
    plan = multisine_plan(128, 1.0, (0.05, 2.5), n_realisations=4, n_periods=2, n_inputs=2, seed=8)
    u = plan.signal
    y = np.column_stack(
        [sps.lfilter(*FIRST, u[:, 0]) + 0.5 * u[:, 1], sps.lfilter(*SECOND, u[:, 1])]
    )
    bla = robust_bla(u, y, 1.0, period=128, n_realisations=4, n_periods=2)
    assert bla.n_blocks == 2
    np.testing.assert_allclose(bla.frf[:, 0, 0], _response(FIRST, bla.omega), atol=1e-6)
    np.testing.assert_allclose(bla.frf[:, 0, 1], 0.5, atol=1e-6)
    np.testing.assert_allclose(bla.frf[:, 1, 0], 0.0, atol=1e-6)


def test_etfe_and_smoothed_estimates_on_open_loop_data() -> None:
    rng = np.random.default_rng(9)
    u = rng.standard_normal(8192)
    y = sps.lfilter(*FIRST, u) + 0.05 * rng.standard_normal(u.size)
    raw = etfe(u, y, 1.0)
    assert raw.omega.size == 4096 and np.isnan(raw.band_radius).all()
    for method, width in (("welch", None), ("blackman-tukey", 128)):
        estimate = smoothed_frf(u, y, 1.0, method=method, lag_width=width)
        truth = _response(FIRST, estimate.omega)
        assert estimate.inside(truth).mean() >= 0.9, method
        assert estimate.coherence.max() > 0.9
    # spa's default width (30 lags) smooths the resonance away: a bias its band does not cover
    narrow = smoothed_frf(u, y, 1.0, method="blackman-tukey")
    assert narrow.inside(_response(FIRST, narrow.omega)).mean() < 0.8


class _NoisySensor:
    """The simulated neck with a coloured measurement noise the controller sees too."""

    def __init__(self, noise: np.ndarray) -> None:
        from neckid.plant import SoftNeck

        self.neck, self.noise, self.index = SoftNeck(seed=1), noise, 0
        self.ts, self.output_names = self.neck.ts, self.neck.output_names

    def reset(self) -> None:
        self.neck.reset()
        self.index = 0

    def step(self, u):
        value = self.neck.step(u) + self.noise[self.index]
        self.index += 1
        return value


def test_indirect_estimate_recovers_the_neck_in_closed_loop() -> None:
    from neckid.plant import InclinationController, closed_loop

    n, ts, segment = 2**15, 0.02, 2048
    rng = np.random.default_rng(0)
    reference = 10 + 2 * sps.lfilter(*sps.butter(2, 0.1), rng.standard_normal(n))
    noise = sps.lfilter(*sps.butter(1, 0.3), rng.standard_normal(n))
    runs = {}
    for name, level in (("clean", 0.0), ("noisy", 1.0)):
        data = closed_loop(_NoisySensor(level * noise), InclinationController(), reference, ts)
        runs[name] = (data.channel("velocity_command"), data.y[:, 0])
    u, y = runs["clean"]
    truth = smoothed_frf(u, y, ts, segment=segment).frf  # the open-loop plant on this trajectory
    loop = smoothed_frf(reference, y, ts, segment=segment)
    bandwidth = loop.omega[np.argmax(np.abs(loop.frf) < 1 / math.sqrt(2))]
    inside_band = loop.omega <= bandwidth
    assert 2.0 < bandwidth < 20.0
    u, y = runs["noisy"]
    indirect = indirect_frf(reference, u, y, ts, segment=segment, reference_name="reference")
    direct = smoothed_frf(u, y, ts, segment=segment)
    assert indirect.inside(truth)[inside_band].mean() >= 0.90
    assert direct.inside(truth)[inside_band].mean() < 0.5
    assert indirect.estimate.startswith("indirect through reference")
