"""Exports (``neckid.export``, ``neckid export``): the description, its JSON and MATLAB files.

Every registered method exports to JSON and to a ``.mat`` file that reads back equal; the
exported coefficients are checked against the models themselves: ARX polynomials and transfer
functions reproduce the free run (``scipy.signal.lfilter``), the state-space matrices the
simulation, the polynomial's monomials, the network's layers and the Set Membership data set
the one-step predictions, the scheduled lines the gain and pole.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.io
from scipy.signal import lfilter
from typer.testing import CliRunner

import neckid
from _synthetic import arx_system
from neckid import IOData, Lags, LinearARX, export_model, write_export
from neckid.cli import app
from neckid.export import MATLAB_FIELD_LENGTH, json_text, matlab_script

METHODS = sorted(neckid.methods())
LINEAR_METHODS = {"arx", "rls", "ss"}
runner = CliRunner()


def _data(seed: int = 0, n: int = 400) -> IOData:
    """A first-order system with a saturating input held in steps (as the contract test's)."""
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
    )


DATA = _data()


@pytest.fixture(scope="module")
def fitted() -> dict[str, Any]:
    """Every registered method, fitted with its quick settings on :data:`DATA`."""
    models = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the quick network stops before converging
        for name in METHODS:
            models[name] = neckid.methods()[name].make(Lags.arx(1, 1, 1), quick=True).fit(DATA)
    return models


def _same(expected: Any, got: Any, where: str) -> None:
    """``got`` (``scipy.io.loadmat``'s, unsqueezed) holds ``expected`` as the export promised."""
    if isinstance(expected, dict):
        assert got.shape == (1, 1), where
        assert set(got.dtype.names) == set(expected), where
        for key, value in expected.items():
            _same(value, got[0, 0][key], f"{where}.{key}")
    elif expected is None:
        assert got.size == 0, where
    elif isinstance(expected, np.ndarray):
        assert got.dtype != object and got.size == expected.size, where
        np.testing.assert_array_equal(got.reshape(expected.shape), expected, err_msg=where)
    elif isinstance(expected, list):
        assert got.dtype == object, where
        table = bool(expected) and all(isinstance(row, list) for row in expected)
        shape = (len(expected), len(expected[0])) if table else (1, len(expected))
        assert got.shape == (shape if expected else (0, 0)), where
        items = [item for row in expected for item in row] if table else expected
        for index, item in zip(np.ndindex(*shape), items, strict=False):
            _same(item, got[index], f"{where}{{{index}}}")
    elif isinstance(expected, str):
        assert got.size <= 1 and "".join(got.tolist()) == expected, where
    else:  # a number or a bool: a 1 x 1 double or logical
        np.testing.assert_array_equal(got, [[float(expected)]], err_msg=where)


def _keys(value: Any) -> list[str]:
    """Every key of a nested description."""
    if isinstance(value, dict):
        return [*value, *(k for v in value.values() for k in _keys(v))]
    if isinstance(value, list):
        return [k for v in value for k in _keys(v)]
    return []


# ============================================================================ every method
@pytest.mark.parametrize("name", METHODS)
def test_every_method_exports_to_json_and_a_mat_file_that_reads_back(
    fitted: dict[str, Any], name: str, tmp_path: Path
) -> None:
    model = fitted[name]
    description = export_model(model)
    method = neckid.methods()[description["method"]]  # the registry's (quick settings aside)
    assert method.estimator.endswith(":" + type(model).__name__)
    assert description["label"] == method.label
    assert description["linear"] is (name in LINEAR_METHODS)
    assert (description["ts"], description["input_names"]) == (0.02, ["command"])
    assert (description["output_names"], description["output_units"]) == (["inclination"], ["deg"])
    assert description["input_units"] == ["rad/s"]
    np.testing.assert_array_equal(
        description["output_ranges"], [model.training_ranges_["inclination"]]
    )
    assert isinstance(description["parameters"]["equation"], str)
    for key in _keys(description):  # the struct's field names, in every MATLAB since R14
        assert re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", key) and len(key) <= MATLAB_FIELD_LENGTH
    text = write_export(model, tmp_path / "model.json", to="json").read_text(encoding="utf-8")

    def refuse(constant: str) -> None:
        raise AssertionError(f"{constant} in strict JSON")

    document = json.loads(text, parse_constant=refuse)
    assert document == json.loads(json_text(description))
    assert document["structure"] == description["structure"]
    mat = scipy.io.loadmat(write_export(model, tmp_path / "model.mat", to="mat"))
    _same(description, mat["model"], "model")


