"""Frequency-domain commands: ``excite`` (a multisine plan to run on the rig) and ``frf``.

Also :func:`bode_validation`, what ``validate --bode`` runs: a model's response over the one a log
measures (:func:`neckid.frequency.frequency_fit`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.markup import escape
from rich.table import Table

from neckid.cli._app import FORCE_OPTION, LOG_HELP, _split, app, console, handled
from neckid.cli.options import LogSpec, log_options

__all__ = ["BODE_HELP", "MULTISINE_HELP", "bode_validation", "excite", "frf", "parse_multisine"]

BODE_HELP = (
    "Write a PNG of the model's frequency response (first input to first output) over the one"
    " each log measures, with its 95 % band; print the share of frequencies inside it and the"
    " weighted error (docs/frequency.md)."
)
MULTISINE_HELP = (
    "M,P[,T]: the log is a multisine experiment of M realisations x (T transient + P) periods"
    " (T default 1): the measured response is the robust BLA; without it, the Welch estimate."
)


def _band(text: str) -> tuple[float, float]:
    parts = _split(text) or []
    try:
        low, high = (float(p) for p in parts)
    except ValueError:
        raise ValueError(f"--band must be LOW,HIGH in rad/s (e.g. 0.5,20); got {text!r}") from None
    return low, high


def parse_multisine(text: str | None) -> tuple[int, int, int] | None:
    """``"M,P[,T]"`` as ``(M, P, T)``; one clear line naming ``--multisine`` otherwise."""
    if text is None:
        return None
    parts = _split(text) or []
    try:
        values = [int(p) for p in parts]
    except ValueError:
        values = []
    if len(values) == 2:
        values.append(1)
    if len(values) != 3 or values[0] < 1 or values[1] < 1 or values[2] < 0:
        raise ValueError(
            f"--multisine must be M,P or M,P,T (realisations >= 1, periods >= 1, transient >= 0);"
            f" got {text!r}"
        )
    return values[0], values[1], values[2]


@app.command()
@handled
def excite(
    out: Path = typer.Option(
        ..., "--out", help="CSV to write: time, realisation, period, commands."
    ),
    band: str = typer.Option(..., "--band", help="Excited band LOW,HIGH in rad/s, e.g. 0.5,20."),
    ts: float = typer.Option(0.02, "--ts", help="Sampling period of the rig's loop, s."),
    period: int = typer.Option(
        1024, "--period", help="Samples per period (even); resolution 2π/(N ts) rad/s."
    ),
    kind: str = typer.Option(
        "random-odd", "--kind", help="random-odd, odd or full (which lines are excited)."
    ),
    realisations: int = typer.Option(
        8, "--realisations", help="M: realisations with new random phases."
    ),
    periods: int = typer.Option(4, "--periods", help="P: measured periods per realisation."),
    transient: int = typer.Option(
        1, "--transient", help="T: periods played first and thrown away."
    ),
    rms: float = typer.Option(
        1.0, "--rms", help="RMS value of each command, in the command's unit."
    ),
    offset: float = typer.Option(
        0.0, "--offset", help="Operating point the multisine is played around."
    ),
    name: str = typer.Option(
        "command",
        "--name",
        help="Column name(s) of the command(s), comma-separated: one per input.",
    ),
    seed: int = typer.Option(0, "--seed", help="Seed of the phases and of the left-out lines."),
    force: bool = FORCE_OPTION,
) -> None:
    """Write a multisine plan to run on the rig (M realisations x (T + P) periods) and its lines' table.

    The plan's CSV holds time [s], realisation, period (negative: transient) and the commands;
    OUT.lines.csv beside it lists every line of the band with its role (excited, odd
    detection, even detection). After the run: neckid frf LOG --realisations M --periods P.
    """
    from neckid.signals import multisine_plan
    from neckid.utils.files import atomic_path, check_output_file

    names = _split(name) or []
    lines_path = out.with_name(out.stem + ".lines.csv")
    check_output_file(out, force=force)
    check_output_file(lines_path, force=force, option="--out")
    plan = multisine_plan(
        period,
        ts,
        _band(band),
        kind=kind,  # type: ignore[arg-type]  # checked by multisine_plan
        n_realisations=realisations,
        n_periods=periods,
        transient_periods=transient,
        rms=rms,
        offset=offset,
        n_inputs=len(names),
        seed=seed,
    )
    import pandas as pd

    frame = pd.DataFrame(plan.signal, columns=names)
    frame.insert(0, "period", plan.period_index)
    frame.insert(0, "realisation", plan.realisation)
    frame.insert(0, "time", plan.ts * pd.RangeIndex(len(frame)))
    with atomic_path(out) as temporary:
        frame.to_csv(temporary, index=False, float_format="%.9g")
    with atomic_path(lines_path) as temporary:
        pd.DataFrame(plan.lines_table()).to_csv(temporary, index=False, float_format="%.9g")
    excited = plan.omegas[plan.roles == "excited"]
    console.print(
        f"plan: {realisations} realisations x ({transient} + {periods}) periods x {period}"
        f" samples = {len(frame)} samples ({len(frame) * ts:.1f} s at ts = {ts} s);"
        f" {excited.size} excited lines from {excited.min():.4g} to {excited.max():.4g} rad/s,"
        f" line spacing {2 * 3.141592653589793 / (period * ts):.4g} rad/s",
        markup=False,
    )
    console.print(f"plan written to {out}, lines' table to {lines_path}", markup=False)
    console.print(
        f"after the run: neckid frf LOG --inputs {','.join(names)} --outputs ..."
        f" --realisations {realisations} --periods {periods} --transient {transient}",
        markup=False,
    )


def _read(logs: list[Path], inputs: list[str], outputs: list[str], spec: LogSpec) -> list[Any]:
    from neckid.cli.workflow import read_log

    return [read_log(p, inputs or None, outputs or None, **spec.reading()) for p in logs]


def _excited_lines(path: Path | None) -> Any:
    """The excited lines of a lines' table (``line`` and ``role`` columns), or None."""
    if path is None:
        return None
    import pandas as pd

    table = pd.read_csv(path)
    missing = [c for c in ("line", "role") if c not in table.columns]
    if missing:
        raise ValueError(
            f"--lines {str(path)!r} has no column {missing[0]!r}: give the PLAN.lines.csv that"
            " neckid excite wrote"
        )
    excited = table.loc[table["role"] == "excited", "line"]
    if excited.empty:
        raise ValueError(f"--lines {str(path)!r} lists no line with role 'excited'")
    return excited.to_numpy(dtype="int64")


