"""The model contract, run over every method of ``neckid.methods()``.

A method passes by being registered: there is no per-model code here. The contract (see
``neckid.models.base``): keyword-only hyper-parameters after ``lags``, declared in
``_parameter_constraints``; ``fit`` returns ``self``; ``predict`` (one step) and ``simulate``
(free run) return a :class:`~neckid.ModelResult` that says which it is, with channel names, units
and inputs; ``simulate`` runs from inputs only and ``initial``; ``simulator()`` steps to the
same values; files round-trip; ``clone`` and ``set_params(lags=...)``; unfitted use raises.
"""

from __future__ import annotations

import inspect

import numpy as np
import pytest
from sklearn.base import clone

import neckid
from neckid import IOData, Lags, ModelResult, NotFittedError

METHODS = sorted(neckid.methods())
LAGS = Lags.arx(1, 1, 1)
OTHER_LAGS = Lags.arx(1, 1, 2)


def _data(seed: int = 0, n: int = 800) -> IOData:
    """A slow first-order system with a saturating input, in degrees, held in steps."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1.0, 1.0, n // 20), 20) + 0.05 * rng.normal(size=n)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.8 * y[t - 1] + 0.3 * np.tanh(2.0 * u[t - 1])
    return IOData(
        u,
        y + 0.01 * rng.normal(size=n),
        ts=0.02,
        input_names=["command"],
        output_names=["inclination"],
        input_units=["rad/s"],
        output_units=["deg"],
        name=f"synthetic-{seed}",
    )


DATA = _data()


@pytest.fixture(scope="module", params=METHODS)
def fitted(request: pytest.FixtureRequest):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the quick network stops before converging
        model = neckid.methods()[request.param].make(LAGS, quick=True)
        assert model.fit(DATA) is model
    return request.param, model


def test_the_registry_lists_every_method() -> None:
    assert METHODS == [
        "arx",
        "greybox-neck",
        "greybox-tanks",
        "koopman",
        "lpv",
        "nn",
        "pnlss",
        "poly",
        "rls",
        "scheduled",
        "scheduled-position",
        "sindy",
        "sm",
        "sm-linear",
        "sm-multistep",
        "sm-parallel",
        "sm-parallel-koopman",
        "sm-parallel-poly",
        "sm-parallel-sindy",
        "ss",
    ]
    for name, method in neckid.methods().items():
        assert method.name == name
        assert method.label and method.summary


@pytest.mark.parametrize("name", METHODS)
def test_hyper_parameters_are_keyword_only_and_declared(name: str) -> None:
    cls = neckid.methods()[name].estimator_class()
    parameters = list(inspect.signature(cls.__init__).parameters.values())[1:]
    assert parameters[0].name == "lags"
    assert parameters[0].kind is inspect.Parameter.POSITIONAL_OR_KEYWORD
    assert all(p.kind is inspect.Parameter.KEYWORD_ONLY for p in parameters[1:])
    assert set(cls._parameter_constraints) == {p.name for p in parameters}
    with pytest.raises(TypeError):
        cls(LAGS, 1.0)  # a second positional argument is refused


@pytest.mark.parametrize("name", METHODS)
def test_unfitted_model_raises_not_fitted(name: str) -> None:
    model = neckid.methods()[name].make(LAGS)
    assert not model.__sklearn_is_fitted__()
    for call in (
        lambda: model.predict(DATA),
        lambda: model.simulate(DATA),
        model.simulator,
        lambda: model.save("never-written.npz"),
    ):
        with pytest.raises(NotFittedError, match="not fitted yet"):
            call()


@pytest.mark.parametrize("name", METHODS)
def test_a_bad_hyper_parameter_is_refused_at_fit_naming_it(name: str) -> None:
    cls = neckid.methods()[name].estimator_class()
    model = neckid.methods()[name].make(LAGS, quick=True)
    # The first declared numeric parameter with an interval, set below its range.
    from neckid.utils.checks import Interval

    numeric = [
        (key, c)
        for key, accepted in cls._parameter_constraints.items()
        for c in accepted
        if isinstance(c, Interval) and c.low is not None
    ]
    assert numeric, f"{cls.__name__} declares no numeric range"
    key, interval = numeric[0]
    model.set_params(**{key: interval.low - 1})
    with pytest.raises(ValueError, match=rf"^{key} must be"):
        model.fit(DATA)
    model.set_params(**{key: "text"})
    with pytest.raises((TypeError, ValueError), match=rf"^{key} must be"):
        model.fit(DATA)


def test_fitted_models_know_their_channels(fitted) -> None:
    _name, model = fitted
    assert model.__sklearn_is_fitted__()
    assert model.max_lag_ >= 1
    assert model.ts_ == DATA.ts
    assert model.input_names_ == ("command",)
    assert model.output_names_ == ("inclination",)
    assert model.output_units_ == ("deg",)


def _check_result(result: ModelResult, kind: str, model) -> None:
    assert isinstance(result, ModelResult)
    assert result.kind == kind
    assert result.y.shape == (DATA.n_samples, 1)
    assert result.n_initial == model.max_lag_
    assert result.output_names == ("inclination",)
    assert result.output_units == ("deg",)
    assert result.input_names == ("command",)
    assert result.input_units == ("rad/s",)
    np.testing.assert_array_equal(result.u, DATA.u)
    np.testing.assert_array_equal(result.time, DATA.time)
    assert np.all(np.isfinite(result.y))
    frame = result.to_frame()
    assert list(frame.columns[:3]) == ["time", "command", "inclination"]
    assert frame.attrs["units"]["inclination"] == "deg"
    assert frame.attrs["units"]["command"] == "rad/s"
    assert frame.attrs["kind"] == kind


def test_predict_is_one_step_and_says_so(fitted) -> None:
    _, model = fitted
    result = model.predict(DATA)
    kind = "simulation" if model.predicts_by_simulation else "prediction"
    _check_result(result, kind, model)
    # The initial-condition samples are the measured ones.
    np.testing.assert_array_equal(result.y[: model.max_lag_], DATA.y[: model.max_lag_])


def test_simulate_is_a_free_run(fitted) -> None:
    _, model = fitted
    result = model.simulate(DATA)
    _check_result(result, "simulation", model)
    # A free run does not look at the measured outputs after the initial ones.
    changed = IOData(
        DATA.u,
        np.vstack([DATA.y[: model.max_lag_], DATA.y[model.max_lag_ :] + 5.0]),
        ts=DATA.ts,
        input_names=DATA.input_names,
        output_names=DATA.output_names,
        input_units=DATA.input_units,
        output_units=DATA.output_units,
    )
    np.testing.assert_allclose(model.simulate(changed).y, result.y, rtol=0, atol=1e-12)


def test_simulate_from_inputs_and_initial_outputs(fitted) -> None:
    _, model = fitted
    m = model.max_lag_
    inputs_only = IOData(DATA.u, ts=DATA.ts, input_names=["command"], input_units=["rad/s"])
    from_initial = model.simulate(inputs_only, initial=DATA.y[:m])
    np.testing.assert_allclose(from_initial.y, model.simulate(DATA).y, rtol=0, atol=1e-12)
    assert from_initial.output_names == ("inclination",)
    with pytest.raises(ValueError, match="initial"):
        model.simulate(inputs_only)
    with pytest.raises(ValueError, match="initial"):
        model.simulate(inputs_only, initial=np.zeros((m + 3, 2)))


def test_simulator_steps_to_the_simulation(fitted) -> None:
    _, model = fitted
    m = model.max_lag_
    expected = model.simulate(DATA).y
    simulator = model.simulator()
    simulator.reset(y0=DATA.y[:m], u0=DATA.u[:m])
    stepped = np.array([simulator.step(DATA.u[t]) for t in range(m, DATA.n_samples)])
    np.testing.assert_allclose(stepped, expected[m:], rtol=0, atol=1e-10)


def test_save_load_round_trip(fitted, tmp_path) -> None:
    name, model = fitted
    path = model.save(tmp_path / name)
    loaded = neckid.load_model(path)
    assert type(loaded) is type(model)
    assert loaded.get_params().keys() == model.get_params().keys()
    assert loaded.max_lag_ == model.max_lag_
    assert loaded.output_units_ == model.output_units_
    np.testing.assert_allclose(loaded.simulate(DATA).y, model.simulate(DATA).y, rtol=0, atol=1e-12)
    np.testing.assert_allclose(loaded.predict(DATA).y, model.predict(DATA).y, rtol=0, atol=1e-12)
    assert type(model).load(path).max_lag_ == model.max_lag_


@pytest.mark.parametrize("name", METHODS)
def test_fit_leaves_the_data_it_is_given_unchanged(name: str) -> None:
    import warnings

    data = _data()
    u, y = data.u.copy(), data.y.copy()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        neckid.methods()[name].make(LAGS, quick=True).fit(data)
    np.testing.assert_array_equal(data.u, u)
    np.testing.assert_array_equal(data.y, y)


def test_clone_and_set_params_lags(fitted) -> None:
    _name, model = fitted
    copy = clone(model)
    assert not copy.__sklearn_is_fitted__()
    assert repr(copy.get_params()) == repr(model.get_params())
    other = clone(model).set_params(lags=OTHER_LAGS)
    assert other.get_params()["lags"] == OTHER_LAGS
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        other.fit(DATA)
    assert other.max_lag_ >= 1
    assert other.simulate(DATA).y.shape == DATA.y.shape


def test_a_log_with_other_channels_is_refused(fitted) -> None:
    _, model = fitted
    renamed = IOData(
        DATA.u, DATA.y, ts=DATA.ts, input_names=["torque"], output_names=["inclination"]
    )
    with pytest.raises(ValueError, match="torque"):
        model.simulate(renamed)


def _payload_runs() -> list[IOData]:
    """Three runs of the synthetic system whose gain and offset depend on a payload [kg]."""
    runs = []
    for seed, payload in enumerate((0.0, 0.3, 0.6)):
        base = _data(seed, n=600)
        y = base.y[:, 0] * (1.0 - payload) + 0.5 * payload
        runs.append(
            IOData(
                base.u, y, ts=base.ts, input_names=base.input_names,
                output_names=base.output_names, input_units=base.input_units,
                output_units=base.output_units, name=f"payload-{payload}",
                conditions={"payload": payload, "controller": "pi"},
                condition_units={"payload": "kg"},
            )
        )  # fmt: skip
    return runs


@pytest.mark.parametrize("name", METHODS)
def test_conditions_are_inputs_through_the_lags(name: str, tmp_path) -> None:
    """Lags(..., conditions=[...]) makes a condition a constant input of every NARX-type method."""
    import warnings

    train, held_out, other = _payload_runs()[0], _payload_runs()[2], _payload_runs()[1]
    lags = Lags([1], [1], conditions=["payload"])
    model = neckid.methods()[name].make(lags, quick=True)
    if name.startswith("scheduled"):  # schedules on the inclination only: says so
        with pytest.raises(ValueError, match="no conditions"):
            model.fit([train, held_out])
        return
    if name == "greybox-tanks":  # a structure's channels are its own: one pump input
        with pytest.raises(ValueError, match="takes 1 input"):
            model.fit([train, held_out])
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit([train, held_out])
        result = model.simulate(other)
    assert model.input_names_ == ("command", "payload")
    assert model.training_ranges_["payload"] == (0.0, 0.6)
    assert np.isfinite(result.y).all()
    model.save(tmp_path / "model")
    loaded = neckid.load_model(next(tmp_path.iterdir()))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        np.testing.assert_allclose(loaded.simulate(other).y, result.y)
    bare = IOData(other.u, other.y, ts=other.ts, input_names=other.input_names,
                  output_names=other.output_names)  # fmt: skip
    with pytest.raises(KeyError, match="condition 'payload'"):
        model.simulate(bare)


def _mimo_data(seed: int = 0, n: int = 900) -> IOData:
    """Three motors, two coupled outputs (a tilt vector): the 3-D neck's shape in miniature."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1.0, 1.0, (n // 20, 3)), 20, axis=0)
    y = np.zeros((n, 2))
    for t in range(1, n):
        y[t, 0] = 0.8 * y[t - 1, 0] + 0.3 * np.tanh(2.0 * u[t - 1, 0]) - 0.1 * u[t - 1, 1]
        y[t, 1] = 0.7 * y[t - 1, 1] + 0.2 * u[t - 1, 2] + 0.1 * np.tanh(y[t - 1, 0])
    return IOData(
        u, y + 0.005 * rng.normal(size=y.shape), ts=0.02,
        input_names=["motor_position_1", "motor_position_2", "motor_position_3"],
        output_names=["tilt_x", "tilt_y"], input_units=["rad"] * 3, output_units=["deg"] * 2,
    )  # fmt: skip


