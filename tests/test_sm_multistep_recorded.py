"""sm-multistep's choice and bands on the shared soft-neck logs stay the ones recorded (issue 42).

The speed-ups of issue 42 (partial distance search in every walk of the kd-tree: a point's
squared distance is summed only until it exceeds the distance at which the point could change a
running bound) must leave the chosen settings, ε, γ, the cross-validation table and the
guaranteed bands bit for bit as they were. The values below were recorded with the code of
commit 11e6845 (before the change), on the first 700 samples of three stair logs for training
and one for testing, horizon 4, every setting left to the cross-validation.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from neckid import Lags
from neckid.datasets import load_softneck_log
from neckid.experiments.benchmark import softneck_protocol
from neckid.models.set_membership.multistep import MultiStepSetMembership

STAIR = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "softneck" / "stair"

#: Recorded at commit 11e6845 (see the module docstring).
SETTINGS = [(3.0, 0.3, "local"), (2.5, 0.3, "local"), (2.0, 0.3, "local"), (2.0, 0.3, "local")]
EPSILON = [1.043393987183534, 1.2953266434058057, 1.1683476601736342, 1.1984075604188118]
GAMMA = [17.12493520138995, 9.729441457750083, 16.121152459681902, 13.669005479536384]
#: Sums over the 4 x 28 rows of ``selection_.table()`` (math.fsum).
COVERAGE_SUM, WIDTH_SUM = 110.28944826341365, 1812.4899265886422
#: Sums of the guaranteed band's lower and upper ends on the test log, by horizon.
BANDS = {1: (10696.303629068005, 12672.490429853635), 4: (10022.98947570151, 12311.815904852865)}


def _log(name: str):
    path = STAIR / f"{name}response.csv"
    if not path.exists():
        pytest.skip(f"the shared soft-neck logs are not at {STAIR} (needs {path.name})")
    return softneck_protocol(load_softneck_log(path))[:700]


def test_choice_and_bands_as_recorded() -> None:
    train = [_log("ada000"), _log("int600"), _log("fra000")]
    test = _log("fra200")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = MultiStepSetMembership(Lags(outputs=[1, 2], inputs=[0, 1]), horizon=4).fit(train)
    chosen = [(s.epsilon_factor, s.input_weight, s.lipschitz) for s in model.settings_]
    assert chosen == SETTINGS
    assert model.epsilon_[:, 0].tolist() == EPSILON
    assert model.gamma_[:, 0].tolist() == GAMMA
    table = model.selection_.table()
    assert math.fsum(table.coverage.tolist()) == COVERAGE_SUM
    assert math.fsum(table.width.tolist()) == WIDTH_SUM
    for k, (low, high) in BANDS.items():
        ahead = model.predict_ahead(test, steps=k)
        s = ahead.n_initial
        assert (float(np.sum(ahead.lower[s:])), float(np.sum(ahead.upper[s:]))) == (low, high)
