"""The benchmark's stages: shared fits, work units of all methods together, pruning, timings.

Every test writes its own small data (a cascaded-tanks file, a soft-neck log) and compares the
staged run with a plain reference: each method's candidates scored by
:func:`neckid.selection.lags.score_candidates`, the best refitted and run, one method at a time.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import MappingProxyType, SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from sklearn.base import BaseEstimator, clone
from threadpoolctl import threadpool_info, threadpool_limits

from neckid import IOData, Lags, LinearARX, methods
from neckid.experiments.benchmark import load_benchmark, run_benchmark, settings
from neckid.experiments.benchmark.plans import choose, selection_parts
from neckid.experiments.benchmark.settings import (
    BUILDS_ON,
    PNLSS_MAX_WORK,
    PNLSS_SAMPLES_PER_PARAMETER,
    SELECTION_FRACTION,
    candidates,
    pnlss_order,
    shared_fits,
)
from neckid.experiments.benchmark.shared import RecordingCache, SharedFits, fit_key
from neckid.experiments.benchmark.stages import final_unit, fit_unit, score_unit
from neckid.models.cache import ResultCache, use_caches
from neckid.models.pnlss.fitting import Layout
from neckid.models.polynomial.narx import PolynomialNARX
from neckid.selection.lags import free_run, score_candidates

#: Wall-time columns: the only ones a run on other workers may change.
WALL_TIMES = ["train_time_s", "simulate_time_s"]

#: Small lag sets for the written cascaded-tanks file, so that degree-3 polynomials fit fast.
SMALL_TANKS_GRID = (Lags.arx(1, 1, 1), Lags.arx(2, 1, 1))


@pytest.fixture
def tanks(tmp_path: Path, write_cascaded_tanks) -> Path:
    return write_cascaded_tanks(tmp_path / "data", np.random.default_rng(3))


@pytest.fixture
def small_tanks_grid(monkeypatch: pytest.MonkeyPatch) -> None:
    grids = dict(settings.LAG_GRIDS, cascaded_tanks=SMALL_TANKS_GRID)
    monkeypatch.setattr(settings, "LAG_GRIDS", MappingProxyType(grids))


def reference(data_dir: Path, method: str, benchmark: str) -> tuple[str, list[float]]:
    """One method the plain way: score_candidates on the split, argmin, refit, free runs."""
    bench = load_benchmark(benchmark, data_dir)
    options = candidates(method, benchmark, bench.train)
    chosen = options[0]
    if len(options) > 1:
        fit_part, check_part = bench.train.split(SELECTION_FRACTION)
        table = score_candidates(
            options, fit_part, check_part, criteria=("simulation",), n_initial=bench.n_initial
        ).table
        chosen = options[int(np.argmin(table["rmse_simulation"].to_numpy()))]
    model = clone(chosen[1]).fit(bench.train)
    errors = []
    for record in bench.tests.values():
        y, skip = free_run(model, record, bench.n_initial, diverged="keep")
        errors.append(float(np.sqrt(np.mean((record.y[skip:] - y[skip:]) ** 2))))
    return chosen[0], errors


# ---------------------------------------------------------------------------- the same results
@pytest.mark.parametrize("method", ["arx", "ss", "sm-parallel", "poly"])
def test_the_staged_run_equals_one_method_at_a_time(tanks, small_tanks_grid, method):
    report = run_benchmark(tanks, methods=[method, "arx"], errors="raise")
    row = report.table[report.table["method"] == method].iloc[0]
    settings_text, errors = reference(tanks, method, "cascaded_tanks")
    assert row["settings"] == settings_text
    assert row["rmse"] == pytest.approx(errors[0], rel=1e-12)


def test_the_table_is_the_same_on_one_worker_and_on_two(tanks, small_tanks_grid):
    kwargs = {"methods": ["arx", "ss", "sm", "sm-parallel"], "errors": "raise"}
    one = run_benchmark(tanks, n_jobs=1, **kwargs)
    two = run_benchmark(tanks, n_jobs=2, backend="threading", **kwargs)
    pd.testing.assert_frame_equal(
        one.table.drop(columns=WALL_TIMES), two.table.drop(columns=WALL_TIMES)
    )
    assert one.details == two.details
    assert len(two.timings["stages"]) >= 2  # selection, then the final fits


# ---------------------------------------------------------------------------- shared and pruned
def test_sm_on_the_polynomial_sits_on_the_lags_poly_chose(tanks, small_tanks_grid):
    report = run_benchmark(tanks, methods=["poly", "sm-parallel-poly"], errors="raise")
    methods_details = report.details["benchmarks"]["cascaded_tanks"]["methods"]
    chosen_lags = methods_details["poly"]["chosen"].split(", degree")[0]
    scores = methods_details["sm-parallel-poly"]["selection"]
    assert len(scores) == 8  # 2 SM regressors x 2 epsilons x 2 estimates, on one lag set
    assert all(s["settings"].startswith(chosen_lags + ", degree=3") for s in scores)
    assert BUILDS_ON["sm-parallel-poly"] == "poly"
    # The scale of its noise bounds is the error of that very polynomial fitted for poly.
    assert report.timings["shared"]["fits"] >= 1


def test_a_base_method_not_asked_for_runs_hidden(tanks, small_tanks_grid):
    report = run_benchmark(tanks, methods=["sm-parallel-poly"], errors="raise")
    assert set(report.table["method"]) == {"sm-parallel-poly"}
    timings = report.timings["benchmarks"]["cascaded_tanks"]["methods"]
    assert "poly (for sm-parallel-poly)" in timings
    assert timings["poly (for sm-parallel-poly)"]["n_candidates"] == len(SMALL_TANKS_GRID)


def test_each_polynomial_is_fitted_once_per_lags_and_data(tanks, small_tanks_grid, monkeypatch):
    # In one process (n_jobs=1) a counter sees every least-squares start of a polynomial fit:
    # poly's candidates on the split, its final fit, and nothing more for SM on the polynomial.
    fits: list[tuple[str, int]] = []
    original = PolynomialNARX._fit_regression

    def counted(self, x, y):
        fits.append((repr(self.lags), x.shape[0]))
        return original(self, x, y)

    monkeypatch.setattr(PolynomialNARX, "_fit_regression", counted)
    with use_caches(polynomial_fits=None):  # no process-wide cache: the run's sharing only
        run_benchmark(tanks, methods=["poly", "sm-parallel-poly"], errors="raise", n_jobs=1)
    assert len(fits) == len(set(fits)) == len(SMALL_TANKS_GRID) + 1


@pytest.mark.parametrize(
    ("method", "base"), [("sm-parallel-sindy", "sindy"), ("sm-parallel-koopman", "koopman")]
)
def test_sm_on_a_sparse_or_koopman_base_fits_the_base_once_per_lags_and_data(
    tanks, monkeypatch, method, base
):
    # Every candidate of SM on the sparse NARX or the Koopman model refits its base, whose own
    # selection runs inside the fit: the base's fit of each lag set on each part is done once.
    fits: list[tuple[str, int]] = []
    cls = type(methods()[base].make(Lags.arx(1, 1, 1)))
    original = cls._fit

    def counted(self, data):
        records = data if isinstance(data, list | tuple) else [data]
        fits.append((repr(self.lags), sum(r.n_samples for r in records)))
        return original(self, data)

    monkeypatch.setattr(cls, "_fit", counted)
    with use_caches(polynomial_fits=None):  # no process-wide cache: the run's sharing only
        report = run_benchmark(tanks, methods=[method], errors="raise", n_jobs=1)
    assert len(fits) == len(set(fits)) > 0
    assert report.table["method"].eq(method).any()


def test_shared_fits_are_declared_for_the_grids_that_read_them(tanks):
    train = load_benchmark("cascaded_tanks", tanks).train
    grid_input = settings.GridInput("cascaded_tanks", train)
    declared = shared_fits("sm-parallel-poly", grid_input)
    assert [type(e).__name__ for e, _ in declared] == ["PolynomialNARX"] * 3
    assert all(on_parts for _, on_parts in declared)
    for method, base in [
        ("sm-parallel-sindy", "SparseNARX"),
        ("sm-parallel-koopman", "KoopmanEDMD"),
    ]:
        declared = shared_fits(method, grid_input)
        assert [type(e).__name__ for e, _ in declared] == [base] * len(declared) != []
        assert all(on_parts for _, on_parts in declared)
    [(ss, on_parts)] = shared_fits("pnlss", grid_input)
    assert type(ss).__name__ == "SubspaceStateSpace" and not on_parts
    assert shared_fits("arx", grid_input) == []


# ---------------------------------------------------------------------------- the store
def test_shared_fits_keep_one_model_per_estimator_and_data():
    rng = np.random.default_rng(0)
    u = rng.normal(size=300)
    y = np.convolve(u, [0.0, 1.0, 0.4])[:300] + 0.01 * rng.normal(size=300)
    data = IOData(u, y, ts=1.0)
    shared = SharedFits()
    first = shared.fitted(LinearARX(Lags.arx(1, 2)), data)
    assert shared.fitted(LinearARX(Lags.arx(1, 2)), data) is first
    assert shared.fitted(LinearARX(Lags.arx(2, 2)), data) is not first
    assert shared.fitted(LinearARX(Lags.arx(1, 2)), data[:200]) is not first
    assert shared.reused["fits"] == 1
    one_step = shared.arx_scale(Lags.arx(1, 2), data)
    residual = data.y[2:] - first.predict(data).y[2:]
    assert one_step == pytest.approx(float(np.sqrt(np.mean(residual**2))), rel=1e-12)
    assert shared.arx_scale(Lags.arx(1, 2), data) == one_step
    assert shared.reused["arx_scales"] == 1
    assert fit_key(LinearARX(Lags.arx(1, 2)), data) != fit_key(
        LinearARX(Lags.arx(1, 2)), data[:200]
    )


def test_an_arx_scale_whose_free_run_is_not_finite_says_so():
    class Overflowing:  # an ARX whose free run overflowed (the store holds it as fitted)
        def simulate(self, record):
            return SimpleNamespace(y=np.full((record.n_samples, 1), np.inf), n_initial=1)

    data = IOData(np.arange(50.0), np.arange(50.0) ** 0.5, ts=1.0)
    shared = SharedFits()
    shared.add_fitted(methods()["arx"].make(Lags(outputs=[1])), data, Overflowing())
    with pytest.raises(ValueError, match=r"ARX with Lags\(outputs=\[1\], inputs=\[\]\) diverges"):
        shared.arx_scale(Lags(outputs=[1]), data, free_run=True)


def test_a_recording_cache_starts_from_the_known_states_and_records_the_new_ones():
    cache = RecordingCache([(b"k", {"coef_": 1})], max_entries=1)
    assert cache.get(b"k") == {"coef_": 1}
    cache.put(b"new", 2)
    assert cache.added == [(b"new", 2)]
    assert isinstance(cache, ResultCache) and len(cache) == 2


def test_units_report_their_errors_instead_of_raising():
    data = IOData(np.arange(5.0), np.arange(5.0), ts=1.0)
    outcome = fit_unit(LinearARX(Lags.arx(4, 4)), data)
    assert outcome.value is None and isinstance(outcome.error, ValueError)
    assert outcome.seconds >= 0.0


class _BlasProbe(BaseEstimator):
    """An estimator whose fit records how many threads the BLAS libraries may use."""

    def fit(self, data):
        self.blas_threads_ = [
            pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"
        ]
        return self


def test_units_run_with_one_blas_thread_wherever_they_run():
    data = IOData(np.arange(5.0), np.arange(5.0), ts=1.0)
    with threadpool_limits(limits=2, user_api="blas"):
        probe = fit_unit(_BlasProbe(), data).value
    assert probe.blas_threads_ and set(probe.blas_threads_) == {1}


def test_a_score_unit_gives_the_row_score_candidates_gives():
    rng = np.random.default_rng(2)
    u = rng.normal(size=400)
    y = np.zeros(400)
    for t in range(2, 400):
        y[t] = 0.6 * y[t - 1] + np.tanh(u[t - 1])
    data = IOData(u, y, ts=1.0)
    options = [(f"na={na}", LinearARX(Lags.arx(na, 2))) for na in (1, 2, 3)]
    fit_part, check_part = data.split(SELECTION_FRACTION)
    table = score_candidates(options, fit_part, check_part, criteria=("simulation",)).table
    rows = [
        score_unit(name, est, data, None, fraction=SELECTION_FRACTION, folds=None).value
        for name, est in options
    ]
    assert [r["rmse_simulation"] for r in rows] == table["rmse_simulation"].tolist()
    chosen, scores = choose(options, rows)
    assert chosen is options[int(table["rmse_simulation"].idxmin())]
    assert [s["holdout_rmse"] for s in scores] == table["rmse_simulation"].tolist()
    runs = [data[:150], data[150:280], data[280:]]
    assert [len(p) for p in selection_parts(runs)] == [2, 2, 2]
    final = final_unit(options[0][1], _bench(data), keep_model=True).value
    assert final_unit(options[0][1], _bench(data)).value.model is None
    [run] = final.tests
    simulated = final.model.simulate(data).y
    assert run.n_initial == final.model.max_lag_ == 2
    assert run.rmse == pytest.approx(
        float(np.sqrt(np.mean((simulated[2:] - y[2:, None]) ** 2))), rel=1e-12
    )


def _bench(data: IOData):
    from neckid.datasets.benchmarks import BenchmarkData

    return BenchmarkData(
        name="made", train=data, tests={"same": data}, n_initial=None, description="",
        citation="", source="", rmse_unit="",
    )  # fmt: skip


# ---------------------------------------------------------------------------- state models
def _pnlss_size(order: int, n_inputs: int) -> int:
    return sum(rows * columns for rows, columns in Layout(order, n_inputs, 1, 3, False).shapes())


def _pnlss_fits(order: int, n_samples: int, n_inputs: int) -> bool:
    size = _pnlss_size(order, n_inputs)
    return n_samples * size**2 <= PNLSS_MAX_WORK and n_samples >= PNLSS_SAMPLES_PER_PARAMETER * size


@pytest.mark.parametrize(
    ("ss_order", "n_samples", "n_inputs"),
    [(6, 40_960, 1), (8, 512, 1), (4, 3_605, 2), (2, 25_636, 3), (6, 65_062, 1)],
)
def test_pnlss_order_is_the_largest_under_the_budget(ss_order, n_samples, n_inputs):
    order = pnlss_order(ss_order, n_samples, n_inputs, 1)
    assert 1 <= order <= ss_order
    assert order == 1 or _pnlss_fits(order, n_samples, n_inputs)
    assert order == ss_order or not _pnlss_fits(order + 1, n_samples, n_inputs)


def test_state_models_are_one_candidate_each(tanks):
    train = load_benchmark("cascaded_tanks", tanks).train
    for name in ("ss", "pnlss"):
        [(text, estimator)] = candidates(name, "cascaded_tanks", train)
        assert type(estimator) is methods()[name].estimator_class()
        assert not hasattr(estimator, "order_")
    [(text, _)] = candidates("pnlss", "cascaded_tanks", train)
    assert text.startswith("order=") and "(ss order" in text
    assert settings.runs_on("greybox-neck", "softneck-payload")
    assert not settings.runs_on("greybox-neck", "cascaded_tanks")


def test_state_models_take_the_payload_across_runs():
    rng = np.random.default_rng(4)
    runs = []
    for payload in (0.0, 0.6, 0.2):
        u = rng.uniform(0, 1, size=(300, 2))
        runs.append(
            IOData(u, u[:, 0] + payload, ts=0.025, conditions={"payload": payload},
                   input_names=["motor_displacement", "motor_velocity"])
        )  # fmt: skip
    for name in ("ss", "greybox-neck"):
        [(text, estimator)] = candidates(name, "softneck-payload", runs, quick=True)
        assert list(estimator.get_params()["lags"].conditions) == ["payload"]
        assert text.endswith("conditions=['payload']")


# ---------------------------------------------------------------------------- the report
def test_timings_say_where_the_time_went_and_are_written(tanks, tmp_path):
    out = tmp_path / "out"
    report = run_benchmark(tanks, methods=["arx", "sm"], quick=True, output_dir=out)
    timings = report.timings
    assert timings["wall_time_s"] > 0 and timings["stages"]
    work = timings["benchmarks"]["cascaded_tanks"]
    assert set(work["methods"]) == {"arx", "sm"}
    for entry in work["methods"].values():
        assert {"grid_s", "selection_s", "final_fit_s", "simulate_s"} <= set(entry)
        assert all(math.isfinite(entry[k]) and entry[k] >= 0 for k in ("grid_s", "final_fit_s"))
    assert work["work_s"] >= sum(e["final_fit_s"] for e in work["methods"].values())
    written = json.loads((out / "benchmark.json").read_text())
    assert written["timings"]["benchmarks"]["cascaded_tanks"]["methods"].keys() == {"arx", "sm"}
    assert "timings" not in report.details  # details stay the same wherever the run ran


@pytest.mark.parametrize(
    ("method", "base"), [("sm-parallel-sindy", "sindy"), ("sm-parallel-koopman", "koopman")]
)
def test_a_base_with_conditions_is_taken_from_the_base_methods_scores(monkeypatch, method, base):
    # SM hands its base the logs with the conditions appended as inputs; the base's own
    # candidate was fitted on the logs as they came. Both are one fit, and the score is the
    # one a unit without the known states gives.
    rng = np.random.default_rng(0)
    runs = []
    for i in range(4):
        u = rng.normal(size=300)
        y = np.zeros(300)
        for t in range(2, 300):
            y[t] = 0.6 * y[t - 1] - 0.1 * y[t - 2] ** 2 + 0.5 * np.tanh(u[t - 1]) + 0.1 * i
        runs.append(IOData(u, y, ts=0.1, name=f"run{i}", conditions={"payload": 0.2 * i}))
    lags = Lags(outputs=[1, 2], inputs=[0, 1], conditions=["payload"])
    cls = type(methods()[base].make(lags))
    fits: list[int] = []
    original = cls._fit

    def counted(self, data):
        fits.append(1)
        return original(self, data)

    monkeypatch.setattr(cls, "_fit", counted)
    options = {"fraction": SELECTION_FRACTION, "folds": None}
    first = score_unit("base", methods()[base].make(lags), runs, None, **options)
    assert first.error is None and len(fits) == len(first.polynomial_fits) == len(runs)
    sm = methods()[method].make(lags, epsilon=0.1, progress=False)
    with use_caches(polynomial_fits=None):
        shared = score_unit("sm", sm, runs, None, **options, known=first.polynomial_fits)
        assert shared.error is None and len(fits) == len(runs)
        alone = score_unit("sm", sm, runs, None, **options)
    assert len(fits) == 2 * len(runs)
    timeless = [{k: v for k, v in o.value.items() if k != "fit_time_s"} for o in (shared, alone)]
    assert timeless[0] == timeless[1]
