from __future__ import annotations

import itertools
import json
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from neckid import IOData, Lags, LinearARX, methods
from neckid.cli import app
from neckid.experiments.benchmark import (
    BENCHMARK_METHODS,
    BENCHMARKS,
    CROSS_RUN_BENCHMARKS,
    LAG_GRIDS,
    SOFTNECK_STAIR_EDGES,
    SOFTNECK_TRAINING_LOG,
    candidates,
    load_benchmark,
    published_frame,
    published_table,
    published_units,
    run_benchmark,
    softneck_protocol,
)
from neckid.registry import DEPRECATED_NAMES
from neckid.selection.lags import free_run, score_candidates, select_lags

#: The shared data folder, beside the repository (``../shared/data`` from its root).
SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"

needs_softneck = pytest.mark.skipif(
    not (SHARED_DATA / "softneck").is_dir(),
    reason=f"the real soft-neck logs are not at {SHARED_DATA / 'softneck'}",
)
needs_tanks = pytest.mark.skipif(
    not (SHARED_DATA / "benchmarks" / "cascaded_tanks").is_dir(),
    reason=f"the cascaded-tanks benchmark file is not at {SHARED_DATA / 'benchmarks'}",
)


def neck_log(rng: np.random.Generator, n: int, offset: float, t0: float) -> np.ndarray:
    """A 7-column soft-neck log of a linear neck: inclination follows the motor displacement."""
    levels = np.repeat(rng.uniform(0.5, 4.0, size=n // 50 + 1), 50)[:n]
    levels[:50] = 0.0  # every log starts with the neck at rest
    position = offset + levels + 0.05 * rng.normal(size=n) * (levels > 0)
    velocity = np.gradient(position, 0.025)
    incl = np.zeros(n)
    for t in range(1, n):
        incl[t] = 0.8 * incl[t - 1] + 1.5 * (position[t - 1] - offset)
    raw = incl + 0.01 * rng.normal(size=n)
    time = t0 + 0.025 * np.arange(n)
    return np.column_stack([time, incl, np.zeros(n), position, raw, velocity, velocity])


@pytest.fixture
def data_dir(tmp_path: Path, write_cascaded_tanks) -> Path:
    rng = np.random.default_rng(3)
    root = tmp_path / "data"
    (root / "softneck" / "stair").mkdir(parents=True)
    (root / "softneck" / "step").mkdir()
    np.savetxt(
        root / "softneck" / SOFTNECK_TRAINING_LOG, neck_log(rng, 1300, 1.1, 0.0), delimiter=", "
    )
    np.savetxt(
        root / "softneck" / "stair" / "fra200response.csv",
        neck_log(rng, 400, 0.7, 20.0),
        delimiter=", ",
    )
    six = np.delete(neck_log(rng, 200, 1.4, 20.0), 2, axis=1)  # the 6-column layout
    np.savetxt(root / "softneck" / "step" / "int000stepresponse.csv", six, delimiter=", ")
    three = neck_log(rng, 100, 1.0, 20.0)[:, :3]  # no raw inclination: not a validation log
    np.savetxt(root / "softneck" / "step" / "200stepresponse.csv", three, delimiter=", ")
    return write_cascaded_tanks(root, rng)


# ---------------------------------------------------------------------------- a quick run
def test_quick_benchmark_on_written_data(data_dir, tmp_path):
    out = tmp_path / "out"
    report = run_benchmark(
        data_dir, methods=["arx", "sm", "sm-parallel"], quick=True, errors="raise", output_dir=out
    )
    table = report.table
    assert set(table["benchmark"]) == {"softneck", "cascaded_tanks"}
    assert set(report.details["missing"]) == {
        "silverbox",
        "bouc_wen",
        "robot_arm",
        *CROSS_RUN_BENCHMARKS,  # the folder lacks their staircases
    }
    assert set(table["method"]) == {"arx", "sm", "sm-parallel"}  # the registry's names
    neck = table[table["benchmark"] == "softneck"]
    # Two validation logs with a raw inclination (the 3-column log is left out), plus the mean.
    assert set(neck["test"]) == {
        "stair/fra200response.csv",
        "step/int000stepresponse.csv",
        "mean",
    }
    assert np.isfinite(table["rmse"]).all() and np.isfinite(table["fit_percent"]).all()
    # The data are a noiseless-ish linear neck: ARX with the motor displacement fits them well.
    arx = neck[(neck["method"] == "arx") & (neck["test"] != "mean")]
    assert (arx["fit_percent"] > 90).all()
    assert (table["train_time_s"] >= 0).all()
    margins = report.details["benchmarks"]["softneck"]
    assert set(margins["sm-parallel_minus_arx"]) == {
        "stair/fra200response.csv",
        "step/int000stepresponse.csv",
    }
    assert "sm_minus_arx" in margins
    assert set(report.published["benchmark"]) == {"cascaded_tanks"}
    written = {p.name for p in out.iterdir()}
    assert written == {"benchmark.csv", "published.csv", "benchmark.json"}
    content = json.loads((out / "benchmark.json").read_text())
    assert len(content["table"]) == len(table)
    assert content["details"]["settings"]["methods"] == ["arx", "sm", "sm-parallel"]
    assert report.rich_table().row_count == len(table)


def test_scheduled_runs_on_the_soft_neck_only(data_dir):
    # The synthetic training log is 32.5 s long: its stairs at 0-20 and 20-30 s give two
    # operating points (30-32.5 s is under half a stair: left out), enough for the lines.
    report = run_benchmark(data_dir, methods="scheduled", quick=True)
    assert set(report.table["benchmark"]) == {"softneck"}
    assert report.table["settings"].str.contains("window=50").all()


def test_cross_run_protocols_train_on_several_runs_with_the_payload(tmp_path):
    """Both cross-run protocols on written staircases: one model per method over several runs."""
    rng = np.random.default_rng(5)
    stair = tmp_path / "softneck" / "stair"
    stair.mkdir(parents=True)
    for controller in ("ada", "fra", "int"):
        for grams in ("000", "200", "400", "600"):
            log = neck_log(rng, 600, 1.0 + int(grams) / 1000, 0.0)
            np.savetxt(stair / f"{controller}{grams}response.csv", log, delimiter=", ")
    report = run_benchmark(
        tmp_path, methods=["arx", "sm-parallel"], benchmarks=sorted(CROSS_RUN_BENCHMARKS),
        quick=True, errors="raise",
    )  # fmt: skip
    table = report.table
    payload = table[table["benchmark"] == "softneck-payload"]
    assert set(payload["test"]) == {
        "stair/ada200response.csv",
        "stair/ada400response.csv",
        "stair/fra200response.csv",
        "mean",
    }  # quick: 3 test logs
    controller = table[table["benchmark"] == "softneck-controller"]
    assert set(controller["test"]) - {"mean"} <= {f"stair/int{g}response.csv" for g in
                                                  ("000", "200", "400", "600")}  # fmt: skip
    assert table["settings"].str.contains("conditions=['payload']", regex=False).all()
    assert np.isfinite(table["fit_percent"]).all()
    assert (table[table["method"] == "arx"]["fit_percent"] > 90).all()
    assert "sm-parallel_minus_arx" in report.details["benchmarks"]["softneck-payload"]


@pytest.mark.parametrize(("old", "new"), sorted(DEPRECATED_NAMES.items()))
def test_deprecated_method_names_warn_and_map(data_dir, old, new):
    with pytest.warns(FutureWarning, match=f"{old!r} is deprecated.*{new!r}"):
        report = run_benchmark(data_dir, methods=[old], benchmarks=["cascaded_tanks"], quick=True)
    assert set(report.table["method"]) == {new}
    assert report.details["settings"]["methods"] == [new]


def test_failures_are_recorded_or_raised(data_dir, monkeypatch):
    def broken(self, data):
        raise RuntimeError("model exploded")

    monkeypatch.setattr(LinearARX, "fit", broken)
    report = run_benchmark(data_dir, methods=["arx"], benchmarks=["cascaded_tanks"], quick=True)
    assert report.table["note"].str.contains("model exploded").all()
    assert report.table["rmse"].isna().all()
    with pytest.raises(RuntimeError, match="model exploded"):
        run_benchmark(
            data_dir, methods=["arx"], benchmarks=["cascaded_tanks"], quick=True, errors="raise"
        )


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"methods": ["lstm"]}, ValueError, r"methods must be among .*\['lstm'\]"),
        ({"methods": ["rls"]}, ValueError, r"methods must be among .*\['rls'\]"),
        ({"benchmarks": ["wiener"]}, ValueError, r"benchmarks must be among .*\['wiener'\]"),
        ({"errors": "ignore"}, ValueError, "errors must be"),
    ],
)
def test_bad_arguments(data_dir, kwargs, error, match):
    with pytest.raises(error, match=match):
        run_benchmark(data_dir, **kwargs)


