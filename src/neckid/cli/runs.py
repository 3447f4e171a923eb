"""Commands that run a whole protocol: demo (simulated neck) and benchmark (real data)."""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import typer
from rich.markup import escape
from rich.table import Table

from neckid.cli._app import (
    SCHEDULER_OPTION,
    _fail,
    _method_name,
    _on_scheduler,
    _split,
    app,
    console,
    error_console,
    handled,
)


@contextmanager
def _steps(n_steps: int) -> Iterator[Callable[[str], None]]:
    """A rich progress bar over a protocol's steps; plain log lines when not in a terminal."""
    from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

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
                done = int(progress.tasks[0].completed)
                console.print(f"step {done}/{n_steps}: {text}", markup=False)

        yield on_step


def _demo3d(out: Path, *, quick: bool, seed: int, force: bool) -> None:
    """``neckid demo --3d``: run the 3-D protocol and print its tables."""
    import numpy as np

    from neckid.experiments.neck3d import Demo3DSettings, run_demo3d

    with _steps(6) as on_step:
        result = run_demo3d(
            out, Demo3DSettings.make(quick=quick, seed=seed), on_step=on_step, force=force
        )
    bands = ", ".join(f"{d:g} deg: {b:.2f}" for d, b in result.bandwidths.items())
    console.print(f"bandwidth per tilt direction [rad/s]: {bands}", markup=False)
    console.print(f"regressor: {result.lags!r}")
    records = list(dict.fromkeys(column[0] for column in result.fit.columns))
    for title, frame, pair, digits in (
        ("Free-run fit [%]: tilt_x / tilt_y", result.fit, ("tilt_x", "tilt_y"), 1),
        (
            "Mean absolute error [deg]: inclination / orientation",
            result.mae,
            ("inclination", "orientation"),
            2,
        ),
    ):
        table = Table(title=escape(title))
        table.add_column("model")
        for record in records:
            table.add_column(record, justify="right")
        for name in frame.index:
            cells = []
            for record in records:
                a, b = (float(frame.loc[name, (record, key)]) for key in pair)
                cells.append(
                    " / ".join(f"{v:.{digits}f}" if np.isfinite(v) else "-" for v in (a, b))
                )
            table.add_row(str(name), *cells)
        console.print(table)
    console.print(f"report: {result.files['report']}  ({result.wall_time:.1f} s)")


