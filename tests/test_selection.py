"""select_lags, lag_grid and the He & Asada Lipschitz order index."""

from __future__ import annotations

from typing import Any

import matplotlib
import numpy as np
import pandas as pd
import pytest

from _synthetic import arx_system
from neckid import IOData, Lags, LinearARX
from neckid.experiments.benchmark.runner import _select
from neckid.metrics import fit_percent
from neckid.models.neural.narx import NeuralNARX
from neckid.models.results import DivergenceError
from neckid.report.selection_plots import plot_lipschitz_index
from neckid.selection.lags import (
    LagSelection,
    lag_grid,
    lipschitz_quotients,
    score_candidates,
    select_lags,
)

matplotlib.use("Agg")


TRUE_LAGS = Lags.arx(na=2, nb=2, delay=3)


# ---------------------------------------------------------------------- lag_grid
def test_lag_grid_covers_orders_and_delays() -> None:
    grid = lag_grid([0, 1, 2], [0, 1, 2], [1, 3])
    assert len(grid) == len({repr(g) for g in grid})
    # (na, nb) in {0,1,2}^2 minus (0, 0); nb = 0 gives one candidate, nb > 0 one per delay.
    assert len(grid) == 2 * 1 + 3 * 2 * 2
    assert Lags.arx(2, 2, 3) in grid
    assert Lags(outputs=[1, 2]) in grid
    assert lag_grid(1, 1) == [Lags.arx(1, 1, 1)]


