"""The domain of validity: regressors of a new log against the training regressors."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from neckid import IOData, Lags, LinearARX, SetMembership, load_model
from neckid.models.base import ExtrapolationWarning
from neckid.models.io import read_model_file, write_model_file


def _log(seed: int, scale: float = 1.0, n: int = 600) -> IOData:
    rng = np.random.default_rng(seed)
    u = scale * np.repeat(rng.uniform(-1.0, 1.0, n // 10), 10)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.8 * y[t - 1] + 0.4 * u[t - 1]
    return IOData(u, y, ts=0.02, output_names=["inclination"], output_units=["deg"])


def test_the_training_log_is_inside_and_a_wider_one_outside_by_term_and_channel() -> None:
    train = _log(1)
    model = LinearARX(Lags.arx(1, 2)).fit(train)
    inside = model.domain(train)
    assert inside.share == 0.0 and set(inside.by_term) == set(model.lags_.names)
    wide = model.domain(_log(2, scale=3.0))
    assert wide.share > 0.3
    assert set(wide.by_channel) == {"u", "inclination"}
    assert wide.by_term["u(t-1)"] > 0.3
    assert not wide.outside[: model.max_lag_].any()


def test_sm_models_also_measure_the_distance_to_the_nearest_training_regressor() -> None:
    train = _log(3)
    model = SetMembership(Lags.arx(1, 1)).fit(train)
    found = model.domain(train)
    assert found.radius is not None and found.distance is not None
    assert np.nanmax(found.distance) == pytest.approx(0.0, abs=1e-9)  # its own regressors
    # Inside the box, but a combination the training never produced: y high while u low.
    odd = train.replace(y=np.where(train.u[:, 0] < 0, train.y.max(), train.y.min()) * 0.9)
    far = model.domain(odd)
    assert np.nanmax(far.distance) > far.radius
    assert far.share > 0


def test_the_ranges_travel_in_the_model_file_and_old_files_still_load(tmp_path: Path) -> None:
    model = LinearARX(Lags.arx(1, 1)).fit(_log(4))
    path = model.save(tmp_path / "arx.npz")
    loaded = load_model(path)
    assert loaded.regressor_ranges_ == model.regressor_ranges_
    # A file written before the ranges were recorded: the same header without the key.
    class_name, arrays, meta = read_model_file(path)
    meta.pop("regressor_ranges")
    old = write_model_file(tmp_path / "old.npz", class_name, arrays, meta)
    again = load_model(old)
    assert again.regressor_ranges_ == {} and again.domain(_log(5)).by_term == {}


def test_a_free_run_outside_the_regressor_box_warns_naming_the_terms() -> None:
    model = LinearARX(Lags.arx(1, 1)).fit(_log(6))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = model.simulate(_log(7, scale=2.5))
    messages = [str(w.message) for w in caught if issubclass(w.category, ExtrapolationWarning)]
    assert any(
        "regressor terms outside their training range: inclination(t-1)" in m for m in messages
    )
    assert any("u(t-1) " in m for m in messages)
    assert result.extras["outside_domain"] > 0.05