@pytest.mark.parametrize("name", METHODS)
def test_several_inputs_and_outputs(name: str, tmp_path) -> None:
    """MIMO: fit, predict, free run, simulator and files with three inputs and two outputs."""
    import warnings

    train, test = _mimo_data(0), _mimo_data(1)
    model = neckid.methods()[name].make(Lags(outputs=1, inputs=[1]), quick=True)
    if name.startswith("scheduled"):  # a first-order model of one command and one inclination
        with pytest.raises(ValueError, match="first order in one output"):
            model.fit(train)
        return
    if name == "greybox-tanks":  # the two tanks: one pump voltage in, one level out
        with pytest.raises(ValueError, match="takes 1 input"):
            model.fit(train)
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit(train)
        result = model.simulate(test)
        prediction = model.predict(test)
    assert model.input_names_ == train.input_names and model.output_names_ == train.output_names
    assert result.y.shape == prediction.y.shape == (test.n_samples, 2)
    assert result.output_units == ("deg", "deg")
    assert np.all(np.isfinite(result.y))
    if name != "nn":  # the quick networks stop long before converging (see test_neural.py)
        assert np.all(result.fit_percent(test) > 50.0), result.fit_percent(test)
    m = model.max_lag_
    simulator = model.simulator()
    simulator.reset(y0=test.y[:m], u0=test.u[:m])
    stepped = np.array([simulator.step(test.u[t]) for t in range(m, test.n_samples)])
    np.testing.assert_allclose(stepped, result.y[m:], rtol=0, atol=1e-9)
    loaded = neckid.load_model(model.save(tmp_path / name))
    np.testing.assert_allclose(loaded.simulate(test).y, result.y, rtol=0, atol=1e-12)
    if result.lower is not None:  # Set Membership: a band per output
        assert result.lower.shape == result.upper.shape == result.y.shape