def test_missing_data_dir(tmp_path):
    with pytest.raises(FileNotFoundError, match="not a folder"):
        run_benchmark(tmp_path / "nowhere")
    with pytest.raises(FileNotFoundError, match="nothing to run: none of the data sets"):
        run_benchmark(tmp_path)  # a folder, but empty


# ---------------------------------------------------------------------------- the split
def test_benchmark_methods_are_registry_names():
    assert set(BENCHMARK_METHODS) <= set(methods())
    assert list(BENCHMARK_METHODS) == [m for m in methods() if m in BENCHMARK_METHODS]
    assert set(LAG_GRIDS) | CROSS_RUN_BENCHMARKS == set(BENCHMARKS)


def test_candidates_are_made_by_the_registry(data_dir):
    train = load_benchmark("softneck", data_dir).train
    for name in BENCHMARK_METHODS:
        method = methods()[name]
        options = candidates(name, "softneck", train)
        assert options, name
        for settings, estimator in options:
            assert isinstance(settings, str) and settings
            assert type(estimator) is method.estimator_class()
            params = estimator.get_params(deep=False)
            assert all(params[k] == v for k, v in method.defaults.items()), name
            assert not hasattr(estimator, "max_lag_")  # unfitted
    sm_linear = candidates("sm-linear", "softneck", train)
    assert len(sm_linear) == 5 * 3 * 3  # lags x epsilon x input_weight
    assert len(candidates("sm", "softneck", train, quick=True)) == 1
    with pytest.raises(ValueError, match=r"method must be one of .*'rls'"):
        candidates("rls", "softneck", train)


