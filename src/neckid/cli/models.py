"""Commands on models: identify, validate, simulate."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.markup import escape

from neckid.cli._app import (
    CHANNEL_OPTION,
    CONDITION_OPTION,
    FORCE_OPTION,
    INPUTS_HELP,
    LAYOUT_OPTION,
    LOG_HELP,
    LOWPASS_OPTION,
    MAP_OPTION,
    OFFSET_OPTION,
    OUTPUTS_HELP,
    RELATIVE_OPTION,
    RESAMPLE_OPTION,
    RESTAMP_OPTION,
    SEP_OPTION,
    TILT_OPTION,
    TIME_OPTION,
    TS_OPTION,
    _method_name,
    _metrics_table,
    _sep,
    _split,
    app,
    console,
    error_console,
    handled,
)
from neckid.registry import methods


@app.command()
@handled
def identify(
    logs: list[Path] = typer.Argument(
        ...,
        metavar="LOG...",
        help=LOG_HELP + " Several logs are several experiments of one model.",
        exists=True,
    ),
    inputs: str = typer.Option(None, "--inputs", help=INPUTS_HELP),
    outputs: str = typer.Option(None, "--outputs", help=OUTPUTS_HELP),
    method: str = typer.Option(
        "sm",
        "--method",
        help=" | ".join(methods()) + " (neckid.methods()).",
    ),
    lags: str = typer.Option(
        "1-3/8-10",
        "--lags",
        help="OUTPUT_LAGS/INPUT_LAGS in samples, e.g. 1-3/8-10 (the paper's regressor).",
    ),
    save: Path = typer.Option(
        Path("model.npz"), "--save", help="Where to write the model (.npz, no pickle)."
    ),
    time: str = TIME_OPTION,
    ts: float = TS_OPTION,
    layout: str = LAYOUT_OPTION,
    sep: str = SEP_OPTION,
    channels: list[str] = CHANNEL_OPTION,
    seed: int = typer.Option(
        0, "--seed", min=0, help="Seed (>= 0) of the neural network's initial weights."
    ),
    conditions: list[str] = CONDITION_OPTION,
    use_conditions: str = typer.Option(
        None,
        "--use-conditions",
        help="Comma-separated conditions the model takes as constant inputs (e.g. payload);"
        " each log must have them (file name, sidecar or --condition).",
    ),
    tilt: bool = TILT_OPTION,
    maps: list[str] = MAP_OPTION,
    relative: list[str] = RELATIVE_OPTION,
    offsets: list[str] = OFFSET_OPTION,
    lowpass: list[str] = LOWPASS_OPTION,
    resample: float = RESAMPLE_OPTION,
    restamp: bool = RESTAMP_OPTION,
    settings: list[str] = typer.Option(
        None,
        "--set",
        metavar="NAME=VALUE",
        help="A setting of the method (a keyword of its class), e.g. --set lipschitz=local or"
        " --set horizons=[40]; VALUE is read as JSON (numbers, true/false, lists), else as"
        " text (repeat the option).",
    ),
    force: bool = FORCE_OPTION,
) -> None:
    """Identify a model from one log or several (one experiment each) and save it.

    Example: neckid identify run.csv --inputs velocity_command --outputs inclination --method sm --lags 1-3/8-10

    Preprocessing (--restamp, --tilt, --relative, --offset, --lowpass, --resample, in that order)
    is stored in the model and applied again by validate, simulate and info --model.
    """
    from neckid.outputs import check_output_file, output_name
    from neckid.regressors import Lags
    from neckid.workflow import (
        make_estimator,
        parse_lags,
        parse_mapping,
        pipeline_from_options,
        read_log,
    )

    save = output_name(save, ".npz", option="--save")
    check_output_file(save, force=force, inputs=list(logs), option="--save")
    pipeline = pipeline_from_options(
        relative=relative or (),
        offsets=offsets or (),
        lowpass=lowpass or (),
        resample=resample,
        restamp=restamp,
        tilt=tilt,
    )
    experiments = [
        read_log(
            log,
            _split(inputs),
            _split(outputs),
            time=time,
            ts=ts,
            layout=layout,  # type: ignore[arg-type]
            sep=_sep(sep),
            channels=channels or (),
            conditions=conditions or (),
            maps=parse_mapping(maps or []),
            preprocessing=pipeline,
        )
        for log in logs
    ]
    method = _method_name(method)
    options = _method_settings(method, settings or ())
    parsed = parse_lags(lags)
    regressor = Lags(parsed.outputs, parsed.inputs, conditions=_split(use_conditions) or ())
    estimator = make_estimator(method, regressor, random_state=seed, **options)
    estimator.fit(experiments if len(experiments) > 1 else experiments[0])
    rows: list[dict[str, Any]] = []
    for log, data in zip(logs, experiments, strict=True):
        result = estimator.simulate(data)  # a diverging model stops here, before it is saved
        fits, rmses = result.fit_percent(data), result.rmse(data)
        rows.extend(
            {"log": log.name, "output": name, "fit %": float(f), f"RMSE [{unit or '-'}]": float(r)}
            for name, unit, f, r in zip(
                data.output_names, data.output_units, fits, rmses, strict=True
            )
        )
    estimator.preprocessing_ = pipeline
    path = estimator.save(save)
    if pipeline:
        console.print(f"preprocessing stored in the model: {pipeline.describe()}", markup=False)
    if len(logs) == 1:
        rows = [{k: v for k, v in row.items() if k != "log"} for row in rows]
    where = logs[0].name if len(logs) == 1 else f"{len(logs)} logs"
    console.print(
        _metrics_table(f"{_describe_model(estimator)} on {where} (free run, training data)", rows)
    )
    console.print(f"model saved to {path}")


def _method_settings(method: str, items: Sequence[str]) -> dict[str, Any]:
    """``--set NAME=VALUE`` items as keyword arguments of the method's class (names checked)."""
    import json

    from neckid.registry import get_method

    own_option = {"random_state": "--seed", "lags": "--lags"}
    known = sorted(set(get_method(method).estimator_class()._parameter_constraints) - {"lags"})
    options: dict[str, Any] = {}
    for item in items:
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise ValueError(f"--set takes NAME=VALUE (e.g. lipschitz=local); got {item!r}")
        if name in own_option:
            raise ValueError(f"--set {name}: give it with {own_option[name]} instead")
        if name not in known:
            raise ValueError(
                f"--set {name}: method {method!r} has no setting {name!r}; its settings are"
                f" {', '.join(known)}"
            )
        try:
            options[name] = json.loads(text)
        except json.JSONDecodeError:
            options[name] = text
    return options


