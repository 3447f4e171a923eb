"""What a benchmark run measured: :class:`BenchmarkReport`, its table, files and terminal tables."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from neckid.utils.files import StagedFolder, output_folder

__all__ = ["TABLE_COLUMNS", "BenchmarkReport"]

#: Columns of :attr:`BenchmarkReport.table`.
TABLE_COLUMNS = (
    "benchmark",
    "test",
    "method",
    "rmse",
    "rmse_unit",
    "fit_percent",
    "n_initial",
    "train_time_s",
    "simulate_time_s",
    "settings",
    "note",
)


@dataclass(frozen=True)
class BenchmarkReport:
    """What :func:`~neckid.experiments.benchmark.run_benchmark` measured.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per (benchmark, test, method) with columns ``benchmark``, ``test``, ``method``
        (the registry name: ``"sm-linear"``), ``rmse`` (free run, in ``rmse_unit``),
        ``rmse_unit``, ``fit_percent`` (NRMSE fit), ``n_initial`` (initial samples skipped),
        ``train_time_s`` (seconds of work of the method's selection and final fit: its grid,
        every candidate's fits summed over the workers that ran them, the final fit),
        ``simulate_time_s`` (the free run of that test record), ``settings`` (the chosen
        hyper-parameters) and ``note``. On the soft-neck logs a row with ``test == "mean"`` holds
        the mean over the validation logs.
    published : pandas.DataFrame
        The published figures next to which the table is read: ``benchmark``, ``test``,
        ``method``, ``rmse``, ``rmse_unit``, ``source``.
    details : dict
        JSON-serialisable extras: the command settings, the selection scores of every candidate,
        per benchmark the protocol text, and for the soft-neck logs the per-log difference
        ``fit(method) - fit(arx)`` (``"<method>_minus_arx"``). The same for the same settings and
        data, wherever the fits ran.
    timings : dict
        Where the time went (JSON-serialisable, wall and work seconds; they change from run to
        run): ``wall_time_s`` of the whole run, ``n_jobs``, per stage its units and wall time
        (``stages``), per data set and method the seconds of work of its grid, selection (and
        per candidate), final fit and free runs (``benchmarks``), and how many results were
        taken from the run's shared fits instead of computed again (``shared``).
    """

    table: pd.DataFrame
    published: pd.DataFrame
    details: dict[str, Any] = field(default_factory=dict)
    timings: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The whole report as a JSON-serialisable dict (``table`` and ``published`` as records)."""
        return {
            "table": _records(self.table),
            "published": _records(self.published),
            "details": self.details,
            "timings": self.timings,
        }

    def comparison(self) -> pd.DataFrame:
        """Our RMSE beside the published ones: one row per (benchmark, test, method)."""
        ours = self.table[["benchmark", "test", "method", "rmse", "rmse_unit"]].assign(
            source="neckid"
        )
        return pd.concat([ours, self.published], ignore_index=True)

    def write(self, output_dir: str | Path, *, force: bool = False) -> dict[str, Path]:
        """Write ``benchmark.csv``, ``published.csv`` and ``benchmark.json`` into a folder.

        The folder is locked while it is written and the files move in together
        (:func:`neckid.utils.files.output_folder`); a folder that holds files already is refused
        unless ``force``.

        Returns
        -------
        dict of str to Path
            The files written, by kind (``"table"``, ``"published"``, ``"json"``).
        """
        with output_folder(output_dir, force=force) as staged:
            return self.write_into(staged)

    def write_into(self, staged: StagedFolder) -> dict[str, Path]:
        """Write the three files into a staged output folder; return their final paths."""
        names = {"table": "benchmark.csv", "published": "published.csv", "json": "benchmark.json"}
        self.table.to_csv(staged.path(names["table"]), index=False)
        self.published.to_csv(staged.path(names["published"]), index=False)
        staged.path(names["json"]).write_text(
            json.dumps(self.to_dict(), indent=2, default=_json_default)
        )
        return {kind: staged.final(name) for kind, name in names.items()}

    def rich_table(self) -> Any:
        """A :class:`rich.table.Table` of the results, for the CLI to print.

        One row per (data set, test, method), narrow enough for an 80-column terminal: the
        published figures are in :meth:`published_rich_table`, the wall times and settings in the
        written files.
        """
        from rich.markup import escape
        from rich.table import Table

        table = Table(title="neckid benchmark: free run (RMSE in each data set's unit)")
        table.add_column("data set / test", overflow="fold")
        table.add_column("method", no_wrap=True)
        table.add_column("RMSE", justify="right", no_wrap=True)
        table.add_column("fit [%]", justify="right", no_wrap=True)
        table.add_column("train [s]", justify="right", no_wrap=True)
        table.add_column("note", overflow="fold")
        previous = None
        for row in self.table.itertuples(index=False):
            where = f"{row.benchmark} / {row.test}"
            table.add_row(
                where if where != previous else "",
                str(row.method),
                _fmt(row.rmse, f" {row.rmse_unit!s}" if row.rmse_unit else ""),
                _fmt(row.fit_percent, digits=3),
                _fmt(row.train_time_s, digits=2),
                escape(str(row.note or "")),  # a note may hold brackets: neckid[peers]
                end_section=False,
            )
            previous = where
        return table

    def published_rich_table(self) -> Any:
        """The published free-run RMSE next to which the results are read (a rich table)."""
        from rich.table import Table

        table = Table(title="published free-run RMSE (same split)")
        for column in ("data set / test", "method", "RMSE"):
            table.add_column(column, overflow="fold")
        for row in self.published.itertuples(index=False):
            table.add_row(
                f"{row.benchmark} / {row.test}",
                str(row.method),
                _fmt(row.rmse, f" {row.rmse_unit}"),
            )
        return table


def _fmt(value: Any, suffix: str = "", digits: int = 4) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return f"{float(value):.{digits}g}{suffix}"


def _json_default(value: Any) -> Any:
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def _records(frame: pd.DataFrame) -> list[dict[str, Any]]:
    return [
        {
            str(k): (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in record.items()
        }
        for record in frame.to_dict(orient="records")
    ]