@pytest.mark.parametrize("name", sorted(set(METHODS) - LINEAR_METHODS))
def test_a_transfer_function_of_a_nonlinear_model_is_refused_naming_the_exports_that_work(
    fitted: dict[str, Any], name: str, tmp_path: Path
) -> None:
    with pytest.raises(TypeError, match=r"nonlinear.*: export it with --to json or --to mat$"):
        write_export(fitted[name], tmp_path / "model.m", to="tf")
    assert not (tmp_path / "model.m").exists()


@pytest.mark.parametrize(
    ("model", "error", "message"),
    [
        (LinearARX(Lags.arx(1, 1)), neckid.NotFittedError, "not fitted yet"),
        ("model.npz", TypeError, "export_model takes a fitted neckid model .*; got a str"),
    ],
)
def test_an_unfitted_model_or_another_object_is_refused(
    model: Any, error: type[Exception], message: str
) -> None:
    with pytest.raises(error, match=message):
        export_model(model)


def test_json_writes_non_finite_numbers_as_null_and_the_mat_file_keeps_them(
    tmp_path: Path,
) -> None:
    from neckid import GainScheduledModel

    model = GainScheduledModel.from_coefficients([-0.059, 1.857], [0.01175, -0.4797], ts=0.02)
    description = export_model(model)
    np.testing.assert_array_equal(description["parameters"]["schedule_range"], [-np.inf, np.inf])
    document = json.loads(write_export(model, tmp_path / "s.json").read_text(encoding="utf-8"))
    assert document["parameters"]["schedule_range"] == [None, None]
    mat = scipy.io.loadmat(write_export(model, tmp_path / "s.mat", to="mat"))
    schedule = mat["model"]["parameters"][0, 0]["schedule_range"][0, 0]
    np.testing.assert_array_equal(schedule, [[-np.inf, np.inf]])


def test_the_preprocessing_stored_in_the_model_is_exported(fitted: dict[str, Any]) -> None:
    from neckid.data.preprocess import LowPass, Pipeline, Relative

    model = LinearARX(Lags.arx(1, 1)).fit(DATA)
    model.preprocessing_ = Pipeline([Relative("command"), LowPass("inclination", 1.0)])
    steps = export_model(model)["preprocessing"]
    assert steps == model.preprocessing_.to_list()
    assert [s["step"] for s in steps] == ["relative", "lowpass"]


# ============================================================================ linear models
def _zero_start(data: IOData, m: int) -> IOData:
    """``data`` with the inputs of the first ``m`` samples at zero (a filter at rest)."""
    u = data.u.copy()
    u[:m] = 0.0
    return IOData(
        u, data.y, ts=data.ts, input_names=data.input_names, output_names=data.output_names
    )


def _lfilter_tf(num: np.ndarray, den: np.ndarray, u: np.ndarray) -> np.ndarray:
    """A transfer function in descending powers of z run by ``lfilter`` (powers of z^-1)."""
    return lfilter(np.r_[np.zeros(den.size - num.size), num], den, u)


@pytest.mark.parametrize("name", ["arx", "rls"])
def test_arx_polynomials_and_transfer_function_reproduce_the_free_run(name: str) -> None:
    data = arx_system(400, seed=1)  # na = 2, nb = 2, delay nk = 3
    model = neckid.methods()[name].make(Lags.arx(2, 2, 3), quick=True).fit(data)
    description = export_model(model)
    parameters, tf = description["parameters"], description["transfer_function"]
    assert description["input_lags"][0].tolist() == [3, 4]
    assert (parameters["na"].tolist(), parameters["nb"].tolist(), parameters["nk"].tolist()) == (
        [[2]],
        [[2]],
        [[3]],
    )
    a, b = parameters["A"][0][0], parameters["B"][0][0]
    assert a[0] == 1.0 and np.all(b[:3] == 0.0)  # idpoly: A = [1 a1 a2], B = [0 0 0 b3 b4]
    np.testing.assert_allclose(a, [1.0, -1.2, 0.5], atol=0.02)
    np.testing.assert_allclose(b[3:], [0.8, 0.4], atol=0.02)
    y0 = tf["output_offset"]
    run = _zero_start(data, model.max_lag_)
    expected = model.simulate(run, initial=y0).y[:, 0]
    np.testing.assert_allclose(y0[0] + lfilter(b, a, run.u[:, 0]), expected, rtol=0, atol=1e-10)
    through_tf = y0[0] + _lfilter_tf(tf["num"][0][0], tf["den"][0][0], run.u[:, 0])
    np.testing.assert_allclose(through_tf, expected, rtol=0, atol=1e-10)