def _load_for_model(
    model_path: Path,
    log: Path,
    time: str,
    ts: float | None,
    layout: str,
    sep: str = ",",
    maps: list[str] | None = None,
    channels: list[str] | None = None,
    conditions: list[str] | None = None,
    tilt: bool = False,
) -> tuple[Any, Any]:
    from neckid.models.io import load_model
    from neckid.workflow import parse_mapping, read_log_for_model

    model = load_model(model_path)
    # The model's channels, renamed by --map (conditions kept), through its preprocessing.
    data, pipeline = read_log_for_model(
        model,
        log,
        time=time,
        ts=ts,
        layout=layout,  # type: ignore[arg-type]
        sep=_sep(sep),
        channels=channels or (),
        maps=parse_mapping(maps or []),
        conditions=conditions or (),
        tilt=tilt,
    )
    if pipeline is not None:
        console.print(f"preprocessing from the model: {pipeline.describe()}", markup=False)
    return model, data


def _describe_model(model: Any) -> str:
    """The label of the model's method (``Set Membership + linear``), or its class name."""
    from neckid.registry import method_of

    method = method_of(model)
    return method.label if method is not None else type(model).__name__


def _print_prior(model: Any) -> None:
    """ε and γ of a Set Membership model (or of the SM map of a parallel one), with units."""
    sm = getattr(model, "sm_", model)
    if not hasattr(sm, "gamma_") or getattr(sm.gamma_, "ndim", 1) != 1:
        return  # a model with one prior per horizon describes itself (neckid info)
    for name, unit, epsilon, gamma in zip(
        model.output_names_, model.output_units_, sm.epsilon_, sm.gamma_, strict=True
    ):
        shown = f" {unit}" if unit else ""
        console.print(
            f"Set Membership prior for {name}: noise bound ε = {epsilon:.4g}{shown}, Lipschitz"
            f" constant γ = {gamma:.4g}{shown} per unit of the scaled regressor"
        )