def test_published_json_is_package_data_and_matches_units():
    text = resources.files("neckid.experiments.benchmark").joinpath("published.json").read_text()
    raw = json.loads(text)
    assert set(raw) == {"cascaded_tanks", "silverbox", "bouc_wen"}
    assert published_units() == {"cascaded_tanks": "V", "silverbox": "mV", "bouc_wen": "m"}
    table = published_table()
    assert table["silverbox"]["multisine"]["LSTM"] == 1.50
    assert table["cascaded_tanks"]["validation"]["GP-NARX"] == 0.622
    assert table["bouc_wen"]["multisine"]["dynoNet"] == 4.52e-5
    frame = published_frame()
    n_figures = sum(len(m) for tests in table.values() for m in tests.values())
    assert len(frame) == n_figures == 22
    for name, unit in published_units().items():
        assert (frame.loc[frame["benchmark"] == name, "rmse_unit"] == unit).all()
        assert frame.loc[frame["benchmark"] == name, "source"].str.len().gt(0).all()
    assert published_frame(["softneck", "robot_arm"]).empty


@needs_tanks
def test_published_units_are_those_of_the_loaders():
    for name, unit in published_units().items():
        bench = load_benchmark(name, SHARED_DATA)
        if bench is None:  # pragma: no cover - a partial copy of the shared data
            pytest.skip(f"{name} is not under {SHARED_DATA}")
        assert bench.rmse_unit == unit


# ---------------------------------------------------------------------------- evaluation
def test_protocol_initial_samples_are_the_last_before_evaluation():
    # A noiseless ARX system: with the protocol's 50 initial samples the free run starts from the
    # measured outputs just before sample 50, so it is exact from there on.
    rng = np.random.default_rng(0)
    u = rng.normal(size=400)
    y = np.zeros(400)
    for t in range(2, 400):
        y[t] = 1.2 * y[t - 1] - 0.5 * y[t - 2] + u[t - 1]
    data = IOData(u, y, ts=1.0)
    model = LinearARX(Lags.arx(2, 1, 1), fit_intercept=False).fit(data)
    simulated, skip = free_run(model, data, n_initial=50)
    assert skip == 50
    np.testing.assert_array_equal(simulated[:48], y[:48, None])  # measured before the start
    np.testing.assert_allclose(simulated[50:], y[50:, None], atol=1e-8)
    simulated, skip = free_run(model, data, n_initial=None)
    assert skip == model.max_lag_ == 2