@app.command()
@handled
def demo(
    out: Path = typer.Option(
        None,
        "--out",
        help="Folder for report.html, metrics.json, figures, models (default neckid-demo, or"
        " neckid-demo-3d with --3d).",
        show_default=False,
    ),
    quick: bool = typer.Option(
        False,
        "--quick",
        help="Shorter records and fewer lag candidates (about 1.6x faster on 2 cores).",
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
    three_d: bool = typer.Option(
        False,
        "--3d",
        help="The three-tendon neck instead: three motor positions in, the tilt vector out.",
    ),
    frequency: bool = typer.Option(
        False,
        "--frequency",
        help="The frequency demo instead: a random-odd multisine on the neck's loop, its BLA and"
        " distortion levels (docs/frequency.md).",
    ),
) -> None:
    """Run the paper's whole protocol on the built-in simulated neck and write a report.

    Bandwidth from the up-chirp, identification by Set Membership (pure and with a linear part),
    neural NARX 2x25, linear ARX and the CFF-RLS inclination-scheduled model, validation, and the
    three closed-loop tests (2 rad/s sine, 5 deg staircase, 20 deg step). Fits are NRMSE fits [%]
    of free-run simulations; errors are in degrees of inclination.

    With --3d: the three-tendon neck. Bandwidth per tilt direction, a tendon-space multisine with
    a pre-tension, every MIMO method from the three motor positions [rad] to the tilt vector
    (tilt_x, tilt_y) [deg], and three 3-D closed-loop tests (a circle at 15 deg, orientation
    steps, a 20 deg step on a diagonal), scored per tilt component and in inclination and
    orientation.
    """
    import numpy as np

    from neckid.experiments.paper import EXPERIMENTS, DemoSettings, run_demo

    if frequency:
        from neckid.cli.frequency import frequency_demo_command

        frequency_demo_command(out or Path("neckid-demo-frequency"), seed=seed, force=force)
        return
    if three_d:
        if paper_regressor:
            _fail("--paper-regressor has one motor; --3d selects its own regressor")
        _demo3d(out or Path("neckid-demo-3d"), quick=quick, seed=seed, force=force)
        return
    settings = DemoSettings.make(quick=quick, seed=seed, paper_regressor=paper_regressor)
    with _steps(8) as on_step:
        result = run_demo(out or Path("neckid-demo"), settings, on_step=on_step, force=force)
    console.print(
        f"bandwidth of the simulated neck: {result.bandwidth:.2f} rad/s (paper: 4.2 rad/s)"
    )
    console.print(f"regressor: {result.lags!r}")
    table = Table(title=escape("Free-run fit [%] (ours above, the paper's own neck below)"))
    table.add_column("model")
    for experiment in EXPERIMENTS:
        table.add_column(experiment, justify="right")
    for i, (name, row) in enumerate(result.table.iterrows()):
        cells = [f"{v:.2f}" if np.isfinite(v) else "-" for v in row.to_numpy(dtype=float)]
        table.add_row(str(name), *cells, end_section=i == len(result.mae) - 1)
    console.print(table)
    mae = Table(title=escape("Mean absolute error [deg]"))
    mae.add_column("model")
    for experiment in EXPERIMENTS:
        mae.add_column(experiment, justify="right")
    for name, row in result.mae.iterrows():
        mae.add_row(str(name), *(f"{v:.3f}" for v in row.to_numpy(dtype=float)))
    console.print(mae)
    console.print(f"report: {result.files['report']}  ({result.wall_time:.1f} s)")


@app.command()
@handled
def warmup() -> None:
    """Compile neckid's kernels into their on-disk cache now, once after installing.

    Runs the quick demo on the simulated neck in a temporary folder (deleted afterwards), which
    compiles every kernel the demo and a first identification use; later processes load them
    from the cache instead of compiling (``make`` does this as part of the install).
    """
    import os
    import tempfile
    import time

    from neckid.experiments.paper import DemoSettings, run_demo

    started = time.perf_counter()
    settings = DemoSettings.make(quick=True, seed=0, paper_regressor=False)
    console.print(
        "compiling neckid's kernels into their cache (a minute or two, once)", markup=False
    )
    with tempfile.TemporaryDirectory(prefix="neckid-warmup-") as folder:
        # the demo's steps are not the user's business here: no step lines, one line at the end
        run_demo(Path(folder) / "demo", settings, on_step=lambda _text: None)
    where = os.environ.get("NUMBA_CACHE_DIR") or "beside the package's sources"
    console.print(
        f"kernels compiled and cached in {time.perf_counter() - started:.1f} s ({where})",
        markup=False,
    )


def _cell(value: object) -> str:
    """A table cell: text as it is, a number to 2 decimals; −inf (a diverged run) and NaN said."""
    if isinstance(value, str):
        return value
    number = float(value)  # type: ignore[arg-type]
    if number != number:
        return "–"  # nothing to measure (no oscillation, no int log)
    return "diverged" if number == float("-inf") else f"{number:.2f}"


#: The protocol that runs every method in the lab's loops of the payload split's test logs.
IN_LOOP = "softneck-in-loop"


def _in_loop_benchmark(
    data_dir: Path, methods: list[str], quick: bool, seed: int, out: Path, force: bool
) -> None:
    """The softneck-in-loop protocol: its rankings printed, its tables written into ``out``."""
    from neckid.experiments.benchmark import PEER_METHODS
    from neckid.experiments.benchmark.in_loop import run_in_loop_benchmark
    from neckid.utils.files import output_folder

    with output_folder(out, force=force) as staged:
        report = run_in_loop_benchmark(
            data_dir, [m for m in methods if m not in PEER_METHODS], quick=quick, seed=seed
        )
        report.table.to_csv(staged.path("in_loop.csv"), index=False)
        rankings = report.rankings()
        rankings.to_csv(staged.path("in_loop_rankings.csv"), index=False)
    table = Table(title="softneck-in-loop: payload split, test logs (200 g, 400 g)")
    columns = {
        "method": "method",
        "free_run_fit": "free-run fit [%]",
        "inclination_fit": "in-loop fit [%]",
        "command_fit": "command fit [%]",
        "int_period_ratio": "PI period ratio [-]",
        "int_tracking_ratio": "PI tracking ratio [-]",
    }
    for header in columns.values():
        table.add_column(header, justify="left" if header == "method" else "right")
    for row in rankings.to_dict("records"):
        table.add_row(*(_cell(row[k]) for k in columns))
    console.print(table)
    diverged = report.table[report.table["diverged_at"].notna()]
    for run in diverged.to_dict("records"):
        error_console.print(
            f"[yellow]diverged in the loop:[/yellow] {escape(str(run['method']))} on"
            f" {escape(str(run['log']))} at row {int(float(run['diverged_at']))} (its in-loop fit"
            " counts as -inf in the mean)",
            highlight=False,
        )
    console.print(f"in-loop tables written to {out}/ (in_loop.csv, in_loop_rankings.csv)")


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
            "Comma-separated registry names: arx, ss, pnlss, greybox-neck, poly, sm, sm-linear,"
            " sm-parallel, sm-parallel-poly, nn, scheduled, lpv, koopman, sm-parallel-koopman,"
            " sindy, sm-parallel-sindy, and the peers sysidentpy-frols (SysIdentPy's FROLS) and"
            " pysindy-stlsq (PySINDy's DiscreteSINDy; both: pip install 'neckid[peers]');"
            " the peer pykoopman-edmdc runs in the python NECKID_PYKOOPMAN_PYTHON names (pykoopman"
            " pins NumPy 1.26). Default: every neckid method but"
            " lpv (its grid multiplies the lags by three degrees); lpv and the peer run when named."
        ),
    ),
    only: str = typer.Option(
        None,
        "--only",
        help="Comma-separated benchmarks: softneck, softneck-payload, softneck-controller (cross-run),"
        " silverbox, cascaded_tanks, bouc_wen, robot_arm, and softneck-in-loop (every method in"
        " the lab's loops of the payload split; not in the default run; its tables go into"
        " --out, or --out/softneck-in-loop beside others).",
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
    scheduler: str = SCHEDULER_OPTION,
    jobs: int = typer.Option(
        -1,
        "--jobs",
        help="Parallel candidate fits on this machine (-1: every core; 1: one at a time). The"
        " table is the same either way.",
    ),
) -> None:
    """Run the models on real logs and public benchmarks with their official protocols.

    Free-run simulation; RMSE in each benchmark's unit (Silverbox mV, cascaded tanks V, Bouc-Wen m,
    soft neck deg) next to the published figures; wall time of each method.

    With --scheduler, the hyper-parameter candidates are fitted on the workers of a Dask cluster
    (the final fits and the test simulations too); the table is that of a local run.
    """
    from neckid.experiments.benchmark import DEFAULT_METHODS, PEER_METHODS, run_benchmark

    asked = dict.fromkeys(_split(methods) or DEFAULT_METHODS)
    names = [n if n in PEER_METHODS else _method_name(n) for n in asked]
    # Long work reports progress: one line per data set and method, in a terminal or a log file.
    logging.getLogger("neckid.experiments.benchmark").setLevel(logging.INFO)
    asked_only = _split(only)
    in_loop = asked_only is not None and IN_LOOP in asked_only
    rest = [b for b in asked_only if b != IN_LOOP] if asked_only is not None else None
    if in_loop and not rest:
        _in_loop_benchmark(data_dir, names, quick, seed, out, force)
        return
    with _on_scheduler(scheduler):
        report = run_benchmark(
            data_dir,
            methods=names,
            benchmarks=rest,
            quick=quick,
            seed=seed,
            output_dir=out,
            force=force,
            n_jobs=None if scheduler else jobs,
        )
    if in_loop:
        _in_loop_benchmark(data_dir, names, quick, seed, out / IN_LOOP, force)
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
