"""``--adapt SECONDS``: validate a model adapted on each log's first seconds (a labelled mode).

``neckid validate MODEL LOG --adapt 5 [--adapt-mode offset|update|both]`` adapts a copy of the
model on each log's first 5 s (:func:`neckid.models.adapted.adapted_run`: the log's later
samples are never read before they are predicted), free-runs the rest, and prints the fit
"free run after 5 s of adaptation" beside the un-adapted model's fit on the same samples, with
the running coverage of a 95 % adaptive conformal band around the adapted run.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.markup import escape

from neckid.cli._app import _fail, _metrics_table, console, error_console
from neckid.cli.options import LogSpec, read_for_model

__all__ = ["ADAPT_HELP", "ADAPT_MODE_HELP", "checked_adaptation", "validate_adapted"]

ADAPT_HELP = (
    "Adapt a copy of the model on each log's first SECONDS (causally: the rest is never read"
    " before it is predicted), then free-run the rest; reported as 'free run after SECONDS s"
    " of adaptation', the un-adapted fit on the same samples beside it."
)
ADAPT_MODE_HELP = (
    "What --adapt adapts: offset (a constant output offset), update (the model's partial_fit)"
    " or both."
)


def checked_adaptation(seconds: float | None, mode: str) -> tuple[float, str] | None:
    """``(seconds, mode)`` from ``--adapt`` and ``--adapt-mode``; one line and exit 2 if bad."""
    if seconds is None:
        if mode != "offset":
            _fail(f"--adapt-mode {mode} needs --adapt SECONDS")
        return None
    from neckid.models.adapted import check_adaptation

    if not (np.isfinite(seconds) and seconds > 0):
        _fail(f"--adapt must be a number of seconds > 0; got {seconds!r}")
    try:
        return check_adaptation(seconds, mode)
    except ValueError:
        _fail(f"--adapt-mode must be offset, update or both; got {mode!r}")
    return None  # unreachable: _fail exits


def _record(log: Path, data: Any, run: Any) -> dict[str, Any]:
    """The JSON record of one adapted log."""
    result, scored = run.adapted.result, run.adapted.scored
    rmses = result.rmse(scored)
    plain: list[float | None] = (
        [float(f) for f in run.unadapted.fit] if run.unadapted is not None else [None] * len(rmses)
    )
    return {
        "log": log.name,
        "kind": run.label,
        "warmup_samples": run.adapted.warmup_samples,
        "outputs": [
            {
                "output": name,
                "unit": unit,
                "fit_percent": float(run.adapted.fit[j]),
                "fit_percent_unadapted": plain[j],
                "rmse": float(rmses[j]),
                "offset": float(run.adapted.offset[j]),
                "adaptive_band": {
                    "coverage": 0.95,
                    "running_coverage": float(run.band_coverage[j]),
                    "mean_width": float(run.band_width[j]),
                },
            }
            for j, (name, unit) in enumerate(zip(data.output_names, data.output_units, strict=True))
        ],
    }


def _print_record(record: dict[str, Any], model_name: str) -> None:
    rows = []
    for o in record["outputs"]:
        unit = o["unit"] or "-"
        plain = o["fit_percent_unadapted"]
        rows.append(
            {
                "output": o["output"],
                "fit %": o["fit_percent"],
                "fit % un-adapted": "diverged" if plain is None else plain,
                f"RMSE [{unit}]": o["rmse"],
                f"offset [{unit}]": o["offset"],
                "95 % adaptive band holds [%]": 100 * o["adaptive_band"]["running_coverage"],
            }
        )
    console.print(_metrics_table(f"{model_name} on {record['log']} ({record['kind']})", rows))


def _mean(records: list[dict[str, Any]], label: str) -> dict[str, Any]:
    done = [r for r in records if "outputs" in r]
    mean: dict[str, Any] = {"logs": len(done), "diverged": len(records) - len(done), "kind": label}
    rows = []
    for j, first in enumerate(done[0]["outputs"] if done else []):
        outputs = [r["outputs"][j] for r in done]
        plain = [o["fit_percent_unadapted"] for o in outputs]
        entry = {
            "output": first["output"],
            "fit_percent": float(np.mean([o["fit_percent"] for o in outputs])),
            "fit_percent_unadapted": None if None in plain else float(np.mean(plain)),
            "lowest_band_coverage": min(o["adaptive_band"]["running_coverage"] for o in outputs),
        }
        mean.setdefault("outputs", []).append(entry)
        rows.append(
            {
                "output": entry["output"],
                "mean fit %": entry["fit_percent"],
                "mean fit % un-adapted": entry["fit_percent_unadapted"] or "–",
                "lowest band coverage [%]": 100 * entry["lowest_band_coverage"],
            }
        )
    if rows:
        console.print(_metrics_table(f"mean over {len(done)} logs ({label})", rows))
    return mean


def validate_adapted(
    model: Any,
    model_path: Path,
    logs: list[Path],
    spec: LogSpec,
    adapt: tuple[float, str],
    *,
    json_out: Path | None = None,
    plot: Path | None = None,
) -> None:
    """``validate --adapt``: every log adapted, run, printed; JSON and plot as asked; exit 3 if diverged."""
    from neckid.cli.explain import _describe_model, _save_panels
    from neckid.models.adapted import adaptation_label, adapted_run
    from neckid.models.base import DivergenceError

    label = adaptation_label(*adapt)
    name = _describe_model(model)
    records: list[dict[str, Any]] = []
    panels = []
    for log in logs:
        data = read_for_model(model, log, spec)
        try:
            run = adapted_run(model, data, *adapt)
        except (DivergenceError, ValueError) as exc:
            error_console.print(
                f"[red]{'diverged' if isinstance(exc, DivergenceError) else 'error'}:[/red]"
                f" {escape(str(exc))}",
                highlight=False,
                soft_wrap=True,
            )
            records.append({"log": log.name, "kind": label, "diverged": str(exc)})
            continue
        record = _record(log, data, run)
        _print_record(record, name)
        records.append(record)
        shown = {f"{name}, {label}": run.band if run.band is not None else run.adapted.result}
        if run.unadapted is not None:
            shown[f"{name}, un-adapted"] = run.unadapted.result
        fits = ", ".join(f"{o['fit_percent']:.1f} %" for o in record["outputs"])
        panels.append((run.adapted.scored, shown, f"{log.name}: {label}, fit {fits}", None))
    mean = _mean(records, label) if len(logs) > 1 else None
    if json_out is not None:
        from neckid.utils.files import write_json

        document = {
            "model": model_path.name,
            "kind": label,
            "adapt": {"seconds": adapt[0], "mode": adapt[1]},
            "logs": records,
            "mean": mean,
        }
        write_json(json_out, document)
        console.print(f"results written to {json_out}")
    if plot is not None and panels:
        _save_panels(panels, plot)
        console.print(f"figure written to {plot}")
    if any("diverged" in r for r in records):
        raise typer.Exit(code=3)
