"""Choosing the regressor from the command line: select, --orders, and the JSON of identify and simulate."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from _synthetic import arx_system
from neckid import IOData, load_model
from neckid.cli import app
from neckid.cli.workflow import format_lags, parse_order_grid, parse_orders

runner = CliRunner()


def _plain(text: str) -> str:
    return re.sub(r"\s+", " ", text)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Three runs of y(t) = 1.2 y(t-1) - 0.5 y(t-2) + 0.8 u(t-3) + 0.4 u(t-4) + e (orders 2,2,3)."""
    folder = tmp_path_factory.mktemp("select")
    paths = []
    for seed in range(3):
        run = arx_system(500, 20 + seed)
        data = IOData(run.u, run.y, ts=0.02, input_names=["cmd"], output_names=["incl"])
        data.to_csv(folder / f"run{seed}.csv")
        paths.append(folder / f"run{seed}.csv")
    return paths


def _channels() -> list[str]:
    return ["--inputs", "cmd", "--outputs", "incl"]


def test_orders_read_as_matlab_does() -> None:
    assert parse_orders("2,2,3").inputs == (3, 4)
    assert parse_orders("2,2,3").outputs == (1, 2)
    assert len(parse_order_grid("1-2,1-2,0-1")) == 8
    for bad, match in [
        ("2,2", r"--orders must be NA,NB,NK"),
        ("1-2,2,1", r"--orders takes one NA,NB,NK"),
        ("0,0,1", r"NA and NB are both 0"),
        ("a,2,1", r"--orders \(NA\): cannot read 'a'"),
    ]:
        with pytest.raises(ValueError, match=match):
            parse_orders(bad)


def test_select_finds_the_true_orders_and_saves_the_model(runs: list[Path], tmp_path: Path) -> None:
    out, model_path = tmp_path / "ranking.json", tmp_path / "chosen.npz"
    args = ["select", *map(str, runs), *_channels(), "--orders", "1-3,1-3,1-4"]
    result = runner.invoke(app, [*args, "--json", str(out), "--save", str(model_path)])
    assert result.exit_code == 0, result.output
    text = _plain(result.output)
    # three logs, each held out in 2 time blocks (at least 6 folds: neckid.data.folds.fold_plan)
    assert "experiments × time-blocks, 6 folds" in text
    assert "chosen: --lags 1-2/3-4 (safe rule)" in text
    document = json.loads(out.read_text())
    assert document["chosen"] == "1-2/3-4" and document["scheme"] == "experiments × time-blocks"
    assert len(document["candidates"]) == 36
    assert document["warnings"] == [] and document["baselines"]["training mean"] <= 0
    chosen = [c for c in document["candidates"] if c["status"] == "chosen"]
    assert len(chosen) == 1 and len(chosen[0]["fold_fits_percent"]) == 6
    assert np.isclose(np.mean(chosen[0]["fold_fits_percent"]), chosen[0]["mean_fit_percent"])
    model = load_model(model_path)
    assert format_lags(model.lags_) == "1-2/3-4"
    # the output exists now: refused without --force
    again = runner.invoke(app, [*args, "--json", str(out)])
    assert again.exit_code != 0 and "--force" in _plain(again.output)


def test_select_on_one_log_uses_time_blocks(runs: list[Path]) -> None:
    result = runner.invoke(
        app, ["select", str(runs[0]), *_channels(), "--lags", "1-2/3-4", "--lags", "1/1"]
    )
    assert result.exit_code == 0, result.output
    assert "time-blocks, 3 folds" in _plain(result.output)


