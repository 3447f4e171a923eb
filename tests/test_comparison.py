"""Safe selection on training logs and the comparison on test logs (neckid.compare)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import neckid
from neckid import IOData, Lags, LinearARX
from neckid.cli import app
from neckid.data.training import TrainingSet
from neckid.selection.comparison import compare, select_safely, stretched, time_blocks


def _run(seed: int, n: int = 900) -> IOData:
    """A mildly nonlinear first-order plant driven by held random steps."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1.0, 1.0, n // 15 + 1), 15)[:n]
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.85 * y[t - 1] + 0.3 * np.tanh(1.5 * u[t - 1])
    return IOData(u, y + 0.005 * rng.normal(size=n), ts=0.02, name=f"run {seed}")


class _Unstable(LinearARX):
    """An ARX whose free run grows without bound (a pole at 1.05) but stays finite."""

    def _fit_regression(self, x: np.ndarray, y: np.ndarray) -> None:
        super()._fit_regression(x, y)
        self.coef_ = self.coef_.copy()
        self.coef_[0, 0] = 1.05


def test_time_blocks_cut_one_record_in_order() -> None:
    data = _run(1, 100)
    blocks = time_blocks(data, 4)
    assert [b.n_samples for b in blocks] == [25, 25, 25, 25]
    np.testing.assert_array_equal(np.vstack([b.y for b in blocks]), data.y)
    with pytest.raises(ValueError, match="n_blocks must be an integer >= 3"):
        time_blocks(data, 2)


def test_stretched_inputs_reach_beyond_the_range_by_the_fraction() -> None:
    data = _run(2, 300)
    wide = stretched(data, 0.1)
    half = 0.5 * np.ptp(data.u)
    assert np.ptp(wide.u) == pytest.approx(2 * half * 1.1)
    np.testing.assert_array_equal(wide.y, data.y)


def test_a_runaway_candidate_is_rejected_with_its_reason_even_if_it_would_score_well() -> None:
    options = [("arx", LinearARX(Lags.arx(1, 1))), ("unstable", _Unstable(Lags.arx(1, 1)))]
    found = select_safely(options, [_run(1), _run(2), _run(3)])
    # three logs, each held out in 2 time blocks: 6 folds (fold_plan's rule)
    assert found.scheme == "experiments × time-blocks" and len(found.folds) == 6
    assert found.chosen == "arx"
    assert "ran away" in found.rejected["unstable"]
    table = found.table.set_index("name")
    assert table.loc["unstable", "status"] == "rejected"
    assert len(table.loc["arx", "fold_fits"]) == 6


def test_one_standard_error_rule_prefers_the_simpler_candidate() -> None:
    data = [_run(1), _run(2), _run(3)]
    options = [("wide", LinearARX(Lags.arx(3, 3))), ("narrow", LinearARX(Lags.arx(1, 1)))]
    found = select_safely(options, data)
    table = found.table.set_index("name")
    # Both fit about equally; the rule takes the one with fewer terms when it is within one SE.
    assert table.loc["narrow", "fit_mean"] >= found.bar
    assert found.chosen == "narrow"
    with pytest.raises(ValueError, match="candidate names must differ"):
        select_safely([options[0], options[0]], data)


def test_every_candidate_rejected_is_an_error_naming_them() -> None:
    with pytest.raises(ValueError, match=r"every candidate was rejected.*unstable"):
        select_safely([("unstable", _Unstable(Lags.arx(1, 1)))], _run(4))


def test_compare_chooses_on_training_logs_and_runs_each_method_on_each_test_log() -> None:
    result = neckid.compare(
        [_run(1), _run(2)], [_run(5), _run(6)], methods=["sm"], lags=Lags.arx(1, 1)
    )
    assert set(result.settings) == {"arx", "sm"}  # ARX is always a candidate
    assert set(result.results["log"]) == {"run 5", "run 6"}
    assert result.recommended in ("arx", "sm")
    summary = result.summary()
    assert list(summary["method"]) == ["arx", "sm"]
    assert (summary["fit_percent"] > 80).all()
    sm = result.results[result.results["method"] == "sm"]
    assert sm["band"].str.startswith("SM free-run band").all()
    document = json.loads(json.dumps(result.to_json(), allow_nan=False))
    assert document["recommended"] == result.recommended
    first = document["methods"][0]
    assert {"method", "settings", "fold_fits"} <= set(first)
    assert {"log", "fit_percent", "rmse", "outside_domain"} <= set(first["tests"][0])
    assert compare is neckid.compare


