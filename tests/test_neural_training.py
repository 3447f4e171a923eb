"""The compiled trainer of NeuralNARX against scikit-learn's MLPRegressor, which it reimplements.

Both run on the same rows from the same seeds; the trainer must run the same epochs and reach
the same weights to rounding (the sums run in another order, so never bit for bit).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numba import njit
from sklearn.exceptions import ConvergenceWarning
from sklearn.neural_network import MLPRegressor

from neckid.models.neural._adam import _tanh, layout
from neckid.models.neural._training import TrainingSettings, more_epochs, train_ensemble

#: Weights agree to this (rounding grows over the epochs; measured: below 1e-12 after 300 epochs).
CLOSE = 1e-9


def rows(n: int, n_out: int = 1, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3))
    y = np.tanh(x @ rng.normal(size=(3, n_out))) + 0.3 * x[:, :1] ** 2
    return x, y + 0.05 * rng.normal(size=(n, n_out))


def settings(activation: str = "tanh", **changed: object) -> TrainingSettings:
    values: dict[str, object] = {
        "activation": activation, "alpha": 1e-4, "learning_rate_init": 3e-3, "max_iter": 300,
        "tol": 1e-5, "n_iter_no_change": 10, "early_stopping": True, "validation_fraction": 0.15,
    }  # fmt: skip
    values.update(changed)
    return TrainingSettings(**values)  # type: ignore[arg-type]


def reference(s: TrainingSettings, layers: tuple[int, ...], seed: int) -> MLPRegressor:
    return MLPRegressor(
        hidden_layer_sizes=layers, activation=s.activation, solver="adam", alpha=s.alpha,
        learning_rate_init=s.learning_rate_init, max_iter=s.max_iter, tol=s.tol,
        n_iter_no_change=s.n_iter_no_change, early_stopping=s.early_stopping,
        validation_fraction=s.validation_fraction, random_state=seed,
    )  # fmt: skip


def assert_same(trained, networks: list[MLPRegressor]) -> None:
    assert trained.n_iter.tolist() == [n.n_iter_ for n in networks]
    for m, net in enumerate(networks):
        for k in range(len(net.coefs_)):
            np.testing.assert_allclose(trained.coefs[k][m], net.coefs_[k], rtol=0, atol=CLOSE)
            np.testing.assert_allclose(
                trained.intercepts[k][m], net.intercepts_[k], rtol=0, atol=CLOSE
            )


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
@pytest.mark.parametrize("activation", ["tanh", "relu", "logistic", "identity"])
@pytest.mark.parametrize("early_stopping", [True, False])
def test_the_trainer_is_mlpregressor(activation: str, early_stopping: bool) -> None:
    x, y = rows(700)
    s = settings(activation, early_stopping=early_stopping)
    layers = (6, 4)
    trained = train_ensemble(x, y, layers, [3, 11], s)
    networks = [reference(s, layers, seed).fit(x, y[:, 0]) for seed in (3, 11)]
    assert_same(trained, networks)
    assert trained.n_iter.min() > 10  # trained, not stopped at once


def test_two_outputs_and_a_batch_shorter_than_200() -> None:
    x, y = rows(130, n_out=2, seed=4)  # 110 training rows: one short batch per epoch
    s = settings(max_iter=60)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        trained = train_ensemble(x, y, (5,), [0], s)
        net = reference(s, (5,), 0).fit(x, y)
    assert_same(trained, [net])


def test_more_epochs_are_partial_fit() -> None:
    x, y = rows(600, seed=1)
    x_new, y_new = rows(250, seed=2)
    s = settings()
    trained = train_ensemble(x, y, (6,), [5], s)
    net = reference(s, (6,), 5).fit(x, y[:, 0])
    net.set_params(early_stopping=False)
    net.best_loss_ = np.inf  # as NeuralNARX.partial_fit did with scikit-learn
    for _ in range(4):
        net.partial_fit(x_new, y_new[:, 0])
    coefs, intercepts = more_epochs(
        trained.coefs, trained.intercepts, trained.state, x_new, y_new, 4, s
    )
    for k in range(2):
        np.testing.assert_allclose(coefs[k][0], net.coefs_[k], rtol=0, atol=CLOSE)
        np.testing.assert_allclose(intercepts[k][0], net.intercepts_[k], rtol=0, atol=CLOSE)
    assert trained.state.steps[0] == net._optimizer.t


def test_networks_that_run_out_of_epochs_are_named() -> None:
    x, y = rows(300)
    with pytest.warns(ConvergenceWarning, match=r"2 of 2 networks ran all max_iter=3"):
        trained = train_ensemble(x, y, (4,), [0, 1], settings(max_iter=3))
    assert trained.n_iter.tolist() == [3, 3] and not trained.converged.any()


def test_too_few_rows_held_out_is_refused() -> None:
    x, y = rows(8)
    with pytest.raises(ValueError, match=r"validation_fraction=0.1 of 8 .* holds out 1"):
        train_ensemble(x, y, (4,), [0], settings(validation_fraction=0.1))


def test_progress_advances_once_per_network() -> None:
    x, y = rows(300)
    done: list[int] = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        train_ensemble(x, y, (4,), [0, 1, 2], settings(max_iter=40), lambda: done.append(1))
    assert len(done) == 3


@njit(cache=True)
def _tanh_all(z: np.ndarray) -> np.ndarray:
    out = np.empty_like(z)
    for i in range(z.shape[0]):
        out[i] = _tanh(z[i])
    return out


def test_the_vectorised_tanh_is_tanh_to_rounding() -> None:
    rng = np.random.default_rng(0)
    z = np.concatenate(
        [rng.normal(scale=3.0, size=200_000), np.linspace(-25, 25, 20_001), [0.0, 1e-300, 40.0]]
    )
    ours = _tanh_all(z)
    assert np.max(np.abs(ours - np.tanh(z))) <= 4.5e-16
    edge = _tanh_all(np.array([-0.0, 1e6, -1e6, np.inf, -np.inf, np.nan]))
    assert np.signbit(edge[0]) and edge[1:5].tolist() == [1.0, -1.0, 1.0, -1.0]
    assert np.isnan(edge[5])


def test_layout() -> None:
    offsets = layout(np.array([3, 5, 2]))
    assert offsets.tolist() == [[0, 15], [20, 30], [32, 32]]
