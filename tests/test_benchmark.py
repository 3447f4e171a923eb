from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from neckid import IOData, Lags, LinearARX
from neckid.experiments.benchmark import (
    PUBLISHED,
    SOFTNECK_TRAINING_LOG,
    _free_run,
    run_benchmark,
    softneck_protocol,
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
def data_dir(tmp_path: Path) -> Path:
    rng = np.random.default_rng(3)
    root = tmp_path / "data"
    (root / "softneck" / "stair").mkdir(parents=True)
    (root / "softneck" / "step").mkdir()
    np.savetxt(
        root / "softneck" / SOFTNECK_TRAINING_LOG, neck_log(rng, 900, 1.1, 0.0), delimiter=", "
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
    tanks = root / "benchmarks" / "cascaded_tanks"
    tanks.mkdir(parents=True)
    u = rng.uniform(2, 8, size=(300, 2))
    y = np.zeros((300, 2))
    for t in range(1, 300):
        y[t] = 0.9 * y[t - 1] + 0.1 * np.sqrt(u[t - 1])
    frame = pd.DataFrame(
        {"uEst": u[:, 0], "uVal": u[:, 1], "yEst": y[:, 0], "yVal": y[:, 1], "Ts": np.nan}
    )
    frame.loc[0, "Ts"] = 4.0
    frame.to_csv(tanks / "dataBenchmark.csv", index=False)
    return root


def test_quick_benchmark_on_written_data(data_dir, tmp_path):
    out = tmp_path / "out"
    report = run_benchmark(
        data_dir, methods=["arx", "sm", "sm_parallel"], quick=True, errors="raise", output_dir=out
    )
    table = report.table
    assert set(table["benchmark"]) == {"softneck", "cascaded_tanks"}
    assert set(report.details["missing"]) == {"silverbox", "bouc_wen", "robot_arm"}
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
    assert "sm_minus_arx" in report.details["benchmarks"]["softneck"]
    assert "sm_parallel_minus_arx" in report.details["benchmarks"]["softneck"]
    assert set(report.published["benchmark"]) == {"cascaded_tanks"}
    written = {p.name for p in out.iterdir()}
    assert written == {"benchmark.csv", "published.csv", "benchmark.json"}
    content = json.loads((out / "benchmark.json").read_text())
    assert len(content["table"]) == len(table)
    assert report.rich_table().row_count == len(table)


def test_failures_are_recorded_or_raised(data_dir, monkeypatch):
    import neckid.experiments.benchmark as bench

    def broken(*args, **kwargs):
        raise RuntimeError("model exploded")

    monkeypatch.setattr(bench, "_select", broken)
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
    simulated, skip = _free_run(model, data, n_initial=50)
    assert skip == 50
    np.testing.assert_allclose(simulated[50:], y[50:, None], atol=1e-8)
    simulated, skip = _free_run(model, data, n_initial=None)
    assert skip == 2


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


def test_published_figures_are_those_of_the_source():
    assert PUBLISHED["silverbox"]["multisine"]["LSTM"] == 1.50
    assert PUBLISHED["cascaded_tanks"]["validation"]["GP-NARX"] == 0.622