def test_the_compare_command_writes_json_plot_and_report(tmp_path: Path) -> None:
    paths = []
    for seed in (1, 2, 5):
        path = tmp_path / f"run{seed}.csv"
        _run(seed, 600).to_csv(path)
        paths.append(path)
    out = tmp_path / "compare.json"
    result = CliRunner().invoke(
        app,
        [
            "compare", str(paths[0]), str(paths[1]), "--test", str(paths[2]),
            "--inputs", "u", "--outputs", "y", "--methods", "sm", "--lags", "1/1",
            "--json", str(out), "--plot", str(tmp_path / "c.png"),
            "--report", str(tmp_path / "report"),
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "recommended:" in result.output
    document = json.loads(out.read_text())
    assert {m["method"] for m in document["methods"]} == {"arx", "sm"}
    assert (tmp_path / "c.png").stat().st_size > 0
    assert "Selection on the training logs" in (tmp_path / "report" / "report.html").read_text()
    again = CliRunner().invoke(
        app, ["compare", str(paths[0]), "--test", str(paths[2]), "--inputs", "u", "--outputs",
              "y", "--json", str(out)],
    )  # fmt: skip
    assert again.exit_code != 0 and "--force" in again.output


def test_the_recommended_method_runs_the_chosen_candidate_on_the_tests() -> None:
    # the first-order system: arx(1, 1) is chosen over arx(2, 2) by the one-standard-error rule
    result = compare([_run(2)], [_run(100)], methods=["arx"], lags=[Lags.arx(1, 1), Lags.arx(2, 2)])
    chosen = result.selection.chosen
    assert result.settings["arx"]["candidate"] == chosen
    assert result.models["arx"].lags_.n_terms == (2 if "outputs=[1]," in chosen else 4)


def test_the_stress_check_reaches_as_far_as_the_test_inputs() -> None:
    train, test = _run(1), _run(3)
    wide = test.replace(u=3.0 * test.u)  # the test inputs go well beyond the training range
    result = compare([train], [wide], methods=["arx"], lags=Lags.arx(1, 1))
    reach = TrainingSet.of([train]).input_reach([wide])
    assert reach > 1.0
    assert any(f"stretched {reach:.0%}" in r for r in result.reasons)
    two = [Lags.arx(1, 1), Lags.arx(2, 2)]
    names = compare([train], [test], methods=["ss"], lags=two).selection.table["name"]
    assert sorted(names) == [
        "arx Lags(outputs=[1, 2], inputs=[1, 2])",
        "arx Lags(outputs=[1], inputs=[1])",
        "ss",
    ]


def test_a_periodic_record_is_averaged_and_folded_within_one_period() -> None:
    from neckid.data.folds import fold_records, input_period

    one = _run(5, 300)
    u = np.tile(one.u[:, 0], 4)
    y = np.zeros(u.size)
    for t in range(1, u.size):
        y[t] = 0.85 * y[t - 1] + 0.3 * np.tanh(1.5 * u[t - 1])
    record = IOData(u, y + 0.005 * np.random.default_rng(0).normal(size=u.size), ts=0.02)
    assert input_period(record) == 300
    records, scheme = fold_records([record])
    assert scheme == "time-blocks of one period" and sum(r.n_samples for r in records) == 300
    found = select_safely([("arx", LinearARX(Lags.arx(1, 1)))], record)
    assert found.scheme == "time-blocks of one period"
    assert input_period(_run(6)) is None


def test_compare_gives_each_methods_seconds_and_runs_the_stress_checks_model() -> None:
    """Per-method wall seconds in the result and the JSON; no second fit for the test logs."""
    result = compare([_run(1), _run(2)], [_run(3)], methods=["ss"], lags=Lags.arx(1, 1))
    assert set(result.seconds) == {"arx", "ss"}
    for spent in result.seconds.values():
        assert spent["selection"] > 0.0 and spent["test"] >= 0.0
    assert all(result.selection.table["seconds"] > 0.0)
    for method, setting in result.settings.items():
        assert result.models[method] is result.selection.fitted[setting["candidate"]]
    by_method = {entry["method"]: entry for entry in result.to_json()["methods"]}
    assert by_method["ss"]["seconds"] == pytest.approx(result.seconds["ss"])
    fresh = compare([_run(1), _run(2)], [_run(3)], methods=["ss"], lags=Lags.arx(1, 1), stress=0)
    assert fresh.selection.fitted == {}
    np.testing.assert_allclose(fresh.models["ss"].A_, result.models["ss"].A_, rtol=1e-12)
