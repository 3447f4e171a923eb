"""The ``neckid`` command line: demo, identify, validate, simulate, bandwidth, benchmark."""

from __future__ import annotations

import functools
import json
import logging
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import typer
from rich.console import Console
from rich.table import Table

from neckid._version import __version__

app = typer.Typer(
    name="neckid",
    help=(
        "Identify dynamic models of a tendon-driven soft robotic neck from input/output logs. "
        "Angles are in degrees, motor positions in rad and velocities in rad/s at the gearbox "
        "output, time in seconds, unless a log's own units say otherwise."
    ),
    no_args_is_help=True,
    add_completion=False,
    # Markdown joins the lines of a docstring paragraph, so help text reflows to the terminal.
    rich_markup_mode="markdown",
)
console = Console()
error_console = Console(stderr=True)

#: Set by ``--debug``: unexpected errors show their traceback.
_STATE = {"debug": False}

Command = TypeVar("Command", bound=Callable[..., Any])

#: Errors that come from what the user gave (a file, a column, a value): one line, exit status 2.
_USER_ERRORS: tuple[type[BaseException], ...] = (
    ValueError,
    KeyError,
    TypeError,
    OSError,
)


def _version_callback(value: bool) -> None:
    if value:
        console.print(f"neckid {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: bool = typer.Option(
        False,
        "--version",
        callback=_version_callback,
        is_eager=True,
        help="Print the version and exit.",
    ),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Log progress messages."),
    debug: bool = typer.Option(
        False, "--debug", help="Show the full traceback of an unexpected error."
    ),
) -> None:
    """Identify dynamic models of a tendon-driven soft robotic neck from input/output logs."""
    _STATE["debug"] = debug
    logging.basicConfig(
        level=logging.INFO if verbose else logging.WARNING, format="%(name)s: %(message)s"
    )


def _split(text: str | None) -> list[str] | None:
    if text is None:
        return None
    return [p.strip() for p in text.split(",") if p.strip()]


def _fail(message: str) -> None:
    error_console.print(f"[red]error:[/red] {message}", highlight=False, soft_wrap=True)
    raise typer.Exit(code=2)


def _message(exc: BaseException) -> str:
    if isinstance(exc, KeyError) and exc.args:
        return str(exc.args[0])
    if isinstance(exc, OSError) and exc.strerror and exc.filename:
        return f"{exc.filename}: {exc.strerror}"
    return str(exc) or type(exc).__name__


def _show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: Any = None,
    line: str | None = None,
) -> None:
    """Print a library warning as one line (no file path): what the user can act on."""
    text = str(message).splitlines()[0] if str(message) else category.__name__
    error_console.print(f"[yellow]warning:[/yellow] {text}", highlight=False, soft_wrap=True)


def handled(command: Command) -> Command:
    """Run a command with the one error policy of the command line.

    What the user gave wrong (:data:`_USER_ERRORS`) prints one ``error:`` line and exits with
    status 2; Ctrl-C says that the run was interrupted and that no output was half written
    (status 130); anything else prints one line with the error's type and the hint to rerun
    with ``--debug`` (status 1), or the traceback with ``--debug``.
    """

    @functools.wraps(command)
    def run(*args: Any, **kwargs: Any) -> Any:
        from neckid.models.base import ExtrapolationWarning

        try:
            with warnings.catch_warnings():
                # The commands report extrapolation themselves; other warnings get one line each,
                # once, without the library's file path.
                warnings.simplefilter("ignore", ExtrapolationWarning)
                warnings.showwarning = _show_warning
                return command(*args, **kwargs)
        except (typer.Exit, typer.Abort):
            raise
        except KeyboardInterrupt:
            error_console.print(
                "[yellow]interrupted[/yellow]: stopped before the end; outputs are written whole"
                " or not at all, so no file was left half written"
            )
            raise typer.Exit(code=130) from None
        except _USER_ERRORS as exc:
            _fail(_message(exc))
        except Exception as exc:
            if _STATE["debug"]:
                raise
            error_console.print(
                f"[red]unexpected error[/red] ({type(exc).__name__}): {_message(exc)}; rerun with"
                " `neckid --debug ...` for the traceback and report it",
                highlight=False,
                soft_wrap=True,
            )
            raise typer.Exit(code=1) from None

    return run  # type: ignore[return-value]


