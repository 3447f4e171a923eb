"""``neckid resid`` and ``validate --resid`` on ARX logs the tests write."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from neckid.cli import app
from test_residuals import arx_data

runner = CliRunner()


def _plain(text: str) -> str:
    return re.sub(r"\s+", " ", text)


@pytest.fixture(scope="module")
def models(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A training and a validation log of an ARX(2, 2) system, and ARX models of order 2 and 1."""
    folder = tmp_path_factory.mktemp("resid")
    arx_data(2000, 0).to_csv(folder / "train.csv")
    arx_data(2000, 1).to_csv(folder / "valid.csv")
    paths = {"train": folder / "train.csv", "valid": folder / "valid.csv"}
    for name, orders in (("right", "2,2,1"), ("low", "1,1,1")):
        paths[name] = folder / f"{name}.npz"
        result = runner.invoke(
            app,
            [
                "identify",
                str(paths["train"]),
                *("--inputs", "cmd", "--outputs", "incl", "--method", "arx"),
                *("--orders", orders, "--save", str(paths[name])),
            ],
        )
        assert result.exit_code == 0, result.output
    return paths


def test_resid_passes_the_right_order_and_fails_one_too_low(models: dict[str, Path]) -> None:
    result = runner.invoke(app, ["resid", str(models["right"]), str(models["valid"])])
    assert result.exit_code == 0, result.output
    text = _plain(result.output)
    assert "residual tests on the one-step prediction residual" in text
    assert "whiteness of e(incl): passed" in text
    assert "independence of e(incl) and cmd: passed" in text
    assert "verdict: passed (no test rejects the model at 99 % confidence)" in text
    result = runner.invoke(app, ["resid", str(models["low"]), str(models["valid"])])
    assert result.exit_code == 0, result.output
    text = _plain(result.output)
    assert "whiteness of e(incl): FAILED" in text
    assert "independence of e(incl) and cmd: FAILED" in text
    assert "verdict: failed" in text


def test_resid_json_and_plot(models: dict[str, Path], tmp_path: Path) -> None:
    out, png = tmp_path / "r.json", tmp_path / "r.png"
    result = runner.invoke(
        app,
        [
            "resid",
            str(models["low"]),
            str(models["valid"]),
            *("--lags", "15", "--json", str(out), "--plot", str(png)),
        ],
    )
    assert result.exit_code == 0, result.output
    document = json.loads(out.read_text())
    assert document["model"] == "low.npz" and document["log"] == "valid.csv"
    assert document["max_lag"] == 15 and document["confidence"] == 0.99
    assert document["passed"] is False
    (output,) = document["outputs"]
    assert output["output"] == "incl"
    assert output["whiteness"]["lags"] == list(range(16))
    assert output["independence"]["cmd"]["lags"] == list(range(-15, 16))
    assert output["independence"]["cmd"]["degrees_of_freedom"] == 31
    assert output["whiteness"]["statistic"] > output["whiteness"]["threshold"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_an_existing_plot_is_refused_without_force(models: dict[str, Path], tmp_path: Path) -> None:
    png = tmp_path / "r.png"
    png.write_bytes(b"keep")
    arguments = ["resid", str(models["right"]), str(models["valid"]), "--plot", str(png)]
    result = runner.invoke(app, arguments)
    assert result.exit_code == 2
    assert "--plot" in result.output and "--force" in result.output
    assert len(result.output.strip().splitlines()) == 1, result.output
    assert png.read_bytes() == b"keep"
    result = runner.invoke(app, [*arguments, "--force"])
    assert result.exit_code == 0, result.output
    assert png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--lags", "5000"], r"--lags 5000 is too large for valid.*give --lags <= 998"),
        (["--lags", "0"], r"--lags"),
        (["--map", "nothing=cmd"], r"nothing"),
    ],
)
def test_bad_input_is_one_line(models: dict[str, Path], extra: list[str], match: str) -> None:
    result = runner.invoke(app, ["resid", str(models["right"]), str(models["valid"]), *extra])
    assert result.exit_code == 2, result.output
    assert re.search(match, _plain(result.output)), result.output
    assert len(result.output.strip().splitlines()) == 1, result.output


def test_validate_resid_adds_the_verdict(models: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "v.json"
    result = runner.invoke(
        app,
        ["validate", str(models["low"]), str(models["valid"]), "--resid", "--json", str(out)],
    )
    assert result.exit_code == 0, result.output
    text = _plain(result.output)
    assert "(free run)" in text and "verdict: failed" in text
    (record,) = json.loads(out.read_text())["logs"]
    assert record["resid"]["passed"] is False
    assert record["resid"]["residual"] == "one-step prediction"
    plain = runner.invoke(app, ["validate", str(models["low"]), str(models["valid"])])
    assert "verdict" not in plain.output


def test_validate_resid_refuses_in_loop(models: dict[str, Path]) -> None:
    result = runner.invoke(
        app, ["validate", str(models["right"]), str(models["valid"]), "--resid", "--in-loop"]
    )
    assert result.exit_code == 2
    assert "--resid" in result.output and "--in-loop" in result.output
