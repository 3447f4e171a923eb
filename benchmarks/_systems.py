"""Synthetic systems shared by the benchmark scripts (run them as ``python benchmarks/bench_*.py``)."""

from __future__ import annotations

import numpy as np

from neckid import IOData, Lags

#: The regressor of the neck-like system: three past outputs, 8-10 past values of each input.
NECK_LIKE_LAGS = Lags(outputs=3, inputs=[8, 9, 10])
#: Bound of the uniform noise added to each output sample.
NECK_LIKE_NOISE = 1e-3


def neck_like(n_samples: int, seed: int) -> IOData:
    """Three smoothed random-step inputs (motor velocities) into a saturating second-order output."""
    rng = np.random.default_rng(seed)
    hold = 25
    steps = rng.uniform(-1, 1, size=(n_samples // hold + 1, 3)).repeat(hold, axis=0)[:n_samples]
    u = np.empty_like(steps)
    u[0] = steps[0]
    for t in range(1, n_samples):
        u[t] = 0.9 * u[t - 1] + 0.1 * steps[t]
    y = np.zeros(n_samples)
    drive = u @ np.array([1.0, -0.5, -0.5])
    for t in range(10, n_samples):
        y[t] = (
            1.6 * y[t - 1]
            - 0.7 * y[t - 2]
            + 0.08 * np.tanh(2.0 * drive[t - 8])
            + 0.02 * drive[t - 9] * abs(y[t - 1])
            + rng.uniform(-NECK_LIKE_NOISE, NECK_LIKE_NOISE)
        )
    return IOData(u, y, ts=0.02)


#: The regressor of the held-input log (issue 33): the last output and the last input.
HELD_INPUT_LAGS = Lags(outputs=[1], inputs=[1])


def held_input(n_samples: int, seed: int = 0, hold: int = 20, noise: float = 1e-3) -> IOData:
    """A first-order saturating plant whose input is held for ``hold`` samples at a time.

    ``y(t) = 0.9 y(t-1) + 0.1 tanh(2 u(t-1)) + 0.02 u(t-1) |y(t-1)|`` plus uniform noise of
    bound ``noise`` on the measured output. Nearly linear in ``y(t-1)``: many distant pairs of
    regressors have nearly the largest slope, the hard case for γ*(ε) at large ε.
    """
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n_samples // hold + 1).repeat(hold)[:n_samples]
    y = np.zeros(n_samples)
    for t in range(1, n_samples):
        y[t] = 0.9 * y[t - 1] + 0.1 * np.tanh(2 * u[t - 1]) + 0.02 * u[t - 1] * abs(y[t - 1])
    return IOData(u[:, None], y + rng.uniform(-noise, noise, n_samples), ts=0.02)
