"""Shared test set-up: a non-interactive matplotlib backend and small reusable logs."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
import pytest

matplotlib.use("Agg")


@pytest.fixture(autouse=True)
def _close_figures():
    """Close every figure a test (or doctest) opened, so memory does not grow over the run."""
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator; tests never depend on the global NumPy state."""
    return np.random.default_rng(12345)


def _write_cascaded_tanks(root: Path, rng: np.random.Generator) -> Path:
    """A small ``benchmarks/cascaded_tanks/dataBenchmark.csv`` under ``root`` (300 samples)."""
    tanks = root / "benchmarks" / "cascaded_tanks"
    tanks.mkdir(parents=True)
    u = rng.uniform(2, 8, size=(300, 2))
    y = np.zeros((300, 2))
    for t in range(1, 300):
        y[t] = 0.9 * y[t - 1] + 0.1 * np.sqrt(u[t - 1])
    frame = pd.DataFrame(
        {"uEst": u[:, 0], "uVal": u[:, 1], "yEst": y[:, 0], "yVal": y[:, 1], "Ts": np.nan}
    )
    frame.loc[0, "Ts"] = 4.0
    frame.to_csv(tanks / "dataBenchmark.csv", index=False)
    return root


@pytest.fixture
def write_cascaded_tanks() -> Callable[[Path, np.random.Generator], Path]:
    """``write(root, rng)``: a small cascaded-tanks benchmark file in the shared data layout."""
    return _write_cascaded_tanks