FORCE_HELP = "Overwrite an existing output."


def _model_channels(model: Any) -> tuple[list[str], list[str]]:
    return list(model.input_names_), list(model.output_names_)


def _method_name(name: str) -> str:
    """The registry name of a method; an old spelling prints a deprecation line and maps over."""
    from neckid.registry import DEPRECATED_NAMES, get_method

    if name in DEPRECATED_NAMES:
        console.print(
            f"[yellow]deprecated:[/yellow] method name {name!r} will be removed in the next"
            f" release; use {DEPRECATED_NAMES[name]!r}"
        )
        return DEPRECATED_NAMES[name]
    return get_method(name).name


def _metrics_table(title: str, rows: list[dict[str, Any]]) -> Table:
    table = Table(title=title)
    for key in rows[0]:
        table.add_column(key, justify="right" if key != "output" else "left")
    for row in rows:
        table.add_row(*(f"{v:.3f}" if isinstance(v, float) else str(v) for v in row.values()))
    return table


@app.command()
@handled
def demo(
    out: Path = typer.Option(
        Path("neckid-demo"), "--out", help="Folder for report.html, metrics.json, figures, models."
    ),
    quick: bool = typer.Option(
        False, "--quick", help="Shorter records and fewer lag candidates (about 3x faster)."
    ),
    paper_regressor: bool = typer.Option(
        False,
        "--paper-regressor",
        help="Use the paper's regressor y(t-1..t-3), u(t-8..t-10) instead of selecting one.",
    ),
    seed: int = typer.Option(
        0,
        "--seed",
        min=0,
        help="Seed (>= 0) of the neck's noise, the excitations and the networks.",
    ),
    force: bool = typer.Option(
        False, "--force", help="Replace the files of an existing --out folder."
    ),
) -> None:
    """Run the paper's whole protocol on the built-in simulated neck and write a report.

    Bandwidth from the up-chirp, identification by Set Membership (pure and with a linear part),
    neural NARX 2x25, linear ARX and the CFF-RLS inclination-scheduled model, validation, and the
    three closed-loop tests (2 rad/s sine, 5 deg staircase, 20 deg step). Fits are NRMSE fits [%]
    of free-run simulations; errors are in degrees of inclination.
    """
    import numpy as np
    from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from neckid.experiments.paper import EXPERIMENTS, DemoSettings, run_demo

    settings = DemoSettings.make(quick=quick, seed=seed, paper_regressor=paper_regressor)
    n_steps = 7
    with Progress(
        SpinnerColumn(),
        TextColumn("{task.description}"),
        BarColumn(),
        TimeElapsedColumn(),
        console=console,
        transient=True,
    ) as progress:
        task = progress.add_task("starting", total=n_steps)

        def on_step(text: str) -> None:
            progress.update(task, description=text, advance=1)
            if not console.is_terminal:  # no live bar: plain log lines
                console.print(f"[{int(progress.tasks[0].completed)}/{n_steps}] {text}")

        result = run_demo(out, settings, on_step=on_step, force=force)
    console.print(
        f"bandwidth of the simulated neck: {result.bandwidth:.2f} rad/s (paper: 4.2 rad/s)"
    )
    console.print(f"regressor: {result.lags!r}")
    table = Table(title="Free-run fit [%] (ours above, the paper's own neck below)")
    table.add_column("model")
    for experiment in EXPERIMENTS:
        table.add_column(experiment, justify="right")
    for i, (name, row) in enumerate(result.table.iterrows()):
        cells = [f"{v:.2f}" if np.isfinite(v) else "-" for v in row.to_numpy(dtype=float)]
        table.add_row(str(name), *cells, end_section=i == len(result.mae) - 1)
    console.print(table)
    mae = Table(title="Mean absolute error [deg]")
    mae.add_column("model")
    for experiment in EXPERIMENTS:
        mae.add_column(experiment, justify="right")
    for name, row in result.mae.iterrows():
        mae.add_row(str(name), *(f"{v:.3f}" for v in row.to_numpy(dtype=float)))
    console.print(mae)
    console.print(f"report: {result.files['report']}  ({result.wall_time:.1f} s)")