def _print_band(result: Any, data: Any) -> None:
    """Mean width and coverage of a result's band, and which kind of band it is."""
    if result.lower is None or result.upper is None:
        return
    from neckid.metrics import coverage, mean_width
    from neckid.models.bands import band_meaning

    kind = band_meaning(result.extras)
    skip = result.n_initial
    widths = mean_width(result.lower, result.upper, skip=skip)
    covered = coverage(data.y, result.lower, result.upper, skip=skip)
    for j, name in enumerate(data.output_names):
        unit = f" {data.output_units[j]}" if data.output_units[j] else ""
        console.print(
            f"band of {name}: mean width {widths[j]:.4g}{unit}, holds {covered[j]:.1%} of the"
            f" measured samples. {kind}",
            markup=False,
        )


def _print_horizons(model: Any, data: Any) -> None:
    """For a multi-step SM model: the guaranteed k-step band on the log, per named horizon.

    The horizons shown are 1, the block ``horizon`` and the extra ``horizons``; for each, the
    band of ``predict_ahead`` (its mean width and the share of the measured samples it holds),
    ε_k, and the smallest ε_k that would hold every sample (γ_k kept).
    """
    if not hasattr(model, "horizons_"):
        return
    from neckid.metrics import coverage, mean_width

    named = sorted({1, int(model.horizon), *(int(k) for k in model.horizons or ())})
    rows: list[dict[str, Any]] = []
    for k in named:
        i = model.horizons_.tolist().index(k)
        predictor = model.estimators_[i]  # only the named horizons, not all of invalidation()'s
        if data.n_samples <= predictor.lags_.max_lag:
            continue
        ahead = model.predict_ahead(data, steps=k)
        skip = ahead.n_initial
        widths = mean_width(ahead.lower, ahead.upper, skip=skip)
        held = coverage(data.y, ahead.lower, ahead.upper, skip=skip)
        needed = predictor.invalidation(data).smallest_epsilon
        for j, name in enumerate(data.output_names):
            unit = data.output_units[j] or "-"
            rows.append(
                {
                    "k [samples]": str(k),
                    "k [s]": f"{k * data.ts:.3g}",
                    "output": name,
                    f"mean width [{unit}]": float(widths[j]),
                    "holds [%]": float(100 * held[j]),
                    f"eps_k [{unit}]": float(model.epsilon_[i, j]),
                    f"eps_k to hold all, gamma kept [{unit}]": float(needed[j]),
                }
            )
    if rows:
        console.print(
            _metrics_table("guaranteed k-step bands (predicted k samples ahead from the log)", rows)
        )


def _print_prior_check(model: Any, data: Any) -> None:
    """For an SM model: does the log contradict its prior, one step ahead? And what to do."""
    check = getattr(model, "invalidation", None)
    epsilon = getattr(model, "epsilon_", None)
    if check is None or epsilon is None or hasattr(model, "horizons_") or epsilon.ndim != 1:
        return
    found = check(data)
    for j, name in enumerate(data.output_names):
        unit = f" {data.output_units[j]}" if data.output_units[j] else ""
        share = float(found.fraction[j])
        if share == 0:
            console.print(
                f"prior check of {name} (one step ahead, measured regressors): every sample lies"
                f" in [f_l − ε, f_u + ε] (ε = {float(epsilon[j]):.4g}{unit}); the log does not"
                " contradict the prior",
                markup=False,
            )
            continue
        advice = (
            f"{share:.1%} of the samples of {name} fall outside [f_l − ε, f_u + ε] one step"
            f" ahead (ε = {float(epsilon[j]):.4g}{unit}, γ kept): the SM bounds are not"
            " guaranteed on this log. The smallest ε that holds them all is"
            f" {float(found.smallest_epsilon[j]):.4g}{unit}. Identify again with this log among"
            " the training logs, or with a larger --set epsilon=..., or update the model with"
            " it (SetMembership.partial_fit in Python)."
        )
        error_console.print(
            f"[yellow]prior contradicted:[/yellow] {escape(advice)}",
            highlight=False,
            soft_wrap=True,
        )