def test_identify_orders_json_and_the_lone_lag_note(runs: list[Path], tmp_path: Path) -> None:
    out, summary = tmp_path / "m.npz", tmp_path / "m.json"
    args = ["identify", str(runs[0]), *_channels(), "--method", "arx", "--save", str(out)]
    result = runner.invoke(app, [*args, "--orders", "2,2,3", "--json", str(summary)])
    assert result.exit_code == 0, result.output
    assert "regressor: 1-2/3-4 (--orders 2,2,3)" in _plain(result.output)
    document = json.loads(summary.read_text())
    assert document["lags"] == "1-2/3-4" and document["method"] == "arx"
    (row,) = document["training"]["outputs"]
    assert row["output"] == "incl" and row["fit_percent"] > 95
    both = runner.invoke(app, [*args, "--force", "--orders", "2,2,3", "--lags", "1/1"])
    assert both.exit_code != 0 and "not both" in _plain(both.output)
    lone = runner.invoke(app, [*args, "--force", "--lags", "3/3"])
    assert lone.exit_code == 0 and "the output lag 3 alone, y(t-3)" in _plain(lone.output)
    default = runner.invoke(app, [*args, "--force"])
    assert "regressor: 1-2/1-2 (the default --orders 2,2,1)" in _plain(default.output)


def test_simulate_writes_a_json_summary(runs: list[Path], tmp_path: Path) -> None:
    model_path, csv, summary = tmp_path / "m.npz", tmp_path / "s.csv", tmp_path / "s.json"
    fitted = runner.invoke(
        app, ["identify", str(runs[0]), *_channels(), "--method", "arx", "--orders", "2,2,3",
              "--save", str(model_path)],
    )  # fmt: skip
    assert fitted.exit_code == 0, fitted.output
    result = runner.invoke(
        app,
        ["simulate", str(model_path), str(runs[1]), "--out", str(csv), "--json", str(summary)],
    )
    assert result.exit_code == 0, result.output
    document = json.loads(summary.read_text())
    assert document["kind"] == "free run" and document["diverged"] is False
    assert document["n_samples"] == 500 and document["outputs"][0]["fit_percent"] > 95


def test_the_readme_command_line_example_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The README's example commands, word for word, on logs of the simulated neck."""
    import shlex

    from neckid.plant import SoftNeck
    from neckid.signals import multisine

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    example = readme[readme.index("For example `neckid") : readme.index("Every option, the")]
    commands = [c for c in re.findall(r"`(neckid [^`]+)`", example.replace("\n", " "))]
    runnable = [c for c in commands if "..." not in c]
    assert [c.split()[1] for c in runnable] == ["select", "validate"]
    neck = SoftNeck(seed=5)
    for seed, name in ((1, "run1.csv"), (2, "run2.csv"), (3, "other.csv")):
        position = 2.5 + 2.0 * multisine(500, neck.ts, band=(0.05, 4.0), phases="random", seed=seed)
        velocity = np.concatenate(
            [np.full(150, position[0] / 3.0), np.diff(position, prepend=position[0]) / neck.ts]
        )
        neck.reset()
        neck.run(velocity)[150:].to_csv(tmp_path / name)
    monkeypatch.chdir(tmp_path)
    for command in runnable:
        result = runner.invoke(app, shlex.split(command)[1:])
        assert result.exit_code == 0, f"{command}\n{result.output}"
    assert (tmp_path / "model.npz").exists()


def test_a_long_set_membership_fit_is_announced(
    runs: list[Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import neckid.cli.models

    monkeypatch.setattr(neckid.cli.models, "LONG_SM_SAMPLES", 400)
    args = ["identify", str(runs[0]), *_channels(), "--orders", "2,2,3", "--save"]
    result = runner.invoke(app, [*args, str(tmp_path / "sm.npz"), "--method", "sm-linear"])
    assert result.exit_code == 0, result.output
    assert "note: sm-linear on 500 samples takes minutes" in _plain(result.output)
    quiet = runner.invoke(app, [*args, str(tmp_path / "arx.npz"), "--method", "arx"])
    assert "takes minutes" not in quiet.output


def test_a_contradiction_never_rounds_to_zero() -> None:
    from neckid.cli.explain import _share_text

    assert _share_text(0.0) == "0.0%"
    assert _share_text(1e-5) == "fewer than 0.1 %"
    assert _share_text(0.9999) == "more than 99.9 %"
    assert _share_text(0.25) == "25.0%"
