"""Sweeps on a Dask cluster: the same results as on this machine, and clear errors without one.

The cluster tests start a ``LocalCluster`` of 2 worker processes (so every work unit is pickled
and runs in another interpreter, as on a real cluster) and are skipped when the ``dask`` extra is
not installed; the error tests run either way.
"""

from __future__ import annotations

import re
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from _synthetic import arx_system
from neckid import LinearARX
from neckid.cli import app
from neckid.experiments.benchmark import run_benchmark
from neckid.models.neural.narx import NeuralNARX
from neckid.selection.lags import lag_grid, score_candidates, select_lags
from neckid.utils.parallel import check_backend, run_jobs

SKIP_REASON = "the Dask tests need the distributed package: pip install neckid[dask]"

#: Columns that are wall times: the only ones a run elsewhere may change.
WALL_TIMES = ("fit_time_s", "score_time_s", "train_time_s", "simulate_time_s")


@pytest.fixture
def tanks_folder(write_cascaded_tanks):
    """``tanks_folder(root)``: a data folder holding only a small cascaded-tanks benchmark file."""
    return lambda root: write_cascaded_tanks(root, np.random.default_rng(3))


def without_wall_times(table: pd.DataFrame) -> pd.DataFrame:
    return table.drop(columns=[c for c in WALL_TIMES if c in table.columns])


def _plain(text: str) -> str:
    """CLI output without colour codes and line breaks (rich wraps to the terminal)."""
    return " ".join(re.sub(r"\x1b\[[0-9;]*m", "", text).split())


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    distributed = pytest.importorskip("distributed", reason=SKIP_REASON)
    # Processes, not threads: the work units are pickled to other interpreters, as on a cluster.
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as local:
        yield local


@pytest.fixture
def client(cluster: Any) -> Iterator[Any]:
    """A client of the cluster, current inside the test only (not the process-wide default)."""
    import distributed

    with distributed.Client(cluster, set_as_default=False) as dask_client, dask_client.as_current():
        yield dask_client


# ---------------------------------------------------------------------- the same results
def test_select_lags_on_dask_equals_the_local_run(client: Any) -> None:
    from distributed import get_task_stream

    data = arx_system(500, seed=1)
    runs = [data[:170], data[170:340], data[340:]]
    grid = lag_grid([1, 2], [1, 2], [2, 3])
    local = select_lags(runs, None, grid, LinearARX(), progress=False, n_jobs=1)
    with get_task_stream(client) as tasks:
        remote = select_lags(runs, None, grid, LinearARX(), progress=True, backend="dask")
    assert tasks.data, "no task ran on the cluster"
    assert {task["worker"] for task in tasks.data} <= set(client.scheduler_info()["workers"])
    pd.testing.assert_frame_equal(without_wall_times(remote.table), without_wall_times(local.table))
    assert remote.best_lags == local.best_lags
    assert remote.best(tolerance=0.5) == local.best(tolerance=0.5)
    assert remote.scheme == "leave-one-experiment-out"


def test_a_joblib_context_moves_a_seeded_sweep_to_dask(client: Any) -> None:
    from joblib import parallel_config

    data = arx_system(400, seed=2)
    options = [
        (f"seed {s}", NeuralNARX(lag, hidden_layer_sizes=(4,), max_iter=40, n_networks=1,
                                 random_state=s))
        for s in (0, 1)
        for lag in lag_grid([1, 2], [2], [3])
    ]  # fmt: skip
    local = score_candidates(options, data[:300], data[300:], n_jobs=1).table
    with parallel_config(backend="dask"):
        remote = score_candidates(options, data[:300], data[300:]).table
    pd.testing.assert_frame_equal(without_wall_times(remote), without_wall_times(local))
    # The seeds travel with the estimators: different seeds give different networks.
    assert local["fit_simulation"].nunique() > 1


def test_benchmark_on_dask_equals_the_local_run(client: Any, tmp_path: Path, tanks_folder) -> None:
    from distributed import get_task_stream

    root = tanks_folder(tmp_path / "data")
    kwargs: dict[str, Any] = {"methods": ["arx"], "benchmarks": ["cascaded_tanks"]}
    local = run_benchmark(root, errors="raise", **kwargs)
    with get_task_stream(client) as tasks:
        remote = run_benchmark(root, errors="raise", backend="dask", **kwargs)
    assert tasks.data, "no task ran on the cluster"
    # Three lag candidates are ranked (not a quick run), so the selection did run on the cluster.
    assert len(local.details["benchmarks"]["cascaded_tanks"]["methods"]["arx"]["selection"]) == 3
    pd.testing.assert_frame_equal(without_wall_times(remote.table), without_wall_times(local.table))
    assert remote.details == local.details


