"""What the 3-D demo writes: figures, model files, metrics and the HTML report."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from neckid.data.iodata import IOData
from neckid.experiments.demo_outputs import _FigureSaver
from neckid.experiments.neck3d_settings import TESTS_3D, Demo3DSettings
from neckid.models.base import ModelResult
from neckid.regressors import Lags
from neckid.utils.files import StagedFolder

if TYPE_CHECKING:
    from neckid.report.html import Link, Report

__all__ = ["SETTING_UNITS_3D", "write_outputs_3d"]

#: Unit and meaning of each :class:`Demo3DSettings` field (report table).
SETTING_UNITS_3D: dict[str, tuple[str, str]] = {
    "seed": ("", "seeds sensor noise, multisine phases and networks"),
    "quick": ("", "shorter records, one chirp direction, fewer lag candidates"),
    "ts": ("s", "sampling period"),
    "train_duration": ("s", "identification record"),
    "validation_duration": ("s", "validation record"),
    "test_duration": ("s", "each closed-loop test"),
    "chirp_duration": ("s", "each bandwidth chirp"),
    "directions": ("deg", "orientations of the bandwidth chirps"),
    "pretension": ("rad", "q0: mean motor position (tendons taut)"),
    "amplitude": ("rad", "A: peak motor deviation per unit bending direction"),
    "band_low": ("rad/s", "lowest excited frequency (the highest is the bandwidth)"),
    "orientation_min_inclination": ("deg", "orientation errors scored above this inclination"),
    "regressor (NARX)": ("samples", "output and input lags"),
}

#: File name and figure number of each record's figures.
_FIGURES = {
    TESTS_3D[0]: ("fig2_validation", "Fig. 2"),
    TESTS_3D[1]: ("fig3_circle", "Fig. 3"),
    TESTS_3D[2]: ("fig4_orientation_steps", "Fig. 4"),
    TESTS_3D[3]: ("fig5_diagonal_step", "Fig. 5"),
}


def _flat(frame: pd.DataFrame, unit: str) -> pd.DataFrame:
    flat = frame.copy()
    flat.columns = [f"{column[0]}: {column[1]} [{unit}]" for column in frame.columns]
    return flat.reset_index(names="model")


def write_outputs_3d(
    out: StagedFolder,
    settings: Demo3DSettings,
    chirps: dict[float, tuple[Any, Any, Any, Any]],
    views: dict[str, IOData],
    references: dict[str, np.ndarray],
    results: dict[str, dict[str, ModelResult]],
    models: dict[str, Any],
    fit: pd.DataFrame,
    mae: pd.DataFrame,
    selection_table: pd.DataFrame,
    lags: Lags,
) -> dict[str, Path]:
    """Write the 3-D demo's figures, model files and report into the staged folder.

    Returns the final path of every file by kind; ``metrics.json`` is written by the caller.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)

    from neckid.report.html import Report, library_versions, settings_frame

    saver = _FigureSaver(out)
    files = saver.files
    _save_bandwidth_figure(saver, chirps)
    _save_record_figures(saver, views, references, results)
    links = _save_models_3d(out, files, models)

    report = Report("neckid demo --3d: the three-tendon neck, tendons in, tilt out")
    _add_what_ran(report, settings, chirps, lags)
    _add_tables_3d(report, settings, fit, mae, selection_table)
    report.add_figures("Figures", saver.figures)
    report.add_links(
        "Files in this folder",
        links,
        intro="Python: import neckid, json, pathlib first.",
    )
    derived = {"regressor (NARX)": repr(lags)}
    frame = settings_frame({**asdict(settings), **derived}, SETTING_UNITS_3D, ts=settings.ts)
    report.add_table("Settings", frame)
    report.add_mapping("Versions", library_versions())
    report.write(out.path("report.html"))
    files["report"] = out.final("report.html")
    return files


def _save_bandwidth_figure(
    saver: _FigureSaver, chirps: dict[float, tuple[Any, Any, Any, Any]]
) -> None:
    """Fig. 1: the amplitudes of each bandwidth chirp, one panel per direction."""
    import matplotlib.pyplot as plt

    from neckid.report.signal_plots import plot_bandwidth

    fig, axes = plt.subplots(
        1, len(chirps), figsize=(5.2 * len(chirps), 3.8), layout="constrained", squeeze=False
    )
    for ax, (direction, run) in zip(axes[0], chirps.items(), strict=True):
        plot_bandwidth(run[0], ax=ax, unit="deg")
        ax.set_title(f"towards {direction:g}°: {run[0].bandwidth:.2f} rad/s", fontsize=10)
    saver.save(
        fig,
        "fig1_bandwidth",
        "Fig. 1",
        "Amplitude of the up-chirp inclination reference and of the tilt along its direction"
        " [deg] against frequency [rad/s], one panel per orientation of the chirp; the vertical"
        " line is the bandwidth (90 % rule).",
    )


