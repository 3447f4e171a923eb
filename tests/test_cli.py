"""The command line on logs the tests write: identify, validate, simulate, bandwidth, demo."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import neckid
from neckid import load_model
from neckid.cli import app
from neckid.experiments.paper import EXPERIMENTS
from neckid.plant import InclinationController, SoftNeck, closed_loop
from neckid.signals import multisine, paper_chirp

runner = CliRunner()


@pytest.fixture(scope="module")
def neck_logs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Two open-loop runs of the simulated neck, written as CSV with a header row."""
    folder = tmp_path_factory.mktemp("logs")
    neck = SoftNeck(seed=3)
    paths = []
    for seed, name in ((1, "train.csv"), (2, "valid.csv")):
        position = 2.5 + 2.0 * multisine(
            1500, neck.ts, band=(0.05, 4.0), phases="random", seed=seed
        )
        velocity = np.concatenate(
            [np.full(150, position[0] / 3.0), np.diff(position, prepend=position[0]) / neck.ts]
        )
        neck.reset()
        data = neck.run(velocity)[150:]
        data.to_csv(folder / name)
        paths.append(folder / name)
    return paths[0], paths[1]


def _plain(text: str) -> str:
    return re.sub(r"\s+", " ", text)


#: Methods whose free run at the lags below runs away on the validation log (the polynomial reaches
#: 2.3e4 deg, the chained multi-step SM run -1.9e3 deg, where the training log spans 12-32 deg).
RUNS_AWAY_ON_VALID = {"poly", "sm-multistep"}


@pytest.mark.parametrize("method", [*sorted(neckid.methods()), "sm_linear"])
def test_identify_validate_simulate_round_trip(
    neck_logs: tuple[Path, Path], tmp_path: Path, method: str
) -> None:
    train, valid = neck_logs
    model_path = tmp_path / f"{method}.npz"
    lags = {"rls": "1-2/1-2", "scheduled": "1/1", "scheduled-position": "1/1"}.get(
        method, "1-2/1-3"
    )
    inputs = "velocity_command" if method in ("rls", "scheduled") else "motor_position"
    result = runner.invoke(
        app,
        [
            "identify",
            str(train),
            "--inputs",
            inputs,
            "--outputs",
            "inclination",
            "--method",
            method,
            "--lags",
            lags,
            "--save",
            str(model_path),
        ],
    )
    assert result.exit_code == 0, result.output
    assert model_path.exists()
    assert "fit %" in result.output
    if method == "sm_linear":
        assert "deprecated" in result.output and "'sm-linear'" in result.output
    model = load_model(model_path)
    assert model.n_inputs_ == 1
    result = runner.invoke(app, ["info", str(model_path)])
    assert result.exit_code == 0, result.output
    assert "training range of motor_position" in _plain(result.output) or method in (
        "rls",
        "scheduled",
    )

    if method in RUNS_AWAY_ON_VALID:
        # Their free run on the validation log leaves the training outputs by far (ten times
        # the range): it is stopped as a runaway (exit 3); the round trip runs on the training log.
        result = runner.invoke(app, ["validate", str(model_path), str(valid)])
        assert result.exit_code == 3 and "ran away" in _plain(result.output), result.output
        valid = train
    plot = tmp_path / "val.png"
    result = runner.invoke(app, ["validate", str(model_path), str(valid), "--plot", str(plot)])
    assert result.exit_code == 0, result.output
    assert "inclination" in result.output and plot.stat().st_size > 1000
    if method.startswith("sm"):  # every Set Membership form reports its band
        assert "mean width" in _plain(result.output)
        assert "of the measured samples" in _plain(result.output)

    out = tmp_path / "sim.csv"
    result = runner.invoke(app, ["simulate", str(model_path), str(valid), "--out", str(out)])
    assert result.exit_code == 0, result.output
    frame = pd.read_csv(out)
    assert len(frame) == len(pd.read_csv(valid))
    assert "inclination" in frame.columns
    if method.startswith("sm"):
        assert {"inclination_lower", "inclination_upper"} <= set(frame.columns)