LOG_HELP = "Log file: CSV with a header row (or .parquet / .mat), or a headerless soft-neck log with --layout softneck."
INPUTS_HELP = "Comma-separated input channel names (e.g. velocity_command)."
OUTPUTS_HELP = "Comma-separated output channel names (e.g. inclination, in degrees)."
TIME_HELP = "Name of the time column (seconds). Ignored when --ts is given."
TS_HELP = "Sampling period in seconds, for a log without a time column."
SEP_HELP = "Column separator of a CSV log, e.g. ';' or '\\t' (tab)."
LAYOUT_HELP = (
    "'csv' (a header row names the columns) or 'softneck' (the UC3M bench's headerless logs;"
    " 3 columns: time, inclination_filtered, motor_position; 6 columns add inclination,"
    " velocity_command, motor_velocity; 7 columns add control_filtered)."
)
MAP_HELP = (
    "MODEL_CHANNEL=LOG_CHANNEL: read a model channel from a log column of another name, e.g."
    " inclination=inclination_filtered (repeat the option for several)."
)


@app.command()
@handled
def identify(
    log: Path = typer.Argument(..., help=LOG_HELP, exists=True, dir_okay=False),
    inputs: str = typer.Option(None, "--inputs", help=INPUTS_HELP),
    outputs: str = typer.Option(None, "--outputs", help=OUTPUTS_HELP),
    method: str = typer.Option(
        "sm",
        "--method",
        help="arx | rls | sm | sm-linear | sm-parallel | nn | scheduled (neckid.methods()).",
    ),
    lags: str = typer.Option(
        "1-3/8-10",
        "--lags",
        help="OUTPUT_LAGS/INPUT_LAGS in samples, e.g. 1-3/8-10 (the paper's regressor).",
    ),
    save: Path = typer.Option(
        Path("model.npz"), "--save", help="Where to write the model (.npz, no pickle)."
    ),
    time: str = typer.Option("time", "--time", help=TIME_HELP),
    ts: float = typer.Option(None, "--ts", help=TS_HELP),
    layout: str = typer.Option("csv", "--layout", help=LAYOUT_HELP),
    sep: str = typer.Option(",", "--sep", help=SEP_HELP),
    seed: int = typer.Option(
        0, "--seed", min=0, help="Seed (>= 0) of the neural network's initial weights."
    ),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
) -> None:
    """Identify a model from a log and save it.

    Example: neckid identify run.csv --inputs velocity_command --outputs inclination --method sm --lags 1-3/8-10
    """
    from neckid.outputs import check_output_file
    from neckid.workflow import make_estimator, parse_lags, read_log

    save = save if save.suffix == ".npz" else save.with_name(save.name + ".npz")
    check_output_file(save, force=force, inputs=[log], option="--save")
    data = read_log(
        log,
        _split(inputs),
        _split(outputs),
        time=time,
        ts=ts,
        layout=layout,  # type: ignore[arg-type]
        sep=_sep(sep),
    )
    method = _method_name(method)
    estimator = make_estimator(method, parse_lags(lags), random_state=seed)
    estimator.fit(data)
    result = estimator.simulate(data)  # a diverging model stops here, before it is saved
    fits, rmses = result.fit_percent(data), result.rmse(data)
    path = estimator.save(save)
    rows = [
        {"output": name, "fit %": float(f), f"RMSE [{unit or '-'}]": float(r)}
        for name, unit, f, r in zip(data.output_names, data.output_units, fits, rmses, strict=True)
    ]
    console.print(
        _metrics_table(
            f"{_describe_model(estimator)} on {log.name} (free run, training data)", rows
        )
    )
    console.print(f"model saved to {path}")


def _sep(text: str) -> str:
    """The separator the user typed; a backslash and a t (as a shell passes it) means a tab."""
    return "\t" if text == "\\t" else text


