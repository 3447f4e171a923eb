"""LinearARX's simulation plan (issue 42): built once per fitted model, never stale, never saved.

``LinearARX.simulate`` keeps what its single-output free run reads of the model (the filters,
the terms with a training range, the plain divergence envelope, the impulse-response norms) in
``model._simulation_plan``. Each test changes what a plan is built from, in every way a user
can (refit, ``partial_fit``, an attribute set or changed in place), and checks the run against
a model that never had a plan: the same model written to a file and read back.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from neckid import IOData, Lags, LinearARX, load_model
from neckid.models.results import DivergenceError, ExtrapolationWarning, ModelResult

pytestmark = pytest.mark.filterwarnings("ignore", category=ExtrapolationWarning)


def log(n: int, seed: int, gain: float = 0.5, scale: float = 1.0) -> IOData:
    rng = np.random.default_rng(seed)
    u = scale * rng.normal(size=n)
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = 0.7 * y[t - 1] - 0.2 * y[t - 2] + gain * u[t - 1] + 0.01 * rng.normal()
    return IOData(u, y, ts=0.02, input_names=["u"], output_names=["incl"])


def fresh(model: LinearARX, folder: Path) -> LinearARX:
    """The same fitted model without a plan: written to a file and read back."""
    return load_model(model.save(folder / f"model{len(list(folder.iterdir()))}.npz"))


def same(a: ModelResult, b: ModelResult) -> bool:
    return a.y.tobytes() == b.y.tobytes() and a.extras == b.extras


def test_refit_and_partial_fit_rebuild_the_plan(tmp_path: Path) -> None:
    data, other = log(3000, 0), log(3000, 1, gain=-0.8, scale=2.0)
    model = LinearARX(Lags.arx(2, 2, 1)).fit(data)
    before = model.simulate(other)
    model.fit(other)  # refitted: other coefficients, ranges and lags
    after = model.simulate(other)
    assert not same(after, before)
    assert same(after, fresh(model, tmp_path).simulate(other))
    model.partial_fit(data)
    assert same(model.simulate(other), fresh(model, tmp_path).simulate(other))
    assert not same(model.simulate(other), after)


def test_attributes_changed_in_place_rebuild_the_plan(tmp_path: Path) -> None:
    data = log(3000, 0)
    model = LinearARX(Lags.arx(2, 2, 1)).fit(data)
    first = model.simulate(data)
    model.coef_[2, 0] *= 1.5  # an input coefficient, in place
    changed = model.simulate(data)
    assert not same(changed, first)
    assert same(changed, fresh(model, tmp_path).simulate(data))
    model.intercept_ += 0.25
    assert same(model.simulate(data), fresh(model, tmp_path).simulate(data))
    # a narrower output range, in place: the envelope (and the run's verdict) follow it
    low, high = model.training_ranges_["incl"]
    model.training_ranges_["incl"] = (low / 100, high / 100)
    with pytest.raises(DivergenceError) as raised:
        model.simulate(data)
    with pytest.raises(DivergenceError) as expected:
        fresh(model, tmp_path).simulate(data)
    assert str(raised.value) == str(expected.value)
    model.training_ranges_ = {}  # as a file written before the ranges were kept
    model.regressor_ranges_ = {}
    result = model.simulate(data)
    assert "outside_domain" not in result.extras
    assert same(result, fresh(model, tmp_path).simulate(data))


def test_impulse_norms_follow_the_coefficients(tmp_path: Path) -> None:
    """The widened envelope of a log beyond the training inputs uses the current filter."""
    data = log(3000, 0)
    far = log(3000, 2, scale=30.0)
    model = LinearARX(Lags.arx(2, 2, 1)).fit(data)
    wide = model.divergence_envelope(data=far)["incl"]
    assert wide[1] > model.divergence_envelope()["incl"][1]  # the inputs reach beyond
    model.coef_[0, 0] = 0.2  # a faster pole: a smaller ||h||_1
    narrower = model.divergence_envelope(data=far)["incl"]
    assert narrower != wide
    assert narrower == fresh(model, tmp_path).divergence_envelope(data=far)["incl"]
    run, expected = (model.simulate(far), fresh(model, tmp_path).simulate(far))
    assert same(run, expected)


def test_plan_is_per_model_and_not_in_the_file(tmp_path: Path) -> None:
    data = log(3000, 0)
    model = LinearARX(Lags.arx(2, 2, 1)).fit(data)
    written = np.load(model.save(tmp_path / "before.npz"))
    model.simulate(data)
    twin = copy.deepcopy(model)
    twin.coef_[3, 0] = 0.0
    assert not same(twin.simulate(data), model.simulate(data))  # the copy's change is its own
    assert same(model.simulate(data), fresh(model, tmp_path).simulate(data))
    rewritten = np.load(model.save(tmp_path / "after.npz"))
    assert sorted(rewritten.files) == sorted(written.files)
