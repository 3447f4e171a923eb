"""The learnt SM distance (``scaling="gradient"``): each term weighted by the targets' slope."""

from __future__ import annotations

import numpy as np
import pytest

from neckid import IOData, Lags, ParallelSetMembership, SetMembership, load_model
from neckid.models.set_membership.metric import GRADIENT_FLOOR, gradient_relevance


def test_relevance_is_the_relative_root_mean_square_slope():
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (4000, 3))
    # Linear in the first two terms with slopes 2 and 1, nothing in the third.
    targets = (2 * x[:, 0] + x[:, 1])[:, None]
    np.testing.assert_allclose(
        gradient_relevance(x, targets), [1.0, 0.5, GRADIENT_FLOOR], atol=1e-6
    )
    # A cubic: the slope 3 x² + 0.5 has root mean square sqrt(E[(3x²+0.5)²]) over U(-1, 1).
    cubic = (x[:, 0] ** 3 + 0.5 * x[:, 0] + 0.25 * x[:, 2])[:, None]
    rms = np.sqrt(np.mean((3 * x[:, 0] ** 2 + 0.5) ** 2))
    np.testing.assert_allclose(
        gradient_relevance(x, cubic), [1.0, GRADIENT_FLOOR, 0.25 / rms], rtol=1e-6
    )
    # The scale of a column does not matter to the weights of the others, only its own slope.
    stretched = x * [1.0, 10.0, 1.0]
    np.testing.assert_allclose(
        gradient_relevance(stretched, targets), [1.0, 0.05, GRADIENT_FLOOR], atol=1e-6
    )
    np.testing.assert_array_equal(gradient_relevance(x, np.ones((4000, 1))), np.ones(3))


def _output_only_system(n: int, seed: int) -> IOData:
    """y(t) = 0.7 y(t-1) - 0.3 y(t-1)^3 + 0.2 u(t-1): the nonlinearity is in y(t-1) alone."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-2, 2, n)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.7 * y[t - 1] - 0.3 * y[t - 1] ** 3 + 0.2 * u[t - 1] + rng.uniform(-0.002, 0.002)
    return IOData(u, y, ts=0.01)


def test_gradient_metric_narrows_the_bounds_and_keeps_the_true_map(tmp_path):
    train, test = _output_only_system(3000, 1), _output_only_system(600, 2)
    lags = Lags(outputs=[1], inputs=[1, 2, 3])  # u(t-2), u(t-3): terms the residual ignores
    kwargs = {"epsilon": 0.002, "linear_part": True}
    std = SetMembership(lags, **kwargs).fit(train)
    learnt = SetMembership(lags, scaling="gradient", **kwargs).fit(train)
    ratio = learnt.weights_ * train.y.std() / (std.weights_ * train.y.std())
    # The residual of the linear part is -0.3 y³ + ...: its slope is along y(t-1) only.
    assert ratio[0] == pytest.approx(1.0) and np.all(ratio[1:] <= 0.15)
    width = {}
    for name, model in (("std", std), ("gradient", learnt)):
        bounds = model.predict(test)
        inside = slice(model.max_lag_, None)
        truth = test.y[inside, 0]
        # The noise-free map lies within the bounds widened by the noise bound.
        assert np.all(bounds.lower[inside, 0] - 0.002 - 1e-9 <= truth)
        assert np.all(truth <= bounds.upper[inside, 0] + 0.002 + 1e-9)
        width[name] = float(np.mean(bounds.upper[inside, 0] - bounds.lower[inside, 0]))
    assert width["gradient"] < 0.6 * width["std"]
    loaded = load_model(learnt.save(tmp_path / "learnt"))
    np.testing.assert_array_equal(loaded.weights_, learnt.weights_)
    np.testing.assert_array_equal(loaded.predict(test).y, learnt.predict(test).y)
    assert loaded.get_params()["scaling"] == "gradient"


def test_the_parallel_model_passes_the_metric_to_its_sm_map():
    train = _output_only_system(1500, 3)
    model = ParallelSetMembership(
        Lags.arx(1, 1), linear_lags=[0, 1], input_lags=[1, 2], scaling="gradient"
    ).fit(train)
    std = ParallelSetMembership(Lags.arx(1, 1), linear_lags=[0, 1], input_lags=[1, 2]).fit(train)
    assert not np.allclose(model.sm_.weights_, std.sm_.weights_)
    assert np.isfinite(model.simulate(train).y).all()
    # `neckid info` says which distance and estimate a model file holds.
    from neckid.cli.workflow import describe_model

    described = describe_model(model.set_params(estimate="projection"))
    assert described["distance"] == "gradient" and described["estimate"] == "projection"
    assert describe_model(std)["distance"] == "std"


def test_an_unknown_scaling_names_the_options():
    with pytest.raises(ValueError, match="'gradient'"):
        SetMembership(Lags.arx(1, 1), scaling="slope").fit(_output_only_system(50, 0))
