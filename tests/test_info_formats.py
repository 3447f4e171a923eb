"""``neckid info`` reads every format identify reads, and says what it found in each."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.io
from typer.testing import CliRunner

from neckid.cli import app

runner = CliRunner()


def _frame() -> pd.DataFrame:
    t = np.arange(100) * 0.02
    t[50] = t[49]  # one repeated time stamp, so one gap of two periods after it
    return pd.DataFrame({"time": t, "cmd": np.sin(t), "incl": 2.0 + np.cos(t)})


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".mat"])
def test_info_describes_every_format(tmp_path: Path, suffix: str) -> None:
    frame, path = _frame(), tmp_path / f"log{suffix}"
    if suffix == ".csv":
        frame.to_csv(path, index=False)
    elif suffix == ".parquet":
        pytest.importorskip("pyarrow", reason="Parquet needs the parquet extra (pyarrow)")
        frame.to_parquet(path)
    else:
        scipy.io.savemat(path, {**{k: frame[k].to_numpy() for k in frame}, "notes": "bench 2"})
    result = runner.invoke(app, ["info", str(path), "--json"])
    assert result.exit_code == 0, result.output
    described = json.loads(result.output)
    assert described["samples"] == 100 and described["repeated_stamps"] == 1
    assert described["gaps"] == 1
    assert set(described["channels"]) == {"cmd", "incl"}
    assert described["channels"]["incl"]["min"] == pytest.approx(2.0 + np.cos(1.98))
    if suffix == ".mat":
        assert described["skipped"] == ["notes (text)"]


def test_info_on_a_parquet_log_with_datetime_stamps(tmp_path: Path) -> None:
    pytest.importorskip("pyarrow", reason="Parquet needs the parquet extra (pyarrow)")
    frame = _frame()
    frame["time"] = pd.Timestamp("2026-01-01") + pd.to_timedelta(np.arange(100) * 0.02, unit="s")
    frame.to_parquet(tmp_path / "dated.parquet")
    result = runner.invoke(app, ["info", str(tmp_path / "dated.parquet"), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["ts_s"] == pytest.approx(0.02)


def test_info_on_a_damaged_parquet_file_is_one_line(tmp_path: Path) -> None:
    path = tmp_path / "broken.parquet"
    path.write_bytes(b"PAR1" + bytes(range(256)) * 4)
    result = runner.invoke(app, ["info", str(path)])
    assert result.exit_code == 2
    assert "broken.parquet" in result.output and "Traceback" not in result.output
