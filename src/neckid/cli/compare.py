"""``neckid compare``: which model for this neck, chosen on the training logs, run on the test logs."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.markup import escape

from neckid.cli._app import (
    FORCE_OPTION,
    LOG_HELP,
    _method_name,
    _metrics_table,
    _split,
    app,
    console,
    error_console,
    handled,
)
from neckid.cli._training import refuse_repeated_paths
from neckid.cli.adapt import ADAPT_HELP, ADAPT_MODE_HELP, checked_adaptation
from neckid.cli.explain import _save_panels
from neckid.cli.options import LogSpec, log_options, read_training_logs


def _read_all(paths: list[Path], spec: LogSpec) -> list[Any]:
    """The logs read as identify reads them (same channels, map and preprocessing), by file name."""
    experiments, _ = read_training_logs(paths, spec)
    return [data.renamed(path.name) for path, data in zip(paths, experiments, strict=True)]


def _number(value: float) -> float | str:
    """A value for the table: '–' where there is none (no band, a diverged run)."""
    return value if value == value and abs(value) != float("inf") else "–"


def _result_rows(comparison: Any) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    roles = _roles(comparison)
    fit = f"fit % ({comparison.kind})"
    adapted = "fit_percent_unadapted" in comparison.results
    for row in comparison.results.to_dict("records"):
        unit = row["unit"] or "-"
        plain = {"fit % un-adapted": _number(float(row.get("fit_percent_unadapted", "nan")))}
        rows.append(
            {
                "method": row["method"],
                "log": row["log"],
                "output": row["output"],
                fit: _number(float(row["fit_percent"])),
                **(plain if adapted else {}),
                f"RMSE [{unit}]": _number(float(row["rmse"])),
                "outside training range [%]": float(100 * row["outside_training_range"]),
                "outside model domain [%]": float(100 * row["outside_domain"]),
                f"band width [{unit}]": _number(float(row["band_width"])),
                "band holds [%]": _number(float(100 * row["band_coverage"])),
                **roles[row["method"]],
                "seconds": "",
            }
        )
    band_columns = [k for k in rows[0] if k.startswith("band ")] if rows else []
    means = comparison.results.groupby("method", sort=False)
    for row in comparison.summary().to_dict("records"):
        plain = {}
        if adapted:
            mean_plain = float(means["fit_percent_unadapted"].mean()[row["method"]])
            plain = {"fit % un-adapted": _number(mean_plain)}
        rows.append(
            {
                "method": row["method"],
                "log": "mean",
                "output": "all",
                fit: _number(float(row["fit_percent"])),
                **plain,
                "RMSE [-]": _number(float(row["rmse"])),
                "outside training range [%]": float(100 * row["outside_training_range"]),
                "outside model domain [%]": float(100 * row["outside_domain"]),
                **dict.fromkeys(band_columns, ""),  # the per-log rows' columns, kept aligned
                **roles[row["method"]],
                "seconds": _number(_method_seconds(comparison, row["method"])),
            }
        )
    return rows


def _method_seconds(comparison: Any, method: str) -> float:
    """Wall seconds the method took: its selection on the folds and its test runs."""
    spent = comparison.seconds.get(method)
    return float(sum(spent.values())) if spent else float("nan")


def _roles(comparison: Any) -> dict[str, dict[str, Any]]:
    """Per method: its mean fold fit and whether it is the chosen or the best on the folds."""
    selection = comparison.selection
    table = selection.table.set_index("name")
    best_method = selection.best.split(" ")[0]
    roles = {}
    for method, setting in comparison.settings.items():
        words = ["chosen"] if setting["candidate"] == selection.chosen else []
        words += ["best on the folds"] if method == best_method else []
        roles[method] = {
            "mean fold fit [%]": _number(float(table.loc[setting["candidate"], "fit_mean"])),
            "choice": ", ".join(words),
        }
    return roles


def _baseline_line(baselines: dict[str, float]) -> str:
    """The naive references' mean fold fits in one line (replay: only where it applies)."""
    shown = ", ".join(f"{name} {value:.1f} %" for name, value in baselines.items())
    return f"baselines on the same folds: {shown or 'none applies'}"


def _write_plot(comparison: Any, tests: list[Any], path: Path) -> None:
    """Measured output of each test log against every method's free run, one panel per log.

    The runs are those of the comparison (a diverged one is left out: the table says it).
    """
    panels = [
        (record, runs, f"{record.name}: {comparison.kind}", None)
        for record, runs in zip(tests, comparison.runs, strict=True)
    ]
    _save_panels(panels, path)


def _write_report(comparison: Any, tests: list[Any], folder: Path, force: bool) -> None:
    import pandas as pd

    from neckid.report.html import Figure, Report
    from neckid.utils.files import output_folder

    with output_folder(folder, force=force) as staged:
        report = Report("neckid compare")
        report.add_text(
            "Recommended",
            f"{comparison.recommended}. "
            + " ".join(
                [
                    *comparison.reasons,
                    _baseline_line(comparison.selection.baselines) + ".",
                    *(f"Warning: {w}." for w in comparison.warnings),
                ]
            ),
        )
        selection = comparison.selection.table.drop(columns=["fold_fits"]).rename(
            columns={
                "fit_mean": "mean fold fit [%]",
                "fit_se": "standard error [points]",
                "fit_worst": "worst fold fit [%]",
                "diff_best": "mean difference to the best [points]",
                "diff_se": "its standard error [points]",
                "bar": "bar [%]",
            }
        )
        report.add_table(
            f"Selection on the training logs ({comparison.selection.scheme})",
            selection,
            note="Free-run NRMSE fit per held-out fold, every candidate on the same folds; a"
            " candidate that fails or runs away in any fold is rejected; the simplest whose"
            " mean per-fold difference to the best is within one standard error of that"
            " difference (or half a point) is chosen (the paired rule).",
        )
        report.add_table(
            f"Test logs ({comparison.kind})",
            pd.DataFrame(_result_rows(comparison)),
            note="Fit: 100 (1 − ||y − ŷ|| / ||y − mean(y)||), free run from the log's inputs.",
        )
        _write_plot(comparison, tests, staged.path("compare.png"))
        report.add_figures("Free runs", [Figure(staged.path("compare.png"), "every method")])
        report.write(staged.path("report.html"))
    console.print(f"report written to {folder / 'report.html'}")