@pytest.mark.parametrize(
    ("args", "error", "match"),
    [
        (([-1], [1]), ValueError, r"output_orders must hold values >= 0; got -1"),
        (([1], [1], [-2]), ValueError, r"input_delays must hold values >= 0; got -2"),
        (([], [1]), ValueError, r"output_orders is empty"),
        (([1.5], [1]), TypeError, r"output_orders must hold ints; got 1.5"),
        (([0], [0]), ValueError, r"lag_grid has no candidate"),
    ],
)
def test_lag_grid_bad_input(args: tuple, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        lag_grid(*args)


# ---------------------------------------------------------------------- select_lags
@pytest.fixture(scope="module")
def selection() -> LagSelection:
    train, validation = arx_system(1500, 1), arx_system(800, 2)
    grid = lag_grid([1, 2, 3], [1, 2, 3], [1, 2, 3, 4])
    return select_lags(train, validation, grid, LinearARX(), n_jobs=2, progress=False)


def test_select_lags_finds_true_orders(selection: LagSelection) -> None:
    table = selection.table
    assert len(table) == 3 * 3 * 4
    # Candidates whose least-squares ARX is unstable run away on the validation log (finite, but
    # far outside the training outputs): they are rejected, with the reason kept.
    rejected = table[table["error"] != ""]
    assert rejected["error"].str.contains("DivergenceError: the LinearARX free run ran away").all()
    for lags in rejected["candidate"]:
        model = LinearARX(selection.candidates[lags]).fit(arx_system(1500, 1))
        n_out = int((model.lags_.source == 0).sum())
        poles = np.roots(np.r_[1.0, -model.coef_[:n_out, 0]])
        assert np.abs(poles).max() > 1.0
    table = table[table["error"] == ""]
    assert selection.best(tolerance=0.05) == TRUE_LAGS
    # Every candidate lacking a true term fits clearly worse than the best.
    true_terms = {("y", 1), ("y", 2), ("u", 3), ("u", 4)}
    for lags, fit in zip(table["candidate"], table["fit_simulation"], strict=True):
        lg = selection.candidates[lags]
        terms = {("y", k) for k in lg.outputs} | {("u", k) for k in lg.inputs}
        if not true_terms <= terms:
            assert fit < table["fit_simulation"].iloc[0] - 1.0
    # Table sorted best first by the criterion, with the documented columns.
    assert table["fit_simulation"].is_monotonic_decreasing
    for column in ("lags", "n_terms", "max_lag", "fit_prediction", "fit_time_s"):
        assert column in table
    assert "fit_simulation[incl]" in table
    # One validation fold: no standard error, so the safe rule takes the fewest terms within
    # MIN_GAIN (half a point) of the top: the true orders, not a longer memory fitting noise.
    assert selection.best_lags == TRUE_LAGS
    assert selection.best() == selection.candidates[int(table["candidate"].iloc[0])]


def test_select_lags_prediction_criterion_and_single_candidate() -> None:
    train, validation = arx_system(400, 3), arx_system(300, 4)
    result = select_lags(
        train, validation, TRUE_LAGS, LinearARX(), criterion="prediction", progress=True
    )
    assert result.criterion == "prediction"
    assert len(result.table) == 1
    assert result.best_lags == TRUE_LAGS
    assert result.table["fit_prediction"].iloc[0] > 99.0


def test_select_lags_does_not_change_estimator() -> None:
    estimator = LinearARX(ridge=0.0)
    select_lags(arx_system(200, 5), arx_system(200, 6), lag_grid(1, 1), estimator, progress=False)
    assert estimator.lags is None
    assert not hasattr(estimator, "coef_")


def test_failed_candidate_gets_error_row_not_crash() -> None:
    train, validation = arx_system(300, 7), arx_system(60, 8)
    too_long = Lags(outputs=[1], inputs=[100])  # longer than the validation record
    result = select_lags(train, validation, [too_long, TRUE_LAGS], LinearARX(), progress=False)
    table = result.table
    assert result.best_lags == TRUE_LAGS
    failed = table[table["lags"] == repr(too_long)].iloc[0]
    assert failed["fit_simulation"] == -np.inf
    assert failed["fit_prediction"] == -np.inf
    assert "too few for lags up to 100" in failed["error"]


def test_unstable_free_run_is_a_failed_candidate() -> None:
    # Trained on y(t) = 1.5 y(t-1) exactly: the model's pole is 1.5, so a free run of 2000
    # samples overflows to inf; that candidate must become a failed row, not a crash.
    n = 100
    train = IOData(np.zeros(n), 1.5 ** np.arange(n), ts=1.0)
    validation = IOData(np.zeros(2000), np.random.default_rng(0).normal(size=2000), ts=1.0)
    stable = Lags(inputs=[0])  # a constant model: finite, poor fit
    result = select_lags(
        train, validation, [Lags(outputs=[1]), stable], LinearARX(), progress=False
    )
    table = result.table.set_index("lags")
    failed = table.loc[repr(Lags(outputs=[1]))]
    assert failed["fit_simulation"] == -np.inf
    assert "diverged" in failed["error"] and "not finite" in failed["error"]
    assert np.isfinite(failed["fit_prediction"])  # the one-step fit was still computed
    assert result.table["lags"].iloc[-1] == repr(Lags(outputs=[1]))  # ranked last


def test_select_lags_works_with_neural_estimator() -> None:
    rng = np.random.default_rng(9)
    u = rng.uniform(-2, 2, size=700)
    y = np.zeros(700)
    for t in range(2, 700):
        y[t] = 0.6 * y[t - 1] + np.tanh(u[t - 2])
    data = IOData(u, y, ts=0.02)
    estimator = NeuralNARX(hidden_layer_sizes=(8,), learning_rate_init=3e-3, random_state=0)
    candidates = [Lags.arx(1, 1, 1), Lags.arx(1, 1, 2)]
    result = select_lags(data[:500], data[500:], candidates, estimator, progress=False)
    assert result.best_lags == Lags.arx(1, 1, 2)
    assert result.table["fit_simulation"].iloc[0] > 90.0


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        (
            {"criterion": "bic"},
            ValueError,
            r"criterion must be 'simulation' or 'prediction'; got 'bic'",
        ),
        ({"candidates": []}, ValueError, r"candidates is empty"),
        (
            {"candidates": [Lags(1), "y1"]},
            TypeError,
            r"candidates\[1\] must be a neckid.Lags; got str",
        ),
        ({"estimator": object()}, TypeError, r"estimator must be a neckid model .* got object"),
        ({"train": "log.csv"}, TypeError, r"train must be an IOData or a list of them; got str"),
    ],
)
def test_select_lags_bad_input(kwargs: dict, error: type, match: str) -> None:
    data = arx_system(100, 0)
    arguments = {
        "train": data,
        "validation": data,
        "candidates": [Lags(1)],
        "estimator": LinearARX(),
        "progress": False,
        **kwargs,
    }
    with pytest.raises(error, match=match):
        select_lags(**arguments)


def test_select_lags_refuses_mismatched_channels() -> None:
    other = IOData(np.zeros(50), np.arange(50.0), ts=0.02)
    with pytest.raises(ValueError, match=r"has channels \['u'\] -> \['y'\]"):
        select_lags(arx_system(100, 0), other, [Lags(1)], LinearARX(), progress=False)


