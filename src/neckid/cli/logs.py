"""Commands on logs and files: bandwidth of a chirp run, info on a log or a model."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer
from rich.table import Table

from neckid.cli._app import (
    CHANNEL_OPTION,
    CONDITION_OPTION,
    FORCE_OPTION,
    LAYOUT_OPTION,
    MAP_OPTION,
    SEP_OPTION,
    TIME_OPTION,
    TS_OPTION,
    _sep,
    app,
    console,
    handled,
)


@app.command()
@handled
def bandwidth(
    log: Path = typer.Argument(
        ...,
        help="A chirp run: CSV with a header row, or a bench log with --layout softneck.",
        exists=True,
        dir_okay=False,
    ),
    command: str = typer.Option(
        ..., "--command", help="Column of the chirp command (e.g. reference, degrees)."
    ),
    response: str = typer.Option(
        ..., "--response", help="Column of the measured response (same units)."
    ),
    time: str = TIME_OPTION,
    ts: float = TS_OPTION,
    layout: str = LAYOUT_OPTION,
    sep: str = SEP_OPTION,
    threshold: float = typer.Option(
        0.9, "--threshold", help="Amplitude ratio that defines the bandwidth."
    ),
    rate: float = typer.Option(
        None,
        "--rate",
        help="Chirp rate r of the paper's chirp sin(r t^2) (0.1 in the paper): its instantaneous"
        " frequency 2 r t [rad/s] is then used instead of being estimated from the command.",
    ),
    plot: Path = typer.Option(
        None, "--plot", help="Write a PNG of the envelopes (like the paper's Fig. 3)."
    ),
    force: bool = FORCE_OPTION,
) -> None:
    """Find the bandwidth (rad/s) of a chirp run: where the response amplitude stays below 90 % of the command's.

    The rule compares the two amplitudes, so command and response must be in one unit (the
    paper's closed-loop reference and inclination, both in degrees): a run whose amplitude ratio
    at the slow start of the chirp is far from 1 is refused.
    """
    import numpy as np

    from neckid.cli.workflow import read_log
    from neckid.signals import bandwidth_from_chirp, paper_chirp_frequency
    from neckid.utils.files import atomic_path, check_output_file

    if plot is not None:
        check_output_file(plot, force=force, inputs=[log], option="--plot")
    data = read_log(log, [command], [response], time=time, ts=ts, layout=layout, sep=_sep(sep))  # type: ignore[arg-type]
    units = (data.input_units[0], data.output_units[0])
    if all(units) and units[0] != units[1]:
        raise ValueError(
            f"--command {command!r} is in {units[0]} and --response {response!r} in {units[1]}:"
            " the 90 % rule compares amplitudes in one unit; convert one of them"
        )
    t = data.time
    result = bandwidth_from_chirp(
        t,
        data.u[:, 0],
        data.y[:, 0],
        threshold=threshold,
        frequency=None if rate is None else paper_chirp_frequency(t, rate=rate),
    )
    start = result.ratio[: max(1, min(3, result.ratio.size))]
    start_ratio = float(np.median(start)) if start.size else float("nan")
    if np.isfinite(start_ratio) and not 0.5 <= start_ratio <= 2.0:
        raise ValueError(
            f"at the slow start of the chirp the response's amplitude is {start_ratio:.3g} times"
            " the command's; the 90 % rule needs a response that follows the command in the same"
            " unit (a closed loop's reference and output, e.g. both in degrees): check the units"
            " (rad -> deg is x57.3) and that --command is the reference"
        )
    if result.status != "found":
        explanation = {
            "not_reached": "the response never stays below the threshold: chirp further",
            "below_at_start": "the response is below the threshold from the start: chirp slower",
        }.get(result.status, result.status)
        explanation = getattr(result, "reason", "") or explanation
        console.print(f"[yellow]no bandwidth found[/yellow]: {explanation}")
    else:
        console.print(
            f"bandwidth: {result.omega:.3f} rad/s ({result.omega / (2 * np.pi):.3f} Hz)"
            f" at ratio {threshold}"
        )
    if plot is not None:
        from neckid.report.signal_plots import plot_bandwidth

        with atomic_path(plot) as temporary:
            plot_bandwidth(result).savefig(temporary, dpi=120, format="png")
        console.print(f"figure written to {plot}")


def _shown(value: Any) -> str:
    """A value of ``describe_model`` for the table: numbers to 4 significant digits."""
    if isinstance(value, dict):  # per horizon
        return "; ".join(f"k={k}: {_shown(v)}" for k, v in value.items())
    if isinstance(value, list) and value and all(isinstance(v, float) for v in value):
        return ", ".join(f"{v:.4g}" for v in value)
    return str(value)


@app.command()
@handled
def info(
    path: Path = typer.Argument(
        None,
        help="A log, a model file (.npz) or a controller file (.json, of neckid design); without"
        " it, the versions of neckid and its libraries.",
    ),
    layout: str = LAYOUT_OPTION,
    time: str = TIME_OPTION,
    sep: str = SEP_OPTION,
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of tables."),
    maps: list[str] = MAP_OPTION,
    conditions: list[str] = CONDITION_OPTION,
    channels: list[str] = CHANNEL_OPTION,
    model_path: Path = typer.Option(
        None,
        "--model",
        help="A model file: also describe the log as that model reads it (its channels, renamed"
        " by --map, through the model's preprocessing).",
    ),
) -> None:
    """Describe a log or a model file; without a path, print the versions of the libraries.

    A log: channels, units, duration, sampling period, gaps, conditions (file name, sidecar,
    --condition). A model file: method, regressor, channels, sampling period, the conditions it
    takes, its preprocessing, the Set Membership prior, the training range of each channel.
    """
    from neckid.cli.workflow import describe_log, parse_mapping

    if path is None:
        from neckid.report.html import library_versions

        console.print_json(json.dumps(library_versions()))
        return
    if not path.exists():
        raise FileNotFoundError(f"{str(path)!r} does not exist")
    from neckid.utils.formats import file_format

    if path.suffix.lower() == ".npz" or (path.is_file() and file_format(path) in ("npz", "zip")):
        _info_model(path, as_json)
        return
    if path.suffix.lower() == ".json":  # a controller file of neckid design
        from neckid.cli.design import describe_controller_file

        described_controller = describe_controller_file(path)
        if as_json:
            console.print_json(json.dumps(described_controller))
            return
        for line in described_controller["summary"]:
            console.print(line, markup=False)
        model = described_controller.get("model") or {}
        if model:
            console.print(
                f"designed on {model.get('path')} ({model.get('class')}, sha256"
                f" {str(model.get('sha256'))[:12]}...)",
                markup=False,
            )
        return
    mapping = parse_mapping(maps or [])
    described = describe_log(
        path,
        layout=layout,  # type: ignore[arg-type]
        time=time,
        sep=_sep(sep),
        maps=mapping,
        conditions=conditions or (),
        channels_spec=channels or (),
    )
    if model_path is not None:
        described["as_model_reads_it"] = _as_model_reads_it(
            model_path, path, layout, time, sep, mapping, conditions or []
        )
    if as_json:
        console.print_json(json.dumps(described))
        return
    console.print(
        f"{described['file']}: {described['samples']} samples over {described['duration_s']:.4g} s,"
        f" ts = {described['ts_s']:.6g} s (largest step {described['max_step_s']:.6g} s,"
        f" {described['gaps']} gap(s) over 1.5 ts, {described['repeated_stamps']} repeated"
        " time stamp(s))"
    )
    if described.get("skipped"):
        console.print(f"not channels: {', '.join(described['skipped'])}", markup=False)
    table = Table(title="channels")
    for column in ("channel", "kind", "unit", "min", "max", "mean", "non-numeric"):
        names = column in ("channel", "kind", "unit")
        # a narrow console wraps a channel's name, never cuts it (it tells the rows apart)
        _add_column(table, column, justify="left" if names else "right", overflow="fold")
    for name, channel in described["channels"].items():
        _add_row(
            table,
            f"{name} (column {channel['column']})" if "column" in channel else name,
            channel["kind"],
            channel["unit"] or "-",
            f"{channel['min']:.4g}",
            f"{channel['max']:.4g}",
            f"{channel['mean']:.4g}",
            str(channel["non_numeric"]),
        )
    console.print(table)
    console.print(f"conditions: {_conditions_text(described)}", markup=False)
    if model_path is not None:
        _print_as_model_reads_it(described["as_model_reads_it"])


def _info_model(path: Path, as_json: bool) -> None:
    """``neckid info MODEL``: what the model is, its conditions, its preprocessing, its schedule."""
    from neckid.cli.workflow import describe_model
    from neckid.models.io import load_model

    model = load_model(path)
    described = describe_model(model)
    # the scheduled model: its lines and operating points; the LPV model: its polynomials
    described.update(model.schedule_summary())
    if as_json:
        console.print_json(json.dumps(described))
        return
    table = Table(title=f"{path.name}: {described['method']}", show_header=False)
    for key in (
        "class",
        "lags",
        "inputs",
        "outputs",
        "output_units",
        "ts_s",
        "initial_samples",
        "training_samples",
        "horizons",
        "epsilon",
        "gamma",
        "lipschitz",
        "distance",
        "estimate",
        "order",
        "singular_values",
    ):
        if key in described:
            _add_row(
                table, key.replace("_s", " [s]") if key == "ts_s" else key, _shown(described[key])
            )
    for name, (low, high) in described["training_ranges"].items():
        _add_row(table, f"training range of {name}", f"{low:.4g} .. {high:.4g}")
    _add_row(table, "conditions (inputs)", ", ".join(described["conditions"]) or "none")
    if "preprocessing" in described:
        _add_row(table, "preprocessing", model.preprocessing_.describe())
    if "channel_map" in described:
        shown = ", ".join(f"{log}={name}" for log, name in described["channel_map"].items())
        _add_row(table, "channel mapping (--map)", shown)
    console.print(table)
    if "schedule" in described:
        _print_schedule(described["schedule"])
    if "scheduling" in described:
        _print_scheduling(described["scheduling"])
    if "equation" in described:
        _print_equation(described["equation"])


def _print_equation(equation: dict[str, Any]) -> None:
    """A sparse model's identified equation and each kept term's coefficient with its unit."""
    from rich.markup import escape

    for line in equation["equations"]:
        console.print(f"identified equation: {line}", markup=False, soft_wrap=True)
    bags = equation["bags"]
    table = Table(
        title=escape(
            f"kept terms: {len(equation['terms'])} of {equation['library_size']} library functions,"
            f" threshold {equation['threshold']:g} ({equation['chosen_by']})"
            + (", refitted on the free run" if equation["refined"] else "")
        )
    )
    columns = ["output", "term", "coefficient", "unit"]
    if bags:
        columns += [f"95 % of {bags} bags", "kept in bags"]
    for column in columns:
        _add_column(
            table, column, justify="left" if column in ("output", "term", "unit") else "right"
        )
    for row in equation["terms"]:
        cells = [row["output"], row["term"], f"{row['coef']:.6g}", row["unit"]]
        if bags:
            low, high = row["interval"]
            cells += [f"{low:.4g} .. {high:.4g}", f"{row['inclusion']:.0%}"]
        _add_row(table, *cells)
    console.print(table)


def _print_scheduling(scheduling: dict[str, Any]) -> None:
    """The LPV model's scheduling variables and its coefficients as polynomials in them."""
    table = Table(title=f"scheduling (degree {scheduling['degree']})", show_header=False)
    for v in scheduling["variables"]:
        low, high = v["range"]
        shown = f"{v['kind']}, term {v['term']}, range {low:.4g} .. {high:.4g}"
        _add_row(table, v["name"], shown)
    _add_row(table, "largest frozen pole", f"{scheduling['max_pole_radius']:.4g} (stable below 1)")
    for line in scheduling["polynomials"]:
        _add_row(table, "", line)
    console.print(table)


def _print_schedule(schedule: dict[str, Any]) -> None:
    """The scheduled model's lines ``N(i)``, ``P(i)``, range, form, and its operating points."""
    from rich.markup import escape

    low, high = ("-inf" if v is None else f"{v:.4g}" for v in schedule["schedule_range_deg"])
    unit = schedule["gain"]["unit"]
    lines = Table(title=f"schedule ({schedule['form']} form)", show_header=False)
    for key, value in (
        ("model", schedule["equation"]),
        ("gain", f"{schedule['gain']['text']}  [{unit}], i in deg"),
        ("pole", f"{schedule['pole']['text']}  [-], held in ±{schedule['pole_bound']:g}"),
        ("schedule range", f"{low} .. {high} deg (the lines held at their ends outside)"),
        ("points found by", schedule["segmentation"]),
    ):
        _add_row(lines, key, value)
    console.print(lines)
    points = schedule["points"]
    if not points:
        return
    used = sum(p["used"] for p in points)
    converged = sum(bool(p["converged"]) for p in points)
    unknown = sum(p["converged"] is None for p in points)
    flags = f"{converged} converged" if not unknown else f"convergence of {unknown} unknown"
    table = Table(
        title=escape(
            f"operating points: {len(points)}, {flags}, {used} in the lines"
            f" (i [deg], N [{unit}], P [-], from/to [s])"
        )
    )
    for column in ("i", "N", "P", "converged", "used", "from", "to", "samples"):
        _add_column(table, column, justify="right")
    for p in points:
        _add_row(
            table,
            f"{p['inclination_deg']:.4g}",
            f"{p['gain']:.4g}",
            f"{p['pole']:.4g}",
            "?" if p["converged"] is None else ("yes" if p["converged"] else "no"),
            "yes" if p["used"] else "no",
            "-" if p["start_s"] is None else f"{p['start_s']:.4g}",
            "-" if p["stop_s"] is None else f"{p['stop_s']:.4g}",
            str(p["n_samples"]) if p["n_samples"] else "-",
        )
    console.print(table)


def _conditions_text(described: dict[str, Any]) -> str:
    """``payload = 0.4 kg, controller = ada`` (or ``none``)."""
    units = described.get("condition_units", {})
    return (
        ", ".join(
            f"{name} = {value}" + (f" {units[name]}" if units.get(name) else "")
            for name, value in described["conditions"].items()
        )
        or "none"
    )


def _as_model_reads_it(
    model_path: Path,
    path: Path,
    layout: str,
    time: str,
    sep: str,
    mapping: dict[str, str],
    conditions: list[str],
) -> dict[str, Any]:
    """The log as a model reads it: its channels (through --map and the model's preprocessing)."""
    from neckid.cli.workflow import read_log_for_model
    from neckid.models.io import load_model

    model = load_model(model_path)
    data, pipeline = read_log_for_model(
        model,
        path,
        time=time,
        layout=layout,  # type: ignore[arg-type]
        sep=_sep(sep),
        maps=mapping,
        conditions=conditions,
    )
    channels = {}
    for kind, names, units, values in (
        ("input", data.input_names, data.input_units, data.u),
        ("output", data.output_names, data.output_units, data.y),
    ):
        for j, name in enumerate(names):
            column = values[:, j]
            channels[name] = {
                "kind": kind,
                "unit": units[j],
                "min": float(column.min()),
                "max": float(column.max()),
                "mean": float(column.mean()),
            }
    return {
        "model": model_path.name,
        "preprocessing": pipeline.to_list() if pipeline is not None else [],
        "preprocessing_text": pipeline.describe() if pipeline is not None else "none",
        "samples": data.n_samples,
        "ts_s": data.ts,
        "channels": channels,
        "conditions": dict(data.conditions),
    }


def _print_as_model_reads_it(read: dict[str, Any]) -> None:
    console.print(f"preprocessing from the model: {read['preprocessing_text']}", markup=False)
    table = Table(
        title=f"as {read['model']} reads it: {read['samples']} samples, ts {read['ts_s']:.6g} s"
    )
    for column in ("channel", "kind", "unit", "min", "max", "mean"):
        names = column in ("channel", "kind", "unit")
        # a narrow console wraps a channel's name, never cuts it (it tells the rows apart)
        _add_column(table, column, justify="left" if names else "right", overflow="fold")
    for name, channel in read["channels"].items():
        _add_row(
            table,
            name,
            channel["kind"],
            channel["unit"] or "-",
            *(f"{channel[k]:.4g}" for k in ("min", "max", "mean")),
        )
    console.print(table)


def _add_row(table: Table, *cells: Any) -> None:
    """A row of plain text: a channel ``inclination [deg]`` keeps its brackets (not rich markup)."""
    from rich.markup import escape

    table.add_row(*(escape(c) if isinstance(c, str) else c for c in cells))


def _add_column(table: Table, header: str, **options: Any) -> None:
    """A column whose header is plain text (see :func:`_add_row`)."""
    from rich.markup import escape

    table.add_column(escape(header), **options)
