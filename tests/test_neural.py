"""NeuralNARX: recovery of a known nonlinear NARX system, the NumPy forward pass, files, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from neckid import IOData, Lags, NotFittedError
from neckid.models.base import _free_run
from neckid.models.io import load_model, write_model_file
from neckid.models.neural.narx import NeuralNARX, forward_pass, member_seeds


def true_system(n: int, seed: int, noise: float = 0.02) -> IOData:
    """y(t) = 0.7 y(t-1) + tanh(u(t-2)) + e(t), u uniform in [-2, 2], e white output noise."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-2.0, 2.0, size=n)
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = 0.7 * y[t - 1] + np.tanh(u[t - 2])
    return IOData(u, y + noise * rng.normal(size=n), ts=0.02, input_names=["u"], output_names=["y"])


LAGS = Lags(outputs=[1], inputs=[1, 2])


@pytest.fixture(scope="module")
def fitted() -> NeuralNARX:
    return NeuralNARX(LAGS, hidden_layer_sizes=(25, 25), n_networks=3, random_state=0).fit(
        true_system(1500, 1)
    )


@pytest.fixture(scope="module")
def validation() -> IOData:
    return true_system(600, 2)


def test_recovers_known_narx_system_in_free_run(fitted: NeuralNARX, validation: IOData) -> None:
    sim = fitted.simulate(validation)
    assert sim.kind == "simulation"
    assert sim.n_initial == 2
    assert sim.fit_percent(validation)[0] >= 90.0
    pred = fitted.predict(validation)
    assert pred.kind == "prediction"
    assert pred.fit_percent(validation)[0] >= 90.0