def test_mimo_arx_polynomials_and_transfer_matrix_reproduce_the_free_run() -> None:
    rng = np.random.default_rng(2)
    u = rng.normal(size=(500, 2))
    y = np.zeros((500, 2))
    for t in range(2, 500):
        y[t, 0] = 0.5 * y[t - 1, 0] + 0.2 * y[t - 1, 1] + u[t - 1, 0] - 0.3 * u[t - 2, 1] + 0.1
        y[t, 1] = -0.3 * y[t - 1, 0] + 0.6 * y[t - 1, 1] + 0.5 * u[t - 1, 1]
    data = IOData(u, y, ts=0.1, input_names=["m1", "m2"], output_names=["pitch", "roll"])
    model = LinearARX(Lags.arx(1, 2, 1)).fit(data)
    description = export_model(model)
    parameters, tf = description["parameters"], description["transfer_function"]
    a = np.array(parameters["A"])  # (outputs, outputs, 2)
    b = np.array(parameters["B"])  # (outputs, inputs, 3)
    np.testing.assert_allclose(a[:, :, 1], [[-0.5, -0.2], [0.3, -0.6]], atol=1e-9)
    run = _zero_start(data, model.max_lag_)
    expected = model.simulate(run, initial=tf["output_offset"]).y
    # A(q) y(t) = B(q) u(t) + intercept, as a difference equation
    by_polynomials = np.zeros_like(expected)
    by_polynomials[: model.max_lag_] = expected[: model.max_lag_]
    for t in range(model.max_lag_, 500):
        past = sum(a[:, :, lag] @ by_polynomials[t - lag] for lag in range(1, a.shape[2]))
        inputs = sum(b[:, :, lag] @ run.u[t - lag] for lag in range(b.shape[2]))
        by_polynomials[t] = parameters["intercept"] - past + inputs
    np.testing.assert_allclose(by_polynomials, expected, rtol=0, atol=1e-9)
    through_tf = tf["output_offset"] + np.column_stack(
        [
            sum(_lfilter_tf(tf["num"][o][j], tf["den"][o][j], run.u[:, j]) for j in range(2))
            for o in range(2)
        ]
    )
    np.testing.assert_allclose(through_tf, expected, rtol=0, atol=1e-9)


def test_state_space_matrices_reproduce_the_simulation_and_the_transfer_matrix(
    fitted: dict[str, Any],
) -> None:
    model = fitted["ss"]
    description = export_model(model)
    p, tf = description["parameters"], description["transfer_function"]
    m = description["max_lag"]
    x = model.initial_state(DATA.y[:m], DATA.u[:m])
    y = np.empty((DATA.n_samples - m, 1))
    for t in range(m, DATA.n_samples):
        y[t - m] = p["C"] @ x + p["D"] @ DATA.u[t] + p["intercept"]
        x = p["A"] @ x + p["B"] @ DATA.u[t]
    np.testing.assert_allclose(y, model.simulate(DATA).y[m:], rtol=0, atol=1e-10)
    np.testing.assert_array_equal(tf["output_offset"], p["intercept"])
    for z in np.exp(1j * np.array([0.01, 0.3, 2.0])):
        state = p["C"] @ np.linalg.solve(z * np.eye(p["order"]) - p["A"], p["B"]) + p["D"]
        ratio = np.polyval(tf["num"][0][0], z) / np.polyval(tf["den"][0][0], z)
        np.testing.assert_allclose(ratio, state[0, 0], rtol=1e-9)


# ============================================================================ nonlinear models
def _regressors(model: Any) -> tuple[np.ndarray, int]:
    x, _ = model.lags_.build_one(DATA)
    return x, model.max_lag_


def test_polynomial_monomials_reproduce_the_one_step_prediction(fitted: dict[str, Any]) -> None:
    model = fitted["poly"]
    p = export_model(model)["parameters"]
    w, m = _regressors(model)
    x = (w - p["center"]) / p["scale"]
    held = np.clip(x, p["low"], p["high"])
    degree = p["powers"].sum(axis=1)
    monomials = np.column_stack(
        [
            np.prod(np.where(d == 1, x, held) ** row, axis=1)
            for row, d in zip(p["powers"], degree, strict=True)
        ]
    )
    assert p["monomials"][:4] == ["1", "z1", "z2", "z1^2"]
    np.testing.assert_allclose(monomials @ p["coef"], model.predict(DATA).y[m:], atol=1e-10)


