"""The LPV-ARX (``lpv``): dynamics that follow a condition (the payload) or a measured channel.

The floor of issue 40: a spring-mass whose natural frequency falls with the payload, trained at
three payloads and tested at two others, is fitted at >= 94 % in free run by ``lpv`` scheduled on
the payload (a hand prototype reached 96.4 / 94.6 %, ARX with the payload as an additive input
85.1 / 79.3 %, the least-squares LPV alone 80-88 %).
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import cont2discrete

import neckid
from neckid import IOData, Lags
from neckid.export.control import to_control
from neckid.models.lpv import LPVARX

PAYLOAD_LAGS = Lags([1, 2], [1, 2], conditions=["payload"])


def spring_run(payload: float, zeta: float, seed: int, n: int = 1000, ts: float = 0.05) -> IOData:
    """A spring-mass, ω_n = 2π / √(1 + m / 0.4) rad/s, held random steps of 20 samples, 1 % noise."""
    rng = np.random.default_rng(seed)
    wn = 2.0 * np.pi / np.sqrt(1.0 + payload / 0.4)
    a = np.array([[0.0, 1.0], [-(wn**2), -2.0 * zeta * wn]])
    b = np.array([[0.0], [wn**2]])
    ad, bd, cd, _, _ = cont2discrete((a, b, np.array([[1.0, 0.0]]), np.zeros((1, 1))), ts)
    u = np.repeat(rng.uniform(-1.0, 1.0, n // 20 + 1), 20)[:n]
    x, y = np.zeros(2), np.zeros(n)
    for t in range(n):
        y[t] = (cd @ x)[0]
        x = ad @ x + bd[:, 0] * u[t]
    y = y + 0.01 * np.std(y) * rng.normal(size=n)
    return IOData(
        u, y, ts=ts, input_names=["force"], output_names=["position"], input_units=["N"],
        output_units=["m"], name=f"payload-{payload}",
    ).with_conditions(payload=payload)  # fmt: skip


def spring_split(zeta: float) -> tuple[list[IOData], list[IOData]]:
    """Trained at 0, 0.4 and 0.8 kg, tested at 0.2 and 0.6 kg."""
    train = [spring_run(m, zeta, seed) for seed, m in enumerate((0.0, 0.4, 0.8))]
    test = [spring_run(m, zeta, 10 + seed) for seed, m in enumerate((0.2, 0.6))]
    return train, test


def _fits(model, runs: list[IOData]) -> list[float]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [float(model.simulate(d).fit_percent(d)[0]) for d in runs]


@pytest.fixture(scope="module")
def spring() -> tuple[list[IOData], list[IOData], LPVARX]:
    train, test = spring_split(0.3)
    return train, test, LPVARX(PAYLOAD_LAGS, degree=2).fit(train)


def test_lpv_follows_the_payload_of_a_spring_mass(spring) -> None:
    """>= 94 % on both test payloads, where ARX with the payload as an input stays far below."""
    train, test, model = spring
    lpv = _fits(model, test)
    arx = _fits(neckid.methods()["arx"].make(PAYLOAD_LAGS).fit(train), test)
    least_squares = _fits(LPVARX(PAYLOAD_LAGS, degree=2, fit_for="prediction").fit(train), test)
    assert min(lpv) >= 94.0, (lpv, arx, least_squares)
    assert min(lpv) > max(arx) + 5.0, (lpv, arx)  # measured: 96.5 / 94.7 against 87.0 / 76.5
    assert np.mean(lpv) > np.mean(least_squares) + 1.0, (lpv, least_squares)  # the free-run fit
    assert model.fit_report_["max_pole_radius"] < 1.0


def test_a_lightly_damped_spring_too() -> None:
    """ζ = 0.1: measured 89.4 / 79.4 % (ARX 55.0 / 48.9 %); the hand prototype got 88 / 80 %."""
    train, test = spring_split(0.1)
    lpv = _fits(LPVARX(PAYLOAD_LAGS, degree=2).fit(train), test)
    arx = _fits(neckid.methods()["arx"].make(PAYLOAD_LAGS).fit(train), test)
    assert min(lpv) >= 77.0 and min(lpv) > max(arx) + 20.0, (lpv, arx)


def test_the_degree_is_chosen_on_time_blocks_of_the_training_logs() -> None:
    """Held-out time blocks keep every payload in training: the rule then sees degree 2 is better.

    Holding out a whole run leaves two payloads, on which degrees 1 and 2 are the same model (the
    rule then takes the simpler, degree 1: 96.9 / 92.8 % on the test runs, below the floor).
    """
    from neckid.data.folds import time_blocks
    from neckid.selection.comparison import select_safely

    train, _ = spring_split(0.3)
    candidates = [(f"degree={d}", LPVARX(PAYLOAD_LAGS, degree=d)) for d in (1, 2)]
    complexity = {"degree=1": 1, "degree=2": 2}
    blocks = [block for log in train for block in time_blocks(log, 3)]
    assert select_safely(candidates, blocks, complexity=complexity).chosen == "degree=2"
    by_run = select_safely(candidates, train, complexity=complexity)
    assert by_run.chosen == "degree=1"


def test_frozen_models_are_the_arx_at_one_payload(spring) -> None:
    train, test, model = spring
    frozen = model.frozen(payload=0.2)
    assert frozen.input_names_ == ("force",) and frozen.lags_.conditions == ()
    # the frozen ARX runs the 0.2 kg log as the LPV model does (the payload held at 0.2 kg)
    np.testing.assert_allclose(frozen.simulate(test[0]).y, model.simulate(test[0]).y, atol=1e-9)
    system = to_control(model, scheduling={"payload": 0.2}, form="tf")
    assert system.input_labels == ["force"] and system.output_labels == ["position"]
    a1, a2 = frozen.coef_[:2, 0]
    np.testing.assert_allclose(system.den[0][0], [1.0, -a1, -a2], rtol=1e-12)
    poles = np.abs(np.roots([1.0, -a1, -a2]))
    assert poles.max() < 1.0
    default = to_control(model, scheduling={"payload": 0.2})  # the lpv entry's form: ss
    assert type(default).__name__ == "StateSpace" and default.input_labels == ["force"]
    with pytest.raises(ValueError, match="scheduling is required"):
        to_control(model)
    with pytest.raises(ValueError, match="scheduling values must name"):
        model.frozen(mass=0.2)
    arx = neckid.methods()["arx"].make(Lags.arx(2, 2)).fit(train[0])
    with pytest.raises(ValueError, match="scheduling applies to an LPVARX only"):
        to_control(arx, scheduling={"payload": 0.2})


def test_the_lpv_model_is_an_io_system_with_the_payload_as_an_input(spring) -> None:
    import control

    from neckid.export.control import initial_state, to_iosystem

    _, test, model = spring
    system = to_iosystem(model)
    assert system.input_labels == ["force", "payload"]
    log = test[1].conditions_as_inputs(["payload"])
    m = model.max_lag_
    time = np.arange(m, log.n_samples) * log.ts
    x0 = initial_state(model, log.y[:m], log.u[:m])
    response = control.input_output_response(system, time, log.u[m:].T, X0=x0)
    np.testing.assert_allclose(response.outputs.ravel(), model.simulate(log).y[m:, 0], atol=1e-9)


def test_the_schedule_in_words_is_the_polynomial_of_the_model(spring) -> None:
    _, _, model = spring
    described = model.describe_scheduling()
    assert described["variables"][0]["name"] == "payload"
    assert described["variables"][0]["range"] == [0.0, 0.8]
    line = next(s for s in described["polynomials"] if "a[position(t-1)]" in s)
    # a[position(t-1)](p) read back from the line equals the frozen coefficient at p = 0.5
    terms = line.split("=", 1)[1].split()
    value = 0.0
    for term in terms:
        number, _, power = term.partition("*")
        exponent = 0 if not power else int(power.partition("^")[2] or 1)
        value += float(number) * 0.5**exponent
    assert value == pytest.approx(model.frozen(payload=0.5).coef_[0, 0], rel=1e-3)


def test_scheduled_on_the_inclination_as_the_seed_papers_model() -> None:
    """y(t) = P(y) y(t-1) + N(y) u(t-1): G(z, i) = N(i) / (z - P(i)) with i the output itself."""
    rng = np.random.default_rng(3)
    n = 3000
    u = np.repeat(rng.uniform(0.0, 2.0, n // 25), 25)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = (0.5 + 0.02 * y[t - 1]) * y[t - 1] + (1.0 - 0.02 * y[t - 1]) * u[t - 1]
    data = IOData(u, y + 0.001 * rng.normal(size=n), ts=0.02, output_names=["inclination"])
    model = neckid.methods()["lpv"].make(Lags.arx(1, 1), degree=1).fit(data[: n // 2])
    assert model.scheduling_[0].kind == "output" and model.scheduling_[0].name == "inclination"
    assert _fits(model, [data[n // 2 :]])[0] > 99.0
    frozen = model.frozen(inclination=3.0)  # P(3) = 0.56, N(3) = 0.94
    np.testing.assert_allclose(frozen.coef_[:, 0], [0.56, 0.94], atol=5e-3)
    assert model.simulator() is not None


def test_a_schedule_unstable_somewhere_in_its_range_is_refused() -> None:
    """The pole 0.6 + 0.5 m leaves the unit circle at m = 0.8 kg: every start is unstable there."""
    rng = np.random.default_rng(0)
    runs = []
    for m in (0.0, 0.5, 1.0):
        u = np.repeat(rng.uniform(-1.0, 1.0, 6), 10)
        y = np.zeros(60)
        for t in range(1, 60):
            y[t] = (0.6 + 0.5 * m) * y[t - 1] + u[t - 1]
        runs.append(IOData(u, y, ts=0.1).with_conditions(payload=m))
    with pytest.raises(ValueError, match=r"unstable at \{'payload\(t\)': 1.0\}"):
        LPVARX(Lags([1], [1], conditions=["payload"]), degree=1).fit(runs)


def test_scheduling_names_are_checked(spring) -> None:
    train, _, _ = spring
    with pytest.raises(ValueError, match="scheduling 'mass' is neither a condition"):
        LPVARX(PAYLOAD_LAGS, scheduling="mass").fit(train)
    with pytest.raises(ValueError, match="scheduling 'force' is an input with no term"):
        LPVARX(Lags([1, 2], {"force": []}, conditions=["payload"]), scheduling="force").fit(train)
    both = LPVARX(PAYLOAD_LAGS, scheduling="payload,position", degree=1).fit(train)
    assert [v.kind for v in both.scheduling_] == ["condition", "output"]


def test_the_model_file_keeps_the_schedule_and_refuses_another_form(spring, tmp_path) -> None:
    _, test, model = spring
    path = model.save(tmp_path / "lpv")
    loaded = neckid.load_model(path)
    assert loaded.scheduling_ == model.scheduling_ and loaded.degree == 2
    np.testing.assert_array_equal(loaded.simulate(test[1]).y, model.simulate(test[1]).y)
    arrays = dict(np.load(path))
    # switch on a monomial outside the LPV form (position(t-1) * force(t-1)): refused on load
    powers = arrays["powers"]
    outside = int(
        np.flatnonzero((powers[:, 0] == 1) & (powers[:, 2] == 1) & (powers.sum(1) == 2))[0]
    )
    arrays["active"][outside] = 1
    np.savez(tmp_path / "tampered.npz", **arrays)
    with pytest.raises(ValueError, match="outside the LPV form"):
        neckid.load_model(tmp_path / "tampered.npz")
    header = json.loads(str(np.load(path)["__neckid__"])) if "__neckid__" in arrays else None
    if header is not None:  # a scheduling term outside the regressor is refused too
        header["meta"]["scheduling"][0]["terms"] = [99]
        arrays = dict(np.load(path))
        arrays["__neckid__"] = np.array(json.dumps(header))
        np.savez(tmp_path / "terms.npz", **arrays)
        with pytest.raises(ValueError, match="outside the"):
            neckid.load_model(tmp_path / "terms.npz")


def test_set_membership_runs_on_the_lpv_model(spring) -> None:
    train, test, model = spring
    sm = neckid.methods()["sm-parallel"].make(PAYLOAD_LAGS, base="lpv").fit(train)
    assert isinstance(sm.linear_, LPVARX)
    result = sm.simulate(test[0])
    m = sm.max_lag_
    assert result.lower is not None and np.all(result.lower[m:] <= result.upper[m:])
    assert _fits(sm, test[:1])[0] > _fits(model, test[:1])[0] - 2.0


def test_export_describes_the_schedule(spring, tmp_path: Path) -> None:
    _, _, model = spring
    description = neckid.export_model(model)
    parameters = description["parameters"]
    assert description["structure"] == "lpv_arx"
    assert parameters["scheduling"] == ["payload"]
    assert parameters["schedule_monomials"] == ["1", "payload", "payload^2"]
    row = parameters["schedule_rows"].index("position(t-1)")
    coef = parameters["schedule_coef"][0][row]
    assert coef @ [1.0, 0.6, 0.36] == pytest.approx(model.frozen(payload=0.6).coef_[0, 0])
    neckid.write_export(model, tmp_path / "lpv.json")
    neckid.write_export(model, tmp_path / "lpv.mat", to="mat")
    assert json.loads((tmp_path / "lpv.json").read_text())["parameters"]["degree"] == 2
    assert (tmp_path / "lpv.mat").stat().st_size > 0


def test_info_shows_the_scheduling_polynomials(spring, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from neckid.cli import app

    _, _, model = spring
    path = model.save(tmp_path / "lpv")
    result = CliRunner().invoke(app, ["info", str(path)])
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    assert "scheduling (degree 2)" in text
    assert "a[position(t-1)] =" in text and "payload^2" in text
    assert "largest frozen pole" in text