def _load_for_model(
    model_path: Path,
    log: Path,
    time: str,
    ts: float | None,
    layout: str,
    sep: str = ",",
    maps: list[str] | None = None,
) -> tuple[Any, Any]:
    from neckid.models.io import load_model
    from neckid.workflow import map_channels, parse_mapping, read_log

    model = load_model(model_path)
    mapping = parse_mapping(maps or [])  # log name -> model name
    to_log = {v: k for k, v in mapping.items()}
    ins, outs = ([to_log.get(n, n) for n in names] for names in _model_channels(model))
    data = read_log(log, ins, outs, time=time, ts=ts, layout=layout, sep=_sep(sep))  # type: ignore[arg-type]
    return model, map_channels(data, mapping) if mapping else data


def _describe_model(model: Any) -> str:
    """The label of the model's method (``Set Membership + linear``), or its class name."""
    from neckid.registry import method_of

    method = method_of(model)
    return method.label if method is not None else type(model).__name__


def _print_prior(model: Any) -> None:
    """ε and γ of a Set Membership model (or of the SM map of a parallel one), with units."""
    sm = getattr(model, "sm_", model)
    if not hasattr(sm, "gamma_"):
        return
    for name, unit, epsilon, gamma in zip(
        model.output_names_, model.output_units_, sm.epsilon_, sm.gamma_, strict=True
    ):
        shown = f" {unit}" if unit else ""
        console.print(
            f"Set Membership prior for {name}: noise bound ε = {epsilon:.4g}{shown}, Lipschitz"
            f" constant γ = {gamma:.4g}{shown} per unit of the scaled regressor"
        )


def _report_extrapolation(result: Any) -> None:
    from neckid.models.base import EXTRAPOLATION_WARNING

    shares = result.extras.get("extrapolation", {})
    far = {k: v for k, v in shares.items() if v > EXTRAPOLATION_WARNING}
    if far:
        error_console.print(
            "[yellow]warning:[/yellow] the log leaves the range the model was identified on: "
            + ", ".join(f"{k} {v:.0%} of the samples" for k, v in far.items())
            + "; expect a poor fit there",
            highlight=False,
            soft_wrap=True,
        )


@app.command()
@handled
def validate(
    model_path: Path = typer.Argument(
        ..., metavar="MODEL", help="A model file written by identify.", exists=True
    ),
    log: Path = typer.Argument(..., help=LOG_HELP, exists=True, dir_okay=False),
    time: str = typer.Option("time", "--time", help=TIME_HELP),
    ts: float = typer.Option(None, "--ts", help=TS_HELP),
    layout: str = typer.Option("csv", "--layout", help=LAYOUT_HELP),
    sep: str = typer.Option(",", "--sep", help=SEP_HELP),
    maps: list[str] = typer.Option(None, "--map", help=MAP_HELP),
    plot: Path = typer.Option(None, "--plot", help="Write a PNG of measured vs simulated output."),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
) -> None:
    """Free-run simulate a saved model on a log and print fit (%), RMSE and MAE per output.

    Fit is MATLAB's compare fit, 100 (1 - ||y - ŷ|| / ||y - mean(y)||), skipping the initial samples.
    A free run that diverges is reported as such (exit status 3).
    """
    from neckid.models.base import DivergenceError
    from neckid.outputs import atomic_path, check_output_file

    if plot is not None:
        check_output_file(plot, force=force, inputs=[log, model_path], option="--plot")
    model, data = _load_for_model(model_path, log, time, ts, layout, sep, maps)
    try:
        result = model.simulate(data)
    except DivergenceError as exc:
        error_console.print(f"[red]diverged:[/red] {exc}", highlight=False, soft_wrap=True)
        raise typer.Exit(code=3) from None
    fits, rmses, maes = result.fit_percent(data), result.rmse(data), result.mae(data)
    rows = [
        {
            "output": n,
            "fit %": float(f),
            f"RMSE [{unit or '-'}]": float(r),
            f"MAE [{unit or '-'}]": float(m),
        }
        for n, unit, f, r, m in zip(
            data.output_names, data.output_units, fits, rmses, maes, strict=True
        )
    ]
    console.print(_metrics_table(f"{_describe_model(model)} on {log.name} (free run)", rows))
    _print_prior(model)
    _report_extrapolation(result)
    if plot is not None:
        from neckid.report.plots import plot_simulation

        label = _describe_model(model)
        fig = plot_simulation(
            data,
            {label: result},
            title=f"{label} on {log.name}: free run, fit {float(fits[0]):.1f} %",
            residuals=True,
        )
        with atomic_path(plot) as temporary:
            fig.savefig(temporary, dpi=120, format="png")
        console.print(f"figure written to {plot}")


