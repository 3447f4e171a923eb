"""The Koopman model (EDMD with control): a known lifted system recovered, runs, files, export."""

from __future__ import annotations

import json

import numpy as np
import pytest

from neckid import IOData, Lags, load_model
from neckid.models.koopman import KoopmanEDMD
from neckid.models.koopman.dictionary import fit_observables, monomial_powers

LAMBDA, MU, GAIN = 0.97, 0.8, 0.5


def _exact_lift_logs(n_logs: int = 5, n: int = 300, seed: int = 0) -> list[IOData]:
    """x1⁺ = λ x1, x2⁺ = μ x2 + c x1² + u: linear in [x1, x2, x1², u] (a finite Koopman lift).

    Both states are measured; with lags 1 the first monomial of the regressor is x1(t−1)².
    """
    rng = np.random.default_rng(seed)
    logs = []
    for i in range(n_logs):
        u = rng.uniform(-1.0, 1.0, n)
        x = np.zeros((n, 2))
        x[0] = [(-1.0, -0.5, 0.5, 1.0, 0.3)[i % 5], rng.uniform(-1.0, 1.0)]
        for t in range(1, n):
            x[t, 0] = LAMBDA * x[t - 1, 0]
            x[t, 1] = MU * x[t - 1, 1] + GAIN * x[t - 1, 0] ** 2 + u[t - 1]
        logs.append(IOData(u, x, ts=0.01, output_names=["x1", "x2"], name=f"run{i}"))
    return logs


@pytest.fixture(scope="module")
def exact() -> tuple[KoopmanEDMD, list[IOData]]:
    logs = _exact_lift_logs()
    model = KoopmanEDMD(
        Lags(outputs=[1], inputs=[1]), dictionary="monomials", n_observables=1, ridge=0.0
    )
    return model.fit(logs[:4]), logs


def test_a_known_lifted_system_is_recovered(exact):
    model, logs = exact
    eigenvalues = np.sort(np.abs(np.linalg.eigvals(model.A_[:-1, :-1])))
    # the state [x1, x2, u](t-1), x1(t-1)²: eigenvalues 0 (the input delay), λ², μ, λ
    np.testing.assert_allclose(eigenvalues, [0.0, MU, LAMBDA**2, LAMBDA], atol=1e-7)
    assert model.fit_percent(logs[4]).min() > 99.999
    assert model.order_ == 3 + 1 + 1 and model.spectral_radius_ == pytest.approx(LAMBDA)


def test_simulator_state_map_and_python_control_give_simulate(exact):
    control = pytest.importorskip("control")
    from neckid.export.control import to_control

    model, logs = exact
    data = logs[4]
    free = model.simulate(data).y
    sim = model.simulator()
    sim.reset(y0=data.y[:1], u0=data.u[:1])
    stepped = np.array([sim.step(u) for u in data.u[1:]])
    np.testing.assert_array_equal(stepped, free[1:])
    system = to_control(model)
    assert isinstance(system, control.StateSpace) and system.nstates == model.order_
    x0 = model.initial_state(data.y[:1], data.u[:1])
    response = control.forced_response(system, U=data.u[1:].T, X0=x0)
    np.testing.assert_allclose(response.outputs.T, free[1:], rtol=1e-9, atol=1e-9)
    state_map = model.state_map()
    z = state_map.initial_state(data.y[:1], data.u[:1])
    np.testing.assert_allclose(state_map.output(z, data.u[1]), free[1], rtol=1e-12)


def test_one_step_prediction_reads_measured_outputs(exact):
    model, logs = exact
    result = model.predict(logs[4])
    assert result.kind == "prediction"
    np.testing.assert_allclose(result.y[1:], logs[4].y[1:], atol=1e-8)


def test_model_file_round_trip_and_a_damaged_file(exact, tmp_path):
    model, logs = exact
    path = model.save(tmp_path / "koopman.npz")
    loaded = load_model(path)
    np.testing.assert_array_equal(loaded.simulate(logs[4]).y, model.simulate(logs[4]).y)
    arrays = dict(np.load(path, allow_pickle=False))
    header = json.loads(arrays["__neckid__"].item())
    header["meta"]["order"] = 9
    damaged = tmp_path / "damaged.npz"
    arrays["__neckid__"] = np.array(json.dumps(header))
    np.savez(damaged, **arrays)
    with pytest.raises(ValueError, match="order 9"):
        load_model(damaged)