def _periodic(
    datas: list[Any], realisations: int | None, periods: int, transient: int, excited: Any
) -> Any:
    import numpy as np

    from neckid.frequency import robust_bla

    lengths = {d.n_samples for d in datas}
    if len(datas) > 1 and len(lengths) > 1:
        raise ValueError(
            f"the logs have {sorted(lengths)} samples: one realisation each needs one length"
        )
    m = realisations if realisations is not None else len(datas)
    u = np.vstack([d.u for d in datas])
    y = np.vstack([d.y for d in datas])
    period, rest = divmod(u.shape[0], m * (transient + periods))
    if rest or period < 8:
        raise ValueError(
            f"--realisations {m} x (--transient {transient} + --periods {periods}) periods do not"
            f" divide the {u.shape[0]} samples into whole periods of >= 8 samples"
        )
    first = datas[0]
    return robust_bla(
        u,
        y,
        first.ts,
        period=period,
        n_realisations=m,
        n_periods=periods,
        transient_periods=transient,
        excited=excited,
        names=(first.input_names, first.output_names),
        units=(first.input_units, first.output_units),
    )


def _spectral(data: Any, reference: str | None, method: Any, segment: int | None) -> list[Any]:
    from neckid.frequency import etfe, indirect_frf, smoothed_frf

    responses = []
    names = [n for n in data.input_names if n != reference]
    r = data.channel(reference) if reference else None
    for out in data.output_names:
        for name in names:
            u, y = data.channel(name), data.channel(out)
            if method == "etfe":
                if r is not None:
                    raise ValueError("--method etfe has no band and no reference: use welch")
                response = etfe(u, y, data.ts)
            elif r is None:
                response = smoothed_frf(u, y, data.ts, method=method, segment=segment)
            else:
                response = indirect_frf(
                    r,
                    u,
                    y,
                    data.ts,
                    method=method,
                    segment=segment,
                    reference_name=str(reference),
                )
            responses.append((out, name, response))
    return responses