def test_free_run_raises_or_keeps_a_divergence():
    # y(t) = 1.5 y(t-1) exactly: the identified pole is 1.5 and a long free run overflows.
    n = 100
    model = LinearARX(Lags(outputs=[1]), fit_intercept=False).fit(
        IOData(np.zeros(n), 1.5 ** np.arange(n), ts=1.0)
    )
    record = IOData(np.zeros(3000), np.ones(3000), ts=1.0)
    with pytest.raises(ValueError, match="diverged"), np.errstate(all="ignore"):
        free_run(model, record)
    with np.errstate(all="ignore"):
        y, skip = free_run(model, record, n_initial=10, diverged="keep")
    assert skip == 10 and np.isfinite(y[:100]).all() and not np.isfinite(y[-1]).all()
    with pytest.raises(ValueError, match="diverged must be 'raise' or 'keep'; got 'ignore'"):
        free_run(model, record, diverged="ignore")


def test_free_run_needs_a_fitted_model():
    with pytest.raises(ValueError, match="not fitted"):
        free_run(LinearARX(Lags.arx(1, 1, 1)), IOData(np.zeros(10), np.zeros(10), ts=1.0))


def test_select_lags_and_score_candidates_agree():
    # select_lags is score_candidates over clones with the lags set: the same fits, row by row.
    rng = np.random.default_rng(1)
    u = rng.normal(size=500)
    y = np.zeros(500)
    for t in range(2, 500):
        y[t] = 0.7 * y[t - 1] + np.tanh(u[t - 2])
    data = IOData(u, y, ts=0.02)
    grid = [Lags.arx(na, nb, d) for na, nb, d in itertools.product([1, 2], [1, 2], [1, 2])]
    selection = select_lags(data[:350], data[350:], grid, "arx", progress=False)
    scores = score_candidates(
        [(repr(lags), methods()["arx"].make(lags)) for lags in grid], data[:350], data[350:]
    ).table
    by_candidate = selection.table.set_index("candidate").sort_index()
    for kind in ("prediction", "simulation"):
        np.testing.assert_array_equal(by_candidate[f"fit_{kind}"], scores[f"fit_{kind}"])
    assert selection.best() == grid[int(scores["fit_simulation"].idxmax())]
    assert (scores["rmse_simulation"] > 0).all() and (scores["error"] == "").all()


def test_score_candidates_marks_a_diverging_free_run():
    rng = np.random.default_rng(2)
    u = rng.normal(size=300)
    y = np.cumsum(u) * 0.1
    data = IOData(u, y, ts=1.0)
    unstable = LinearARX(Lags.arx(1, 1, 1))
    table = score_candidates(
        [("stable", LinearARX(Lags.arx(2, 2, 1))), ("x", unstable)], data, data
    ).table
    assert list(table["name"]) == ["stable", "x"]
    assert not hasattr(unstable, "max_lag_")  # the estimators given are not fitted
    with pytest.raises(TypeError, match=r"candidates\[0\] must be a \(name, estimator\) pair"):
        score_candidates([LinearARX()], data, data)
    with pytest.raises(ValueError, match="criteria must hold"):
        score_candidates([("a", LinearARX())], data, data, criteria=["one-step"])


def test_select_lags_takes_a_registry_name():
    rng = np.random.default_rng(0)
    u = rng.normal(size=300)
    y = np.zeros(300)
    for t in range(1, 300):
        y[t] = 0.5 * y[t - 1] + u[t - 1]
    data = IOData(u, y, ts=1.0)
    result = select_lags(data[:200], data[200:], [Lags.arx(1, 1, 1)], "arx", progress=False)
    assert result.best_lags == Lags.arx(1, 1, 1)
    with pytest.raises(ValueError, match="method must be one of"):
        select_lags(data[:200], data[200:], [Lags.arx(1, 1, 1)], "lstm", progress=False)


