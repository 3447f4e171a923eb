"""One selection engine (issue 40): the paired rule, the folds of few logs, the baselines, the warning.

Every selection (select_lags, select_safely / compare, the multi-step SM settings, the
benchmark's candidates) chooses with :func:`neckid.data.folds.rank_candidates` on folds of
:func:`neckid.data.folds.fold_plan`; the naive references of :mod:`neckid.selection.baselines`
are scored on the same folds.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from neckid import IOData, Lags, LinearARX
from neckid.cli import app
from neckid.data.folds import MIN_GAIN, blocks_per_log, fold_plan, rank_candidates
from neckid.metrics import fit_percent
from neckid.selection.baselines import Replay, TrainingMean, baseline_warnings
from neckid.selection.comparison import select_safely
from neckid.selection.lags import score_candidates

runner = CliRunner()


# ---------------------------------------------------------------------- the paired rule
def _spread_folds(seed: int = 0) -> np.ndarray:
    """Three candidates on 6 folds whose difficulty spreads over 20 points.

    Row 0 (simplest) is the base; row 1 is 0.5 points below it; row 2 (most complex) is better
    than row 0 by 2 points on every fold (± 0.3 of noise).
    """
    rng = np.random.default_rng(seed)
    base = np.linspace(55.0, 75.0, 6)  # the folds' spread: 20 points
    return np.vstack([base, base - 0.5 + rng.normal(0, 0.3, 6), base + 2.0 + rng.normal(0, 0.3, 6)])


def test_the_paired_rule_keeps_a_model_better_on_every_fold_where_the_unpaired_rule_loses_it():
    fits = _spread_folds()
    assert np.all(fits[2] - fits[0] > 1.0) and np.ptp(fits[0]) == pytest.approx(20.0)
    simplicity = [0, 1, 2]
    paired = rank_candidates(fits, simplicity, rule="paired")
    unpaired = rank_candidates(fits, simplicity, rule="unpaired")
    assert paired.best == 2 and paired.chosen == 2
    assert unpaired.best == 2 and unpaired.chosen == 0  # lost in the spread between folds
    # the unpaired bar is m* − s* with s* the between-fold standard error (≈ 3 points)
    assert unpaired.bar == pytest.approx(fits[2].mean() - fits[2].std(ddof=1) / np.sqrt(6))
    # the paired one: the simplest's difference to the best is −2 ± 0.1: far outside
    assert paired.difference_means[0] == pytest.approx(np.mean(fits[0] - fits[2]))
    assert paired.difference_errors[0] < 0.2 and not paired.eligible[0]


def test_the_paired_rule_still_takes_the_simpler_one_when_the_gain_is_noise_or_tiny():
    rng = np.random.default_rng(3)
    base = np.linspace(55.0, 75.0, 6)
    noisy = np.vstack([base, base + 1.0 + rng.normal(0, 4.0, 6)])  # +1 ± 4: not told apart
    assert rank_candidates(noisy, [0, 1]).chosen == 0
    tiny = np.vstack([base, base + 0.4])  # better on every fold, by less than MIN_GAIN
    assert MIN_GAIN == 0.5 and rank_candidates(tiny, [0, 1]).chosen == 0
    assert rank_candidates(tiny, [0, 1], min_gain=0.0).chosen == 1
    assert rank_candidates(tiny, [0, 1], rule="best").chosen == 1


def test_a_candidate_that_failed_in_a_fold_is_out_and_none_left_is_an_error():
    fits = np.array([[60.0, -np.inf, 70.0], [50.0, 55.0, 60.0]])
    ranking = rank_candidates(fits, [0, 1])
    assert ranking.chosen == ranking.best == 1 and not ranking.eligible[0]
    with pytest.raises(ValueError, match="no candidate is accepted"):
        rank_candidates(fits[:1], [0])
    with pytest.raises(ValueError, match="rule must be one of"):
        rank_candidates(fits, rule="loose")


def test_explain_names_the_best_the_chosen_the_rule_and_the_bar():
    fits = np.vstack([np.linspace(50, 70, 6), np.linspace(50.3, 70.3, 6)])
    ranking = rank_candidates(fits, [0, 1])
    text = ranking.explain(["arx", "sm"])
    assert text.startswith("best sm (mean fold fit 60.3 %); chosen arx (60.0 %)")
    assert "paired one-standard-error rule" in text and f"bar {ranking.bar:.1f} %" in text


# ---------------------------------------------------------------------- the folds of few logs
def _logs(count: int, n: int = 600) -> list[IOData]:
    rng = np.random.default_rng(count)
    return [
        IOData(rng.normal(size=n), rng.normal(size=n), ts=0.1, name=f"run{i}") for i in range(count)
    ]


def test_three_logs_give_six_folds_each_one_block_of_one_log_fitted_on_the_others():
    logs = _logs(3)
    plan = fold_plan(logs)
    assert plan.scheme == "experiments × time-blocks" and plan.n_folds == 6
    for i, split in enumerate(plan.splits):
        assert [d.name for d in split.fit_on] == [d.name for j, d in enumerate(logs) if j != i]
        blocks = [fold[0] for fold in split.folds]
        assert all(len(fold) == 1 for fold in split.folds)  # a fold never mixes two blocks
        # contiguous blocks of the held-out log, in order, that cover it exactly
        np.testing.assert_array_equal(np.vstack([b.y for b in blocks]), logs[i].y)
        assert [b.name for b in blocks] == [f"run{i} [block {k}/2]" for k in (1, 2)]


def test_the_blocks_per_log_rule():
    assert [blocks_per_log(_logs(k)) for k in (2, 3, 4, 6, 9)] == [3, 2, 2, 1, 1]
    assert blocks_per_log(_logs(2, n=250)) == 2  # each block keeps 100 samples
    assert blocks_per_log(_logs(2, n=150)) == 1
    assert fold_plan(_logs(6)).scheme == "leave-one-experiment-out"
    assert fold_plan(_logs(1)).scheme == "time-blocks" and fold_plan(_logs(1)).n_folds == 3
    assert fold_plan(_logs(3), blocks=3).n_folds == 9
    with pytest.raises(ValueError, match="blocks must be an int >= 1"):
        fold_plan(_logs(3), blocks=0)


def test_score_candidates_scores_every_block_with_the_model_of_the_other_logs():
    logs = _logs(3)
    scores = score_candidates(
        [("arx", LinearARX(Lags.arx(1, 1)))], logs, criteria=["simulation"], blocks_per_log=None
    )
    assert scores.scheme == "experiments × time-blocks" and scores.fold_fits[
        "fit_simulation"
    ].shape == (1, 6)
    model = LinearARX(Lags.arx(1, 1)).fit(logs[1:])
    block = logs[0][300:]
    expected = model.fit_percent(block)[0]
    assert scores.fold_fits["fit_simulation"][0, 1] == pytest.approx(expected, rel=1e-12)
    assert not scores.table.attrs


# ---------------------------------------------------------------------- the baselines
def _steps(seed: int, gain: float, n: int = 600) -> IOData:
    u = np.repeat(np.random.default_rng(seed).uniform(-1, 1, n // 20), 20)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.8 * y[t - 1] + 0.2 * gain * u[t - 1]
    return IOData(u, y, ts=0.05, name=f"steps {seed} x{gain}")


def test_the_training_mean_never_fits_above_zero_and_replay_needs_the_same_inputs():
    train, same_inputs, other = _steps(1, 1.0), _steps(1, 1.1), _steps(2, 1.0)
    mean = TrainingMean().fit(train).simulate(other)
    assert fit_percent(other.y, mean.y)[0] <= 0.0
    replayed = Replay().fit([other, train]).simulate(same_inputs[100:400])
    np.testing.assert_array_equal(replayed.y, train.y[100:400])
    assert fit_percent(same_inputs.y[100:400], replayed.y)[0] > 80.0
    with pytest.raises(ValueError, match="replay does not apply"):
        Replay().fit(train).simulate(other)


def test_select_safely_scores_the_baselines_on_the_same_folds():
    logs = [_steps(1, g) for g in (0.8, 1.0, 1.2)]  # one motor trajectory, three payloads
    found = select_safely([("arx", LinearARX(Lags.arx(1, 1)))], logs)
    assert set(found.baselines) == {"training mean", "replay"}
    assert len(found.baseline_fits["replay"]) == len(found.folds) == 6
    assert found.baselines["training mean"] <= 0.0 < found.baselines["replay"]
    different = select_safely(
        [("arx", LinearARX(Lags.arx(1, 1)))], [_steps(s, 1.0) for s in (1, 2, 3)]
    )
    assert set(different.baselines) == {"training mean"}  # no log repeats another's inputs


def test_baseline_warnings_say_it_in_one_line():
    assert baseline_warnings("arx", 12.0, {"training mean": -1.0, "replay": 30.0}) == [
        "no model is good: the recommended arx has mean fold fit 12.0 %, below the baseline"
        " replay (30.0 %)"
    ]
    assert baseline_warnings("arx", 12.0, {"training mean": -1.0}) == []


# ---------------------------------------------------------------------- the warning in the CLI
def _noise_logs(folder: Path, count: int) -> list[Path]:
    """Logs whose output ignores the input: no model can be good."""
    paths = []
    for i in range(count):
        rng = np.random.default_rng(40 + i)
        u = np.repeat(rng.uniform(-1, 1, 30), 20)
        y = np.cumsum(rng.normal(size=600)) * 0.05 + rng.normal(0, 3.0)
        path = folder / f"noise{i}.csv"
        IOData(u, y, ts=0.05, input_names=["cmd"], output_names=["incl"]).to_csv(path)
        paths.append(path)
    return paths


def test_compare_says_plainly_when_no_model_is_good(tmp_path: Path):
    paths = _noise_logs(tmp_path, 4)
    out = tmp_path / "compare.json"
    result = runner.invoke(
        app,
        [
            "compare", *map(str, paths[:3]), "--test", str(paths[3]), "--inputs", "cmd",
            "--outputs", "incl", "--methods", "arx", "--lags", "1/1", "--json", str(out),
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    lines = [line for line in result.output.splitlines() if "no model is good" in line]
    assert len(lines) == 1 and ("training mean" in lines[0] or "below 0 %" in lines[0])
    assert "baselines on the same folds: training mean" in result.output
    document = json.loads(out.read_text())
    assert len(document["warnings"]) == 1 and "no model is good" in document["warnings"][0]
    assert document["selection"]["best"] == "arx" and "bar" in document["selection"]


def test_select_says_plainly_when_no_model_is_good(tmp_path: Path):
    paths = _noise_logs(tmp_path, 3)
    out = tmp_path / "select.json"
    result = runner.invoke(
        app,
        ["select", *map(str, paths), "--inputs", "cmd", "--outputs", "incl", "--lags", "1/1",
         "--lags", "1-2/1-2", "--json", str(out)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert sum("no model is good" in line for line in result.output.splitlines()) == 1
    document = json.loads(out.read_text())
    assert len(document["warnings"]) == 1 and document["baselines"]["training mean"] <= 0


def test_outside_training_range_means_one_thing_for_every_method():
    from neckid.selection.comparison import compare

    train = [_steps(1, 1.0), _steps(2, 1.0)]
    test = _steps(3, 1.6)  # outputs beyond the training range
    result = compare(train, [test], methods=["sm"], lags=Lags.arx(1, 1))
    shares = result.results.groupby("log")["outside_training_range"].nunique()
    assert (shares == 1).all() and result.results["outside_training_range"].iloc[0] > 0
    document = result.to_json()
    arx = next(m for m in document["methods"] if m["method"] == "arx")
    assert arx["fold_differences_to_arx"] == [0.0] * len(document["folds"])
    assert document["selection"]["best"] in {"arx", "sm"} and isinstance(document["warnings"], list)


def test_the_compare_table_marks_the_chosen_and_the_best_with_their_fold_fits():
    from neckid.cli.compare import _result_rows
    from neckid.selection.comparison import compare

    result = compare([_steps(1, 1.0), _steps(2, 1.0)], [_steps(3, 1.0)], methods=["sm"])
    rows = _result_rows(result)
    assert len({len(row) for row in rows}) == 1  # the mean rows stay aligned with the others
    chosen = [row for row in rows if "chosen" in row["choice"]]
    assert chosen and {row["method"] for row in chosen} == {result.recommended}
    best = [row for row in rows if "best on the folds" in row["choice"]]
    assert {row["method"] for row in best} == {result.selection.best.split(" ")[0]}
    table = result.selection.table.set_index("name")
    for row in rows:
        name = result.settings[row["method"]]["candidate"]
        assert row["mean fold fit [%]"] == pytest.approx(table.loc[name, "fit_mean"])