def _db_text(variance: float) -> str:
    """A variance as a standard deviation in dB; '-' for zero or NaN (not measured)."""
    import math

    return f"{10 * math.log10(variance):.1f}" if variance > 0 else "-"


def _bla_table(bla: Any) -> Table:
    import numpy as np

    table = Table(title=f"{bla.estimate}: {bla.n_blocks} blocks x {bla.n_periods} periods")
    for column in (
        "output <- input",
        "lines",
        "ω [rad/s]",
        "|G| first line [dB]",
        "noise std [dB]",
        "nonlinear std [dB]",
        "NL detected",
    ):
        table.add_column(escape(column))
    detected = bla.nonlinear_detected()
    with np.errstate(divide="ignore"):
        for i, out in enumerate(bla.output_names):
            for j, name in enumerate(bla.input_names):
                table.add_row(
                    f"{out} <- {name}",
                    str(bla.lines.size),
                    f"{bla.omega.min():.3g}-{bla.omega.max():.3g}",
                    f"{20 * np.log10(abs(bla.frf[0, i, j])):.1f}",
                    _db_text(float(np.nanmedian(bla.noise_variance[:, i, j]))),
                    _db_text(float(np.nanmedian(bla.nl_variance[:, i, j]))),
                    f"{100 * detected[:, i, j].mean():.0f} %",
                )
    return table


def _bla_figure(bla: Any) -> Any:
    import matplotlib.pyplot as plt

    from neckid.report.frequency_plots import plot_bla

    pairs = [(i, j) for i in range(bla.frf.shape[1]) for j in range(bla.frf.shape[2])]
    fig = plt.figure(figsize=(11, 6 * len(pairs)), layout="constrained")
    subfigures = _panels(fig, len(pairs))
    for pair, sub in zip(pairs, subfigures, strict=True):
        plot_bla(bla, pair, fig=sub)
    return fig


def _spectral_figure(responses: list[Any], data: Any) -> Any:
    import matplotlib.pyplot as plt

    from neckid.report.frequency_plots import plot_frf

    fig = plt.figure(figsize=(11, 7 * len(responses)), layout="constrained")
    subfigures = _panels(fig, len(responses))
    for (out, name, response), sub in zip(responses, subfigures, strict=True):
        units = (data.unit(out), data.unit(name))
        plot_frf(response, units=units, title=f"{response.estimate}: {out} / {name}", fig=sub)
    return fig


def _panels(fig: Any, count: int) -> list[Any]:
    """``count`` subfigures stacked in ``fig`` (the figure itself for one)."""
    return list(fig.subfigures(count, 1)) if count > 1 else [fig]


def _save(fig: Any, path: Path) -> None:
    from neckid.utils.files import atomic_path

    with atomic_path(path) as temporary:
        fig.savefig(temporary, dpi=110, format="png", bbox_inches="tight")
    console.print(f"figure written to {path}", markup=False)


def _report(folder: Path, verdict: str, fig: Any, document: dict[str, Any], force: bool) -> None:
    from neckid.report.html import Figure, Report
    from neckid.utils.files import output_folder, write_json

    with output_folder(folder, force=force) as staged:
        report = Report("neckid frf")
        report.add_text("Verdict", verdict)
        fig.savefig(staged.path("frf.png"), dpi=110, format="png", bbox_inches="tight")
        report.add_figures("Frequency response", [Figure(staged.path("frf.png"), verdict)])
        write_json(staged.path("frf.json"), document)
        report.write(staged.path("report.html"))
    console.print(f"report written to {folder / 'report.html'}", markup=False)