@app.command()
@handled
def simulate(
    model_path: Path = typer.Argument(
        ..., metavar="MODEL", help="A model file written by identify.", exists=True
    ),
    log: Path = typer.Argument(..., help=LOG_HELP, exists=True, dir_okay=False),
    out: Path = typer.Option(
        Path("simulation.csv"), "--out", help="CSV to write: time, inputs, outputs (and bounds)."
    ),
    time: str = typer.Option("time", "--time", help=TIME_HELP),
    ts: float = typer.Option(None, "--ts", help=TS_HELP),
    layout: str = typer.Option("csv", "--layout", help=LAYOUT_HELP),
    sep: str = typer.Option(",", "--sep", help=SEP_HELP),
    maps: list[str] = typer.Option(None, "--map", help=MAP_HELP),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    keep_diverged: bool = typer.Option(
        False,
        "--keep-diverged",
        help="Write the run even when it diverges (non-finite values); exit status 3 still.",
    ),
) -> None:
    """Free-run simulate a saved model with the inputs of a log; write time, inputs and outputs to CSV.

    The log's first max-lag outputs are the initial conditions; Set Membership models add
    OUTPUT_lower and OUTPUT_upper columns (OUTPUT: each output's name). A run that diverges is not written (exit status 3)
    unless --keep-diverged.
    """
    from neckid.models.base import DivergenceError
    from neckid.outputs import atomic_path, check_output_file

    check_output_file(out, force=force, inputs=[log, model_path])
    model, data = _load_for_model(model_path, log, time, ts, layout, sep, maps)
    diverged: DivergenceError | None = None
    try:
        result = model.simulate(data)
    except DivergenceError as exc:
        diverged, result = exc, exc.result
        error_console.print(f"[red]diverged:[/red] {exc}", highlight=False, soft_wrap=True)
        if not keep_diverged:
            raise typer.Exit(code=3) from None
    with atomic_path(out) as temporary:
        result.to_frame().to_csv(temporary, index=False)
    console.print(f"{result.n_samples} samples written to {out}")
    _report_extrapolation(result)
    if diverged is not None:
        raise typer.Exit(code=3)


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
    time: str = typer.Option("time", "--time", help=TIME_HELP),
    ts: float = typer.Option(None, "--ts", help=TS_HELP),
    layout: str = typer.Option("csv", "--layout", help=LAYOUT_HELP),
    sep: str = typer.Option(",", "--sep", help=SEP_HELP),
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
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
) -> None:
    """Find the bandwidth (rad/s) of a chirp run: where the response amplitude stays below 90 % of the command's.

    The rule compares the two amplitudes, so command and response must be in one unit (the
    paper's closed-loop reference and inclination, both in degrees): a run whose amplitude ratio
    at the slow start of the chirp is far from 1 is refused.
    """
    import numpy as np

    from neckid.outputs import atomic_path, check_output_file
    from neckid.signals import bandwidth_from_chirp, paper_chirp_frequency
    from neckid.workflow import read_log

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


