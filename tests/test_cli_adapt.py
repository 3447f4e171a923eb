"""The command line of issue 40: --adapt, --use-conditions on select/compare, conditions by name."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from neckid import IOData, load_model
from neckid.cli import app

runner = CliRunner()

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")


def _plain(text: str) -> str:
    return re.sub(r"\s+", " ", text)


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Runs named ``neck_payload=<g>g_run<k>.csv``: the output's offset grows with the payload,
    and each run has a sensor zero of its own (what --adapt's offset learns)."""
    folder = tmp_path_factory.mktemp("named")
    rng = np.random.default_rng(3)
    zeros = {0: 0.0, 200: 1.5, 400: -1.0, 600: 0.5}
    for k, grams in enumerate((0, 200, 400, 600)):
        u = np.repeat(rng.uniform(-1, 1, 60), 10)
        y = np.zeros(u.size)
        for t in range(1, u.size):
            y[t] = 0.7 * y[t - 1] + 0.5 * u[t - 1] + 0.6 * grams / 1000
        y = y + zeros[grams] + 0.01 * rng.normal(size=u.size)
        IOData(u, y, ts=0.02, input_names=["cmd"], output_names=["incl"],
               output_units=["deg"]).to_csv(folder / f"neck_payload={grams}g_run{k}.csv")  # fmt: skip
    return folder


def _log(folder: Path, grams: int) -> str:
    return str(next(folder.glob(f"neck_payload={grams}g_*.csv")))


NAME = ["--condition-from-name", r"payload=(\d+)g", "--condition-unit", "g"]
CHANNELS = ["--inputs", "cmd", "--outputs", "incl"]


def test_conditions_from_the_file_name_and_a_sidecar_winning(logs: Path, tmp_path: Path) -> None:
    save = tmp_path / "model.npz"
    done = runner.invoke(
        app,
        ["identify", _log(logs, 0), _log(logs, 600), *CHANNELS, "--method", "arx", "--lags",
         "1/1", "--use-conditions", "payload", *NAME, "--save", str(save)],
    )  # fmt: skip
    assert done.exit_code == 0, done.output
    model = load_model(save)
    assert model.training_ranges_["payload"] == (0.0, 600.0)
    sidecar = Path(_log(logs, 200)).with_suffix(".conditions.json")
    try:
        sidecar.write_text(json.dumps({"payload": {"value": 900, "unit": "g"}}))
        out = tmp_path / "v.json"
        ran = runner.invoke(
            app, ["validate", str(save), _log(logs, 200), *NAME, "--json", str(out)]
        )
        assert ran.exit_code == 0, ran.output
        assert "payload 100%" in _plain(ran.output)  # the sidecar's 900 g: outside, said so
    finally:
        sidecar.unlink()
    named = runner.invoke(app, ["validate", str(save), _log(logs, 200), *NAME])
    assert named.exit_code == 0, named.output
    assert "payload 100%" not in _plain(named.output)  # the name's 200 g: inside
    bad = runner.invoke(
        app, ["validate", str(save), _log(logs, 200), "--condition-from-name", r"mass=(\d+)kg"]
    )
    assert bad.exit_code == 2
    assert "--condition-from-name" in bad.output and "does not match" in _plain(bad.output)


def test_validate_adapt_reports_both_fits_and_the_band(logs: Path, tmp_path: Path) -> None:
    save = tmp_path / "model.npz"
    runner.invoke(
        app,
        ["identify", _log(logs, 0), _log(logs, 600), *CHANNELS, "--method", "arx", "--lags",
         "1/1", "--save", str(save)],
    )  # fmt: skip
    out, plot = tmp_path / "adapt.json", tmp_path / "adapt.png"
    ran = runner.invoke(
        app,
        ["validate", str(save), _log(logs, 200), _log(logs, 400), "--adapt", "2", "--json",
         str(out), "--plot", str(plot)],
    )  # fmt: skip
    assert ran.exit_code == 0, ran.output
    assert "free run after 2 s of adaptation (offset)" in _plain(ran.output)
    document = json.loads(out.read_text())
    assert document["kind"] == "free run after 2 s of adaptation (offset)"
    for record in document["logs"]:
        first = record["outputs"][0]
        assert first["fit_percent"] > first["fit_percent_unadapted"] + 10
        assert 0.85 < first["adaptive_band"]["running_coverage"] <= 1.0
    assert plot.stat().st_size > 0
    for bad in (["--adapt", "0"], ["--adapt", "2", "--adapt-mode", "retrain"],
                ["--adapt-mode", "both"]):  # fmt: skip
        refused = runner.invoke(app, ["validate", str(save), _log(logs, 200), *bad])
        assert refused.exit_code == 2, refused.output
        assert "--adapt" in refused.output


def test_compare_adapt_and_use_conditions(logs: Path, tmp_path: Path) -> None:
    out = tmp_path / "compare.json"
    ran = runner.invoke(
        app,
        ["compare", _log(logs, 0), _log(logs, 600), _log(logs, 400), "--test", _log(logs, 200),
         *CHANNELS, "--methods", "arx", "--lags", "1/1", "--use-conditions", "payload", *NAME,
         "--adapt", "2", "--json", str(out)],
    )  # fmt: skip
    assert ran.exit_code == 0, ran.output
    assert "free run after 2 s of adaptation (offset)" in _plain(ran.output)
    document = json.loads(out.read_text())
    assert document["kind"] == "free run after 2 s of adaptation (offset)"
    test = document["methods"][0]["tests"][0]
    assert test["fit_percent"] > test["fit_percent_unadapted"]
    assert "payload" in document["methods"][0]["settings"]["lags"]


def test_select_use_conditions(logs: Path) -> None:
    ran = runner.invoke(
        app,
        ["select", _log(logs, 0), _log(logs, 600), _log(logs, 400), *CHANNELS, "--lags", "1/1",
         "--lags", "2/1", "--use-conditions", "payload", *NAME],
    )  # fmt: skip
    assert ran.exit_code == 0, ran.output
    assert "chosen: --lags" in ran.output


def test_validate_in_loop_adapt(rng: np.random.Generator, tmp_path: Path) -> None:
    from test_lab_loop import _logged_loop, _plant_model
    from test_loop_checks import _softneck_file

    model = _plant_model(rng)
    log = _softneck_file(_logged_loop(model), tmp_path / "int000stepresponse.csv")
    saved = model.save(tmp_path / "model.npz")
    out = tmp_path / "loop.json"
    ran = runner.invoke(
        app,
        ["validate", str(saved), str(log), "--in-loop", "--adapt", "2", "--json", str(out)],
    )
    assert ran.exit_code == 0, ran.output
    assert "in loop after 2 s of adaptation (offset)" in _plain(ran.output)
    document = json.loads(out.read_text())
    assert document["kind"] == "in loop after 2 s of adaptation (offset)"
    record = document["logs"][0]
    # an exact model learns no offset: the adapted loop is the un-adapted one
    assert record["inclination_fit_percent"] == pytest.approx(
        record["unadapted_inclination_fit_percent"], abs=0.5
    )
    refused = runner.invoke(app, ["validate", str(saved), str(log), "--in-loop", "--adapt", "-1"])
    assert refused.exit_code == 2 and "--adapt" in refused.output