def test_identify_reports_unknown_column(neck_logs: tuple[Path, Path], tmp_path: Path) -> None:
    train, _ = neck_logs
    result = runner.invoke(
        app,
        [
            "identify",
            str(train),
            "--inputs",
            "nope",
            "--outputs",
            "inclination",
            "--save",
            str(tmp_path / "m"),
        ],
    )
    assert result.exit_code == 2
    assert "nope" in _plain(result.output)


def test_identify_reports_bad_lags(neck_logs: tuple[Path, Path], tmp_path: Path) -> None:
    train, _ = neck_logs
    result = runner.invoke(
        app,
        [
            "identify",
            str(train),
            "--inputs",
            "motor_position",
            "--outputs",
            "inclination",
            "--lags",
            "3",
        ],
    )
    assert result.exit_code == 2
    assert "OUTPUT_LAGS/INPUT_LAGS" in _plain(result.output)


def test_identify_passes_method_settings(neck_logs: tuple[Path, Path], tmp_path: Path) -> None:
    train, valid = neck_logs
    base = ["identify", str(train), "--inputs", "motor_position", "--outputs", "inclination"]
    base += ["--method", "sm-multistep", "--lags", "1-2/1-2"]
    path = tmp_path / "k.npz"
    settings = ["--set", "lipschitz=local", "--set", "horizon=2", "--set", "horizons=[5]"]
    result = runner.invoke(app, [*base, *settings, "--save", str(path)])
    assert result.exit_code == 0, result.output
    model = load_model(path)
    assert model.lipschitz == "local" and model.horizons_.tolist() == [1, 2, 5]
    assert all(m.point_gamma_ is not None for m in model.estimators_)
    result = runner.invoke(app, ["validate", str(path), str(valid)])
    assert result.exit_code == 0, result.output
    text = _plain(result.output)
    assert "guaranteed k-step bands" in text and "holds [%]" in text

    result = runner.invoke(app, [*base, "--set", "lipschits=local", "--save", str(tmp_path / "x")])
    assert result.exit_code == 2
    assert "lipschits" in result.output and "lipschitz" in _plain(result.output)
    result = runner.invoke(app, [*base, "--set", "lipschitz", "--save", str(tmp_path / "x")])
    assert result.exit_code == 2 and "NAME=VALUE" in result.output
    result = runner.invoke(app, [*base, "--set", "lipschitz=cell", "--save", str(tmp_path / "x")])
    assert result.exit_code == 2 and "lipschitz" in result.output and "cell" in result.output
    assert not (tmp_path / "x.npz").exists()


def test_bandwidth_of_a_chirp_log(tmp_path: Path) -> None:
    neck = SoftNeck(seed=0)
    t = np.arange(3000) * neck.ts
    reference = paper_chirp(t)
    data = closed_loop(neck, InclinationController(ts=neck.ts), reference, neck.ts)
    path = tmp_path / "chirp.csv"
    data.to_csv(path)
    plot = tmp_path / "bw.png"
    result = runner.invoke(
        app,
        [
            "bandwidth",
            str(path),
            "--command",
            "reference",
            "--response",
            "inclination",
            "--rate",
            "0.1",
            "--plot",
            str(plot),
        ],
    )
    assert result.exit_code == 0, result.output
    omega = float(re.search(r"bandwidth: ([0-9.]+) rad/s", result.output).group(1))  # type: ignore[union-attr]
    assert 2.0 < omega < 8.0
    assert plot.exists()


def test_version() -> None:
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0
    assert result.output.startswith("neckid ")


def test_warmup_compiles_in_a_temporary_folder_it_removes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)  # re-read TMPDIR
    result = runner.invoke(app, ["warmup"])
    assert result.exit_code == 0, result.output
    assert "kernels compiled and cached" in _plain(result.output)
    assert "step 1/8" not in result.output  # the demo's steps are not shown (issue 39)
    assert len(result.output.strip().splitlines()) == 2, result.output
    assert list(tmp_path.glob("neckid-warmup-*")) == []  # the demo's folder is gone


