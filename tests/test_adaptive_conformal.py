"""Adaptive conformal bands (Gibbs & Candès 2021): running coverage under a change of run."""

from __future__ import annotations

import numpy as np
import pytest

from neckid import IOData, Lags, LinearARX
from neckid.metrics import coverage
from neckid.models.adaptive_conformal import adaptive_band
from neckid.models.bands import band_meaning
from neckid.models.conformal import calibrate


def _plant(n: int, seed: int, drift: float = 0.0, noise: float = 0.05) -> IOData:
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1.0, 1.0, n)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1] + noise * (1 + drift * t / n) * rng.normal()
    return IOData(u, y + drift * np.linspace(0.0, 1.0, n), ts=0.02)


@pytest.mark.parametrize("steps", [5, None])
def test_running_coverage_tends_to_the_nominal_level_where_a_split_band_does_not(steps) -> None:
    model = LinearARX(Lags.arx(1, 1)).fit(_plant(1000, 0))
    shifted = _plant(4000, 1, drift=1.5)
    band = adaptive_band(model, shifted, steps=steps, coverage=0.9)
    running = band.extras["running_coverage"][-1, 0]
    # Gibbs & Candès, Prop. 4.1: |miss rate − α| <= (max(α1, 1 − α1) + γ) / (γ T).
    bound = (0.9 + 0.005) / (0.005 * (shifted.n_samples - band.n_initial))
    assert abs(running - 0.9) <= bound + 1e-12
    assert abs(running - 0.9) < 0.02
    split = calibrate(model, _plant(1000, 2), coverage=0.9, kind=steps or "simulation")
    fixed = split.simulate(shifted) if steps is None else split.predict_ahead(shifted, steps)
    held = coverage(shifted.y, fixed.lower, fixed.upper, skip=fixed.n_initial)[0]
    assert held < 0.85  # the split band, calibrated before the drift, falls short
    assert band.extras["band"] == "adaptive"
    assert band_meaning(band.extras).startswith("adaptive conformal band (90 % nominal)")


def test_a_calibration_log_starts_the_window() -> None:
    model = LinearARX(Lags.arx(1, 1)).fit(_plant(800, 0))
    data = _plant(300, 3)
    cold = adaptive_band(model, data, steps=1)
    warm = adaptive_band(model, data, steps=1, calibration=_plant(500, 4))
    first = cold.n_initial
    assert np.isinf(cold.upper[first, 0])  # no scores yet: the band cannot be finite
    assert np.isfinite(warm.upper[first, 0])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"coverage": 1.0}, "coverage"),
        ({"step": 0.0}, "step"),
        ({"window": 0}, "window must be an integer >= 1"),
        ({"steps": 0}, "steps must be an integer >= 1 or None"),
    ],
)
def test_bad_settings_are_refused_by_name(kwargs, message) -> None:
    model = LinearARX(Lags.arx(1, 1)).fit(_plant(300, 0))
    with pytest.raises(ValueError, match=message):
        adaptive_band(model, _plant(200, 1), **kwargs)
