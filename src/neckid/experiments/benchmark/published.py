"""The published free-run figures the benchmark is read against, from ``published.json``.

The file holds, per benchmark, the ``unit`` of its literature, the ``source`` the figures come
from (``benchmarks/SOURCE.md`` in the shared data) and ``tests``: test record -> method -> RMSE.
It is package data, read with :mod:`importlib.resources`.

Examples
--------
>>> from neckid.experiments.benchmark import published_table, published_units
>>> published_table()["silverbox"]["multisine"]["LSTM"], published_units()["silverbox"]
(1.5, 'mV')
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from importlib import resources
from typing import Any

import pandas as pd

__all__ = ["PUBLISHED_COLUMNS", "published_frame", "published_table", "published_units"]

#: Columns of :func:`published_frame`.
PUBLISHED_COLUMNS = ("benchmark", "test", "method", "rmse", "rmse_unit", "source")


def _read() -> dict[str, Any]:
    text = resources.files(__package__).joinpath("published.json").read_text(encoding="utf-8")
    data: dict[str, Any] = json.loads(text)
    return data


def published_table() -> Mapping[str, Mapping[str, Mapping[str, float]]]:
    """The published figures, benchmark -> test -> method -> RMSE (in :func:`published_units`)."""
    return {name: entry["tests"] for name, entry in _read().items()}


def published_units() -> Mapping[str, str]:
    """The unit of each benchmark's published RMSE (``"mV"`` for Silverbox)."""
    return {name: str(entry["unit"]) for name, entry in _read().items()}


def published_frame(benchmarks: Sequence[str] | None = None) -> pd.DataFrame:
    """The published figures as a table, one row per (benchmark, test, method).

    Parameters
    ----------
    benchmarks : sequence of str, optional
        Keep these benchmarks (in this order); default all. Those without published figures
        (the soft-neck logs, the robot arm) give no row.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`PUBLISHED_COLUMNS`.
    """
    figures = _read()
    names = list(figures) if benchmarks is None else list(benchmarks)
    rows = [
        {
            "benchmark": name,
            "test": test,
            "method": method,
            "rmse": float(value),
            "rmse_unit": figures[name]["unit"],
            "source": figures[name]["source"],
        }
        for name in names
        for test, by_method in figures.get(name, {}).get("tests", {}).items()
        for method, value in by_method.items()
    ]
    return pd.DataFrame(rows, columns=list(PUBLISHED_COLUMNS))