def test_export_describes_the_lifted_system(exact):
    from neckid.export import export_model

    model, _ = exact
    described = export_model(model)
    assert described["structure"] == "koopman_edmd"
    assert np.shape(described["parameters"]["A"]) == (5, 5)
    assert described["parameters"]["states"][-1] == "one"


def test_selection_chooses_size_and_ridge_on_the_training_logs():
    rng = np.random.default_rng(3)
    u = rng.uniform(-1.0, 1.0, 1200)
    y = np.zeros(1200)
    for t in range(1, 1200):  # a static nonlinearity on the output: the dictionary pays
        y[t] = 0.8 * y[t - 1] + 0.4 * u[t - 1] + 0.3 * np.tanh(3.0 * y[t - 1])
    data = IOData(u, y, ts=0.01)
    model = KoopmanEDMD(Lags.arx(1, 1), dictionary="gaussian").fit(data)
    chosen = model.selection_
    assert chosen["scheme"].startswith("time-blocks")
    assert (model.n_observables_, model.ridge_) == tuple(chosen["candidates"][_index(chosen)])
    assert "paired one-standard-error rule" in chosen["explanation"]
    from neckid.models.koopman.summary import describe_koopman

    assert describe_koopman(model)[1]["selection"].isascii()  # a .mat file keeps ASCII only


def _index(chosen: dict) -> int:
    pairs = [tuple(c) for c in chosen["candidates"]]
    return pairs.index((chosen["n_observables"], chosen["ridge"]))


def test_stability_constraint_pulls_the_spectral_radius_inside():
    rng = np.random.default_rng(4)
    u = rng.normal(size=800)
    y = np.cumsum(0.1 * u)  # an integrator: unconstrained, a mode at 1
    data = IOData(u, y, ts=0.01)
    free = KoopmanEDMD(Lags.arx(1, 1), n_observables=5, ridge=1e-8).fit(data)
    held = KoopmanEDMD(Lags.arx(1, 1), n_observables=5, ridge=1e-8, max_spectral_radius=0.95).fit(
        data
    )
    assert free.spectral_radius_ > 0.99
    assert held.spectral_radius_ <= 0.95 + 1e-9


def test_conditions_are_inputs():
    rng = np.random.default_rng(5)
    logs = []
    for payload in (0.0, 0.2, 0.4):
        u = rng.uniform(-1, 1, 400)
        y = np.zeros(400)
        for t in range(1, 400):
            y[t] = 0.7 * y[t - 1] + 0.5 * u[t - 1] + payload
        logs.append(IOData(u, y, ts=0.01, conditions={"payload": payload}))
    lags = Lags(outputs=[1], inputs=[1], conditions=["payload"])
    model = KoopmanEDMD(lags, n_observables=0, ridge=1e-10).fit(logs[::2])
    assert model.input_names_ == ("u", "payload")
    assert model.fit_percent(logs[1])[0] > 99.9


@pytest.mark.parametrize(
    ("params", "match"),
    [
        ({"dictionary": "splines"}, "dictionary"),
        ({"n_observables": -1}, "n_observables"),
        ({"max_spectral_radius": 1.5}, "max_spectral_radius"),
        ({"n_observables": 50, "ridge": 1e-6}, "distinct training regressors"),
    ],
)
def test_bad_settings_are_refused(params, match):
    data = IOData(np.tile([0.0, 1.0], 20), np.tile([0.0, 0.5], 20), ts=0.1)
    with pytest.raises(ValueError, match=match):
        KoopmanEDMD(Lags.arx(1, 1), **params).fit(data)


def test_lags_are_required():
    with pytest.raises(ValueError, match="needs lags"):
        KoopmanEDMD().fit(IOData(np.zeros(20), np.arange(20.0), ts=0.1))


