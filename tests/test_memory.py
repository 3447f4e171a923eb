"""Settings that would need more memory than the machine has are refused before anything is allocated."""

from __future__ import annotations

import numpy as np
import pytest

import neckid
import neckid.utils.memory
from _synthetic import arx_system
from neckid import Lags, LinearARX, NeuralNARX


@pytest.fixture
def small_machine(monkeypatch: pytest.MonkeyPatch) -> None:
    """A machine with 2 MB available."""
    monkeypatch.setattr(neckid.utils.memory, "available_bytes", lambda: 2 * 1024**2)


def test_a_regressor_too_large_for_the_machine_is_refused(small_machine: None) -> None:
    data = arx_system(20_000, 0)
    with pytest.raises(
        ValueError, match=r"regressor of .*19,970 rows x 60 terms\) needs about 18\.3 MB"
    ):
        LinearARX(Lags.arx(30, 30, 1)).fit(data)
    LinearARX(Lags.arx(2, 2, 1)).fit(data[:2000])  # 2,000 x 4 terms: 125 KB


def test_a_network_too_large_for_the_machine_is_refused(small_machine: None) -> None:
    data = arx_system(300, 0)
    model = NeuralNARX(Lags.arx(2, 2, 3), hidden_layer_sizes=(300, 300), n_networks=2)
    with pytest.raises(
        ValueError, match=r"2 networks of layers \[300, 300\].*smaller hidden layers"
    ):
        model.fit(data)


def test_the_available_memory_is_read() -> None:
    available = neckid.utils.memory.available_bytes()
    assert available is None or available > 0
    assert neckid.utils.memory.describe_bytes(512) == "512 B"
    assert np.isclose(float(neckid.utils.memory.describe_bytes(1.5 * 1024**2).split()[0]), 1.5)


def test_set_membership_refuses_more_terms_than_rows() -> None:
    data = arx_system(300, 1)
    with pytest.raises(
        ValueError, match=r"more training rows than regressor terms: 150 rows for 300"
    ):
        neckid.methods()["sm"].make(Lags.arx(150, 150, 1)).fit(data)


def test_a_pnlss_jacobian_too_large_for_the_machine_is_refused(small_machine: None) -> None:
    from neckid.models.pnlss import PolynomialStateSpace

    with pytest.raises(ValueError, match=r"free-run fit's Jacobian .* needs about .*order=3"):
        PolynomialStateSpace(order=3, degree=3, max_iter=2).fit(arx_system(2000, 2))
