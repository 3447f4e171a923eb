"""``neckid validate MODEL LOG --in-loop``: the model in the lab's loop of a real log.

``validate`` (:mod:`neckid.cli.models`) hands over to :func:`validate_in_loop` when
``--in-loop`` is given. The log is read with every channel (a headerless soft-neck log as the
``softneck`` layout), the controller chosen by ``--controller`` or the log's name, and
:func:`neckid.loops.lab_loop.in_loop_on_log` runs the model in the loop with the drive identified
on the shared training logs (:meth:`neckid.loops.lab_drive.LabDrive.identified`).

What the loop must agree with is checked first (:mod:`neckid.loops.loop_checks`): a controller
whose commands, fed the logged inclination, differ from the logged ones by more than 1e-4 rad/s
is refused (exit status 2, one line naming the log, the controller and the check) unless
``--force``; so are a controller at another sampling period than the log, and adaptive parameter
logs given for a log that another controller made. ``--map`` (and the model's stored mapping)
and ``--condition`` apply to the log as in a free run, ``--channel`` to a ROS 2 bag
(``--layout rosbag``; refused for another layout); ``--tilt`` is refused (the lab's controllers
measure the inclination alone). A loop that diverges exits with status 3, as a
diverging free run does; ``--plot`` draws each log's loop (:mod:`neckid.report.loop_plots`).
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
    " one, re-implemented tuner: approximate, so refused by the controller check without"
    " --force), an adaptive parameter log adacon*.csv or a folder holding it (the adaptive"
    " controller replayed; ada* logs only), or a controller file (.json) written by `neckid"
    " design` (read by neckid.design.load_controller; at the log's period). Default: the one the"
    " log's name says. A controller that does not reproduce the log's commands (controller"
    " check beyond 1e-4 rad/s) is refused unless --force."
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


def _mapping(path: Path, model: Any, spec: LogSpec, softneck: bool) -> dict[str, str]:
    """``{log name: model name}``: the user's ``--map``, else the model's stored mapping."""
    from neckid.cli.options import _stored_mapping

    mapping = spec.mapping()
    if mapping or softneck or not model.channel_map_:
        return mapping
    return _stored_mapping(model, path, spec)


def _available(path: Path, spec: LogSpec, sep: str) -> set[str]:
    """The channel names a log with named columns (or a bag's ``--channel`` list) offers."""
    if spec.layout == "rosbag":
        from neckid.cli.workflow import parse_channels

        return set(parse_channels(list(spec.channels)))
    from neckid.cli.options import _column_names

    return _column_names(path, sep, spec.time)


def _read(path: Path, model: Any, spec: LogSpec) -> Any:
    """The log with every channel the loop and the model read, renamed by the mapping."""
    from neckid.cli.workflow import read_log

    if spec.tilt:
        raise ValueError(
            "--tilt: the lab's loop measures the inclination alone (its controllers read the raw"
            " inclination), so a model of the tilt vector has no lab loop; validate it without"
            " --in-loop"
        )
    if spec.channels and spec.layout != "rosbag":
        raise ValueError(
            f"--channel {spec.channels[0]!r}: --channel names the channels of a ROS 2 bag"
            f" (--layout rosbag); {path.name} is read with --layout {spec.layout}, whose"
            " columns have names of their own (rename them with --map MODEL=LOG)"
        )
    sep = _sep(spec.sep)
    softneck = spec.layout == "softneck" or (spec.layout == "csv" and _headerless(path, sep))
    mapping = _mapping(path, model, spec, softneck)
    if softneck:
        inputs = list(_LOOP_CHANNELS)
    else:
        to_log = {name: log for log, name in mapping.items()}
        offered = _available(path, spec, sep)
        wanted = [*_LOOP_CHANNELS, *model.input_names_]
        inputs = [n for n in dict.fromkeys(wanted) if to_log.get(n, n) in offered]
    return read_log(
        path,
        inputs,
        ["inclination"],
        time=spec.time,
        ts=spec.ts,
        layout="softneck" if softneck else spec.layout,
        sep=sep,
        channels=spec.channels,
        conditions=spec.conditions,
        maps=mapping,
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
    row("controller check [rad/s] (tolerance 1e-4)", summary["controller_check_rad_s"], fmt=".2e")
    first_stair_row = summary["controller_check_first_stair_row_rad_s"]
    if first_stair_row == first_stair_row:  # an adaptive replay: its unlogged starting gains
        row("  first stair row (starting gains, not checked)", first_stair_row, fmt=".2e")
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


def _run(model: Any, log: Path, data: Any, controller: tuple[Any, Any], force: bool) -> Any:
    """:func:`~neckid.loops.lab_loop.in_loop_on_log` on one log; a refusal names the log."""
    from neckid.loops.lab_loop import in_loop_on_log
    from neckid.loops.loop_checks import CONTROLLER_CHECK_TOLERANCE, ControllerMismatchError

    chosen, parameters = controller
    try:
        result = in_loop_on_log(
            model,
            data,
            chosen,
            adaptive_parameters=parameters,
            check_tolerance=None if force else CONTROLLER_CHECK_TOLERANCE,
        )
    except ControllerMismatchError as exc:
        raise ValueError(f"{exc}; --force runs it anyway") from None
    except (ValueError, FileNotFoundError) as exc:
        text = str(exc)
        raise type(exc)(text if text.startswith(log.name) else f"{log.name}: {text}") from None
    check = result.controller_check
    if check != check:
        error_console.print(
            f"[yellow]warning:[/yellow] {escape(log.name)} has no velocity_command: the"
            f" controller {escape(result.controller)} could not be checked against the log",
            highlight=False,
            soft_wrap=True,
        )
    elif check > CONTROLLER_CHECK_TOLERANCE:
        error_console.print(
            f"[yellow]warning (--force):[/yellow] {escape(log.name)}: the controller"
            f" {escape(result.controller)} does not reproduce the log's commands (controller"
            f" check {check:.3g} rad/s, tolerance {CONTROLLER_CHECK_TOLERANCE:.0e} rad/s): the"
            " in-loop figures compare two different loops",
            highlight=False,
            soft_wrap=True,
        )
    return result


def _write_plot(results: list[Any], plot: Path) -> None:
    """Each log's loop (:func:`neckid.report.loop_plots.plot_lab_loops`) as one PNG."""
    from neckid.cli.explain import _save_figure
    from neckid.report.loop_plots import plot_lab_loops

    _save_figure(plot_lab_loops(results), plot)
    console.print(f"figure written to {plot}")


def _adapted(model: Any, data: Any, adapt: tuple[float, str] | None) -> Any:
    """The model the loop runs: ``model``, or a copy adapted on the log's first seconds."""
    if adapt is None:
        return model
    from neckid.loops.lab_loop import model_view
    from neckid.models.adapted import adapted_model

    return adapted_model(model, model_view(model, data), *adapt)


def validate_in_loop(
    model_path: Path,
    logs: list[Path],
    controller: str | None,
    json_out: Path | None,
    spec: LogSpec,
    *,
    plot: Path | None = None,
    force: bool = False,
    adapt: tuple[float, str] | None = None,
) -> None:
    """Run ``model_path`` in the loop of each log; print the figures; write them as JSON.

    Every log is checked and run before anything is written: a refusal (a controller that does
    not reproduce the log, another sampling period, a log the model cannot run in) stops the
    command with one line naming the log (exit status 2). A loop that diverges is reported
    and the command ends with exit status 3, after the other logs and the outputs.

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
        ``channels``, ``conditions``, ``maps`` are read here; ``tilt`` is refused).
    plot : Path, optional
        ``--plot`` (already checked by the caller): each log's loop.
    force : bool, default False
        Run a controller whose check exceeds its tolerance (with a warning).
    adapt : (float, str), optional
        ``--adapt SECONDS`` and ``--adapt-mode``: the loop runs a copy of the model adapted on
        the log's first seconds (:func:`neckid.models.adapted.adapted_model`); the un-adapted
        loop's inclination fit is printed and written beside it.
    """
    from neckid.models.io import load_model
    from neckid.utils.files import write_json

    model = load_model(model_path)
    chosen = _controller(controller)
    results, unadapted = [], []
    for log in logs:
        data = _read(log, model, spec)
        result = _run(_adapted(model, data, adapt), log, data, chosen, force)
        console.print(_table(result))
        if adapt is not None:
            plain = _run(model, log, data, chosen, force)
            unadapted.append(plain.inclination_fit)
            console.print(
                f"in loop after {adapt[0]:g} s of adaptation ({adapt[1]}): inclination fit"
                f" {result.inclination_fit:.1f} % (un-adapted {plain.inclination_fit:.1f} %)",
                markup=False,
            )
        if len(result.stairs):
            console.print(_stairs_table(result))
        if result.diverged_at is not None:
            error_console.print(
                f"[red]diverged:[/red] {escape(log.name)}: the loop's inclination left ±1000 deg"
                f" or stopped being finite at row {result.diverged_at}"
                f" (t = {float(result.measured.time[result.diverged_at]):.3f} s)",
                highlight=False,
                soft_wrap=True,
            )
        results.append(result)
    if json_out is not None:
        records = [r.to_dict() for r in results]
        kind = "in loop"
        if adapt is not None:
            kind = f"in loop after {adapt[0]:g} s of adaptation ({adapt[1]})"
            for record, fit in zip(records, unadapted, strict=True):
                record["unadapted_inclination_fit_percent"] = fit
        write_json(json_out, {"model": model_path.name, "kind": kind, "logs": records})
        console.print(f"results written to {json_out}")
    if plot is not None:
        _write_plot(results, plot)
    if any(r.diverged_at is not None for r in results):
        raise typer.Exit(code=3)
