"""SparseNARX (sindy): recovery of a sparse system, the threshold's selection, bags, files, info."""

from __future__ import annotations

import json

import numpy as np
import pytest

import neckid
from neckid import IOData, Lags
from neckid.models.sindy import SparseNARX
from neckid.models.sindy.summary import coefficient_unit, describe_sindy, equation_summary

TRUE_TERMS = {"y(t-1)": 0.5, "y(t-1)^3": -0.1, "u(t-1)": 0.8, "y(t-1) u(t-1)": 0.2}


def _sparse_system(n: int = 3000, noise: float = 0.01, seed: int = 0) -> IOData:
    """y(t) = 0.5 y(t−1) − 0.1 y(t−1)³ + 0.8 u(t−1) + 0.2 u(t−1) y(t−1), output noise 1 % of its std."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1.0, 1.0, n)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.5 * y[t - 1] - 0.1 * y[t - 1] ** 3 + 0.8 * u[t - 1] + 0.2 * u[t - 1] * y[t - 1]
    measured = y + noise * y.std() * rng.normal(size=n)
    return IOData(u, measured, ts=0.01, input_units=["V"], output_units=["deg"])


@pytest.mark.parametrize("fit_for", ["simulation", "prediction"])
def test_recovers_exactly_the_four_terms_within_two_percent(fit_for: str) -> None:
    model = SparseNARX(Lags.arx(1, 1), fit_for=fit_for).fit(_sparse_system())
    found = model.terms()
    assert set(found) == set(TRUE_TERMS), found
    for name, value in TRUE_TERMS.items():
        assert abs(found[name] - value) <= 0.02 * abs(value), (name, found[name])
    others = np.delete(model.coef_[:, 0], list(np.flatnonzero(model.coef_[:, 0])))
    assert np.all(np.abs(others) <= 1e-3)
    assert model.selection_["rule"].startswith("paired")
    assert model.threshold_ in model.selection_["thresholds"]


def test_a_large_threshold_keeps_fewer_terms_and_the_rule_chooses_on_held_out_fits() -> None:
    data = _sparse_system(1500)
    coarse = SparseNARX(Lags.arx(1, 1), thresholds=[0.3], fit_for="prediction").fit(data)
    assert len(coarse.terms()) < 4
    assert coarse.selection_ == {}  # one threshold: used as given
    chosen = SparseNARX(Lags.arx(1, 1), fit_for="prediction").fit(data)
    report = chosen.selection_
    means = report["mean_fit"]
    pairs = list(zip(report["degrees"], report["thresholds"], strict=True))
    picked = pairs.index((report["chosen_degree"], chosen.threshold_))
    assert means[picked] >= max(m for m in means if m is not None) - 1.0
    assert report["chosen_degree"] == 3  # the cubic term matters: degree 1 and 2 fit worse
    assert max(means[: len(means) // 3]) < means[picked] - 1.0


def test_bags_give_intervals_around_the_coefficients_and_inclusion() -> None:
    model = SparseNARX(Lags.arx(1, 1), fit_for="prediction", ensemble=12).fit(_sparse_system(1500))
    kept = np.flatnonzero(model.coef_[:, 0])
    low, high = model.coef_interval_[:, kept, 0]
    assert np.all(low <= model.coef_[kept, 0]) and np.all(model.coef_[kept, 0] <= high)
    assert np.all(model.inclusion_[kept, 0] == 1.0)
    rows = equation_summary(model)["terms"]
    assert all("interval" in row and row["inclusion"] == 1.0 for row in rows)


def test_the_equation_has_units() -> None:
    model = SparseNARX(Lags.arx(1, 1), fit_for="prediction").fit(_sparse_system(1500))
    summary = model.schedule_summary()["equation"]
    assert summary["equations"][0].startswith("y(t) [deg] = 0.4999 y(t-1) + 0.8 u(t-1)")
    units = {row["term"]: row["unit"] for row in summary["terms"]}
    assert units == {
        "y(t-1)": "-",
        "u(t-1)": "deg/V",
        "y(t-1) u(t-1)": "1/V",
        "y(t-1)^3": "1/deg^2",
    }
    assert coefficient_unit("rad", {"rad": 1, "N": 2}) == "1/N^2"  # type: ignore[arg-type]


def test_trigonometric_and_user_functions_join_the_library() -> None:
    rng = np.random.default_rng(1)
    u = rng.uniform(-2.0, 2.0, 1200)
    y = np.zeros(1200)
    for t in range(1, 1200):
        y[t] = 0.6 * y[t - 1] + 0.5 * np.sin(2.0 * u[t - 1])
    data = IOData(u, y, ts=0.1)
    trig = SparseNARX(Lags.arx(1, 1), degree=1, trigonometric=[2.0], fit_for="prediction")
    assert set(trig.fit(data).terms()) == {"y(t-1)", "sin(2 u(t-1))"}
    user = SparseNARX(
        Lags.arx(1, 1), degree=1, functions={"s2": lambda v: np.sin(2.0 * v)}, max_iter=5
    ).fit(data)
    assert set(user.terms()) == {"y(t-1)", "s2(u(t-1))"}
    np.testing.assert_allclose(user.simulate(data).y[:, 0], y, atol=1e-6)
    with pytest.raises(ValueError, match="user functions cannot be saved"):
        user._get_state()


def test_model_file_round_trip_and_validation(tmp_path) -> None:
    model = SparseNARX(Lags.arx(1, 1), ensemble=4, max_iter=10).fit(_sparse_system(1200))
    path = model.save(tmp_path / "sindy")
    loaded = neckid.load_model(path)
    np.testing.assert_array_equal(loaded.coef_, model.coef_)
    np.testing.assert_array_equal(loaded.coef_interval_, model.coef_interval_)
    assert loaded.terms() == model.terms()
    loaded.allowed_[np.flatnonzero(loaded.coef_[:, 0])[0]] = False
    with pytest.raises(ValueError, match="outside the allowed"):
        loaded._check_state()
    loaded = neckid.load_model(path)
    loaded.library_ = type(loaded.library_)(
        loaded.library_.kind, loaded.library_.powers[::-1].copy(), loaded.library_.var,
        loaded.library_.frequency, loaded.library_.function,
    )  # fmt: skip
    with pytest.raises(ValueError, match="library powers"):
        loaded._check_state()


def test_describer_exports_the_terms() -> None:
    model = SparseNARX(Lags.arx(1, 1), fit_for="prediction").fit(_sparse_system(1200))
    structure, parameters = describe_sindy(model)
    assert structure == "sparse_narx"
    assert parameters["coef"].shape == (10, 1)
    assert {row["term"] for row in parameters["terms"]} == set(TRUE_TERMS)


def test_the_payload_is_an_input_through_the_lags() -> None:
    rng = np.random.default_rng(2)
    runs = []
    for i, payload in enumerate([0.0, 0.3, 0.6, 0.0, 0.6]):
        u = rng.uniform(-1.0, 1.0, 600)
        y = np.zeros(600)
        for t in range(1, 600):
            y[t] = 0.7 * y[t - 1] + 0.5 * u[t - 1] - 0.4 * payload * u[t - 1]
        runs.append(IOData(u, y, ts=0.02, conditions={"payload": payload}, name=f"run{i}"))
    model = SparseNARX(Lags(outputs=[1], inputs=[1], conditions=["payload"]), fit_for="prediction")
    model.fit(runs)
    found = model.terms()
    assert set(found) == {"y(t-1)", "u(t-1)", "u(t-1) payload(t)"}, found
    assert found["u(t-1) payload(t)"] == pytest.approx(-0.4, rel=1e-6)
    assert model.selection_["scheme"].startswith("experiments")


def test_info_prints_the_equation_with_units(tmp_path) -> None:
    from typer.testing import CliRunner

    from neckid.cli import app

    model = SparseNARX(Lags.arx(1, 1), fit_for="prediction", ensemble=5).fit(_sparse_system(1200))
    path = model.save(tmp_path / "sindy")
    result = CliRunner().invoke(app, ["info", str(path)], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    assert "identified equation: y(t) [deg] = 0.4" in result.output
    assert "deg/V" in result.output and "1/deg^2" in result.output and "5 bags" in result.output
    described = CliRunner().invoke(app, ["info", str(path), "--json"])
    assert json.loads(described.output)["equation"]["terms"][1]["unit"] == "deg/V"
