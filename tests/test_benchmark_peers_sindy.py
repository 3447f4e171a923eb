"""The PySINDy peer (pysindy-stlsq): the same regressor as neckid's, its compiled free run checked."""

from __future__ import annotations

import numpy as np
import pytest

from neckid import IOData, Lags
from neckid.experiments.benchmark.peers import peer_candidates, peer_unavailable
from neckid.experiments.benchmark.settings import PEER_METHODS, runs_on


def _record(n: int = 1500) -> IOData:
    rng = np.random.default_rng(0)
    u = rng.uniform(-1.0, 1.0, n)
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = 0.5 * y[t - 1] + 0.1 * y[t - 2] - 0.1 * y[t - 1] ** 3 + 0.8 * u[t - 1] + 0.3 * u[t]
    return IOData(u, y, ts=1.0)


def test_the_peer_is_listed_and_runs_on_the_public_benchmarks_only() -> None:
    assert "pysindy-stlsq" in PEER_METHODS
    assert runs_on("pysindy-stlsq", "silverbox") and not runs_on("pysindy-stlsq", "softneck")


def test_the_peer_identifies_and_simulates_as_pysindy_does() -> None:
    if peer_unavailable("pysindy-stlsq") is not None:
        pytest.skip("PySINDy is not installed (pip install 'neckid[peers]')")
    from neckid.experiments.benchmark.peers_sindy import PySindyPeer

    data = _record()
    peer = PySindyPeer(Lags.arx(2, 2, 0), threshold=0.01).fit(data)
    assert peer.max_lag_ == 2
    assert peer.check_simulate(data, steps=300) < 1e-9  # the compiled loop is DiscreteSINDy's
    result = peer.simulate(data)
    assert result.fit_percent(data)[0] > 99.9
    np.testing.assert_array_equal(result.y[:2], data.y[:2])
    assert len(peer_candidates("pysindy-stlsq", "silverbox")) == 15  # 3 lag sets x 5 thresholds
