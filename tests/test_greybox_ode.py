"""User-defined grey-box state-space models (:class:`~neckid.models.greybox.GreyBoxODE`).

Parameter recovery on data made by the structures themselves (the cascaded tanks, a user's one
tank), the compiled free run against its Python reference, files (shipped structure by name, a
user's passed explicitly, an unknown one refused with its name), conditions as inputs, the
simulator and state map against the free run, the divergence safeguard, and table-driven
refusals of bad structures and settings.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from numba import njit

import neckid
from neckid import IOData, Lags, NotFittedError
from neckid.models.greybox import (
    GreyBoxODE,
    GreyBoxStructure,
    StructureParameter,
    shipped_structures,
    simulate_structure,
)
from neckid.models.greybox.ode_kernels import free_run

TANKS = shipped_structures()["cascaded-tanks"]
#: k1, a1, k3, a2, k4, pump dead zone, lower outlet, upper capacity, overflow share, lower
#: capacity.
TANKS_TRUTH = np.array([0.05, 0.5, 0.05, 0.6, 0.06, 0.3, 0.2, 12.0, 0.5, 10.0])


def _tanks_data(n: int = 400, seed: int = 2, x0: list[float] | None = None) -> IOData:
    """Pump steps that fill both tanks to overflow and let them drain; noise-free level [V]."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(0.2, 6.5, n // 20), 20)
    start = TANKS.initial_state(np.array([3.0]), u[:1], TANKS_TRUTH) if x0 is None else x0
    _, y = simulate_structure(TANKS, u, TANKS_TRUTH, ts=4.0, x0=start)
    return IOData(
        u, y, ts=4.0, input_names=["pump_voltage"], output_names=["level_lower"],
        input_units=["V"], output_units=["V"],
    )  # fmt: skip


# ---------------------------------------------------------------------------- a user's structure
def _tank_state(x, u, p):
    """One tank: dx/dt = b u - a sqrt(x) (Torricelli), level [cm]."""
    return np.array([p[1] * u[0] - p[0] * math.sqrt(max(x[0], 0.0))])


def _tank_level(x, u, p):
    return np.array([x[0]])


def _tank_start(y0, u0, p):
    return np.array([max(y0[0], 0.0)])


def _one_tank(name: str = "one-tank", compiled: bool = False, **changes) -> GreyBoxStructure:
    """The one-tank structure (plain Python, or numba-compiled), with ``changes`` applied."""
    wrap = njit if compiled else (lambda f: f)
    settings = {
        "state_equation": wrap(_tank_state),
        "output_equation": wrap(_tank_level),
        "initial_state": wrap(_tank_start),
        "parameters": (
            StructureParameter("outflow", 0.2, 1e-3, 5.0, "cm^0.5/s", log_scale=True),
            StructureParameter("pump_gain", 0.2, 1e-3, 5.0, "cm/(V s)", log_scale=True),
        ),
        "state_names": ("level",),
        "state_units": ("cm",),
        "n_inputs": 1,
        "n_outputs": 1,
        "state_lower": (0.0,),
    }
    return GreyBoxStructure(name=name, **{**settings, **changes})


ONE_TANK = _one_tank()
TANK_TRUTH = np.array([0.3, 0.5])


