"""Tests of the shared model machinery: ModelResult, NarxSimulator, model files, NotFittedError."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest

from neckid import IOData, Lags, LinearARX, ModelResult, NotFittedError, load_model
from neckid.models.base import NarxSimulator
from neckid.models.io import FORMAT_VERSION, read_model_file, write_model_file


@pytest.fixture
def arx_data(rng: np.random.Generator) -> IOData:
    u = rng.normal(size=(400, 2))
    y = np.zeros(400)
    for t in range(2, 400):
        y[t] = 1.2 * y[t - 1] - 0.5 * y[t - 2] + 0.7 * u[t - 1, 0] - 0.3 * u[t - 2, 1] + 0.1
    return IOData(u, y, ts=0.02, input_names=["m1", "m2"], output_names=["incl"])


@pytest.fixture
def model(arx_data: IOData) -> LinearARX:
    return LinearARX(Lags.arx(na=2, nb=2, delay=1)).fit(arx_data)


def test_model_result_metrics_skip_initial_conditions(arx_data: IOData, model: LinearARX) -> None:
    result = model.simulate(arx_data)
    assert isinstance(result, ModelResult) and result.kind == "simulation"
    assert result.n_initial == 2 and result.n_samples == 400
    np.testing.assert_array_equal(result.y[:2], arx_data.y[:2])
    np.testing.assert_allclose(result.fit_percent(arx_data), [100.0], atol=1e-6)
    assert result.rmse(arx_data)[0] < 1e-8 and result.mae(arx_data.y)[0] < 1e-8
    frame = result.to_frame()
    assert list(frame.columns) == ["time", "m1", "m2", "incl"]
    assert frame.attrs["kind"] == "simulation" and frame.attrs["units"]["time"] == "s"
    bounded = ModelResult(
        "simulation", result.time, result.y, ("incl",), 2, lower=result.y - 1, upper=result.y + 1
    )
    assert list(bounded.to_frame().columns) == ["time", "incl", "incl_lower", "incl_upper"]


def test_simulator_reproduces_simulate(arx_data: IOData, model: LinearARX) -> None:
    sim = model.simulator()
    assert isinstance(sim, NarxSimulator)
    sim.reset(y0=arx_data.y[:2], u0=arx_data.u[:2])
    stepped = np.array([sim.step(arx_data.u[t]) for t in range(2, 400)])
    np.testing.assert_allclose(stepped, model.simulate(arx_data).y[2:], rtol=1e-10, atol=1e-10)
    # reset starts again from the same state
    sim.reset(y0=arx_data.y[:2], u0=arx_data.u[:2])
    np.testing.assert_allclose(sim.step(arx_data.u[2]), stepped[0])
    with pytest.raises(ValueError, match=r"u must have 2 values \(one per input\); got 3"):
        sim.step([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"y0 must have shape \(1,\) or \(2, 1\); got \(3, 1\)"):
        sim.reset(y0=np.zeros((3, 1)))
    with pytest.raises(ValueError, match="non-finite value nan"):
        sim.step([np.nan, 0.0])


def test_not_fitted_error(arx_data: IOData) -> None:
    fresh = LinearARX(Lags.arx(1, 1))
    assert issubclass(NotFittedError, ValueError) and issubclass(NotFittedError, AttributeError)
    for call in (
        lambda: fresh.predict(arx_data),
        lambda: fresh.simulate(arx_data),
        fresh.simulator,
        lambda: fresh.save("unused.npz"),
    ):
        with pytest.raises(NotFittedError, match="LinearARX is not fitted yet; call fit"):
            call()
    assert not any(k.endswith("_") for k in vars(fresh))


def test_model_file_round_trip(arx_data: IOData, model: LinearARX, tmp_path) -> None:
    path = model.save(tmp_path / "model")
    assert path.suffix == ".npz"
    loaded = load_model(path)
    assert isinstance(loaded, LinearARX) and LinearARX.load(path).get_params()["ridge"] == 0.0
    np.testing.assert_array_equal(loaded.coef_, model.coef_)
    np.testing.assert_array_equal(loaded.simulate(arx_data).y, model.simulate(arx_data).y)
    assert loaded.lags_.names == model.lags_.names
    # The file is a plain zip of .npy arrays and a JSON header, readable without pickle.
    with zipfile.ZipFile(path) as archive:
        names = set(archive.namelist())
    assert {"coef.npy", "intercept.npy", "__neckid__.npy"} <= names
    class_name, _, meta = read_model_file(path)
    assert class_name == "LinearARX" and meta["ts"] == 0.02
    header = json.loads(str(np.load(path, allow_pickle=False)["__neckid__"]))
    assert header["version"] == FORMAT_VERSION and header["format"] == "neckid-model"


def test_model_file_refusals(tmp_path) -> None:
    np.savez(tmp_path / "plain.npz", a=np.zeros(2))
    with pytest.raises(ValueError, match="not a neckid model file"):
        load_model(tmp_path / "plain.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="is not a neckid model file"):
        load_model(tmp_path / "junk.npz")
    write_model_file(tmp_path / "other.npz", "Mystery", {"a": np.zeros(1)}, {})
    with pytest.raises(ValueError, match="holds a 'Mystery', which this neckid cannot load"):
        load_model(tmp_path / "other.npz")
    with pytest.raises(TypeError, match="dtype object, which cannot be stored without pickle"):
        write_model_file(tmp_path / "obj.npz", "X", {"a": np.array([None, 1], dtype=object)}, {})
    future = tmp_path / "future.npz"
    header = {"format": "neckid-model", "version": FORMAT_VERSION + 1, "class": "LinearARX"}
    np.savez(future, __neckid__=np.array(json.dumps(header)))
    with pytest.raises(ValueError, match="newer than this neckid reads"):
        load_model(future)


def test_a_free_run_that_leaves_the_envelope_of_the_training_outputs_is_a_divergence() -> None:
    from neckid import DivergenceError, IOData, Lags, LinearARX
    from neckid.models.base import DIVERGENCE_SPANS

    rng = np.random.default_rng(5)
    u = rng.uniform(-1.0, 1.0, 600)
    y = np.zeros(600)
    for t in range(1, 600):
        y[t] = 0.8 * y[t - 1] + 0.5 * u[t - 1]
    data = IOData(u, y, ts=0.02)
    model = LinearARX(Lags.arx(1, 1), fit_intercept=False).fit(data)
    assert model.simulate(data).y.shape == (600, 1)  # the stable model stays inside
    low, high = model.divergence_envelope()["y"]
    width = y.max() - y.min()
    assert low == pytest.approx(y.min() - DIVERGENCE_SPANS * width)
    assert high == pytest.approx(y.max() + DIVERGENCE_SPANS * width)
    model.coef_[0, 0] = 1.05  # y(t) = 1.05 y(t-1) + ...: finite for 600 samples, but runs away
    with pytest.raises(DivergenceError, match="ran away: output 'y'") as caught:
        model.simulate(data)
    run = caught.value.result.y[:, 0]
    assert np.all(np.isfinite(run)) and np.abs(run).max() > high
