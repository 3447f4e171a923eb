"""Commands on models: identify, validate, simulate."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
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
from neckid.cli._training import (
    LAGS_OPTION,
    ORDERS_OPTION,
    _method_settings,
    _regressor,
    _regressor_text,
)
from neckid.cli.adapt import ADAPT_HELP, ADAPT_MODE_HELP, checked_adaptation, validate_adapted
from neckid.cli.explain import (
    _describe_model,
    _print_band,
    _print_domain,
    _print_horizons,
    _print_prior,
    _print_prior_check,
    _report_extrapolation,
    _save_figure,
    _save_panels,
)
from neckid.cli.frequency import BODE_HELP, MULTISINE_HELP, bode_validation, parse_multisine
from neckid.cli.in_loop import CONTROLLER_HELP, validate_in_loop
from neckid.cli.options import (
    LogSpec,
    attach_log_options,
    log_options,
    read_for_model,
    read_training_logs,
)
from neckid.cli.resid import RESID_HELP, resid_record
from neckid.registry import methods


@app.command()
@handled
@log_options(training=True)
def identify(
    logs: list[Path] = typer.Argument(
        ...,
        metavar="LOG...",
        help=LOG_HELP + " Several logs are several experiments of one model.",
        exists=True,
    ),
    method: str = typer.Option(
        "sm",
        "--method",
        help=" | ".join(methods()) + " (neckid.methods()).",
    ),
    lags: str = LAGS_OPTION,
    orders: str = ORDERS_OPTION,
    save: Path = typer.Option(
        Path("model.npz"), "--save", help="Where to write the model (.npz, no pickle)."
    ),
    seed: int = typer.Option(
        0, "--seed", min=0, help="Seed (>= 0) of the neural network's initial weights."
    ),
    use_conditions: str = typer.Option(
        None,
        "--use-conditions",
        help="Comma-separated conditions the model takes as constant inputs (e.g. payload);"
        " each log must have them (file name, sidecar or --condition).",
    ),
    settings: list[str] = typer.Option(
        None,
        "--set",
        metavar="NAME=VALUE",
        help="A setting of the method (a keyword of its class), e.g. --set lipschitz=local or"
        " --set horizons=[40]; VALUE is read as JSON (numbers, true/false, lists), else as"
        " text (repeat the option).",
    ),
    json_out: Path = typer.Option(
        None, "--json", help="Write the model's regressor, settings and training fit as JSON."
    ),
    force: bool = FORCE_OPTION,
    *,
    spec: LogSpec,
) -> None:
    """Identify a model from one log or several (one experiment each) and save it.

    Example: neckid identify run.csv --inputs velocity_command --outputs inclination --method sm --orders 2,2,1

    The regressor: --orders NA,NB,NK (MATLAB's [na nb nk]: y(t-1..t-NA), u(t-NK..t-NK-NB+1))
    or --lags OUTPUT_LAGS/INPUT_LAGS (each lag listed: 1-3/8-10 is y(t-1..t-3), u(t-8..t-10);
    3/1 is y(t-3) alone). Neither: --orders 2,2,1 (the scheduled model: first order).
    neckid select chooses one on your logs.

    Preprocessing (--restamp, --tilt, --relative, --offset, --lowpass, --resample, in that order)
    is stored in the model and applied again by validate, simulate and info --model.
    """
    from neckid.cli.workflow import (
        make_estimator,
    )
    from neckid.utils.files import check_output_file, output_name

    save = output_name(save, ".npz", option="--save")
    check_output_file(save, force=force, inputs=list(logs), option="--save")
    if json_out is not None:
        check_output_file(json_out, force=force, inputs=[*logs, save], option="--json")
    experiments, pipeline = read_training_logs(logs, spec)
    method = _method_name(method)
    options = _method_settings(method, settings or ())
    regressor, chosen_by = _regressor(method, lags, orders, _split(use_conditions) or ())
    estimator = make_estimator(method, regressor, random_state=seed, **options)
    _warn_long_fit(method, sum(d.n_samples for d in experiments))
    estimator.fit(experiments if len(experiments) > 1 else experiments[0])
    records: list[dict[str, Any]] = []
    for log, data in zip(logs, experiments, strict=True):
        result = estimator.simulate(data)  # a diverging model stops here, before it is saved
        fits, rmses = result.fit_percent(data), result.rmse(data)
        records.extend(
            {
                "log": log.name,
                "output": name,
                "unit": unit,
                "fit_percent": float(f),
                "rmse": float(r),
            }
            for name, unit, f, r in zip(
                data.output_names, data.output_units, fits, rmses, strict=True
            )
        )
    rows = [
        {
            "log": r["log"],
            "output": r["output"],
            "fit %": r["fit_percent"],
            f"RMSE [{r['unit'] or '-'}]": r["rmse"],
        }
        for r in records
    ]
    attach_log_options(estimator, spec, pipeline)
    path = estimator.save(save)
    if pipeline:
        console.print(f"preprocessing stored in the model: {pipeline.describe()}", markup=False)
    if len(logs) == 1:
        rows = [{k: v for k, v in row.items() if k != "log"} for row in rows]
    where = logs[0].name if len(logs) == 1 else f"{len(logs)} logs"
    console.print(
        _metrics_table(f"{_describe_model(estimator)} on {where} (free run, training data)", rows)
    )
    console.print(f"regressor: {_regressor_text(estimator)} ({chosen_by})", markup=False)
    console.print(f"model saved to {path}")
    if json_out is not None:
        from neckid.utils.files import write_json

        document = _identify_summary(path, method, estimator, chosen_by, options, pipeline, records)
        write_json(json_out, document)
        console.print(f"summary written to {json_out}")


#: Samples above which a Set Membership fit is announced as long (see _warn_long_fit).
LONG_SM_SAMPLES = 100_000


def _warn_long_fit(method: str, n_samples: int) -> None:
    """Say up front that a Set Membership fit on a long log takes minutes, and what is faster."""
    if not method.startswith("sm") or n_samples < LONG_SM_SAMPLES:
        return
    error_console.print(
        f"note: {method} on {n_samples:,} samples takes minutes: its prior compares pairs of"
        " samples and its free run searches the data set at every step (measured on 2 cores:"
        " 200,000 samples 1.6 min, 1,000,000 samples 9 min, with the free run on the training"
        " data). --method arx fits in seconds; resampling to a longer period (--resample) makes"
        " the log shorter.",
        markup=False,
        highlight=False,
    )


def _identify_summary(
    path: Path,
    method: str,
    estimator: Any,
    chosen_by: str,
    options: dict[str, Any],
    pipeline: Any,
    records: list[dict[str, Any]],
) -> dict[str, Any]:
    """What ``identify --json`` writes: the model, its regressor and settings, the training fit."""
    return {
        "model": str(path),
        "method": method,
        "lags": _regressor_text(estimator),
        "regressor_from": chosen_by,
        "settings": {k: repr(v) for k, v in options.items()},
        "preprocessing": pipeline.to_list() if pipeline else [],
        "training": {"kind": "free run", "outputs": records},
    }


def _validate_one(model: Any, data: Any, log: Path) -> tuple[dict[str, Any], Any, Any]:
    """Free-run ``model`` on one log, print what it means; the JSON record, result and domain."""
    from neckid.models.base import DivergenceError

    record: dict[str, Any] = {"log": log.name}
    try:
        result = model.simulate(data)
    except DivergenceError as exc:
        error_console.print(
            f"[red]diverged:[/red] {escape(str(exc))}", highlight=False, soft_wrap=True
        )
        record["diverged"] = str(exc)
        return record, None, None
    fits, rmses, maes = result.fit_percent(data), result.rmse(data), result.mae(data)
    record["outputs"] = [
        {"output": n, "unit": u, "fit_percent": float(f), "rmse": float(r), "mae": float(m)}
        for n, u, f, r, m in zip(
            data.output_names, data.output_units, fits, rmses, maes, strict=True
        )
    ]
    rows = [
        {
            "output": o["output"],
            "fit %": o["fit_percent"],
            f"RMSE [{o['unit'] or '-'}]": o["rmse"],
            f"MAE [{o['unit'] or '-'}]": o["mae"],
        }
        for o in record["outputs"]
    ]
    console.print(_metrics_table(f"{_describe_model(model)} on {log.name} (free run)", rows))
    _print_prior(model)
    _print_band(result, data)
    _print_prior_check(model, data)
    _print_horizons(model, data)
    _report_extrapolation(result)
    domain = _print_domain(model, data)
    if domain is not None:
        record["outside_domain"] = domain.share
    if result.lower is not None:
        from neckid.models.bands import band_meaning

        record["band"] = band_meaning(result.extras)
    return record, result, domain


def _print_mean(records: list[dict[str, Any]]) -> dict[str, Any]:
    """The mean over the logs that did not diverge, per output; printed and returned."""
    done = [r for r in records if "outputs" in r]
    mean: dict[str, Any] = {"logs": len(done), "diverged": len(records) - len(done)}
    if not done:
        return mean
    rows = []
    for j, first in enumerate(done[0]["outputs"]):
        unit = first["unit"] or "-"
        fit = float(np.mean([r["outputs"][j]["fit_percent"] for r in done]))
        error = float(np.mean([r["outputs"][j]["rmse"] for r in done]))
        rows.append({"output": first["output"], "mean fit %": fit, f"mean RMSE [{unit}]": error})
        mean.setdefault("outputs", []).append(
            {"output": first["output"], "fit_percent": fit, "rmse": error, "unit": first["unit"]}
        )
    title = f"mean over {len(done)} logs (free run)"
    if mean["diverged"]:
        title += f"; {mean['diverged']} diverged, left out"
    console.print(_metrics_table(title, rows))
    return mean


def _fit_text(result: Any, data: Any) -> str:
    """``fit 81.2 %``, or one fit per output: ``fit 81.2 % (tilt_x), 77.0 % (tilt_y)``."""
    if not np.all(np.isfinite(result.y[result.n_initial :])):
        return "diverged (kept by --keep-diverged)"
    fits = [float(f) for f in result.fit_percent(data)]
    if len(fits) == 1:
        return f"fit {fits[0]:.1f} %"
    return "fit " + ", ".join(
        f"{f:.1f} % ({n})" for f, n in zip(fits, data.output_names, strict=True)
    )


def _validation_plot(model: Any, runs: list[tuple[Path, Any, Any, Any]], plot: Path) -> None:
    """Measured vs simulated outputs, each output in its own axes: with errors for one log."""
    label = _describe_model(model)
    if len(runs) > 1:
        panels = [
            (
                data,
                {label: result},
                f"{log.name}: free run, {_fit_text(result, data)}",
                None if domain is None else domain.outside,
            )
            for log, data, result, domain in runs
        ]
        _save_panels(panels, plot)
    else:
        from neckid.report.plots import plot_outputs

        log, data, result, domain = runs[0]
        fig = plot_outputs(
            data,
            {label: result},
            title=f"{label} on {log.name}: free run, {_fit_text(result, data)}",
            residuals=True,
            outside=None if domain is None else domain.outside,
        )
        _save_figure(fig, plot)
    console.print(f"figure written to {plot}")


@app.command()
@handled
@log_options(training=False)
def validate(
    model_path: Path = typer.Argument(
        ..., metavar="MODEL", help="A model file written by identify.", exists=True
    ),
    logs: list[Path] = typer.Argument(
        ...,
        metavar="LOG...",
        help=LOG_HELP + " Several logs: a table each and the mean.",
        exists=True,
    ),
    plot: Path = typer.Option(
        None,
        "--plot",
        help="Write a PNG of measured vs simulated outputs, each in its own axes (with"
        " --in-loop: the loop of each log: reference, inclinations, commands, motor position).",
    ),
    json_out: Path = typer.Option(
        None, "--json", help="Write per log and the mean: fit %, RMSE, MAE, domain, band."
    ),
    force: bool = typer.Option(
        False,
        "--force",
        help="Overwrite an existing output. With --in-loop, also run a controller that does"
        " not reproduce the log's commands (its controller check beyond 1e-4 rad/s).",
    ),
    in_loop: bool = typer.Option(
        False, "--in-loop", help="Run the model in the lab's loop of each log (docs/in_loop.md)."
    ),
    controller: str = typer.Option(None, "--controller", help=CONTROLLER_HELP),
    adapt: float = typer.Option(None, "--adapt", metavar="SECONDS", help=ADAPT_HELP),
    adapt_mode: str = typer.Option("offset", "--adapt-mode", help=ADAPT_MODE_HELP),
    resid: bool = typer.Option(False, "--resid", help=RESID_HELP),
    bode: Path = typer.Option(None, "--bode", help=BODE_HELP),
    multisine: str = typer.Option(None, "--multisine", metavar="M,P[,T]", help=MULTISINE_HELP),
    *,
    spec: LogSpec,
) -> None:
    """Free-run simulate a saved model on one log or several; print fit (%), RMSE and MAE per output.

    Fit is MATLAB's compare fit, 100 (1 - ||y - ŷ|| / ||y - mean(y)||), skipping the initial samples.
    A free run that diverges is reported as such (exit status 3, after the other logs).
    With --in-loop: the model in the loop of each closed-loop log instead (docs/in_loop.md).
    With --adapt 5: a copy adapted on each log's first 5 s, then the free run of the rest
    (docs/compare.md#adapt), the un-adapted fit beside it.
    """
    from neckid.utils.files import check_output_file, write_json

    adaptation = checked_adaptation(adapt, adapt_mode)
    if resid and (in_loop or adaptation is not None):
        raise ValueError(
            "--resid tests the model's own residuals; it does not combine with --in-loop or --adapt"
        )
    if bode is not None and (in_loop or adaptation is not None):
        raise ValueError("--bode compares the model's own response; not with --in-loop or --adapt")
    parse_multisine(multisine)  # a bad --multisine refused before any run
    given = [*logs, model_path]
    for path, option in ((plot, "--plot"), (json_out, "--json")):
        if path is not None:
            check_output_file(path, force=force, inputs=given, option=option)
    if bode is not None:
        check_output_file(bode, force=force, inputs=given, option="--bode", suffixes=(".png",))
    if in_loop:
        return validate_in_loop(
            model_path, logs, controller, json_out, spec, plot=plot, force=force, adapt=adaptation
        )
    from neckid.models.io import load_model

    model = load_model(model_path)  # once: every log runs the same model
    if adaptation is not None:
        return validate_adapted(
            model, model_path, logs, spec, adaptation, json_out=json_out, plot=plot
        )
    records, runs = [], []
    for log in logs:
        data = read_for_model(model, log, spec)
        record, result, domain = _validate_one(model, data, log)
        if resid and (result is not None or not model.predicts_by_simulation):
            record["resid"] = resid_record(model, data, log)
        records.append(record)
        if result is not None:
            runs.append((log, data, result, domain))
    mean = _print_mean(records) if len(logs) > 1 else None
    frequency = bode_validation(model, logs, spec, bode, multisine) if bode else None
    if json_out is not None:
        document = {"model": model_path.name, "kind": "free run", "logs": records, "mean": mean}
        if frequency is not None:
            document["bode"] = frequency
        write_json(json_out, document)
        console.print(f"results written to {json_out}")
    if plot is not None and runs:
        _validation_plot(model, runs, plot)
    if any("diverged" in r for r in records):
        raise typer.Exit(code=3)


@app.command()
@handled
@log_options(training=False)
def simulate(
    model_path: Path = typer.Argument(
        ..., metavar="MODEL", help="A model file written by identify.", exists=True
    ),
    log: Path = typer.Argument(..., help=LOG_HELP, exists=True),
    out: Path = typer.Option(
        Path("simulation.csv"), "--out", help="CSV to write: time, inputs, outputs (and bounds)."
    ),
    plot: Path = typer.Option(
        None, "--plot", help="Write a PNG of measured vs simulated outputs, each in its own axes."
    ),
    force: bool = FORCE_OPTION,
    keep_diverged: bool = typer.Option(
        False,
        "--keep-diverged",
        help="Write the run even when it diverges (non-finite values); exit status 3 still.",
    ),
    json_out: Path = typer.Option(
        None,
        "--json",
        help="Write a summary as JSON: samples, band kind, and the fit against the log's outputs.",
    ),
    *,
    spec: LogSpec,
) -> None:
    """Free-run simulate a saved model with the inputs of a log; write time, inputs and outputs to CSV.

    The log's first max-lag outputs are the initial conditions; Set Membership models add
    OUTPUT_lower and OUTPUT_upper columns (OUTPUT: each output's name). A run that diverges is not written (exit status 3)
    unless --keep-diverged.
    """
    from neckid.models.base import DivergenceError
    from neckid.utils.files import atomic_path, check_output_file

    check_output_file(out, force=force, inputs=[log, model_path])
    for path, option in ((json_out, "--json"), (plot, "--plot")):
        if path is not None:
            check_output_file(path, force=force, inputs=[log, model_path, out], option=option)
    from neckid.models.io import load_model

    model = load_model(model_path)
    data = read_for_model(model, log, spec)
    diverged: DivergenceError | None = None
    try:
        result = model.simulate(data)
    except DivergenceError as exc:
        diverged, result = exc, exc.result
        error_console.print(
            f"[red]diverged:[/red] {escape(str(exc))}", highlight=False, soft_wrap=True
        )
        if not keep_diverged:
            raise typer.Exit(code=3) from None
    with atomic_path(out) as temporary:
        result.to_frame().to_csv(temporary, index=False)
    console.print(f"{result.n_samples} samples written to {out}")
    _report_extrapolation(result)
    if plot is not None:
        _validation_plot(model, [(log, data, result, None)], plot)
    if json_out is not None:
        from neckid.utils.files import write_json

        write_json(json_out, _simulation_summary(model_path, log, out, data, result, diverged))
        console.print(f"summary written to {json_out}")
    if diverged is not None:
        raise typer.Exit(code=3)


def _simulation_summary(
    model_path: Path, log: Path, out: Path, data: Any, result: Any, diverged: Exception | None
) -> dict[str, Any]:
    """What ``simulate --json`` writes: the run, its band's meaning, its fit to the log."""
    from neckid.models.bands import band_meaning

    document: dict[str, Any] = {
        "model": model_path.name,
        "log": log.name,
        "csv": str(out),
        "kind": "free run",
        "n_samples": int(result.n_samples),
        "band": band_meaning(result.extras) if result.lower is not None else None,
        "diverged": diverged is not None,
    }
    if diverged is not None:
        document["divergence"] = str(diverged)
    if diverged is None and data.n_outputs:
        document["outputs"] = [
            {"output": n, "unit": u, "fit_percent": float(f), "rmse": float(r)}
            for n, u, f, r in zip(
                data.output_names,
                data.output_units,
                result.fit_percent(data),
                result.rmse(data),
                strict=True,
            )
        ]
    return document
