"""The pykoopman peer: its state and control rows, its refusals, and a run when pykoopman is there.

pykoopman pins NumPy 1.26: it runs in the interpreter ``NECKID_PYKOOPMAN_PYTHON`` names (or
this one when it imports here); without either the run test is skipped, saying so.
"""

from __future__ import annotations

import numpy as np
import pytest

from neckid import IOData, Lags
from neckid.experiments.benchmark import peers_koopman
from neckid.experiments.benchmark.peers import peer_candidates, peer_unavailable
from neckid.experiments.benchmark.peers_koopman import PYTHON_VARIABLE, PyKoopmanPeer
from neckid.models.base import NotFittedError


def _record(n: int = 600, seed: int = 0) -> IOData:
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1.0, 1.0, n)
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = 0.6 * y[t - 1] + 0.2 * y[t - 2] + 0.5 * u[t - 1] - 0.1 * y[t - 1] ** 3
    return IOData(u, y, ts=0.1)


@pytest.mark.parametrize(
    ("lags", "delays", "lag", "max_lag"),
    [(Lags.arx(2, 2, 1), 1, 1, 3), (Lags.arx(2, 3, 0), 1, 0, 2), (Lags.arx(1, 1, 1), 0, 1, 2)],
)
def test_the_state_holds_every_lag_of_the_regressor(lags, delays, lag, max_lag):
    peer = PyKoopmanPeer(lags).fit(_record())
    assert (peer.n_delays_, peer.input_lag_, peer.max_lag_) == (delays, lag, max_lag)
    data = _record(20)
    x, c = peer._rows(data, lag)
    # c(t) = u(t + 1 - d): y(t + 1) reads it; x(t) = [y(t), u(t - d)]
    np.testing.assert_array_equal(c[5], data.u[6 - lag])
    np.testing.assert_array_equal(x[5], [data.y[5, 0], data.u[5 - lag, 0]])


def test_refusals():
    with pytest.raises(NotFittedError):
        PyKoopmanPeer(Lags.arx(1, 1)).simulate(_record())
    with pytest.raises(ValueError, match="one training record"):
        PyKoopmanPeer(Lags.arx(1, 1)).fit([_record(), _record(seed=1)])
    with pytest.raises(ValueError, match="input lags from 0 or 1"):
        PyKoopmanPeer(Lags(outputs=[1], inputs=[2])).fit(_record())


def test_a_missing_interpreter_is_a_skip_row(monkeypatch, tmp_path):
    monkeypatch.setenv(PYTHON_VARIABLE, str(tmp_path / "no-python"))
    peers_koopman._probe.cache_clear()
    try:
        reason = peer_unavailable("pykoopman-edmdc")
        assert reason is not None and reason.startswith("skipped:") and PYTHON_VARIABLE in reason
        assert peer_candidates("pykoopman-edmdc", "silverbox") == []
    finally:
        peers_koopman._probe.cache_clear()


def test_the_peer_runs_beside_koopman():
    if peer_unavailable("pykoopman-edmdc") is not None:
        pytest.skip(f"pykoopman cannot run here: {peer_unavailable('pykoopman-edmdc')}")
    train, test = _record(1500), _record(500, seed=2)
    peer = PyKoopmanPeer(Lags.arx(2, 2), n_centers=10).fit(train)
    result = peer.simulate(test)
    assert result.kind == "simulation" and result.n_initial == peer.max_lag_
    np.testing.assert_array_equal(result.y[: peer.max_lag_], test.y[: peer.max_lag_])
    assert result.fit_percent(test)[0] > 80.0