def _one_tank_data(n: int = 150, seed: int = 0) -> IOData:
    u = np.repeat(np.random.default_rng(seed).uniform(0.0, 3.0, n // 15), 15)
    _, y = simulate_structure(ONE_TANK, u, TANK_TRUTH, ts=1.0, x0=[2.0])
    return IOData(u, y, ts=1.0, input_names=["pump"], output_names=["level"])


# ============================================================================ recovery
def test_the_cascaded_tanks_parameters_are_recovered_from_their_free_run() -> None:
    data = _tanks_data(n=400)
    assert data.y.max() == pytest.approx(TANKS_TRUTH[9])  # the lower tank overflows
    model = GreyBoxODE(structure="cascaded-tanks", n_starts=1, max_iter=100).fit(data)
    np.testing.assert_allclose(model.parameters_, TANKS_TRUTH, rtol=0.02, atol=0.01)
    assert model.fit_percent(data)[0] >= 99.0
    assert model.train_rmse_[0] < 0.01
    assert set(model.parameter_values()) == set(TANKS.parameter_names)


def test_an_unknown_initial_state_is_estimated() -> None:
    """Started far from the rule's balanced upper tank: the estimated start recovers it."""
    data = _tanks_data(n=400, seed=2, x0=[1.0, 6.0])
    model = GreyBoxODE(initial_state="estimated", n_starts=1, max_iter=150).fit(data)
    np.testing.assert_allclose(model.initial_states_[0], [1.0, 6.0], rtol=0, atol=0.05)
    np.testing.assert_allclose(model.parameters_[:5], TANKS_TRUTH[:5], rtol=0.02)
    rerun = model.simulate(data, state=model.initial_states_[0])
    assert rerun.fit_percent(data)[0] >= 99.0


def test_fixed_parameters_stay_at_their_guess() -> None:
    data = _tanks_data(n=300)
    model = GreyBoxODE(fixed=["pump_threshold", "lower_outlet"], n_starts=1, max_iter=20)
    model.fit(data)
    assert model.parameter_values()["pump_threshold"] == 0.0
    assert model.parameter_values()["lower_outlet"] == 0.0
    with pytest.raises(ValueError, match=r"fixed must name parameters of structure"):
        GreyBoxODE(fixed=["pump"], n_starts=1).fit(data)


# ============================================================================ kernels
def _as_python(structure: GreyBoxStructure) -> GreyBoxStructure:
    return dataclasses.replace(
        structure,
        **{
            role: getattr(structure, role).py_func
            for role in ("state_equation", "output_equation", "initial_state", "saturation")
        },
    )


def test_the_compiled_free_run_equals_its_python_reference() -> None:
    data = _tanks_data(n=200)
    python = _as_python(TANKS)
    assert TANKS.compiled and not python.compiled
    x0 = np.array([11.5, 9.0])
    compiled = free_run(TANKS, x0, data.u, TANKS_TRUTH, 4.0, 4)
    reference = free_run(python, x0, data.u, TANKS_TRUTH, 4.0, 4)
    for fast, slow in zip(compiled, reference, strict=True):
        np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)


def test_runge_kutta_converges_on_a_linear_tank_at_fourth_order() -> None:
    """dx/dt = -x + u held: exact x(T) = u + (x0 - u) e^{-T}; the error falls ~16x per halving."""

    def linear(x, u, p):
        return np.array([-p[0] * x[0] + u[0]])

    structure = _one_tank(name="linear", state_equation=linear)
    exact = 1.0 + (0.0 - 1.0) * math.exp(-2.0)
    errors = [
        abs(simulate_structure(structure, [1.0, 1.0], [1.0, 0.0], ts=2.0, x0=[0.0], substeps=k)[0][1, 0] - exact)
        for k in (1, 2, 4)
    ]  # fmt: skip
    assert errors[0] / errors[1] > 12 and errors[1] / errors[2] > 14


def test_a_runaway_free_run_is_nan_from_where_it_leaves() -> None:
    def explosive(x, u, p):
        return np.array([p[0] * x[0] * x[0]])

    structure = _one_tank(name="explosive", state_equation=explosive, state_lower=None)
    _, y = free_run(structure, np.array([1.0]), np.zeros((50, 1)), np.array([5.0, 1.0]), 1.0, 4)
    bad = np.flatnonzero(~np.isfinite(y[:, 0]))
    assert bad.size and np.all(np.isfinite(y[: bad[0]])) and np.all(np.isnan(y[bad[0] :]))


# ============================================================================ a user's structure
@pytest.mark.filterwarnings("ignore::neckid.models.base.ExtrapolationWarning")  # other steps
@pytest.mark.parametrize("compiled", [False, True], ids=["python", "numba"])
def test_a_users_one_tank_works_end_to_end(compiled: bool, tmp_path) -> None:
    structure = _one_tank(compiled=compiled)
    train, test = _one_tank_data(seed=0), _one_tank_data(seed=1)
    model = GreyBoxODE(structure=structure, n_starts=1, max_iter=60).fit(train)
    np.testing.assert_allclose(model.parameters_, TANK_TRUTH, rtol=1e-3)
    result = model.simulate(test)
    assert result.kind == "simulation" and result.fit_percent(test)[0] > 99.5
    assert result.extras["state_names"] == ("level",)
    assert model.predict(test).kind == "simulation"
    simulator = model.simulator()
    simulator.reset(y0=test.y[:1], u0=test.u[:1])
    stepped = np.array([simulator.step(row) for row in test.u[1:]])
    np.testing.assert_allclose(stepped, result.y[1:], rtol=0, atol=1e-12)
    assert model.partial_fit(test) is model and model.n_samples_ == test.n_samples
    path = model.save(tmp_path / "tank")
    loaded = GreyBoxODE.load(path, structures=[structure])
    np.testing.assert_array_equal(loaded.simulate(test).y, model.simulate(test).y)


def test_a_file_of_an_unknown_structure_is_refused_naming_it(tmp_path) -> None:
    model = GreyBoxODE(structure=ONE_TANK, n_starts=1, max_iter=20).fit(_one_tank_data())
    path = model.save(tmp_path / "tank")
    with pytest.raises(ValueError, match=r"'one-tank' is not shipped .*structures=\[") as info:
        neckid.load_model(path)
    assert "\n" not in str(info.value)
    with pytest.raises(ValueError, match="'one-tank' is not shipped"):
        GreyBoxODE.load(path, structures=[_one_tank(name="another-tank")])
    renamed = dataclasses.replace(ONE_TANK, state_names=("height",))
    with pytest.raises(ValueError, match=r"has states \['level'\].*pass the structure"):
        GreyBoxODE.load(path, structures=[renamed])


def test_a_shipped_structure_round_trips_through_its_file(tmp_path) -> None:
    data = _tanks_data(n=300)
    model = GreyBoxODE(n_starts=1, max_iter=15).fit(data)
    path = model.save(tmp_path / "tanks")
    for loaded in (neckid.load_model(path), GreyBoxODE.load(path)):
        assert loaded.structure_ is TANKS and loaded.get_params()["structure"] == "cascaded-tanks"
        np.testing.assert_array_equal(loaded.simulate(data).y, model.simulate(data).y)
        np.testing.assert_array_equal(loaded.parameters_, model.parameters_)


def test_conditions_of_the_lags_are_inputs_of_the_structure() -> None:
    """A valve opening per run (a condition) scales the outflow: dx/dt = b u - a v sqrt(x)."""

    def valve_tank(x, u, p):
        return np.array([p[1] * u[0] - p[0] * u[1] * math.sqrt(max(x[0], 0.0))])

    structure = _one_tank(name="valve-tank", state_equation=valve_tank, n_inputs=2)
    runs = []
    for seed, opening in enumerate((0.5, 1.0)):
        base = _one_tank_data(seed=seed)
        inputs = np.column_stack([base.u[:, 0], np.full(base.n_samples, opening)])
        _, y = simulate_structure(structure, inputs, TANK_TRUTH, ts=1.0, x0=[2.0])
        runs.append(
            IOData(base.u, y, ts=1.0, input_names=["pump"], output_names=["level"],
                   conditions={"valve": opening})
        )  # fmt: skip
    model = GreyBoxODE(Lags(1, 1, conditions=["valve"]), structure=structure, n_starts=1)
    model.fit(runs)
    assert model.input_names_ == ("pump", "valve")
    np.testing.assert_allclose(model.parameters_, TANK_TRUTH, rtol=1e-3)
    assert model.simulate(runs[1]).fit_percent(runs[1])[0] > 99.5
    with pytest.raises(ValueError, match="takes 1 input"):
        GreyBoxODE(Lags(1, 1, conditions=["valve"]), structure=ONE_TANK).fit(runs)


# ============================================================================ safeguards
@njit
def _linear_state(x, u, p):
    return np.array([p[0] * x[0] + p[1] * u[0]])


@njit
def _measured_start(y0, u0, p):
    return np.array([y0[0]])


def _first_order(initial: float, lower: float) -> GreyBoxStructure:
    """dx/dt = a x + b u (compiled), the pole's guess ``initial``: a > 0 runs away."""
    return _one_tank(
        name="first-order",
        compiled=True,
        state_equation=_linear_state,
        initial_state=_measured_start,
        state_lower=None,
        parameters=(
            StructureParameter("pole", initial, lower, 2.0, "1/s"),
            StructureParameter("gain", 1.0, -5.0, 5.0, "1/s"),
        ),
    )


def _first_order_data() -> IOData:
    u = np.repeat(np.random.default_rng(3).uniform(-1.0, 1.0, 20), 15)
    _, y = simulate_structure(_first_order(-0.5, -3.0), u, [-0.5, 1.0], ts=1.0, x0=[0.0])
    return IOData(u, y, ts=1.0)


def test_a_diverging_initial_guess_does_not_crash_the_fit() -> None:
    data = _first_order_data()
    unstable = _first_order(1.5, -3.0)  # e^{1.5 t} passes 1e150 at t = 230 s: a runaway
    _, first_run = simulate_structure(unstable, data.u, [1.5, 1.0], ts=1.0, x0=[0.0])
    assert not np.all(np.isfinite(first_run))
    # From that start alone the search stalls at a slower runaway: refused in one line.
    with pytest.raises(ValueError, match=r"still runs away .*more n_starts"):
        GreyBoxODE(structure=unstable, n_starts=1, max_iter=50).fit(data)
    model = GreyBoxODE(structure=unstable, n_starts=4, max_iter=100).fit(data)
    np.testing.assert_allclose(model.parameters_, [-0.5, 1.0], rtol=1e-3)
    assert model.fit_percent(data)[0] > 99.0
    assert model.start_costs_.shape == (4,) and np.argmin(model.start_costs_) != 0


def test_a_structure_that_can_only_run_away_is_refused_not_crashed() -> None:
    data = IOData(_first_order_data().u, np.sin(np.arange(300) / 10.0), ts=1.0)
    with pytest.raises(ValueError, match="still runs away on training experiment 0"):
        GreyBoxODE(structure=_first_order(1.5, 1.0), n_starts=2, max_iter=10).fit(data)


# ============================================================================ refusals
def _list_output(x, u, p):
    return [x[0]]


@pytest.mark.parametrize(
    ("changes", "error", "match"),
    [
        ({"parameters": (StructureParameter("a", 1.0, 2.0, 1.0),)}, ValueError, "lower < upper"),
        ({"parameters": (StructureParameter("a", 3.0, 0.0, 1.0),)}, ValueError, "initial must"),
        ({"parameters": (StructureParameter("a", 1.0, 0.0, 2.0, log_scale=True),)}, ValueError,
         "log_scale needs"),
        ({"parameters": (StructureParameter("a", 1.0), StructureParameter("a", 2.0))}, ValueError,
         "repeat"),
        ({"parameters": (StructureParameter("2a", 1.0),)}, ValueError, "identifier"),
        ({"state_units": ("cm", "cm")}, ValueError, "one entry per state"),
        ({"n_inputs": 0}, ValueError, "n_inputs must be"),
        ({"time": "sampled"}, ValueError, "time must be"),
        ({"output_equation": _list_output}, TypeError, "must return a NumPy array"),
        ({"output_equation": lambda x, u, p: np.array([x[0], x[0]])}, ValueError,
         r"output_equation must return an array of shape \(1,\)"),
        ({"state_equation": njit(lambda x, u, p: 1)}, TypeError, "must return a NumPy array"),
        ({"compiled": True, "output_equation": njit(lambda x, u, p: np.array([1]))}, TypeError,
         r"do not compile with the signature float64\[::1\]"),
    ],
)  # fmt: skip
def test_a_bad_structure_is_refused_naming_the_rule(changes, error, match) -> None:
    changes = dict(changes)
    base = _one_tank(compiled=changes.pop("compiled", False))
    structure = dataclasses.replace(base, **changes)
    with pytest.raises(error, match=match):
        GreyBoxODE(structure=structure, n_starts=1, max_iter=5).fit(_one_tank_data(n=60))


@pytest.mark.parametrize(
    ("settings", "error", "match"),
    [
        ({"structure": "no-such-tanks"}, ValueError, r"'no-such-tanks' is not shipped"),
        ({"structure": 3}, TypeError, "^structure must be"),
        ({"initial_state": "zero"}, ValueError, "^initial_state must be"),
        ({"substeps": 0}, ValueError, "^substeps must be"),
        ({"n_starts": 0}, ValueError, "^n_starts must be"),
        ({"fixed": "pump_gain"}, TypeError, "^fixed must be"),
    ],
)
def test_bad_settings_are_refused_at_fit(settings, error, match) -> None:
    with pytest.raises(error, match=match):
        GreyBoxODE(**settings).fit(_tanks_data(n=60))


def test_data_on_other_channels_is_refused_naming_the_structure() -> None:
    data = _tanks_data(n=60)
    two = IOData(np.column_stack([data.u, data.u]), data.y, ts=4.0)
    with pytest.raises(ValueError, match=r"'cascaded-tanks' takes 1 input\(s\)"):
        GreyBoxODE().fit(two)


def test_unfitted_use_and_a_state_of_the_wrong_size_are_refused() -> None:
    model = GreyBoxODE()
    with pytest.raises(NotFittedError):
        model.simulate(_tanks_data(n=60))
    fitted = GreyBoxODE(n_starts=1, max_iter=5).fit(_tanks_data(n=60))
    with pytest.raises(ValueError, match=r"state must have 2 values \['upper_content'"):
        fitted.simulate(_tanks_data(n=60), state=[1.0])


# ============================================================================ loops
def test_the_state_map_steps_as_the_free_run() -> None:
    data = _tanks_data(n=120)
    model = GreyBoxODE(n_starts=1, max_iter=10).fit(data)
    system = model.state_map()
    assert system.states == ["upper_content", "lower_level"]
    x = system.initial_state(data.y[:1], data.u[:1])
    outputs = []
    for row in data.u[1:]:
        outputs.append(system.output(x, row))
        x = system.update(x, row)
    np.testing.assert_allclose(np.vstack(outputs), model.simulate(data).y[1:], rtol=0, atol=1e-12)


def test_the_fit_reports_each_least_squares_run_from_its_starts() -> None:
    from _progress_recorder import Recorder
    from neckid.utils.progress import reporting

    recorder = Recorder()
    with reporting(recorder):
        GreyBoxODE(structure="cascaded-tanks", n_starts=4, max_iter=30).fit(_tanks_data(n=200))
    # 4 screening runs, then the best 3 refined (max_iter above the screening budget)
    assert [total for _, total in recorder.started] == [7] and recorder.steps == 7
    assert "cascaded-tanks" in recorder.started[0][0]