def test_neural_layers_reproduce_the_one_step_prediction(fitted: dict[str, Any]) -> None:
    model = fitted["nn"]
    p = export_model(model)["parameters"]
    w, m = _regressors(model)
    outputs = []
    for network in range(p["n_networks"]):
        h = (w - p["x_mean"]) / p["x_scale"]
        for layer in p["layers"]:
            h = h @ layer["weights"][network] + layer["biases"][network]
            h = np.tanh(h) if layer["activation"] == "tanh" else h
        outputs.append(h)
    y = p["y_mean"] + p["y_scale"] * np.mean(outputs, axis=0)
    np.testing.assert_allclose(y, model.predict(DATA).y[m:], atol=1e-10)


@pytest.mark.parametrize("name", ["sm", "sm-linear"])
def test_set_membership_data_set_and_prior_reproduce_the_central_estimate(
    fitted: dict[str, Any], name: str
) -> None:
    model = fitted[name]
    p = export_model(model)["parameters"]
    assert p["lipschitz"] == "global" and p["point_gamma"] is None
    w, m = _regressors(model)
    w = w[::7]  # every 7th row: enough to check, brute force over the data set
    linear = w @ p["coef"] + p["intercept"]
    residual = p["outputs"] - (p["regressors"] @ p["coef"] + p["intercept"])
    distance = np.linalg.norm((w[:, None, :] - p["regressors"][None]) * p["weights"], axis=2)
    upper = np.min(residual[None, :, 0] + p["epsilon"] + p["gamma"] * distance, axis=1)
    lower = np.max(residual[None, :, 0] - p["epsilon"] - p["gamma"] * distance, axis=1)
    central = linear[:, 0] + 0.5 * (upper + lower)
    np.testing.assert_allclose(central, model.predict(DATA).y[m:][::7, 0], atol=1e-10)


def test_composite_set_membership_models_nest_their_parts(fitted: dict[str, Any]) -> None:
    parallel = export_model(fitted["sm-parallel"])["parameters"]
    assert parallel["parallel_model"]["structure"] == "arx"
    assert parallel["sm_map"]["input_names"] == ["command", "inclination_linear"]
    multistep = export_model(fitted["sm-multistep"])["parameters"]
    assert multistep["horizons"].tolist() == [1, 2, 3]
    assert [p["structure"] for p in multistep["predictors"]] == ["set_membership"] * 3
    np.testing.assert_array_equal(multistep["epsilon"], fitted["sm-multistep"].epsilon_)


def test_scheduled_lines_reproduce_its_gain_pole_and_points(fitted: dict[str, Any]) -> None:
    model = fitted["scheduled"]
    p = export_model(model)["parameters"]
    assert (p["form"], p["command"], p["delay"], p["degree"]) == ("rate", "command", 1, 1)
    inclination = np.linspace(-2.0, 2.0, 41)
    held = np.clip(inclination, *p["schedule_range"])
    np.testing.assert_allclose(np.polyval(p["gain_coefficients"], held), model.gain(inclination))
    pole = np.clip(np.polyval(p["pole_coefficients"], held), -p["pole_bound"], p["pole_bound"])
    np.testing.assert_allclose(pole, model.pole(inclination))
    np.testing.assert_array_equal(p["points"]["inclinations"], model.inclinations_)
    np.testing.assert_array_equal(p["points"]["gains"], model.gains_)
    # the lines are the least-squares fit through the points
    np.testing.assert_allclose(
        p["gain_coefficients"], np.polyfit(model.inclinations_, model.gains_, 1), atol=1e-12
    )