def test_best_tolerance_validated(selection: LagSelection) -> None:
    with pytest.raises(ValueError, match="tolerance must be a finite number >= 0; got -1"):
        selection.best(tolerance=-1)


def test_validation_scheme_is_named_and_worst_equals_mean(selection: LagSelection) -> None:
    table = selection.table
    assert selection.scheme == "validation" and selection.folds == [["validation[0]"]]
    assert not table.attrs  # the folds travel in the result, not in DataFrame.attrs
    assert (table["scheme"] == "validation").all() and (table["n_folds"] == 1).all()
    for kind in ("prediction", "simulation"):
        np.testing.assert_array_equal(table[f"fit_{kind}_worst"], table[f"fit_{kind}"])


# ---------------------------------------------------------------------- grouped selection
def three_runs() -> list[IOData]:
    """Three experiments of the same ARX system, of different lengths, inputs and gains."""
    runs = []
    for seed, (n, gain) in enumerate([(400, 1.0), (500, 0.6), (350, 1.5)]):
        run = arx_system(n, 10 + seed)
        runs.append(IOData(gain * run.u, gain * run.y, ts=run.ts, input_names=["cmd"],
                           output_names=["incl"], name=f"run{seed}"))  # fmt: skip
    return runs


def test_leave_one_experiment_out_equals_hand_computed_average() -> None:
    runs = three_runs()
    grid = [TRUE_LAGS, Lags.arx(1, 1, 1), Lags.arx(2, 1, 3)]
    # folds=3 of 3 runs: plain leave-one-experiment-out (no time blocks)
    result = select_lags(runs, None, grid, LinearARX(), n_jobs=2, progress=False, folds=3)
    assert result.scheme == "leave-one-experiment-out"
    table = result.table.set_index("candidate")
    assert (table["scheme"] == "leave-one-experiment-out").all() and (table["n_folds"] == 3).all()
    assert result.folds == [["run0"], ["run1"], ["run2"]]
    for i, lags in enumerate(grid):
        fits: dict[str, list[float]] = {"prediction": [], "simulation": []}
        for held in range(3):
            model = LinearARX(lags).fit([r for j, r in enumerate(runs) if j != held])
            record = runs[held]
            for kind, result_ in (
                ("prediction", model.predict(record)),
                ("simulation", model.simulate(record)),
            ):
                fits[kind].append(fit_percent(record.y, result_.y, skip=lags.max_lag)[0])
        for kind, values in fits.items():
            assert table.loc[i, f"fit_{kind}"] == pytest.approx(np.mean(values), rel=1e-12)
            assert table.loc[i, f"fit_{kind}_worst"] == pytest.approx(min(values), rel=1e-12)
            assert table.loc[i, f"fit_{kind}[incl]"] == pytest.approx(np.mean(values), rel=1e-12)
    assert result.best(tolerance=0.05) == TRUE_LAGS


@pytest.mark.filterwarnings("ignore::neckid.models.base.ExtrapolationWarning")
def test_grouped_k_fold_holds_out_every_kth_experiment() -> None:
    runs = three_runs()
    lags = Lags.arx(1, 1, 1)
    options = [("arx", LinearARX(lags))]
    scores = score_candidates(options, runs, criteria=["simulation"], folds=2)
    table = scores.table
    assert scores.folds == [["run0", "run2"], ["run1"]]
    assert table["scheme"].iloc[0] == "grouped-k-fold" and table["n_folds"].iloc[0] == 2
    # Fold 0 fits on run1 and scores run0 and run2 (mean of the two); fold 1 the other way.
    first = LinearARX(lags).fit(runs[1])
    fold0 = np.mean([first.fit_percent(runs[0])[0], first.fit_percent(runs[2])[0]])
    fold1 = LinearARX(lags).fit([runs[0], runs[2]]).fit_percent(runs[1])[0]
    assert table["fit_simulation"].iloc[0] == pytest.approx((fold0 + fold1) / 2, rel=1e-12)
    assert table["fit_simulation_worst"].iloc[0] == pytest.approx(min(fold0, fold1), rel=1e-12)
    assert table["rmse_simulation_worst"].iloc[0] >= table["rmse_simulation"].iloc[0]