def test_observables_are_standardised_and_monomials_graded():
    r = np.random.default_rng(0).normal(size=(300, 3))
    for kind in ("thin-plate", "gaussian", "monomials"):
        phi = fit_observables(r, kind, 6)
        values = phi(r)
        np.testing.assert_allclose(values.mean(axis=0), 0.0, atol=1e-9)
        np.testing.assert_allclose(values.std(axis=0), 1.0, rtol=1e-9)
    assert monomial_powers(3, 100).shape == (6 + 10, 3)


def test_an_update_adds_to_the_least_squares():
    logs = _exact_lift_logs()
    lags = Lags(outputs=[1], inputs=[1])
    model = KoopmanEDMD(lags, dictionary="monomials", n_observables=1, ridge=0.0).fit(logs[:1])
    rows = model.gram_rows_.copy()
    model.partial_fit(logs[1:4])
    np.testing.assert_array_equal(model.gram_rows_, rows + np.array([3 * 299, 3 * 298]))
    eigenvalues = np.sort(np.abs(np.linalg.eigvals(model.A_[:-1, :-1])))
    np.testing.assert_allclose(eigenvalues, [0.0, MU, LAMBDA**2, LAMBDA], atol=1e-7)


def test_design_and_mpc_take_the_lifted_linear_system() -> None:
    """A Koopman model has a linear form (design, MPC): its lifted system without the constant."""
    from neckid.design.linear_form import linear_form
    from neckid.design.mpc import mpc_problem

    rng = np.random.default_rng(4)
    u = np.repeat(rng.uniform(-1.0, 1.0, 200), 10) + 0.5
    y = np.zeros(2000)
    for t in range(1, 2000):
        y[t] = 0.6 * y[t - 1] + 2.8 * u[t - 1] + 1.0  # an offset: the constant state's
    data = IOData(u, y, ts=0.02, input_names=["velocity_command"], output_names=["inclination"])
    model = KoopmanEDMD(Lags.arx(1, 1), n_observables=5, ridge=1e-10).fit(data)
    form = linear_form(model)
    assert "lifted linear system: 7 states" in form.source
    for w in (0.3, 3.0, 30.0):  # the plant's response (offset or not), and the loop's delay
        z = np.exp(1j * w * 0.02)
        exact = 2.8 / (z - 0.6) / z
        assert abs(complex(form.response(w)) - exact) < 1e-6 * abs(exact)
    assert mpc_problem(form, horizon=10).horizon == 10
    with pytest.raises(ValueError, match="linear everywhere"):
        linear_form(model, inclination=10.0)


def test_the_compiled_free_run_gives_the_numpy_one_and_runs_away_the_same_way():
    from neckid.models.koopman.lift import LiftedSystem, free_run, free_run_reference

    rng = np.random.default_rng(4)
    n_z, n_in, n_out = 27, 3, 2
    stable = LiftedSystem(
        0.9 * np.linalg.qr(rng.standard_normal((n_z, n_z)))[0],
        rng.standard_normal((n_z, n_in)),
        rng.standard_normal((n_out, n_z)),
        rng.standard_normal((n_out, n_in)),
    )
    unstable = LiftedSystem(1.5 * stable.A, stable.B, stable.C, stable.D)
    u = rng.standard_normal((3000, n_in))
    for system in (stable, unstable):
        z_fast, z_numpy = rng.standard_normal(n_z), None
        z_numpy = z_fast.copy()
        fast = free_run(system, z_fast, u)
        with np.errstate(all="ignore"):
            numpy = free_run_reference(system, z_numpy, u)
        moderate = np.all(np.abs(numpy) < 1e200, axis=1)  # rounding differs only in its last bits
        np.testing.assert_allclose(fast[moderate], numpy[moderate], rtol=1e-9, atol=1e-12)
        assert np.isfinite(fast[-1]).all() == np.isfinite(numpy[-1]).all() == (system is stable)
    # stepping one row at a time gives the floats of the whole run
    z_whole, z_rows = np.ones(n_z), np.ones(n_z)
    whole = free_run(stable, z_whole, u[:50])
    rows = np.vstack([free_run(stable, z_rows, u[t : t + 1]) for t in range(50)])
    np.testing.assert_array_equal(rows, whole)
    np.testing.assert_array_equal(z_rows, z_whole)