# ============================================================================ command line
@pytest.fixture(scope="module")
def model_files(fitted: dict[str, Any], tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    folder = tmp_path_factory.mktemp("models")
    arx = LinearARX(Lags.arx(2, 2, 3)).fit(arx_system(300, seed=3))
    return [arx.save(folder / "arx.npz"), fitted["sm"].save(folder / "sm.npz")]


@pytest.fixture
def saved_models(model_files: list[Path], tmp_path: Path) -> dict[str, Path]:
    """A linear and a nonlinear model file, alone in a folder of their own."""
    return {path.stem: Path(shutil.copy(path, tmp_path / path.name)) for path in model_files}


def test_cli_exports_json_mat_and_a_matlab_script(saved_models: dict[str, Path]) -> None:
    model = saved_models["arx"]
    for to, suffix in (("json", ".json"), ("mat", ".mat"), ("tf", ".m")):
        result = runner.invoke(app, ["export", str(model), "--to", to])
        assert result.exit_code == 0, result.output
        assert model.with_suffix(suffix).exists()  # beside the model by default
    description = export_model(neckid.load_model(model))
    written = json.loads(model.with_suffix(".json").read_text(encoding="utf-8"))
    assert written == json.loads(json_text(description))
    _same(description, scipy.io.loadmat(model.with_suffix(".mat"))["model"], "model")
    script = model.with_suffix(".m").read_text(encoding="utf-8")
    assert script == matlab_script(neckid.load_model(model))
    assert "G = tf(num, den, Ts, " in script and "idpoly(A, B, [], [], [], [], Ts" in script


def test_cli_refuses_an_existing_output_without_force(saved_models: dict[str, Path]) -> None:
    model = saved_models["arx"]
    out = model.parent / "exported.mat"
    out.write_text("keep me", encoding="utf-8")
    result = runner.invoke(app, ["export", str(model), "--to", "mat", "--out", str(out)])
    assert result.exit_code == 2
    assert "exists already; use --force" in result.output
    assert out.read_text(encoding="utf-8") == "keep me"
    forced = runner.invoke(app, ["export", str(model), "--to", "mat", "--out", str(out), "--force"])
    assert forced.exit_code == 0, forced.output
    assert scipy.io.loadmat(out)["model"]["structure"][0, 0][0] == "arx"


@pytest.mark.parametrize(
    ("which", "arguments", "message"),
    [
        ("sm", ["--to", "tf"], "SetMembership) is nonlinear: export it with --to json or --to mat"),
        ("arx", ["--to", "xml"], "--to must be one of json, mat, tf, c; got 'xml'"),
        ("arx", ["--to", "mat", "--out", "{dir}/x.json"], "its name must end in .mat"),
        ("arx", ["--to", "tf", "--out", "{dir}/arx-1.m"], "choose e.g. 'arx_1.m'"),
    ],
)
def test_cli_refusals_are_one_line(
    saved_models: dict[str, Path], which: str, arguments: list[str], message: str
) -> None:
    model = saved_models[which]
    given = [a.replace("{dir}", str(model.parent)) for a in arguments]
    result = runner.invoke(app, ["export", str(model), *given])
    assert result.exit_code == 2
    text = " ".join(result.output.split())
    assert text.startswith("error:") and message in text
    assert "Traceback" not in result.output
    assert sorted(p.name for p in model.parent.iterdir()) == ["arx.npz", "sm.npz"]


@pytest.mark.skipif(shutil.which("octave-cli") is None, reason="GNU Octave is not installed")
def test_the_matlab_scripts_run_in_octave_and_give_the_free_run(
    fitted: dict[str, Any], tmp_path: Path
) -> None:
    arx_data = arx_system(300, seed=4)
    runs = {  # inputs at rest until the state-space model's first free-run sample
        "arx_model": (LinearARX(Lags.arx(2, 2, 3)).fit(arx_data), _zero_start(arx_data, 10)),
        "ss_model": (fitted["ss"], _zero_start(DATA, 10)),
    }
    commands = ["pkg load control;"]
    for name, (model, run) in runs.items():
        write_export(model, tmp_path / f"{name}.m", to="tf")
        np.savetxt(tmp_path / f"{name}_u.csv", run.u, delimiter=",")
        commands += [
            f"run('{name}.m'); u = dlmread('{name}_u.csv');",
            f"dlmwrite('{name}_G.csv', lsim(G, u) + y0, 'precision', 17);",
        ]
    commands.append("dlmwrite('ss_model_sys.csv', lsim(sys, u) + y0, 'precision', 17);")
    subprocess.run(
        ["octave-cli", "--quiet", "--eval", " ".join(commands)],
        cwd=tmp_path,
        check=True,
        capture_output=True,
        timeout=120,
    )
    for name, system in (("arx_model", "G"), ("ss_model", "G"), ("ss_model", "sys")):
        model, run = runs[name]
        y0 = export_model(model)["transfer_function"]["output_offset"]
        expected = model.simulate(run, initial=y0).y[:, 0]
        octave = np.loadtxt(tmp_path / f"{name}_{system}.csv", delimiter=",")
        m = model.max_lag_
        np.testing.assert_allclose(octave[m:], expected[m:], rtol=0, atol=1e-8)
