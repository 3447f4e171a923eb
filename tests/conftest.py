"""Shared test set-up: a non-interactive matplotlib backend and small reusable logs."""

from __future__ import annotations

import matplotlib
import numpy as np
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