@app.command()
@handled
@log_options(training=True)
def compare(
    train: list[Path] = typer.Argument(
        ...,
        metavar="TRAIN...",
        help=LOG_HELP + " The training logs (one experiment each).",
        exists=True,
    ),
    test: list[Path] = typer.Option(
        ...,
        "--test",
        help="A test log (repeat the option); touched once, after every choice.",
        exists=True,
    ),
    methods: str = typer.Option(
        "arx,sm,sm-parallel",
        "--methods",
        help="Comma-separated registry names; arx is always added (the reference).",
    ),
    lags: list[str] = typer.Option(
        None,
        "--lags",
        help="OUTPUT_LAGS/INPUT_LAGS, e.g. 1-2/1-2 (repeat to try several; default 1-2/1-2).",
    ),
    stress: float = typer.Option(
        0.1,
        "--stress",
        min=0.0,
        help="Reject a candidate that runs away when the training inputs reach this fraction"
        " beyond their range (0 turns the check off).",
    ),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the methods that draw numbers."),
    use_conditions: str = typer.Option(
        None,
        "--use-conditions",
        help="Comma-separated conditions every candidate takes as constant inputs (e.g."
        " payload); each log must have them (file name, sidecar or --condition).",
    ),
    adapt: float = typer.Option(None, "--adapt", metavar="SECONDS", help=ADAPT_HELP),
    adapt_mode: str = typer.Option("offset", "--adapt-mode", help=ADAPT_MODE_HELP),
    json_out: Path = typer.Option(None, "--json", help="Write the comparison as JSON."),
    plot: Path = typer.Option(None, "--plot", help="Write a PNG of every method on each test log."),
    report: Path = typer.Option(None, "--report", help="Write an HTML report into this folder."),
    force: bool = FORCE_OPTION,
    *,
    spec: LogSpec,
) -> None:
    """Choose a model on the training logs, then free-run every method on the test logs.

    Selection uses the training logs only: folds over runs (leave one out, in time blocks when
    there are fewer than 6 logs; one log is cut into 3 time blocks), a candidate that fails or
    runs away in any fold is rejected with its reason, and the simplest candidate whose per-fold
    difference to the best is within one standard error of that difference is recommended; the
    training mean is scored on the same folds, and a recommendation below it or below 0 % is
    said in one warning line. Example: neckid compare run1.csv run2.csv --test run3.csv --inputs
    motor_position --outputs inclination --methods arx,sm,sm-parallel --json compare.json

    --map and the preprocessing options (--relative, --offset, --lowpass, --resample, --restamp,
    --tilt) apply to the training and the test logs alike. With --adapt 5 every free run, in
    the training folds and on the test logs, comes after 5 s of adaptation on the run's own
    start (docs/compare.md).
    """
    from neckid.cli.workflow import parse_lags
    from neckid.regressors import Lags
    from neckid.selection.comparison import compare as run_compare
    from neckid.utils.files import check_output_file, write_json

    adaptation = checked_adaptation(adapt, adapt_mode)
    conditions = _split(use_conditions) or ()
    given = [*train, *test]
    for path, option in ((json_out, "--json"), (plot, "--plot")):
        if path is not None:
            check_output_file(path, force=force, inputs=given, option=option)
    names = [_method_name(m) for m in _split(methods) or ["arx"]]
    regressors = []
    for text in lags or ["1-2/1-2"]:
        parsed = parse_lags(text)
        regressors.append(Lags(parsed.outputs, parsed.inputs, conditions=conditions))
    # the same channels, --map and preprocessing for the training and the test logs: spec
    refuse_repeated_paths([*train, *test], "log (a test log must not be a training log)")
    training, tests = _read_all(train, spec), _read_all(test, spec)
    result = run_compare(
        training,
        tests,
        names,
        regressors,
        stress=stress,
        seed=seed,
        progress=True,
        adapt=adaptation,
    )
    title = f"every method on the test logs ({result.kind})"
    console.print(_metrics_table(title, _result_rows(result)))
    for name, reason in result.selection.rejected.items():
        error_console.print(
            f"[yellow]rejected on the training logs:[/yellow] {escape(name)}: {escape(reason)}",
            highlight=False,
            soft_wrap=True,
        )
    console.print(f"recommended: {result.recommended}", markup=False)
    for reason in result.selection.explain():
        console.print(f"  {reason}", markup=False)
    console.print(f"  {_baseline_line(result.selection.baselines)}", markup=False)
    for line in result.warnings:  # a result, not an error: the exit status stays 0
        console.print(f"[yellow]warning:[/yellow] {escape(line)}", highlight=False, soft_wrap=True)
    if json_out is not None:
        write_json(json_out, result.to_json())
        console.print(f"comparison written to {json_out}")
    if plot is not None:
        _write_plot(result, tests, plot)
        console.print(f"figure written to {plot}")
    if report is not None:
        _write_report(result, tests, report, force)