# ---------------------------------------------------------------------------- the soft neck
def test_softneck_protocol_needs_the_raw_inclination():
    log = IOData(
        u=np.ones((5, 1)),
        y=np.arange(5.0),
        ts=0.025,
        input_names=["motor_position"],
        output_names=["inclination_filtered"],
    )
    with pytest.raises(KeyError, match="motor_velocity"):
        softneck_protocol(log)


@needs_softneck
def test_scheduled_candidate_is_one_point_per_stair():
    # The scheduled candidate fits from the training log itself; it must find the operating
    # points the stairs give when identified one by one (the benchmark's former ScheduledFromStairs).
    from neckid.loops.operating_points import operating_points_from_logs
    from neckid.models.scheduled.model import GainScheduledModel

    train = load_benchmark("softneck", SHARED_DATA).train
    [(_, estimator)] = candidates("scheduled", "softneck", train)
    model = estimator.fit(train)
    stairs = [
        train.time_slice(train.t0 + a, train.t0 + b)
        for a, b in itertools.pairwise(SOFTNECK_STAIR_EDGES)
        if train.t0 + a < train.time[-1]
    ]
    points = operating_points_from_logs(
        stairs,
        input="motor_displacement",
        output="inclination",
        skip=40,
        window=100,
        form="position",
    ).table
    assert len(points) == len(model.inclinations_) == 8
    np.testing.assert_allclose(model.inclinations_, points["inclination"], rtol=1e-12)
    np.testing.assert_allclose(model.gains_, points["gain"], rtol=1e-12)
    np.testing.assert_allclose(model.poles_, points["pole"], rtol=1e-12)
    reference = GainScheduledModel.from_points(
        points["inclination"], points["gain"], points["pole"], ts=train.ts, form="position"
    )
    np.testing.assert_allclose(model.gain_coefficients_, reference.gain_coefficients_, rtol=1e-12)
    np.testing.assert_allclose(model.pole_coefficients_, reference.pole_coefficients_, rtol=1e-12)


@needs_tanks
def test_arx_on_cascaded_tanks_matches_the_documented_figure():
    # docs/benchmarks.md: linear ARX 0.644 V on the validation record (least squares: no
    # randomness; the lags are chosen on the training record by the benchmark's own rule).
    report = run_benchmark(SHARED_DATA, methods=["arx"], benchmarks=["cascaded_tanks"])
    [row] = report.table.to_dict(orient="records")
    assert row["rmse"] == pytest.approx(0.644, abs=5e-4)
    assert row["settings"] == "lags=Lags(outputs=[1, 2, 3, 4], inputs=[1, 2, 3, 4])"


# ---------------------------------------------------------------------------- the command line
def test_cli_help_lists_every_benchmark_method():
    help_text = CliRunner().invoke(app, ["benchmark", "--help"], terminal_width=200).output
    missing = [name for name in BENCHMARK_METHODS if name not in help_text]
    assert missing == []