def _save_record_figures(
    saver: _FigureSaver,
    views: dict[str, IOData],
    references: dict[str, np.ndarray],
    results: dict[str, dict[str, ModelResult]],
) -> None:
    """Figs. 2-5: the tilt components of the validation record and test 3, the tilt plane of tests 1-2."""
    from neckid.report.tilt_plots import plot_tilt_plane

    bands_text = (
        " with the Set Membership bands shaded (each component's band is guaranteed under that"
        " model's prior ε, γ)."
    )
    _save_components(
        saver,
        views,
        results,
        TESTS_3D[0],
        "Fig. 2 — validation record: measured tilt vector and free-run simulations",
        "Validation record (open loop, other multisine phases): tilt_x (top) and tilt_y"
        " (bottom) [deg] against time [s], measured and each model's free run," + bands_text,
    )
    _save_components(
        saver,
        views,
        results,
        TESTS_3D[3],
        f"Fig. 5 — {TESTS_3D[3]}: measured tilt vector and free-run simulations",
        "Test 3 (closed loop on the neck, a 20° step towards 45° at 1 s): tilt_x (top) and"
        " tilt_y (bottom) [deg] against time [s], measured and each model's free run on the"
        " recorded motor positions," + bands_text,
    )
    for record in TESTS_3D[1:3]:
        name, number = _FIGURES[record]
        fig = plot_tilt_plane(
            views[record],
            results[record],
            reference=references.get(record),
            title=f"{number} — {record}: tilt plane",
        )
        saver.save(
            fig,
            name,
            number,
            f"{record[0].upper()}{record[1:]} (closed loop on the neck): the tilt vector's"
            " trajectory [deg] in the tilt plane, measured (black), the reference (dotted) and"
            " each model's free run on the recorded motor positions; grey circles every 10° of"
            " inclination, dashed lines the tendon directions.",
        )


def _save_components(
    saver: _FigureSaver,
    views: dict[str, IOData],
    results: dict[str, dict[str, ModelResult]],
    record: str,
    title: str,
    caption: str,
) -> None:
    """One record's tilt_x and tilt_y, measured and simulated, in two panels."""
    import matplotlib.pyplot as plt

    from neckid.report.plots import plot_simulation

    fig, axes = plt.subplots(2, 1, figsize=(10, 6.4), sharex=True, layout="constrained")
    for k, ax in enumerate(axes):
        plot_simulation(views[record], results[record], output=k, ax=ax)
    axes[0].set_title(title)
    axes[0].set_xlabel("")
    saver.save(fig, *_FIGURES[record], caption)


def _save_models_3d(
    out: StagedFolder, files: dict[str, Path], models: dict[str, Any]
) -> list[Link]:
    """Save every model file; the report's links to them and to the metrics."""
    from neckid.report.html import Link

    described = {}
    for label, model in models.items():
        slug = label.lower().replace(" + ", "_").replace(" ", "_").replace("-", "_")
        files[f"model_{slug}"] = out.final(model.save(out.path(f"model_{slug}.npz")).name)
        described[f"model_{slug}"] = f"{label}: three motor positions [rad] → tilt_x, tilt_y [deg]"
    return [
        *(
            Link(files[k].name, f"{text}. Load it with", f'neckid.load_model("{files[k].name}")')
            for k, text in described.items()
        ),
        Link(
            "metrics.json",
            "every number of this report, machine-readable. Read it with",
            'json.loads(pathlib.Path("metrics.json").read_text())',
        ),
    ]


def _add_what_ran(
    report: Report,
    settings: Demo3DSettings,
    chirps: dict[float, tuple[Any, Any, Any, Any]],
    lags: Lags,
) -> None:
    """The report's "What ran" text: the neck, the bandwidths, the excitation and the models."""
    bands = ", ".join(f"{d:g}°: {run[0].bandwidth:.2f}" for d, run in chirps.items())
    report.add_text(
        "What ran",
        "The simulated three-tendon neck (neckid.plant.SoftNeck, configuration three_tendon)."
        f" Bandwidth per chirp direction [rad/s]: {bands}. The excitation winds motor j to"
        f" q0 + A (x cos α_j + y sin α_j) with q0 = {settings.pretension:g} rad, A ="
        f" {settings.amplitude:g} rad and two multisines x, y (tendons at α = 0°, 120°, 240°),"
        " so the tendons stay taut. Inclination and orientation are identified as the tilt"
        " vector tilt_x = i cos φ, tilt_y = i sin φ [deg] (no wrap at 0/360°, defined at zero"
        f" inclination). Every model maps the three motor positions [rad] to it with {lags!r}."
        " Fit is 100 (1 - ||y - ŷ|| / ||y - mean(y)||) [%] of the free run per output, skipping"
        " the initial-condition samples; the inclination and orientation errors convert each"
        " model's tilt vector back. The inclination-scheduled CFF-RLS model is planar (a scalar schedule)"
        " and is not run here.",
    )


def _add_tables_3d(
    report: Report,
    settings: Demo3DSettings,
    fit: pd.DataFrame,
    mae: pd.DataFrame,
    selection_table: pd.DataFrame,
) -> None:
    """The report's fit, error and lag-selection tables."""
    report.add_table("Free-run fit [%] per tilt component", _flat(fit, "%"))
    report.add_table(
        "Mean absolute error [deg]",
        _flat(mae, "deg"),
        float_format="{:.3f}",
        note="orientation: mean circular error |wrap(φ̂ − φ)| [deg] over the samples whose"
        f" measured inclination is at least {settings.orientation_min_inclination:g}°.",
    )
    report.add_table(
        "Lag selection (ARX, leave-one-half-out on the identification record)",
        pd.DataFrame(
            {
                "candidate lags": [str(v) for v in selection_table["lags"]],
                "terms [count]": selection_table["n_terms"].to_numpy(dtype=np.float64),
                "one-step fit [%]": selection_table["fit_prediction"].to_numpy(dtype=np.float64),
                "free-run fit [%]": selection_table["fit_simulation"].to_numpy(dtype=np.float64),
            }
        ),
        formats={"terms [count]": "{:.0f}"},
        note="Each candidate is fitted on one half of the identification record and free-run on"
        " the other, both ways; the validation record and the tests are not used to choose.",
    )
