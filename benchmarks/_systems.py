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