def encoder_run(n: int, seed: int, encoder_zero: float) -> IOData:
    """A neck whose inclination follows the motor *displacement*; the log has the absolute position.

    ``y(t) = 0.8 y(t-1) + 0.5 d(t-1)`` with ``d = position - encoder_zero``: the encoder zero
    differs between runs (as the soft neck's does), and ``velocity(t) = position(t) -
    position(t-1)``. A model on the absolute position needs an intercept that holds for one run
    only; ``y(t) = 1.8 y(t-1) - 0.8 y(t-2) + 0.5 velocity(t-1)`` holds for every run.
    """
    rng = np.random.default_rng(seed)
    displacement = np.repeat(rng.uniform(0.0, 3.0, size=n // 40 + 1), 40)[:n]
    displacement[:40] = 0.0
    position = encoder_zero + displacement
    velocity = np.diff(position, prepend=position[0])
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.8 * y[t - 1] + 0.5 * displacement[t - 1]
    u = np.column_stack([position, velocity])
    return IOData(u, y, ts=0.025, input_names=["position", "velocity"], output_names=["incl"])


ON_POSITION = Lags(outputs=[1], inputs={"position": [1]})
ON_VELOCITY = Lags(outputs=[1, 2], inputs={"velocity": [1]})


def test_grouped_selection_picks_what_carries_over_to_other_runs() -> None:
    runs = [encoder_run(600, seed, zero) for seed, zero in enumerate([0.0, 2.0, 4.0])]
    grid = [ON_POSITION, ON_VELOCITY]
    # The tail of one run cannot tell the two apart: both fit it exactly, and the parsimonious
    # choice is the absolute position, whose intercept holds for that run only.
    single = select_lags(runs[0][:450], runs[0][450:], grid, LinearARX(), progress=False)
    assert (single.table["fit_simulation"] > 99.9).all()
    assert single.best(tolerance=0.5) == ON_POSITION
    grouped = select_lags(runs, None, grid, LinearARX(), progress=False)
    table = grouped.table.set_index("lags")
    assert table.loc[repr(ON_VELOCITY), "fit_simulation_worst"] > 99.0
    assert table.loc[repr(ON_POSITION), "fit_simulation"] < 90.0
    assert (
        table.loc[repr(ON_POSITION), "fit_simulation_worst"]
        < table.loc[repr(ON_POSITION), "fit_simulation"]
    )
    assert grouped.best(tolerance=0.5) == ON_VELOCITY


def test_a_failing_fold_fails_the_candidate() -> None:
    runs = three_runs()
    runs[1] = runs[1][:60]  # too short for a lag of 80, to fit on or to score
    too_long = Lags(outputs=[1], inputs=[80])
    result = select_lags(runs, None, [too_long, TRUE_LAGS], LinearARX(), progress=False)
    row = result.table.set_index("lags").loc[repr(too_long)]
    assert row["fit_simulation"] == -np.inf and row["fit_simulation_worst"] == -np.inf
    # every fold failed the same way (run1 is too short to fit on or to score): said once
    assert row["error"].startswith("every fold: ")
    assert row["error"].count("run1 has 60 samples, too few for lags up to 80") == 1
    assert result.best_lags == TRUE_LAGS


def test_score_candidates_and_select_lags_agree_on_grouped_scores() -> None:
    runs = three_runs()
    grid = [TRUE_LAGS, Lags.arx(1, 1, 1)]
    selection = select_lags(runs, None, grid, LinearARX(), folds=3, progress=False)
    scores = score_candidates([(repr(g), LinearARX(g)) for g in grid], runs, n_jobs=2).table
    by_candidate = selection.table.set_index("candidate").sort_index()
    for column in ("fit_simulation", "fit_simulation_worst", "fit_prediction_worst"):
        np.testing.assert_array_equal(by_candidate[column], scores[column])
    assert list(scores["scheme"]) == ["leave-one-experiment-out"] * 2


@pytest.mark.parametrize(
    ("train", "kwargs", "error", "match"),
    [
        (1, {"folds": 2}, ValueError, r"validation is None.* at least 2 experiments; got 1"),
        (3, {"rule": "top"}, ValueError, r"rule must be 'safe', 'unpaired' or 'best'; got 'top'"),
        (3, {"folds": 1}, ValueError, r"folds must be in \[2, 3\] .*; got 1"),
        (3, {"folds": 4}, ValueError, r"folds must be in \[2, 3\] .*; got 4"),
        (3, {"folds": 2.0}, TypeError, r"folds must be an int or None; got 2.0"),
        (3, {"folds": 2, "validation": "given"}, ValueError, r"folds applies only when"),
        (3, {"candidates": None}, TypeError, r"select_lags needs candidates=; got None"),
        (3, {"estimator": None}, TypeError, r"select_lags needs estimator=; got None"),
    ],
)
def test_grouped_selection_bad_input(train: Any, kwargs: dict, error: type, match: str) -> None:
    runs = three_runs()
    arguments = {
        "train": runs[0] if train == "one" else runs[:train],
        "validation": None,
        "candidates": [Lags.arx(1, 1, 1)],
        "estimator": LinearARX(),
        "progress": False,
        **kwargs,
    }
    if arguments["validation"] == "given":
        arguments["validation"] = runs[0]
    with pytest.raises(error, match=match):
        select_lags(**arguments)


def test_one_record_is_cut_into_time_blocks() -> None:
    run = three_runs()[0]
    selection = select_lags(run, None, [Lags.arx(1, 1, 1)], LinearARX(), progress=False)
    assert selection.scheme == "time-blocks"
    assert selection.folds == [[f"{run.name} [block {i}/3]"] for i in (1, 2, 3)]
    with pytest.raises(ValueError, match=r"too few for 3 time blocks"):
        select_lags(run[:5], None, [Lags.arx(1, 1, 1)], LinearARX(), progress=False)


def test_safe_rule_takes_fewer_terms_within_one_standard_error() -> None:
    # the system is TRUE_LAGS: longer memories fit as well, within the noise
    runs = three_runs()
    grid = [Lags.arx(3, 3, 3), TRUE_LAGS]
    safe = select_lags(runs, None, grid, LinearARX(), progress=False)
    best = select_lags(runs, None, grid, LinearARX(), progress=False, rule="best")
    table = safe.table.set_index("candidate")
    assert table.loc[1, "status"] == "chosen"
    assert table.loc[1, "fit_simulation"] >= (
        table["fit_simulation"].max()
        - table.loc[table["fit_simulation"].idxmax(), "fit_simulation_se"]
    )
    assert safe.best_lags == grid[1]
    assert best.best_lags == grid[int(best.table["candidate"].iloc[0])]
    assert (safe.table["status"] == "chosen").sum() == 1


def test_safe_rule_rejects_a_candidate_that_diverges_in_a_fold() -> None:
    class Exploding(LinearARX):
        def simulate(self, data, initial=None):  # type: ignore[no-untyped-def]
            raise DivergenceError("the free run left the envelope at sample 10")

    runs = three_runs()
    options = [Lags.arx(1, 1, 1)]
    selection = select_lags(runs, None, options, Exploding(), progress=False)
    row = selection.table.iloc[0]
    assert row["status"] == "rejected" and "DivergenceError" in row["reason"]
    assert selection.chosen is None
    with pytest.raises(ValueError, match="every candidate was rejected"):
        _ = selection.best_lags


# ---------------------------------------------------------------------- the benchmark's selection
def test_benchmark_selects_on_held_out_experiments_given_a_list() -> None:
    runs = [encoder_run(600, seed, zero) for seed, zero in enumerate([0.0, 2.0, 4.0])]
    options = [("position", LinearARX(ON_POSITION)), ("velocity", LinearARX(ON_VELOCITY))]
    (chosen, _), scores = _select(options, runs, None)
    assert chosen == "velocity"
    assert [s["scheme"] for s in scores] == ["leave-one-experiment-out"] * 2
    assert scores[0]["worst_fold_rmse"] >= scores[0]["holdout_rmse"] > scores[1]["holdout_rmse"]
    # One record (or a list of one): the held-out end of it, as before; no scheme key.
    for train in (runs[0], runs[:1]):
        _, single = _select(options, train, None)
        assert "scheme" not in single[0] and set(single[0]) >= {"settings", "holdout_rmse"}


# ---------------------------------------------------------------------- Lipschitz index
def narx_system(n: int, seed: int) -> IOData:
    """y(t) = 0.5 y(t-1) - 0.3 y(t-2) + tanh(u(t-1)) + 0.5 u(t-2)^2: orders na=2, nb=2, delay 1."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, size=n)
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = 0.5 * y[t - 1] - 0.3 * y[t - 2] + np.tanh(u[t - 1]) + 0.5 * u[t - 2] ** 2
    return IOData(u, y, ts=0.1)


@pytest.fixture(scope="module")
def lipschitz_table() -> pd.DataFrame:
    return lipschitz_quotients(narx_system(1500, 0), 3, 3, max_samples=700, seed=1)


def test_lipschitz_index_knee_at_true_order(lipschitz_table: pd.DataFrame) -> None:
    index = lipschitz_table.set_index(["output_order", "input_order"])["index"]
    at_true = index[2, 2]
    # Below the true order in either direction the index is much larger ...
    for na, nb in [(1, 2), (2, 1), (1, 1), (0, 2), (2, 0)]:
        assert index[na, nb] > 3.0 * at_true, (na, nb)
    # ... beyond it, it levels off.
    for na, nb in [(3, 2), (2, 3), (3, 3)]:
        assert 0.6 * at_true < index[na, nb] < 1.5 * at_true, (na, nb)


def test_lipschitz_table_layout(lipschitz_table: pd.DataFrame) -> None:
    assert len(lipschitz_table) == 4 * 4 - 1
    assert set(lipschitz_table.columns) >= {
        "output",
        "output_order",
        "input_order",
        "n_terms",
        "index",
    }
    assert (lipschitz_table["n_rows"] == 700).all()
    assert (lipschitz_table["p"] == round(0.015 * 700)).all()
    row = lipschitz_table[(lipschitz_table.output_order == 2) & (lipschitz_table.input_order == 3)]
    assert int(row["n_terms"].iloc[0]) == 5


def test_lipschitz_matches_brute_force() -> None:
    data = narx_system(120, 3)
    table = lipschitz_quotients(data, 1, 1, max_samples=None, fraction=0.05, standardize=False)
    x, y = Lags(outputs=[1], inputs=[1]).build(data)
    q = [
        abs(y[i, 0] - y[j, 0]) / np.linalg.norm(x[i] - x[j])
        for i in range(len(x))
        for j in range(i + 1, len(x))
    ]
    p = round(0.05 * len(x))
    top = np.sort(q)[::-1][:p]
    expected = np.exp(np.mean(np.log(np.sqrt(2) * top)))
    got = table[(table.output_order == 1) & (table.input_order == 1)]["index"].iloc[0]
    assert got == pytest.approx(expected, rel=1e-12)


def test_lipschitz_subsample_is_seeded() -> None:
    data = narx_system(900, 4)
    a = lipschitz_quotients(data, 1, 1, max_samples=200, seed=5)
    b = lipschitz_quotients(data, 1, 1, max_samples=200, seed=5)
    pd.testing.assert_frame_equal(a, b)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"max_output_lag": -1}, r"max_output_lag must be an int >= 0; got -1"),
        ({"max_input_lag": 1.5}, r"max_input_lag must be an int >= 0; got 1.5"),
        ({"max_output_lag": 0, "max_input_lag": 0}, r"both 0"),
        ({"fraction": 0.0}, r"fraction must be in \(0, 1\).*got 0.0"),
        ({"max_samples": 3}, r"max_samples must be an int >= 10 or None; got 3"),
        ({"input_delay": -1}, r"input_delay must be an int >= 0; got -1"),
    ],
)
def test_lipschitz_bad_input(kwargs: dict, match: str) -> None:
    arguments = {"data": narx_system(50, 0), "max_output_lag": 1, "max_input_lag": 1, **kwargs}
    with pytest.raises(ValueError, match=match):
        lipschitz_quotients(**arguments)


def test_plot_lipschitz_index(lipschitz_table: pd.DataFrame) -> None:
    import matplotlib.pyplot as plt

    fig = plot_lipschitz_index(lipschitz_table)
    ax = fig.axes[0]
    assert ax.get_yscale() == "log"
    assert len(ax.get_lines()) == 4  # one per output order 0..3
    fig2, ax2 = plt.subplots()
    assert plot_lipschitz_index(lipschitz_table, output="y", ax=ax2) is fig2
    plt.close(fig2)
    with pytest.raises(ValueError, match="output 'z' is not in the table"):
        plot_lipschitz_index(lipschitz_table, output="z")
    with pytest.raises(ValueError, match="lacks the columns"):
        plot_lipschitz_index(pd.DataFrame({"a": [1]}))