@app.command()
@handled
@log_options(training=False)
def frf(
    logs: list[Path] = typer.Argument(
        ..., metavar="LOG...", help=LOG_HELP + " Several logs: one realisation each.", exists=True
    ),
    inputs: str = typer.Option(
        None, "--inputs", help="Comma-separated input channels (the excited commands)."
    ),
    outputs: str = typer.Option(None, "--outputs", help="Comma-separated output channels."),
    periods: int = typer.Option(
        None,
        "--periods",
        help="P: measured periods per realisation (multisine log: robust BLA).",
        min=1,
    ),
    realisations: int = typer.Option(
        None, "--realisations", help="M: realisations (default: the number of logs).", min=1
    ),
    transient: int = typer.Option(
        1, "--transient", help="T: transient periods before the measured ones.", min=0
    ),
    lines: Path = typer.Option(
        None,
        "--lines",
        help="The lines' table neckid excite wrote (PLAN.lines.csv): its excited lines are used"
        " (default: the input's lines within 20 dB of its strongest; give the table in a closed"
        " loop, where the command's spectrum is not flat).",
        exists=True,
        dir_okay=False,
    ),
    reference: str = typer.Option(
        None,
        "--reference",
        help="Closed-loop log: the reference channel; G = S_ry / S_ru (indirect).",
    ),
    method: str = typer.Option(
        "welch",
        "--method",
        help="Non-periodic data: welch, blackman-tukey (MATLAB's spa) or etfe (Y/U of the whole"
        " record, no band).",
    ),
    segment: int = typer.Option(
        None, "--segment", help="Welch segment length, samples (default n/8)."
    ),
    plot: Path = typer.Option(
        None, "--plot", help="Write a PNG: magnitude [dB], phase [deg], levels."
    ),
    json_out: Path = typer.Option(None, "--json", help="Write every line's values as JSON."),
    report: Path = typer.Option(
        None, "--report", help="Write a folder with report.html, frf.png, frf.json."
    ),
    force: bool = FORCE_OPTION,
    *,
    spec: LogSpec,
) -> None:
    """The frequency response of logs: the robust BLA with noise and distortion levels, or an FRF with its band.

    With --periods: a multisine experiment (neckid excite): the best linear approximation, the
    noise and nonlinear variances per line, the levels at the non-excited lines and a verdict.
    Without: the Welch (or Blackman-Tukey) estimate with coherence and 95 % band of one log; with
    --reference, the closed-loop indirect estimate through the reference.
    """
    from neckid.utils.files import check_output_file, write_json

    for path, option in ((plot, "--plot"), (json_out, "--json")):
        if path is not None:
            check_output_file(path, force=force, inputs=logs, option=option)
    if method not in ("welch", "blackman-tukey", "etfe"):
        raise ValueError(f"--method must be welch, blackman-tukey or etfe; got {method!r}")
    names_in, names_out = _split(inputs) or [], _split(outputs) or []
    if reference and reference not in names_in:
        names_in = [*names_in, reference]
    datas = _read(logs, names_in, names_out, spec)
    if periods is not None:
        if reference:
            raise ValueError("--reference is for non-periodic logs; drop it with --periods")
        bla = _periodic(datas, realisations, periods, transient, _excited_lines(lines))
        console.print(_bla_table(bla))
        verdict, document = bla.verdict(), bla.to_dict()
        figure = _bla_figure if (plot or report) else None
        found = f"from {lines}" if lines else "from the input (within 20 dB of its strongest)"
        console.print(f"estimate: {bla.estimate}; excited lines {found}", markup=False)
    else:
        if len(datas) > 1:
            raise ValueError("several logs are realisations of a multisine: give --periods")
        responses = _spectral(datas[0], reference, method, segment)
        verdict = "; ".join(
            f"{o} <- {n}: {r.estimate}, median coherence {float(_median(r.coherence)):.2f}"
            for o, n, r in responses
        )
        if reference is None:
            verdict += (
                " (direct S_uy / S_uu: in a closed loop biased toward -1/C where the noise drives"
                " the command; give --reference)"
            )
        document = {"pairs": [{"output": o, "input": n, **r.to_dict()} for o, n, r in responses]}
        figure = (lambda _: _spectral_figure(responses, datas[0])) if (plot or report) else None
        bla = None
    console.print(f"verdict: {verdict}", markup=False)
    if json_out is not None:
        write_json(json_out, document)
        console.print(f"results written to {json_out}", markup=False)
    if figure is not None:
        fig = figure(bla)
        if plot is not None:
            _save(fig, plot)
        if report is not None:
            _report(report, verdict, fig, document, force)


def _median(values: Any) -> float:
    import numpy as np

    return float(np.nanmedian(values)) if np.isfinite(values).any() else float("nan")