def test_demo_quick_writes_report_metrics_figures_models(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    result = runner.invoke(app, ["demo", "--quick", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "Set Membership" in result.output and "(paper)" in result.output

    metrics = json.loads((out / "metrics.json").read_text())
    models = [
        "Set Membership",
        "Set Membership + linear",
        "Neural NARX 2x25",
        "Linear ARX",
        "Scheduled CFF-RLS",
    ]
    for model in models:
        for experiment in EXPERIMENTS:
            value = metrics["fit_percent"][model][experiment]
            assert isinstance(value, float), (model, experiment, value)
            assert isinstance(metrics["mae_deg"][model][experiment], float)
    assert 1.0 < metrics["bandwidth_rad_s"] < 10.0

    figures = sorted(p.name for p in out.glob("*.png"))
    for name in (
        "fig3_bandwidth",
        "fig5_validation",
        "fig6_schedule",
        "fig7_sine",
        "fig8_staircase",
        "fig9_step",
    ):
        assert f"{name}.png" in figures
    model_files = sorted(out.glob("model_*.npz"))
    assert len(model_files) == 5
    for path in model_files:
        load_model(path)  # every model file loads again

    page = (out / "report.html").read_text()
    assert "<table" in page
    assert page.count("data:image/png;base64,") == len(figures)
    for experiment in EXPERIMENTS:
        assert experiment in page
    assert "88.75" in page  # the paper's row is in the table


def test_validate_says_when_a_log_contradicts_the_sm_prior(
    neck_logs: tuple[Path, Path], tmp_path: Path
) -> None:
    train, _ = neck_logs
    model_path = tmp_path / "sm.npz"
    args = ["--inputs", "motor_position", "--outputs", "inclination", "--lags", "1-2/1-3"]
    result = runner.invoke(
        app, ["identify", str(train), *args, "--method", "sm", "--save", str(model_path)]
    )
    assert result.exit_code == 0, result.output
    same = runner.invoke(app, ["validate", str(model_path), str(train)])
    assert same.exit_code == 0, same.output
    assert "does not contradict the prior" in _plain(same.output)
    assert "SM free-run band: bounds f at the simulated regressor, not the trajectory" in _plain(
        same.output
    )
    shifted = pd.read_csv(train)
    shifted["inclination"] += 3.0  # the same run with the sensor offset by 3 deg
    moved = tmp_path / "moved.csv"
    shifted.to_csv(moved, index=False)
    other = runner.invoke(app, ["validate", str(model_path), str(moved)])
    assert other.exit_code == 0, other.output
    text = _plain(other.output)
    assert "prior contradicted:" in text and "the smallest ε that holds them all is" in text.lower()
    assert "guaranteed bounds of the noise-free output" not in text


def test_validate_takes_several_logs_and_writes_json(
    neck_logs: tuple[Path, Path], tmp_path: Path
) -> None:
    train, valid = neck_logs
    model_path = tmp_path / "arx.npz"
    args = ["--inputs", "motor_position", "--outputs", "inclination", "--lags", "1-2/1-2"]
    result = runner.invoke(
        app, ["identify", str(train), *args, "--method", "arx", "--save", str(model_path)]
    )
    assert result.exit_code == 0, result.output
    out = tmp_path / "v.json"
    result = runner.invoke(
        app,
        ["validate", str(model_path), str(train), str(valid), "--json", str(out), "--plot",
         str(tmp_path / "v.png")],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "mean over 2 logs (free run)" in _plain(result.output)
    document = json.loads(out.read_text())
    fits = [r["outputs"][0]["fit_percent"] for r in document["logs"]]
    assert [r["log"] for r in document["logs"]] == [train.name, valid.name]
    assert document["mean"]["outputs"][0]["fit_percent"] == pytest.approx(np.mean(fits))
    assert document["kind"] == "free run" and (tmp_path / "v.png").stat().st_size > 1000
