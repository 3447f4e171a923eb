"""An extrapolation is not a divergence: the envelope widens with the inputs' reach (issue 40)."""

from __future__ import annotations

import numpy as np
import pytest

from neckid import IOData, Lags, LinearARX
from neckid.models.envelope import impulse_l1, input_reach, reach_widening
from neckid.models.results import DivergenceError
from neckid.selection.comparison import compare


def _plant(u: np.ndarray, noise: float, seed: int) -> np.ndarray:
    """``y(t) = 0.8 y(t−1) + 0.5 u(t−1)`` (DC gain 2.5) with output noise."""
    rng = np.random.default_rng(seed)
    y = np.zeros(u.size)
    for t in range(1, u.size):
        y[t] = 0.8 * y[t - 1] + 0.5 * u[t - 1]
    return y + noise * rng.normal(size=u.size)


def _steps(low: float, high: float, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.repeat(rng.uniform(low, high, n // 20 + 1), 20)[:n]


def _logs() -> tuple[list[IOData], IOData]:
    train = []
    for seed in (1, 2, 3):
        u = _steps(0.0, 3.0, 600, seed)
        train.append(IOData(u, _plant(u, 0.01, seed), ts=0.05, name=f"train{seed}"))
    u = _steps(20.0, 50.0, 600, 9)
    return train, IOData(u, _plant(u, 0.01, 9), ts=0.05, name="far")


def test_correct_linear_model_follows_far_inputs() -> None:
    train, far = _logs()
    model = LinearARX(Lags.arx(1, 1)).fit(train)
    with pytest.warns(UserWarning):  # the extrapolation warning stays
        result = model.simulate(far)
    assert result.fit_percent(far)[0] > 99.0
    _, high = model.divergence_envelope()["y"]
    assert far.y.max() > high  # the plain envelope would have called it a runaway
    wide = model.divergence_envelope(data=far)["y"]
    assert wide[1] >= far.y.max()


def test_linear_bound_is_l1_norm_times_reach() -> None:
    train, far = _logs()
    model = LinearARX(Lags.arx(1, 1), fit_intercept=False).fit(train)
    norms = model._impulse_norms()
    a = float(model.coef_[0, 0])
    b = float(model.coef_[1, 0])
    assert norms[0, 0] == pytest.approx(abs(b) / (1 - abs(a)), rel=1e-6)
    reach = input_reach(model.training_ranges_, far)
    r = reach["u"][0]
    assert r == pytest.approx(far.u.max() - train_max(train), rel=1e-12)
    extra = reach_widening(reach, ["u"], np.array([1.0]), norms)
    assert extra[0] == pytest.approx(norms[0, 0] * r)


def train_max(train: list[IOData]) -> float:
    return float(max(d.u.max() for d in train))


def test_unstable_model_is_still_stopped() -> None:
    train, far = _logs()
    model = LinearARX(Lags.arx(1, 1)).fit(train)
    model.coef_ = np.array([[1.05], [0.5]])  # pole at 1.05: a runaway
    assert np.all(np.isinf(model._impulse_norms()))
    with pytest.raises(DivergenceError, match="ran away"), pytest.warns(UserWarning):
        model.simulate(far)
    inside = train[0]
    with pytest.raises(DivergenceError, match="ran away"):
        model.simulate(inside)


def test_nonlinear_rule_widens_by_relative_reach() -> None:
    reach = {"u": (47.0, 3.0)}
    extra = reach_widening(reach, ["u"], np.array([2.0]), None)
    assert extra[0] == pytest.approx(10.0 * 47.0 / 3.0 * 2.0)
    assert reach_widening({"u": (0.0, 3.0)}, ["u"], np.array([2.0]), None)[0] == 0.0


def test_impulse_l1_of_fir_and_unstable_map() -> None:
    fir = impulse_l1(lambda u: np.convolve(u[:, 0], [1.0, -2.0])[: u.shape[0], None], 1, 1)
    assert fir[0, 0] == pytest.approx(3.0)

    def unstable(u: np.ndarray) -> np.ndarray:
        y = np.zeros_like(u)
        for t in range(u.shape[0]):
            y[t] = u[t] + (1.001 * y[t - 1] if t else 0.0)
        return y

    assert np.isinf(impulse_l1(unstable, 1, 1)[0, 0])


def test_compare_keeps_the_true_structure_on_far_inputs() -> None:
    train, far = _logs()
    found = compare(train, far, methods=("arx",), lags=[Lags.arx(1, 1), Lags.arx(2, 2, 1)])
    rows = found.results
    assert not any(str(e).startswith("diverged") for e in rows["error"])
    assert "runs away" not in " ".join(found.selection.table["reason"].astype(str))
    assert float(rows["fit_percent"].min()) > 99.0


def test_validate_runs_the_correct_model_on_far_inputs(tmp_path) -> None:
    from typer.testing import CliRunner

    from neckid.cli import app

    train, far = _logs()
    paths = []
    for data in (*train, far):
        path = tmp_path / f"{data.name}.csv"
        data.to_csv(path)
        paths.append(str(path))
    runner = CliRunner()
    save = str(tmp_path / "arx.npz")
    done = runner.invoke(
        app, ["identify", *paths[:3], "--inputs", "u", "--outputs", "y", "--method", "arx",
              "--lags", "1/1", "--save", save],
    )  # fmt: skip
    assert done.exit_code == 0, done.output
    ran = runner.invoke(app, ["validate", save, paths[3]])
    assert ran.exit_code == 0, ran.output  # was 3: "ran away"
    assert "ran away" not in ran.output and "diverged" not in ran.output