def bode_validation(
    model: Any, logs: list[Path], spec: LogSpec, bode: Path, multisine: str | None
) -> list[dict[str, Any]]:
    """``validate --bode``: every log's measured response and the model's over it, one PNG.

    The model's first input and first output are compared; a linear single-input model by its
    transfer function, any other by the same estimator on its free run (module
    :mod:`neckid.frequency.validation`). Prints the share of frequencies inside the 95 % band
    and the weighted error per log; returns them.
    """
    import matplotlib.pyplot as plt

    from neckid.cli.options import read_for_model
    from neckid.frequency import BestLinearApproximation, frequency_fit
    from neckid.report.frequency_plots import plot_bla, plot_frf

    shape = parse_multisine(multisine)
    fig = plt.figure(figsize=(11, 7 * len(logs)), layout="constrained")
    subfigures = _panels(fig, len(logs))
    records = []
    for log, sub in zip(logs, subfigures, strict=True):
        data = read_for_model(model, log, spec, quiet=True)
        name_in, name_out = data.input_names[0], data.output_names[0]
        fit, measured = frequency_fit(
            model, data, input_name=name_in, output_name=name_out, multisine=shape
        )
        overlay = [(fit.omega, fit.model_frf, f"model ({fit.model_estimate})")]
        if isinstance(measured, BestLinearApproximation):
            plot_bla(measured, overlays=overlay, fig=sub)
        else:
            units = (data.unit(name_out), data.unit(name_in))
            plot_frf(measured, overlays=overlay, units=units, fig=sub)
        console.print(
            f"{log.name}: {name_out} <- {name_in}: model inside the measured 95 % band at"
            f" {100 * fit.share_inside:.0f} % of {fit.omega.size} frequencies, weighted error"
            f" {fit.weighted_error:.2f} (band radii; model: {fit.model_estimate};"
            f" measured: {fit.measured_estimate})",
            markup=False,
        )
        records.append({"log": log.name, **fit.to_dict()})
    _save(fig, bode)
    return records


REAL_LOGS_NOTE = (
    "What the shared real logs allow: the lab's identification log is one record of a"
    " non-periodic excitation, so it gives the Welch estimate with its coherence and band (neckid"
    " frf LOG), not a robust BLA, which needs M realisations x P periods of a multisine (neckid"
    " excite writes one to run on the rig); the stairs logs are closed loop with a reference,"
    " so neckid frf LOG --reference reference gives the indirect estimate, informative only"
    " where the steps carry power (the lowest frequencies)."
)


def frequency_demo_command(out: Path, *, seed: int, force: bool) -> None:
    """``neckid demo --frequency``: the frequency demo's report (docs/frequency.md)."""
    import numpy as np

    from neckid.experiments.frequency_demo import run_frequency_demo
    from neckid.report.frequency_plots import plot_bla
    from neckid.report.html import Figure, Report
    from neckid.utils.files import output_folder, write_json

    with output_folder(out, force=force) as staged:
        demo = run_frequency_demo(seed)
        lines = [
            f"loop (reference -> inclination): {demo.loop.verdict()}",
            f"plant (velocity command -> inclination): {demo.plant.verdict()}",
            f"bandwidth read from the loop's BLA (90 % rule): {demo.bandwidth:.2f} rad/s"
            " (paper: 4.2 rad/s)",
            f"model classes: {demo.advice}",
        ]
        report = Report("neckid demo --frequency")
        plan = demo.plan
        report.add_text(
            "Experiment",
            f"Random-odd multisine reference, {plan.n_realisations} realisations x (1 + "
            f"{plan.n_periods}) periods of {plan.period * plan.ts:.1f} s, {plan.rms} deg RMS around"
            f" {float(np.mean(plan.signal)):.0f} deg, on the simulated neck's inclination loop.",
        )
        report.add_text("What the levels say", "\n\n".join(lines))
        figures = []
        for key, bla in (("loop", demo.loop), ("plant", demo.plant)):
            path = staged.path(f"bla_{key}.png")
            plot_bla(bla).savefig(path, dpi=110, format="png", bbox_inches="tight")
            figures.append(Figure(path, f"{key}: {bla.verdict()}"))
        report.add_figures("Best linear approximations", figures)
        report.add_text("Real logs", REAL_LOGS_NOTE)
        document = {
            "loop": demo.loop.to_dict(),
            "plant": demo.plant.to_dict(),
            "bandwidth_rad_s": demo.bandwidth,
            "model_classes": demo.advice,
        }
        write_json(staged.path("frequency.json"), document)
        report.write(staged.path("report.html"))
    for line in lines:
        console.print(line, markup=False)
    console.print(f"report written to {out / 'report.html'}", markup=False)
