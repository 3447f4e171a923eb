"""The frequency commands as a user runs them: excite, frf, validate --bode, demo --frequency."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from scipy import signal as sps
from typer.testing import CliRunner

from neckid.cli import app

runner = CliRunner()
FILTER = (np.r_[0.0, sps.cheby1(2, 1, 0.3)[0]], sps.cheby1(2, 1, 0.3)[1])  # one sample delay


def _invoke(*args: str):
    return runner.invoke(app, [str(a) for a in args])


def _plan(tmp_path, *extra: str):
    plan = tmp_path / "plan.csv"
    result = _invoke(
        "excite", "--out", plan, "--band", "0.05,2.5", "--ts", "1", "--period", "256",
        "--realisations", "6", "--periods", "3", "--seed", "2", *extra,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    return plan, pd.read_csv(plan)


def _log(tmp_path, frame: pd.DataFrame, output: np.ndarray, name: str = "log.csv"):
    rng = np.random.default_rng(3)
    log = frame[["time", "command"]].assign(output=output + 1e-3 * rng.standard_normal(len(frame)))
    path = tmp_path / name
    log.to_csv(path, index=False)
    return path


def test_excite_writes_the_plan_and_its_lines(tmp_path) -> None:
    plan, frame = _plan(tmp_path)
    assert list(frame.columns) == ["time", "realisation", "period", "command"]
    assert len(frame) == 6 * (1 + 3) * 256
    assert set(frame["period"]) == {-1, 0, 1, 2}
    lines = pd.read_csv(tmp_path / "plan.lines.csv")
    assert set(lines["role"]) == {"excited", "odd detection", "even detection"}
    assert (lines.loc[lines["role"] == "excited", "line"] % 2 == 1).all()
    assert math.isclose(frame["command"].std(), 1.0, rel_tol=0.01)
    again = _invoke("excite", "--out", plan, "--band", "0.05,2.5")
    assert again.exit_code == 2 and "exists already" in again.output
    bad = _invoke("excite", "--out", tmp_path / "x.csv", "--band", "2.5")
    assert bad.exit_code == 2 and "--band must be LOW,HIGH" in bad.output


def test_frf_of_a_cubic_system_tells_its_kind(tmp_path) -> None:
    _, frame = _plan(tmp_path)
    x = sps.lfilter(*FILTER, frame["command"].to_numpy())
    log = _log(tmp_path, frame, x + 0.2 * x**3)
    png, report = tmp_path / "frf.png", tmp_path / "report"
    result = _invoke(
        "frf", log, "--inputs", "command", "--outputs", "output", "--realisations", "6",
        "--periods", "3", "--lines", tmp_path / "plan.lines.csv", "--plot", png,
        "--json", tmp_path / "frf.json", "--report", report,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "odd nonlinearity detected" in result.output
    assert "even nonlinearity not detected" in result.output
    document = json.loads((tmp_path / "frf.json").read_text())
    assert document["estimate"] == "robust BLA" and document["levels"]["odd_nonlinearity"]
    assert png.stat().st_size > 10_000 and (report / "report.html").exists()
    wrong = _invoke(
        "frf", log, "--inputs", "command", "--outputs", "output", "--realisations", "5",
        "--periods", "3",
    )  # fmt: skip
    assert wrong.exit_code == 2 and "--realisations 5" in wrong.output


def test_frf_of_closed_loop_data_through_the_reference(tmp_path) -> None:
    rng = np.random.default_rng(4)
    n = 8192
    reference = sps.lfilter(*sps.butter(2, 0.2), rng.standard_normal(n))
    noise = 1.5 * rng.standard_normal(n)
    u, y = np.zeros(n), np.zeros(n)
    state = np.zeros(2)
    b, a = FILTER
    for k in range(n):  # y = G u + v, u = r - 0.5 y (a proportional loop)
        y[k] = b[1] * (u[k - 1] if k else 0) + b[2] * (u[k - 2] if k > 1 else 0)
        y[k] += b[3] * (u[k - 3] if k > 2 else 0) - a[1] * state[0] - a[2] * state[1]
        state = np.array([y[k], state[0]])
        u[k] = reference[k] - 0.5 * (y[k] + noise[k])
    path = tmp_path / "loop.csv"
    frame = pd.DataFrame({"time": np.arange(n), "r": reference, "u": u, "y": y + noise})
    frame.to_csv(path, index=False)
    shares = {}
    for name, extra in (("indirect", ["--reference", "r"]), ("direct", [])):
        document = tmp_path / f"{name}.json"
        result = _invoke("frf", path, "--inputs", "u", "--outputs", "y", *extra, "--json", document)
        assert result.exit_code == 0, result.output
        pair = json.loads(document.read_text())["pairs"][0]
        omega = np.array(pair["omega_rad_s"])
        estimate = 10 ** (np.array(pair["magnitude_db"]) / 20) * np.exp(
            1j * np.radians(pair["phase_deg"])
        )
        inside = np.abs(estimate - sps.freqz(*FILTER, worN=omega)[1]) <= pair["band95_radius"]
        shares[name] = inside[omega < 1.0].mean()
        assert pair["estimate"].startswith("indirect through r" if extra else "Welch")
    assert shares["indirect"] >= 0.85 and shares["direct"] < 0.5, shares
    raw = _invoke("frf", path, "--inputs", "u", "--outputs", "y", "--method", "etfe")
    assert raw.exit_code == 0 and "ETFE" in raw.output
    bad = _invoke("frf", path, "--inputs", "u", "--outputs", "y", "--method", "spa")
    assert bad.exit_code == 2 and "--method must be" in bad.output


def test_validate_bode_puts_a_right_model_inside_the_band(tmp_path) -> None:
    _, frame = _plan(tmp_path)
    log = _log(tmp_path, frame, sps.lfilter(*FILTER, frame["command"].to_numpy()))
    model = tmp_path / "arx.npz"
    fitted = _invoke(
        "identify", log, "--method", "arx", "--inputs", "command", "--outputs", "output",
        "--orders", "2,3,1", "--save", model,
    )  # fmt: skip
    assert fitted.exit_code == 0, fitted.output
    png, document = tmp_path / "bode.png", tmp_path / "v.json"
    result = _invoke(
        "validate", model, log, "--bode", png, "--multisine", "6,3", "--json", document
    )
    assert result.exit_code == 0, result.output
    bode = json.loads(document.read_text())["bode"][0]
    assert bode["share_inside_95"] >= 0.9, bode
    assert bode["model_estimate"] == "transfer function (to_control)"
    assert png.exists()
    both = _invoke("validate", model, log, "--bode", png, "--in-loop", "--force")
    assert both.exit_code == 2 and "--bode" in both.output
    nonlinear = tmp_path / "poly.npz"
    fitted = _invoke(
        "identify", log, "--method", "poly", "--inputs", "command", "--outputs", "output",
        "--lags", "1-2/1-3", "--save", nonlinear,
    )  # fmt: skip
    assert fitted.exit_code == 0, fitted.output
    result = _invoke(
        "validate", nonlinear, log, "--bode", tmp_path / "p.png", "--multisine", "6,3",
        "--json", tmp_path / "p.json",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    bode = json.loads((tmp_path / "p.json").read_text())["bode"][0]
    assert bode["model_estimate"].startswith("robust BLA of its free run"), bode
    assert bode["share_inside_95"] >= 0.5, bode  # a polynomial of a linear system: near it


def test_frequency_demo_reads_the_necks_bandwidth() -> None:
    from neckid.experiments.frequency_demo import run_frequency_demo

    demo = run_frequency_demo(0, period=1024, n_realisations=4, n_periods=2)
    assert 3.0 < demo.bandwidth < 6.0  # the paper's neck: 4.2 rad/s
    assert demo.plant.levels.kind_detected("even")  # the tendon's one-sided pull
    assert demo.plant.nonlinear_detected().mean() > 0.5
    assert "linear model" in demo.advice


@pytest.mark.parametrize("options", [["--frequency"]])
def test_demo_frequency_writes_its_report(tmp_path, options) -> None:
    out = tmp_path / "demo"
    result = _invoke("demo", *options, "--out", out)
    assert result.exit_code == 0, result.output
    assert "bandwidth read from the loop's BLA" in result.output
    assert {"report.html", "bla_loop.png", "bla_plant.png", "frequency.json"} <= {
        p.name for p in out.iterdir()
    }
