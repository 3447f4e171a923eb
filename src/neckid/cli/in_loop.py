"""``neckid validate MODEL LOG --in-loop``: the model in the lab's loop of a real log.

``validate`` (:mod:`neckid.cli.models`) hands over to :func:`validate_in_loop` when
``--in-loop`` is given. The log is read with every channel (a headerless soft-neck log as the
``softneck`` layout), the controller chosen by ``--controller`` or the log's name, and
:func:`neckid.loops.lab_loop.in_loop_on_log` runs the model in the loop with the drive identified
on the shared training logs (:meth:`neckid.loops.lab_drive.LabDrive.identified`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.markup import escape
from rich.table import Table

from neckid.cli._app import _sep, console, error_console

if TYPE_CHECKING:
    from neckid.cli.options import LogSpec

__all__ = ["CONTROLLER_HELP", "validate_in_loop"]

CONTROLLER_HELP = (
    "With --in-loop: int (the lab's PI), fra (the fixed fractional controller), ada (the adaptive"
    " one, re-implemented tuner), an adaptive parameter log adacon*.csv or a folder holding it"
    " (the adaptive controller replayed), or a controller file (.json) written by `neckid"
    " design` (read by neckid.design.load_controller). Default: the one the log's name says."
)

#: Channels the loop reads from a log with a header row.
_LOOP_CHANNELS = ("motor_position", "velocity_command", "motor_velocity")


def _headerless(path: Path, sep: str) -> bool:
    """Whether the file's first row is all numbers (a soft-neck log), not a header."""
    if path.suffix.lower() not in (".csv", ".txt", ""):
        return False
    with path.open(encoding="utf-8") as handle:
        first = handle.readline()
    try:
        [float(cell) for cell in first.strip().split(sep) if cell.strip()]
    except ValueError:
        return False
    return True


def _read(path: Path, model: Any, spec: LogSpec) -> Any:
    from neckid.cli.workflow import read_log

    sep = _sep(spec.sep)
    softneck = spec.layout == "softneck" or (spec.layout == "csv" and _headerless(path, sep))
    if softneck:
        inputs = list(_LOOP_CHANNELS)
    else:
        import pandas as pd

        header = list(pd.read_csv(path, sep=sep, nrows=0).columns)
        wanted = [*_LOOP_CHANNELS, *model.input_names_]
        inputs = [n for n in dict.fromkeys(wanted) if n in header]
    return read_log(
        path,
        inputs,
        ["inclination"],
        time=spec.time,
        ts=spec.ts,
        layout="softneck" if softneck else spec.layout,
        sep=sep,
        conditions=spec.conditions,
    )


def _controller(text: str | None) -> tuple[Any, Any]:
    """``(controller, adaptive_parameters)`` for :func:`~neckid.loops.lab_loop.in_loop_on_log`."""
    if text is None or text in ("int", "fra", "ada"):
        return text, None
    path = Path(text)
    if path.is_dir() or (path.is_file() and path.suffix.lower() == ".csv"):
        return "ada", path  # an adaptive parameter log, or the folder of them
    if not path.is_file():
        raise typer.BadParameter(
            f"--controller must be int, fra, ada or an existing file; got {text!r}"
        )
    try:
        import neckid.design as design
    except ModuleNotFoundError as exc:
        raise typer.BadParameter(
            f"--controller {text}: controller files come with `neckid design`, which this"
            f" installation does not have ({exc})"
        ) from exc
    loader = getattr(design, "load_controller", None)
    if loader is None:
        raise typer.BadParameter(
            f"--controller {text}: controller files come with `neckid design`"
            " (neckid.design.load_controller), not available yet; use int, fra or ada"
        )
    return loader(path), None


def _table(result: Any) -> Table:
    summary = result.summary()
    table = Table(title=escape(f"{result.log}: in the loop with {result.controller}"))
    for column in ("figure", "model", "log", "ratio"):
        table.add_column(column, justify="left" if column == "figure" else "right")

    def row(label: str, mine: Any, theirs: Any = None, ratio: Any = None, fmt: str = ".3f") -> None:
        cells = [
            format(v, fmt) if isinstance(v, float) else "" if v is None else str(v)
            for v in (mine, theirs, ratio)
        ]
        table.add_row(escape(label), *cells)

    row("free-run fit [%]", summary["free_run_fit_percent"])
    row("in-loop inclination fit [%]", summary["inclination_fit_percent"])
    row("in-loop command fit [%]", summary["command_fit_percent"])
    row(
        "tracking-error RMS [deg]",
        summary["tracking_rms_deg"],
        summary["logged_tracking_rms_deg"],
        summary["tracking_ratio"],
    )
    row(
        "oscillation period [s]",
        summary["period_s"],
        summary["logged_period_s"],
        summary["period_ratio"],
    )
    row("oscillation amplitude [deg]", summary["amplitude_deg"], summary["logged_amplitude_deg"])
    row(
        "mean overshoot [%]",
        summary["mean_overshoot_percent"],
        summary["logged_mean_overshoot_percent"],
    )
    row("controller check [rad/s]", summary["controller_check_rad_s"], fmt=".2e")
    return table


def _stairs_table(result: Any) -> Table:
    stairs = result.stair_table().set_axis(
        ["level", "step", "overshoot", "settling", "logged overshoot", "logged settling"], axis=1
    )
    title = "per stair: level and step [deg], overshoot [%], settling time [s] (band ±1 deg)"
    table = Table(title=escape(title))
    for column in stairs.columns:
        table.add_column(escape(str(column)), justify="right")
    for values in stairs.itertuples(index=False):
        table.add_row(*(f"{float(v):.2f}" for v in values))
    return table


def validate_in_loop(
    model_path: Path,
    logs: list[Path],
    controller: str | None,
    json_out: Path | None,
    spec: LogSpec,
) -> None:
    """Run ``model_path`` in the loop of each log; print the figures; write them as JSON.

    Parameters
    ----------
    model_path : Path
        A model file written by ``identify``.
    logs : list of Path
        Closed-loop soft-neck logs.
    controller : str, optional
        ``--controller``.
    json_out : Path, optional
        ``--json`` (already checked by the caller).
    spec : LogSpec
        The log options of the command line (``time``, ``ts``, ``layout``, ``sep``,
        ``conditions`` are read here).
    """
    from neckid.loops.lab_loop import in_loop_on_log
    from neckid.models.io import load_model
    from neckid.utils.files import write_json

    model = load_model(model_path)
    chosen, parameters = _controller(controller)
    records = []
    for log in logs:
        data = _read(log, model, spec)
        try:
            result = in_loop_on_log(model, data, chosen, adaptive_parameters=parameters)
        except (ValueError, FileNotFoundError) as exc:
            error_console.print(
                f"[red]{escape(log.name)}:[/red] {escape(str(exc))}", soft_wrap=True
            )
            records.append({"log": log.name, "error": str(exc)})
            continue
        console.print(_table(result))
        if len(result.stairs):
            console.print(_stairs_table(result))
        if result.diverged_at is not None:
            console.print(f"[red]the loop diverged at row {result.diverged_at}[/red]")
        records.append(result.to_dict())
    if json_out is not None:
        document = {"model": model_path.name, "kind": "in loop", "logs": records}
        write_json(json_out, document)
        console.print(f"results written to {json_out}")
    if any("error" in r for r in records):
        raise typer.Exit(code=1)
