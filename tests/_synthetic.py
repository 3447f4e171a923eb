"""Synthetic systems that several test modules identify (imported as ``from _synthetic import ...``)."""

from __future__ import annotations

import numpy as np

from neckid import IOData


def arx_system(n: int, seed: int) -> IOData:
    """y(t) = 1.2 y(t-1) - 0.5 y(t-2) + 0.8 u(t-3) + 0.4 u(t-4) + e(t): na=2, nb=2, delay 3."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=n)
    e = 0.01 * rng.normal(size=n)
    y = np.zeros(n)
    for t in range(4, n):
        y[t] = 1.2 * y[t - 1] - 0.5 * y[t - 2] + 0.8 * u[t - 3] + 0.4 * u[t - 4] + e[t]
    return IOData(u, y, ts=0.02, input_names=["cmd"], output_names=["incl"])