@app.command()
@handled
def benchmark(
    data_dir: Path = typer.Option(
        ...,
        "--data-dir",
        help="Folder holding softneck/ and benchmarks/NAME/ (e.g. ../shared/data).",
        exists=True,
        file_okay=False,
    ),
    methods: str = typer.Option(
        None,
        "--methods",
        help=(
            "Comma-separated registry names: arx, sm, sm-linear, sm-parallel, nn, scheduled"
            " (default all)."
        ),
    ),
    only: str = typer.Option(
        None,
        "--only",
        help="Comma-separated benchmarks: softneck, silverbox, cascaded_tanks, bouc_wen, robot_arm.",
    ),
    out: Path = typer.Option(
        Path("neckid-benchmark"),
        "--out",
        help="Folder for benchmark.csv, published.csv, benchmark.json.",
    ),
    quick: bool = typer.Option(
        False, "--quick", help="Smoke run on short subsets; not for reporting."
    ),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed (>= 0) of the neural networks."),
    force: bool = typer.Option(
        False, "--force", help="Replace the files of an existing --out folder."
    ),
) -> None:
    """Run the models on real logs and public benchmarks with their official protocols.

    Free-run simulation; RMSE in each benchmark's unit (Silverbox mV, cascaded tanks V, Bouc-Wen m,
    soft neck deg) next to the published figures; wall time of each method.
    """
    from neckid.experiments.benchmark import BENCHMARK_METHODS, run_benchmark

    names = [_method_name(n) for n in dict.fromkeys(_split(methods) or BENCHMARK_METHODS)]
    # Long work reports progress: one line per data set and method, in a terminal or a log file.
    logging.getLogger("neckid.experiments.benchmark").setLevel(logging.INFO)
    report = run_benchmark(
        data_dir,
        methods=names,
        benchmarks=_split(only),
        quick=quick,
        seed=seed,
        output_dir=out,
        force=force,
    )
    console.print(report.rich_table())
    if len(report.published):
        console.print(report.published_rich_table())
    if report.details.get("missing"):
        console.print(f"not found under {data_dir}: {', '.join(report.details['missing'])}")
    console.print(f"written to {out}/")
    failed = report.table[report.table["note"].astype(str).str.startswith("failed")]
    if len(failed):
        pairs = sorted({f"{r.method} on {r.benchmark}" for r in failed.itertuples()})
        error_console.print(
            f"[red]error:[/red] {len(failed)} row(s) failed ({', '.join(pairs)}); the note column"
            " of benchmark.csv says why"
        )
        raise typer.Exit(code=1)


@app.command()
@handled
def info(
    path: Path = typer.Argument(
        None,
        help="A log or a model file (.npz); without it, the versions of neckid and its libraries.",
    ),
    layout: str = typer.Option("csv", "--layout", help=LAYOUT_HELP),
    time: str = typer.Option("time", "--time", help=TIME_HELP),
    sep: str = typer.Option(",", "--sep", help=SEP_HELP),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of tables."),
) -> None:
    """Describe a log or a model file; without a path, print the versions of the libraries.

    A log: channels, units, duration, sampling period, gaps. A model file: method, regressor,
    channels, sampling period, the Set Membership prior, the training range of each channel.
    """
    from neckid.workflow import describe_log, describe_model

    if path is None:
        from neckid.report.html import library_versions

        console.print_json(json.dumps(library_versions()))
        return
    if not path.exists():
        raise FileNotFoundError(f"{str(path)!r} does not exist")
    if path.suffix == ".npz":
        from neckid.models.io import load_model

        described = describe_model(load_model(path))
        if as_json:
            console.print_json(json.dumps(described))
            return
        table = Table(title=f"{path.name}: {described['method']}", show_header=False)
        for key in ("class", "lags", "inputs", "outputs", "output_units", "ts_s",
                    "initial_samples", "training_samples", "epsilon", "gamma"):  # fmt: skip
            if key in described:
                table.add_row(
                    key.replace("_s", " [s]") if key == "ts_s" else key, str(described[key])
                )
        for name, (low, high) in described["training_ranges"].items():
            table.add_row(f"training range of {name}", f"{low:.4g} .. {high:.4g}")
        console.print(table)
        return
    described = describe_log(path, layout=layout, time=time, sep=_sep(sep))  # type: ignore[arg-type]
    if as_json:
        console.print_json(json.dumps(described))
        return
    console.print(
        f"{described['file']}: {described['samples']} samples over {described['duration_s']:.4g} s,"
        f" ts = {described['ts_s']:.6g} s (largest step {described['max_step_s']:.6g} s,"
        f" {described['gaps']} gap(s) over 1.5 ts)"
    )
    table = Table(title="channels")
    for column in ("channel", "kind", "unit", "min", "max", "mean", "non-numeric"):
        table.add_column(
            column, justify="left" if column in ("channel", "kind", "unit") else "right"
        )
    for name, channel in described["channels"].items():
        table.add_row(
            name, channel["kind"], channel["unit"] or "-", f"{channel['min']:.4g}",
            f"{channel['max']:.4g}", f"{channel['mean']:.4g}", str(channel["non_numeric"]),
        )  # fmt: skip
    console.print(table)