def test_cli_runs_the_benchmark_on_a_scheduler(cluster: Any, tmp_path: Path, tanks_folder) -> None:
    import distributed

    root = tanks_folder(tmp_path / "data")
    common = ["benchmark", "--data-dir", str(root), "--methods", "arx", "--only", "cascaded_tanks"]
    runner = CliRunner()
    local = runner.invoke(app, [*common, "--out", str(tmp_path / "local")])
    # A watcher only (not current, not the default): the command must connect its own client.
    with (
        distributed.Client(cluster, set_as_default=False) as watcher,
        distributed.get_task_stream(watcher) as tasks,
    ):
        remote = runner.invoke(
            app,
            [*common, "--out", str(tmp_path / "remote"), "--scheduler", cluster.scheduler_address],
        )
    assert local.exit_code == 0, local.output
    assert remote.exit_code == 0, remote.output
    assert tasks.data, "no task ran on the cluster"
    tables = [pd.read_csv(tmp_path / name / "benchmark.csv") for name in ("local", "remote")]
    pd.testing.assert_frame_equal(*(without_wall_times(t) for t in tables))


# ---------------------------------------------------------------------- clear errors
def test_dask_without_distributed_says_how_to_install(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    data = arx_system(300, seed=0)
    with pytest.raises(ImportError, match=re.escape("pip install neckid[dask]")):
        select_lags(data[:200], data[200:], lag_grid(1, 1), LinearARX(), backend="dask")
    with pytest.raises(ImportError, match=re.escape("pip install neckid[dask]")):
        run_benchmark(tmp_path, backend="dask")


def test_dask_without_a_client_says_to_create_one() -> None:
    pytest.importorskip("distributed", reason=SKIP_REASON)
    data = arx_system(300, seed=0)
    with pytest.raises(ValueError, match=r"no(ne)?.*create one first.*distributed\.Client\("):
        select_lags(data[:200], data[200:], lag_grid(1, 1), LinearARX(), backend="dask")


@pytest.mark.parametrize(
    ("backend", "error", "match"),
    [
        ("spark", ValueError, r"backend must be one of \[.*'dask'.*\].*; got 'spark'"),
        (3, TypeError, r"backend must be a joblib backend name \(str\) or None; got 3"),
    ],
)
def test_bad_backends(backend: Any, error: type[Exception], match: str) -> None:
    with pytest.raises(error, match=match):
        check_backend(backend)
    data = arx_system(300, seed=0)
    with pytest.raises(error, match=match):
        score_candidates([("arx", LinearARX(lag_grid(1, 1)[0]))], data[:200], data[200:],
                         backend=backend)  # fmt: skip


def test_results_come_back_in_the_order_given() -> None:
    from joblib import delayed

    # The first units sleep longest, so they finish last on 2 threads.
    jobs = (delayed(lambda k: (time.sleep(0.02 * (4 - k)), k)[1])(k) for k in range(5))
    assert run_jobs(jobs, total=5, n_jobs=2, backend="threading", progress=True) == [0, 1, 2, 3, 4]


def test_cli_scheduler_without_distributed(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, tanks_folder
) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)
    root = tanks_folder(tmp_path / "data")
    result = CliRunner().invoke(
        app,
        ["benchmark", "--data-dir", str(root), "--methods", "arx", "--only", "cascaded_tanks",
         "--out", str(tmp_path / "out"), "--scheduler", "tcp://127.0.0.1:8786"],
    )  # fmt: skip
    assert result.exit_code == 2
    text = _plain(result.output)
    assert "--scheduler needs the distributed package" in text
    assert "pip install neckid[dask]" in text
    assert "Traceback" not in text
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:1", "not-an-address"])
def test_cli_scheduler_unreachable_is_one_line(address: str, tmp_path: Path, tanks_folder) -> None:
    dask = pytest.importorskip("dask", reason=SKIP_REASON)
    pytest.importorskip("distributed", reason=SKIP_REASON)
    root = tanks_folder(tmp_path / "data")
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        result = CliRunner().invoke(
            app,
            ["benchmark", "--data-dir", str(root), "--methods", "arx", "--only",
             "cascaded_tanks", "--out", str(tmp_path / "out"), "--scheduler", address],
        )  # fmt: skip
    assert result.exit_code == 2, result.output
    text = _plain(result.output)
    assert f"cannot connect to the Dask scheduler at '{address}'" in text
    assert "Traceback" not in text
    assert not (tmp_path / "out").exists()