def test_cli_maps_deprecated_names(data_dir, tmp_path):
    runner = CliRunner()
    result = runner.invoke(
        app,
        ["benchmark", "--data-dir", str(data_dir), "--methods", "neural", "--only",
         "cascaded_tanks", "--quick", "--out", str(tmp_path / "out")],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "deprecated" in result.output and "'nn'" in result.output
    table = pd.read_csv(tmp_path / "out" / "benchmark.csv")
    assert set(table["method"]) == {"nn"}


def test_the_default_methods_leave_out_only_the_opt_in_ones():
    from neckid.experiments.benchmark.runner import _method_names
    from neckid.experiments.benchmark.settings import (
        DEFAULT_METHODS,
        OPT_IN_METHODS,
        PEER_METHODS,
    )

    assert set(DEFAULT_METHODS) == set(BENCHMARK_METHODS) - OPT_IN_METHODS
    assert {"sm-parallel-poly", "poly"} <= set(_method_names(None))
    assert not set(PEER_METHODS) & set(_method_names(None))  # the peer only when asked
    assert _method_names(["sm-parallel-poly"]) == ["sm-parallel-poly"]


# ---------------------------------------------------------------------------- the peer
def test_a_peer_that_is_not_installed_gives_rows_that_say_so(data_dir, monkeypatch):
    from neckid.experiments.benchmark import peers

    real = peers.importlib.util.find_spec
    monkeypatch.setattr(
        peers.importlib.util, "find_spec", lambda name: None if name == "sysidentpy" else real(name)
    )
    report = run_benchmark(
        data_dir, methods=["arx", "sysidentpy-frols"], quick=True, errors="raise"
    )
    table = report.table
    peer = table[table["method"] == "sysidentpy-frols"]
    # The public data set only (the soft neck has two inputs), one row per test record.
    assert list(peer["benchmark"]) == ["cascaded_tanks"]
    assert peer["note"].iloc[0] == (
        'skipped: SysIdentPy is not installed (pip install "neckid[peers]")'
    )
    assert peer["rmse"].isna().all()
    assert report.details["benchmarks"]["cascaded_tanks"]["methods"]["sysidentpy-frols"] == {
        "skipped": peer["note"].iloc[0]
    }
    assert np.isfinite(table[table["method"] == "arx"]["rmse"]).all()
    # The terminal table shows the note as it is (rich markup would eat "[peers]").
    from rich.console import Console

    console = Console(width=250, record=True)
    console.print(report.rich_table())
    assert 'pip install "neckid[peers]"' in console.export_text()
    with pytest.raises(ImportError, match="SysIdentPy is not installed"):
        peers.FrolsPeer(Lags.arx(1, 1)).fit(IOData(np.arange(9.0), np.arange(9.0), ts=1.0))


def test_a_peer_that_does_not_import_says_why(monkeypatch):
    from neckid.experiments.benchmark import peers

    def broken(name):
        raise ImportError("numpy.core.multiarray failed to import")

    monkeypatch.setattr(peers.importlib.util, "find_spec", lambda name: object())
    monkeypatch.setattr(peers.importlib, "import_module", broken)
    assert peers.peer_unavailable("sysidentpy-frols") == (
        "skipped: SysIdentPy is installed but does not import: ImportError: numpy.core.multiarray"
        " failed to import"
    )
    with pytest.raises(ValueError, match="peer must be one of"):
        peers.peer_unavailable("matlab")


def test_the_peer_takes_single_input_single_output_data_only():
    from neckid.experiments.benchmark.peers import FrolsPeer

    two_inputs = IOData(np.ones((20, 2)), np.arange(20.0), ts=1.0)
    with pytest.raises(ValueError, match="single-input single-output data; the data have 2 inputs"):
        FrolsPeer(Lags.arx(1, 1)).fit(two_inputs)
    with pytest.raises(ValueError, match="FROLS peer fits one training record; got 2"):
        FrolsPeer(Lags.arx(1, 1)).fit([two_inputs, two_inputs])


def test_the_peer_identifies_a_polynomial_narx_with_an_input_at_lag_zero():
    pytest.importorskip(
        "sysidentpy", reason='the peer needs SysIdentPy (pip install "neckid[peers]")'
    )
    from neckid.experiments.benchmark.peers import FrolsPeer

    def system(u: np.ndarray) -> np.ndarray:
        y = np.zeros(u.size)
        for t in range(1, u.size):
            y[t] = 0.6 * y[t - 1] + 0.8 * u[t] - 0.3 * u[t - 1] + 0.2 * y[t - 1] * u[t - 1] ** 2
        return y

    rng = np.random.default_rng(0)
    u_train, u_test = rng.uniform(-1, 1, 2000), rng.uniform(-1, 1, 500)
    peer = FrolsPeer(Lags(outputs=[1], inputs=[0, 1]), n_info_values=10)
    peer.fit(IOData(u_train, system(u_train), ts=1.0))
    test = IOData(u_test, system(u_test), ts=1.0)
    simulated = peer.simulate(test).y[:, 0]
    # The input at lag 0 reaches SysIdentPy as its x(t-1): the free run is the system's.
    assert peer.max_lag_ == 2
    np.testing.assert_allclose(simulated[2:], test.y[2:, 0], atol=1e-8)