def _print_domain(model: Any, data: Any) -> Any:
    """The share of the log outside the model's domain (regressor box, SM nearest regressor)."""
    if not getattr(model, "regressor_ranges_", None) or data.n_samples <= model.max_lag_:
        return None
    domain = model.domain(data)
    worst = sorted(domain.by_term.items(), key=lambda kv: -kv[1])[:3]
    terms = ", ".join(f"{k} {v:.0%}" for k, v in worst if v > 0) or "none"
    text = (
        f"domain: {domain.share:.1%} of the samples lie outside the regressors the model was"
        f" identified on (terms outside their training range: {terms}"
    )
    if domain.radius is not None and domain.distance is not None:
        far = float(np.nanmean(domain.distance[domain.n_initial :] > domain.radius))
        text += (
            f"; {far:.1%} farther from every training regressor than"
            f" {domain.radius:.3g} (the 99th percentile of the training regressors' own"
            " nearest-neighbour distances, scaled space)"
        )
    console.print(text + ")", markup=False)
    return domain


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
    log: Path = typer.Argument(..., help=LOG_HELP, exists=True),
    time: str = TIME_OPTION,
    ts: float = TS_OPTION,
    layout: str = LAYOUT_OPTION,
    sep: str = SEP_OPTION,
    channels: list[str] = CHANNEL_OPTION,
    maps: list[str] = MAP_OPTION,
    conditions: list[str] = CONDITION_OPTION,
    tilt: bool = TILT_OPTION,
    plot: Path = typer.Option(None, "--plot", help="Write a PNG of measured vs simulated output."),
    force: bool = FORCE_OPTION,
) -> None:
    """Free-run simulate a saved model on a log and print fit (%), RMSE and MAE per output.

    Fit is MATLAB's compare fit, 100 (1 - ||y - ŷ|| / ||y - mean(y)||), skipping the initial samples.
    A free run that diverges is reported as such (exit status 3).
    """
    from neckid.models.base import DivergenceError
    from neckid.outputs import atomic_path, check_output_file

    if plot is not None:
        check_output_file(plot, force=force, inputs=[log, model_path], option="--plot")
    model, data = _load_for_model(
        model_path, log, time, ts, layout, sep, maps, channels, conditions, tilt
    )
    try:
        result = model.simulate(data)
    except DivergenceError as exc:
        error_console.print(
            f"[red]diverged:[/red] {escape(str(exc))}", highlight=False, soft_wrap=True
        )
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
    _print_band(result, data)
    _print_prior_check(model, data)
    _print_horizons(model, data)
    _report_extrapolation(result)
    domain = _print_domain(model, data)
    if plot is not None:
        from neckid.report.plots import plot_simulation

        label = _describe_model(model)
        fig = plot_simulation(
            data,
            {label: result},
            title=f"{label} on {log.name}: free run, fit {float(fits[0]):.1f} %",
            residuals=True,
            outside=None if domain is None else domain.outside,
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
    log: Path = typer.Argument(..., help=LOG_HELP, exists=True),
    out: Path = typer.Option(
        Path("simulation.csv"), "--out", help="CSV to write: time, inputs, outputs (and bounds)."
    ),
    time: str = TIME_OPTION,
    ts: float = TS_OPTION,
    layout: str = LAYOUT_OPTION,
    sep: str = SEP_OPTION,
    channels: list[str] = CHANNEL_OPTION,
    maps: list[str] = MAP_OPTION,
    conditions: list[str] = CONDITION_OPTION,
    tilt: bool = TILT_OPTION,
    force: bool = FORCE_OPTION,
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
    model, data = _load_for_model(
        model_path, log, time, ts, layout, sep, maps, channels, conditions, tilt
    )
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
    if diverged is not None:
        raise typer.Exit(code=3)
