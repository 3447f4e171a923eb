"""select_lags, lag_grid and the He & Asada Lipschitz order index."""

from __future__ import annotations

import matplotlib
import numpy as np
import pandas as pd
import pytest

from neckid import IOData, Lags, LinearARX
from neckid.models.neural import NeuralNARX
from neckid.report.selection_plots import plot_lipschitz_index
from neckid.selection import (
    LagSelection,
    lag_grid,
    lipschitz_quotients,
    select_lags,
)

matplotlib.use("Agg")


def arx_system(n: int, seed: int) -> IOData:
    """y(t) = 1.2 y(t-1) - 0.5 y(t-2) + 0.8 u(t-3) + 0.4 u(t-4) + e(t): na=2, nb=2, delay 3."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=n)
    e = 0.01 * rng.normal(size=n)
    y = np.zeros(n)
    for t in range(4, n):
        y[t] = 1.2 * y[t - 1] - 0.5 * y[t - 2] + 0.8 * u[t - 3] + 0.4 * u[t - 4] + e[t]
    return IOData(u, y, ts=0.02, input_names=["cmd"], output_names=["incl"])


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
    assert (table["error"] == "").all()
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
    assert selection.best_lags == selection.candidates[int(table["candidate"].iloc[0])]


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