def test_fast_free_run_equals_generic_loop(fitted: NeuralNARX, validation: IOData) -> None:
    fast = fitted.simulate(validation).y
    generic = _free_run(fitted.lags_, fitted._predict_rows, validation.u, validation.y)
    np.testing.assert_allclose(fast, generic, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(fast[:2], validation.y[:2])


def test_networks_are_the_mlpregressors_of_their_seeds(
    fitted: NeuralNARX, validation: IOData
) -> None:
    """Each network is MLPRegressor's for its seed (to rounding); the map is their mean."""
    from sklearn.neural_network import MLPRegressor

    x_train, y_train = LAGS.build(true_system(1500, 1))
    x, _ = LAGS.build(validation)
    xs = (x - fitted.x_mean_) / fitted.x_scale_
    assert fitted.n_iter_.shape == (3,)
    members = []
    for m, seed in enumerate(member_seeds(0, 3)):
        reference = MLPRegressor(
            hidden_layer_sizes=(25, 25),
            activation="tanh",
            random_state=seed,
            tol=1e-5,
            n_iter_no_change=20,
            early_stopping=True,
            max_iter=1000,
            validation_fraction=0.15,
        )
        reference.fit((x_train - fitted.x_mean_) / fitted.x_scale_,
                      (y_train[:, 0] - fitted.y_mean_[0]) / fitted.y_scale_[0])  # fmt: skip
        assert fitted.n_iter_[m] == reference.n_iter_
        coefs = [w[m] for w in fitted.coefs_]
        intercepts = [b[m] for b in fitted.intercepts_]
        ours = forward_pass(xs, coefs, intercepts, fitted.activation)[:, 0]
        np.testing.assert_allclose(ours, reference.predict(xs), rtol=0, atol=1e-9)
        members.append(ours)
    # The model's one-step map is the mean of its networks, de-standardised.
    expected = fitted.y_mean_[0] + fitted.y_scale_[0] * np.mean(members, axis=0)
    np.testing.assert_allclose(fitted._predict_rows(x)[:, 0], expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("activation", ["tanh", "relu", "logistic", "identity"])
def test_forward_pass_all_activations_equal_mlpregressor(activation: str) -> None:
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.neural_network import MLPRegressor

    rng = np.random.default_rng(5)
    x = rng.normal(size=(60, 3))
    y = rng.normal(size=(60, 2))
    net = MLPRegressor(hidden_layer_sizes=(4, 3), activation=activation, max_iter=5, random_state=0)
    with pytest.warns(ConvergenceWarning):
        net.fit(x, y)
    ours = forward_pass(x, net.coefs_, net.intercepts_, activation)
    np.testing.assert_allclose(ours, net.predict(x), rtol=1e-12, atol=1e-12)


def two_output_system(n: int, seed: int) -> IOData:
    """Two coupled outputs and two inputs, so the regressor mixes channels and lags."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1.0, 1.0, size=(n, 2))
    y = np.zeros((n, 2))
    for t in range(2, n):
        y[t, 0] = 0.5 * y[t - 1, 0] + 0.1 * y[t - 2, 1] + np.tanh(u[t - 1, 0])
        y[t, 1] = 0.3 * y[t - 1, 1] + 0.5 * u[t - 2, 1] * u[t - 1, 0]
    return IOData(u, y, ts=0.1)


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
@pytest.mark.parametrize("activation", ["tanh", "relu", "logistic", "identity"])
@pytest.mark.parametrize("hidden", [(6,), (6, 4)])
def test_compiled_free_run_equals_numpy_loop(activation: str, hidden: tuple[int, ...]) -> None:
    data = two_output_system(400, 3)
    model = NeuralNARX(
        Lags(outputs=2, inputs=[1, 2]),
        hidden_layer_sizes=hidden,
        activation=activation,  # type: ignore[arg-type]
        n_networks=3,
        max_iter=30,
        random_state=1,
    ).fit(data[:250])
    test = data[250:]
    compiled = model._simulate_array(test.u, test.y)
    reference = model._simulate_array(test.u, test.y, compiled=False)
    assert np.all(np.isfinite(reference)) and np.ptp(reference[2:], axis=0).min() > 1e-3
    np.testing.assert_allclose(compiled, reference, rtol=1e-10, atol=1e-10)
    np.testing.assert_array_equal(compiled[:2], test.y[:2])  # the initial conditions
    # the ensemble of some networks only, as simulation_tuning scores them
    np.testing.assert_allclose(
        model._simulate_array(test.u, test.y, [2, 0]),
        model._simulate_array(test.u, test.y, [2, 0], compiled=False),
        rtol=1e-10,
        atol=1e-10,
    )


def test_compiled_tanh_within_rounding_of_numpy() -> None:
    from neckid.models.neural._kernels import _tanh

    z = np.concatenate([np.linspace(-25.0, 25.0, 2001), [0.0, -0.0, 1e-300, -1e-12, 400.0, np.inf]])
    ours = np.array([_tanh(v) for v in z])
    np.testing.assert_allclose(ours, np.tanh(z), rtol=0.0, atol=2.3e-16)
    assert ours[-1] == 1.0 and ours[-2] == 1.0 and np.isnan(_tanh(np.nan))
    assert np.all(np.sign(ours) * np.sign(z) >= 0.0)  # never the opposite sign (tiny z: +-0)


def test_simulator_steps_like_simulate(fitted: NeuralNARX, validation: IOData) -> None:
    sim = fitted.simulator()
    sim.reset(y0=validation.y[:2], u0=validation.u[:2])
    stepped = np.array([sim.step(validation.u[t]) for t in range(2, 50)])
    np.testing.assert_allclose(stepped, fitted.simulate(validation[:50]).y[2:], rtol=1e-12)


def test_save_load_round_trip_identical(fitted: NeuralNARX, validation: IOData, tmp_path) -> None:
    path = fitted.save(tmp_path / "net")
    assert path.suffix == ".npz"
    with np.load(path, allow_pickle=False) as archive:  # plain arrays, no pickle
        assert {"coef_0", "coef_1", "coef_2", "x_mean", "y_scale"} <= set(archive.files)
        assert archive["coef_1"].shape == (3, 25, 25) and archive["intercept_2"].shape == (3, 1)
    loaded = NeuralNARX.load(path)
    assert isinstance(load_model(path), NeuralNARX)
    assert not hasattr(loaded, "networks_")
    assert loaded.get_params()["hidden_layer_sizes"] == (25, 25)
    assert loaded.n_networks == 3
    np.testing.assert_array_equal(loaded.n_iter_, fitted.n_iter_)
    assert loaded.lags_.names == fitted.lags_.names == ("y(t-1)", "u(t-1)", "u(t-2)")
    np.testing.assert_array_equal(loaded.predict(validation).y, fitted.predict(validation).y)
    np.testing.assert_array_equal(loaded.simulate(validation).y, fitted.simulate(validation).y)


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
def test_simulation_tuning_keeps_best_free_run_candidate() -> None:
    data = true_system(800, 3)
    model = NeuralNARX(
        LAGS,
        hidden_layer_sizes=(8,),
        simulation_tuning=2,
        n_networks=1,
        random_state=1,
        max_iter=200,
    ).fit(data)
    assert model.simulation_fits_.shape == (3,)
    # The kept network is the best candidate: re-score it on the same held-out end.
    n_tail = int(np.ceil(0.15 * data.n_samples))
    tail = data[data.n_samples - n_tail :]
    assert model._free_run_score([tail]) == pytest.approx(model.simulation_fits_.max())
    # Trained on the head only.
    assert model.n_samples_ == data.n_samples - n_tail - LAGS.max_lag


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
def test_simulation_tuning_averages_the_best_networks() -> None:
    data = true_system(800, 3)
    settings = {"hidden_layer_sizes": (8,), "random_state": 1, "max_iter": 200}
    model = NeuralNARX(LAGS, simulation_tuning=3, n_networks=2, **settings).fit(data)
    # Five candidates (the seeds of random_state, as with one network), the two best kept.
    assert model.simulation_fits_.shape == (5,) and model.n_iter_.shape == (2,)
    pool = NeuralNARX(LAGS, simulation_tuning=4, n_networks=1, **settings).fit(data)
    np.testing.assert_array_equal(model.simulation_fits_, pool.simulation_fits_)
    best = np.sort(np.argsort(-model.simulation_fits_)[:2])
    seeds = np.random.RandomState(1).randint(0, np.iinfo(np.int32).max, size=5)[best]
    n_tail = int(np.ceil(0.15 * data.n_samples))
    tail = data[data.n_samples - n_tail :]
    head = data[: data.n_samples - n_tail]
    for m, seed in enumerate(seeds):  # the kept networks are those of their seeds
        alone = NeuralNARX(LAGS, n_networks=1, **{**settings, "random_state": int(seed)}).fit(head)
        for stacked, own in zip(model.coefs_, alone.coefs_, strict=True):
            np.testing.assert_array_equal(stacked[m], own[0])
    for m, index in enumerate(best):  # each kept network alone scores what it scored
        assert model._free_run_score([tail], [m]) == pytest.approx(model.simulation_fits_[index])


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
def test_multi_output_and_multi_experiment_fit() -> None:
    rng = np.random.default_rng(4)
    records = []
    for _ in range(2):
        u = rng.uniform(-1, 1, size=(300, 2))
        y = np.zeros((300, 2))
        for t in range(1, 300):
            y[t, 0] = 0.5 * y[t - 1, 0] + np.tanh(u[t - 1, 0])
            y[t, 1] = 0.3 * y[t - 1, 1] + 0.5 * u[t - 1, 1] * u[t - 1, 0]
        records.append(IOData(u, y, ts=0.1))
    model = NeuralNARX(
        Lags(outputs=1, inputs=1), hidden_layer_sizes=(10,), n_networks=2, random_state=0
    )
    model.fit(records)
    result = model.simulate(records[0])
    assert result.y.shape == (300, 2)
    np.testing.assert_allclose(
        result.y, _free_run(model.lags_, model._predict_rows, records[0].u, records[0].y)
    )


def test_not_fitted_refused(validation: IOData) -> None:
    model = NeuralNARX(LAGS)
    for call in (model.predict, model.simulate):
        with pytest.raises(NotFittedError, match="not fitted"):
            call(validation)
    with pytest.raises(NotFittedError):
        model.save("unused.npz")


def test_init_stores_parameters_unchanged() -> None:
    sizes = [3, 4]
    model = NeuralNARX(hidden_layer_sizes=sizes, activation="bogus")  # type: ignore[arg-type]
    assert model.hidden_layer_sizes is sizes
    assert model.activation == "bogus"
    assert not [k for k in vars(model) if k.endswith("_")]


@pytest.mark.parametrize(
    ("params", "error", "match"),
    [
        ({"hidden_layer_sizes": ()}, ValueError, r"hidden_layer_sizes .* got \(\)"),
        ({"hidden_layer_sizes": (5, 0)}, ValueError, r"hidden_layer_sizes .* got \(5, 0\)"),
        ({"hidden_layer_sizes": "ab"}, TypeError, r"hidden_layer_sizes .* got 'ab'"),
        ({"activation": "softmax"}, ValueError, r"activation must be one of .* got 'softmax'"),
        ({"alpha": -1.0}, ValueError, r"alpha must be a number >= 0; got -1.0"),
        ({"alpha": "big"}, TypeError, r"alpha must be a number >= 0; got 'big'"),
        ({"learning_rate_init": 0.0}, ValueError, r"learning_rate_init must be .*> 0; got 0.0"),
        ({"max_iter": 0}, ValueError, r"max_iter must be a whole number >= 1; got 0"),
        (
            {"n_iter_no_change": 2.5},
            ValueError,
            r"n_iter_no_change must be a whole number >= 1; got 2.5",
        ),
        (
            {"validation_fraction": 1.0},
            ValueError,
            r"validation_fraction must be a number in \(0, 1\); got 1.0",
        ),
        (
            {"simulation_tuning": -1},
            ValueError,
            r"simulation_tuning must be a whole number >= 0; got -1",
        ),
        ({"n_networks": 0}, ValueError, r"n_networks must be a whole number >= 1; got 0"),
        ({"n_networks": 2.5}, ValueError, r"n_networks must be a whole number >= 1; got 2.5"),
        ({"lags": None}, ValueError, r"needs lags=Lags\(\.\.\.\); got None"),
        ({"lags": 3}, TypeError, r"lags must be None or a neckid.Lags; got 3"),
    ],
)
def test_bad_parameters_refused_in_fit(params: dict, error: type, match: str) -> None:
    settings = {"lags": LAGS, **params}
    with pytest.raises(error, match=match):
        NeuralNARX(**settings).fit(true_system(100, 0))


def test_bad_data_refused() -> None:
    with pytest.raises(ValueError, match="too few for lags up to 2"):
        NeuralNARX(LAGS).fit(true_system(2, 0))
    with pytest.raises(ValueError, match="needs at least 10 regressor rows to train; got 5"):
        NeuralNARX(LAGS).fit(true_system(7, 0))
    with pytest.raises(ValueError, match=r"simulation_tuning needs a held-out end .* gives 8"):
        NeuralNARX(LAGS, simulation_tuning=1).fit(true_system(50, 0))
    with pytest.raises(TypeError, match="data must be an IOData or a list of them; got ndarray"):
        NeuralNARX(LAGS).fit(np.zeros((10, 2)))  # type: ignore[arg-type]


def test_wrong_channels_refused(fitted: NeuralNARX) -> None:
    other = IOData(np.zeros(20), np.zeros(20), ts=0.02, input_names=["cmd"], output_names=["y"])
    with pytest.raises(ValueError, match=r"data has inputs \['cmd'\], but the model was fitted on"):
        fitted.simulate(other)


# ---------------------------------------------------------------------- the ensemble
SMALL = {"hidden_layer_sizes": (8,), "max_iter": 150, "learning_rate_init": 3e-3}


@pytest.fixture(scope="module")
def small_data() -> IOData:
    return true_system(500, 6)


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
def test_ensemble_is_the_mean_of_single_networks_of_its_seeds(small_data: IOData) -> None:
    ensemble = NeuralNARX(LAGS, n_networks=3, random_state=4, **SMALL).fit(small_data)
    singles = [
        NeuralNARX(LAGS, n_networks=1, random_state=seed, **SMALL).fit(small_data)
        for seed in member_seeds(4, 3)
    ]
    # Every network of the ensemble is the single network its seed gives ...
    for m, single in enumerate(singles):
        for stacked, own in zip(ensemble.coefs_, single.coefs_, strict=True):
            np.testing.assert_array_equal(stacked[m], own[0])
    # ... and the ensemble predicts their mean, one step ahead.
    mean = np.mean([s.predict(small_data).y for s in singles], axis=0)
    np.testing.assert_allclose(ensemble.predict(small_data).y, mean, rtol=1e-12, atol=1e-12)
    # A free run feeds back the mean: the batched loop equals the generic one and the simulator.
    fast = ensemble.simulate(small_data).y
    generic = _free_run(ensemble.lags_, ensemble._predict_rows, small_data.u, small_data.y)
    np.testing.assert_allclose(fast, generic, rtol=1e-12, atol=1e-12)
    simulator = ensemble.simulator()
    simulator.reset(y0=small_data.y[:2], u0=small_data.u[:2])
    stepped = np.array([simulator.step(small_data.u[t]) for t in range(2, 80)])
    np.testing.assert_allclose(stepped, fast[2:80], rtol=1e-12)


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
def test_one_network_is_the_mlpregressor_of_random_state(small_data: IOData) -> None:
    from sklearn.neural_network import MLPRegressor

    model = NeuralNARX(LAGS, n_networks=1, random_state=9, **SMALL).fit(small_data)
    x, y = LAGS.build(small_data)
    reference = MLPRegressor(
        hidden_layer_sizes=(8,), activation="tanh", max_iter=150, learning_rate_init=3e-3, tol=1e-5,
        n_iter_no_change=20, early_stopping=True, validation_fraction=0.15, random_state=9,
    ).fit((x - x.mean(axis=0)) / x.std(axis=0), ((y - y.mean()) / y.std())[:, 0])  # fmt: skip
    # The same draws, epochs and updates; the sums in another order (to rounding).
    assert model.n_iter_[0] == reference.n_iter_
    for ours, theirs in zip(model.coefs_, reference.coefs_, strict=True):
        np.testing.assert_allclose(ours[0], theirs, rtol=0, atol=1e-9)


def test_member_seeds() -> None:
    assert member_seeds(None, 3) == [None, None, None]
    assert member_seeds(5, 1) == [5]
    a, b = member_seeds(np.random.RandomState(1), 3), member_seeds(np.random.RandomState(1), 3)
    assert a[1:] == b[1:] and len(set(a[1:])) == 2
    assert all(0 <= s < 2**32 for s in member_seeds(2**31, 4)[1:])


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
def test_file_of_a_single_network_before_n_networks_loads(small_data: IOData, tmp_path) -> None:
    model = NeuralNARX(LAGS, n_networks=1, random_state=2, **SMALL).fit(small_data)
    arrays, meta = model._get_state()
    # The layout written before ensembles: one network's 2-D weights and 1-D biases, no
    # "n_networks" among the parameters, "n_iter" a number.
    old = {k: (v[0] if k.startswith(("coef_", "intercept_")) else v) for k, v in arrays.items()}
    assert old["coef_0"].shape == (3, 8) and old["intercept_0"].shape == (8,)
    del meta["params"]["n_networks"]
    meta["n_iter"] = int(model.n_iter_[0])
    path = write_model_file(tmp_path / "old.npz", "NeuralNARX", old, meta)
    loaded = load_model(path)
    assert loaded.n_networks == 1 and loaded.coefs_[0].shape == (1, 3, 8)
    np.testing.assert_array_equal(loaded.n_iter_, model.n_iter_)
    np.testing.assert_array_equal(loaded.simulate(small_data).y, model.simulate(small_data).y)


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
def test_load_refuses_networks_that_do_not_match_n_networks(small_data: IOData, tmp_path) -> None:
    model = NeuralNARX(LAGS, n_networks=2, random_state=2, **SMALL).fit(small_data)
    arrays, meta = model._get_state()
    meta["params"]["n_networks"] = 3
    path = write_model_file(tmp_path / "bad.npz", "NeuralNARX", arrays, meta)
    with pytest.raises(ValueError, match=r"invalid NeuralNARX file: n_iter must have shape \(3,\)"):
        load_model(path)
    meta["params"]["n_networks"] = 2
    arrays["coef_1"] = arrays["coef_1"][:1]
    path = write_model_file(tmp_path / "bad2.npz", "NeuralNARX", arrays, meta)
    with pytest.raises(ValueError, match=r"coef_1 must have shape \(2, 8, 1\)"):
        load_model(path)
