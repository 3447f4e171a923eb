"""What the demo writes: figures, model files, the chirp run, metrics and the HTML report."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from neckid.data.iodata import IOData
from neckid.experiments.demo_settings import EXPERIMENTS, OUTPUT, PAPER_LAGS, DemoSettings
from neckid.models.base import ModelResult
from neckid.models.scheduled.model import GainScheduledModel
from neckid.regressors import Lags
from neckid.utils.files import StagedFolder

if TYPE_CHECKING:
    from neckid.report.html import Link, Report

__all__ = ["BANDWIDTH_COMMAND", "CHIRP_RUN", "SETTING_UNITS", "SIMULATION_FIGURES", "write_outputs"]

#: Figures of the free-run simulations: file name and the paper's figure number, per experiment.
SIMULATION_FIGURES = dict(
    zip(
        EXPERIMENTS,
        (
            ("fig5_validation", "Fig. 5"),
            ("fig7_sine", "Fig. 7"),
            ("fig8_staircase", "Fig. 8"),
            ("fig9_step", "Fig. 9"),
        ),
        strict=True,
    )
)

#: The chirp run of step 1, saved for ``neckid bandwidth``.
CHIRP_RUN = "chirp_run.csv"
#: The command that finds the bandwidth in :data:`CHIRP_RUN` (run in the demo folder).
BANDWIDTH_COMMAND = (
    f"neckid bandwidth {CHIRP_RUN} --command reference --response inclination --rate 0.1"
)

#: Unit and meaning of each :class:`DemoSettings` field and of the values the demo derives.
SETTING_UNITS: dict[str, tuple[str, str]] = {
    "seed": ("", "seeds sensor noise, multisine phases, PRBS and networks"),
    "quick": ("", "shorter records and fewer lag candidates"),
    "paper_regressor": ("", "use the paper's regressor instead of selecting the lags"),
    "ts": ("s", "sampling period"),
    "train_duration": ("s", "identification record"),
    "validation_duration": ("s", "validation record"),
    "test_duration": ("s", "each closed-loop test"),
    "chirp_duration": ("s", "bandwidth chirp"),
    "position_center": ("rad", "motor-position excitation: centre"),
    "position_amplitude": ("rad", "motor-position excitation: peak deviation"),
    "band_low": ("rad/s", "lowest excited frequency (the highest is the bandwidth)"),
    "inclinations": ("deg", "operating points of the CFF-RLS protocol"),
    "forgetting_factor": ("-", "CFF-RLS λ (dimensionless)"),
    "bandwidth (measured)": ("rad/s", "Fig. 3; the highest excited frequency"),
    "regressor (NARX)": ("samples", "output and input lags"),
    "sensor delay (simulated neck)": ("samples", "latency of the tilt sensor"),
}


def write_outputs(
    out: StagedFolder,
    settings: DemoSettings,
    chirp: Any,
    chirp_run: tuple[Any, Any, Any],
    records: dict[str, IOData],
    results: dict[str, dict[str, ModelResult]],
    narx_models: dict[str, Any],
    scheduled: GainScheduledModel,
    points: Any,
    table: pd.DataFrame,
    maes: pd.DataFrame,
    selection_table: pd.DataFrame | None,
    lags: Lags,
    *,
    sensor_delay: int,
    loop: dict[str, pd.DataFrame] | None = None,
) -> dict[str, Path]:
    """Write the demo's figures, model files, chirp run and report into the staged folder.

    Returns the final path of every file by kind (``"report"``, ``"fig6_schedule"``,
    ``"model_linear_arx"``, ...); ``metrics.json`` is written by the caller.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)

    from neckid.report.html import Report
    from neckid.report.scheduled_plots import operating_points_frame

    saver = _FigureSaver(out)
    files = saver.files
    dropped = _dropped_points_text(points, scheduled)
    _write_chirp_run(out, files, chirp_run)
    _save_figures(saver, chirp, records, results, narx_models, scheduled, points, dropped)
    links = _save_models(out, files, settings, chirp, narx_models, scheduled)

    report = Report("neckid demo: the soft-neck paper's protocol on the simulated neck")
    _add_result_tables(report, chirp, table, maes, lags, loop)
    report.add_table(
        f"Operating points (CFF-RLS, λ = {settings.forgetting_factor:.2f}), Fig. 6",
        operating_points_frame(points.table),
        note="converged: the estimate stayed in its band over the last window of the log"
        f" (settled at: the sample from which it did).{dropped}",
    )
    if selection_table is not None:
        report.add_table(
            "Lag selection (neural NARX, validation fit)",
            _selection_display(selection_table),
            formats={"terms [count]": "{:.0f}", "max lag [samples]": "{:.0f}"},
            note=_paper_lags_note(selection_table, settings.ts, sensor_delay),
        )
    report.add_figures("Figures", saver.figures)
    report.add_links(
        "Files in this folder",
        links,
        intro="How to use each (Python: import"
        " neckid, json, pathlib first; the command runs in a shell in this folder).",
    )
    _add_settings(report, settings, chirp, lags, sensor_delay)
    report.write(out.path("report.html"))
    files["report"] = out.final("report.html")
    return files


class _FigureSaver:
    """Saves figures into a staged folder, noting each file and its report caption."""

    def __init__(self, out: StagedFolder) -> None:
        from neckid.report.html import Figure

        self.out = out
        self.files: dict[str, Path] = {}
        self.figures: list[Figure] = []

    def save(self, fig: Any, name: str, number: str, caption: str) -> None:
        """Write ``fig`` as ``name.png`` (110 dpi), close it, and note its file and caption."""
        import matplotlib.pyplot as plt

        from neckid.report.html import Figure

        path = self.out.path(f"{name}.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        self.files[name] = self.out.final(path.name)
        self.figures.append(Figure(path, caption, number))


def _dropped_points_text(points: Any, scheduled: GainScheduledModel) -> str:
    """A sentence on the operating points left out of the schedule's lines, if any."""
    left_out = len(points.table) - scheduled.inclinations_.size
    dropped = f" {left_out} operating point(s) whose estimate did not converge are left out of"
    return f"{dropped} the lines N(i), P(i) (drawn hollow in Fig. 6)." if left_out else ""


def _write_chirp_run(
    out: StagedFolder, files: dict[str, Path], chirp_run: tuple[Any, Any, Any]
) -> None:
    """The chirp run as a CSV file, so that `neckid bandwidth` can be tried on a log."""
    columns = dict(zip(("time", "reference", "inclination"), map(np.ravel, chirp_run), strict=True))
    pd.DataFrame(columns).to_csv(out.path(CHIRP_RUN), index=False, float_format="%.10g")
    files["chirp_run"] = out.final(CHIRP_RUN)


def _save_figures(
    saver: _FigureSaver,
    chirp: Any,
    records: dict[str, IOData],
    results: dict[str, dict[str, ModelResult]],
    narx_models: dict[str, Any],
    scheduled: GainScheduledModel,
    points: Any,
    dropped: str,
) -> None:
    """Figs. 3 and 5-9 (bandwidth, free runs, schedule) and S1 (γ*(ε)), in the report's order."""
    from neckid.report.scheduled_plots import GAIN_UNIT, plot_gain_schedule
    from neckid.report.signal_plots import plot_bandwidth

    saver.save(
        plot_bandwidth(chirp),
        "fig3_bandwidth",
        "Fig. 3",
        "Amplitude of the up-chirp reference"
        f" and of the inclination; bandwidth {chirp.bandwidth:.2f} rad/s (paper: 4.2 rad/s).",
    )
    _save_simulation(saver, EXPERIMENTS[0], records, results, narx_models)
    title = "Fig. 6 — CFF-RLS first-order models G(z, i) = N(i) / (z − P(i))"
    saver.save(
        plot_gain_schedule(scheduled, points=points.table, title=title),
        "fig6_schedule",
        "Fig. 6",
        f"Gain N [{GAIN_UNIT}] (left) and pole P [-] (right) of the CFF-RLS"
        f" first-order models against the inclination [deg], with the fitted lines.{dropped}",
    )
    for experiment in EXPERIMENTS[1:]:
        _save_simulation(saver, experiment, records, results, narx_models)
    _save_gamma_curve(saver, narx_models["Set Membership"])


def _save_simulation(
    saver: _FigureSaver,
    experiment: str,
    records: dict[str, IOData],
    results: dict[str, dict[str, ModelResult]],
    narx_models: dict[str, Any],
) -> None:
    """The figure of one experiment's measured inclination and free-run simulations."""
    from neckid.report.plots import plot_simulation

    name, number = SIMULATION_FIGURES[experiment]
    title = f"{number} — {experiment}: measured inclination and free-run simulations"
    view = records[experiment].select(outputs=[OUTPUT])
    fig = plot_simulation(view, results[experiment], title=title, residuals=True)
    saver.save(
        fig,
        name,
        number,
        f"{experiment[0].upper()}{experiment[1:]}: measured inclination"
        " and each model's free run (top; Set Membership bounds shaded), and each model's"
        f" error y − ŷ [deg] (bottom).{_extrapolation_text(narx_models, results[experiment])}",
    )


def _save_gamma_curve(saver: _FigureSaver, sm: Any) -> None:
    """Fig. S1, γ*(ε) of the Set Membership model, when it has the curve."""
    from neckid.report.sm_plots import plot_gamma_curve

    if sm.gamma_curve_ is not None:
        title = "Fig. S1 — γ*(ε) of the Set Membership model (not in the paper)"
        fig = plot_gamma_curve(
            sm.gamma_curve_, unit="deg", chosen=(sm.epsilon_, sm.gamma_), title=title
        )
        saver.save(
            fig,
            "gamma_curve",
            "Fig. S1",
            "γ*(ε): the smallest Lipschitz constant consistent"
            " with the training data, per noise bound ε [deg] (log axes; ε = 0 on the left"
            " edge). The star marks the ε and γ the Set Membership model uses"
            f" (ε = {float(sm.epsilon_[0]):.3g} deg, γ = {float(sm.gamma_[0]):.3g}).",
        )


def _save_models(
    out: StagedFolder,
    files: dict[str, Path],
    settings: DemoSettings,
    chirp: Any,
    narx_models: dict[str, Any],
    scheduled: GainScheduledModel,
) -> list[Link]:
    """Save every model file; the report's links to them, the chirp run and the metrics."""
    from neckid.report.html import Link

    described = {}
    for name, model in narx_models.items():
        slug = name.lower().replace(" + ", "_").replace(" ", "_")
        files[f"model_{slug}"] = out.final(model.save(out.path(f"model_{slug}.npz")).name)
        described[f"model_{slug}"] = f"{name}: motor position [rad] → inclination [deg]"
    scheduled.save(out.path("model_scheduled_cff_rls.npz"))
    files["model_scheduled_cff_rls"] = out.final("model_scheduled_cff_rls.npz")
    described["model_scheduled_cff_rls"] = (
        "Scheduled CFF-RLS: velocity command [rad/s] → inclination [deg]"
    )
    return [
        *(
            Link(
                files[key].name,
                f"{text}. Load it with",
                f'model = neckid.load_model("{files[key].name}")',
            )
            for key, text in described.items()
        ),
        Link(
            CHIRP_RUN,
            "the bandwidth chirp run of Fig. 3: time [s], reference [deg], inclination"
            f" [deg], {1 / settings.ts:.0f} Hz. Find its bandwidth (about"
            f" {chirp.bandwidth:.2f} rad/s, as in Fig. 3) with",
            BANDWIDTH_COMMAND,
        ),
        Link(
            "metrics.json",
            "every number of this report, machine-readable. Read it with",
            'json.loads(pathlib.Path("metrics.json").read_text())',
        ),
    ]


def _add_result_tables(
    report: Report,
    chirp: Any,
    table: pd.DataFrame,
    maes: pd.DataFrame,
    lags: Lags,
    loop: dict[str, pd.DataFrame] | None,
) -> None:
    """The report's "What ran" text, its fit and error tables, and the models-in-the-loop table."""
    report.add_text(
        "What ran",
        "The simulated tendon-driven neck (neckid.plant.SoftNeck, planar) stands in for the real one."
        f" Bandwidth from the paper's up-chirp: {chirp.bandwidth:.2f} rad/s (paper: 4.2 rad/s,"
        f" Fig. 3). NARX models map motor position [rad] to inclination [deg] with the regressor"
        f" {lags!r} (lags in samples); the scheduled model maps velocity command [rad/s] to"
        " inclination rate, integrated. Fit is MATLAB's compare fit, 100 (1 - ||y - ŷ|| /"
        " ||y - mean(y)||) [%], of the free-run simulation, skipping the initial-condition"
        " samples (Figs. 5, 7-9).",
    )
    fits = table.reset_index().set_axis(["model", *(f"{e}, fit [%]" for e in EXPERIMENTS)], axis=1)
    report.add_table(
        "Fit [%] (free run), ours and the paper's",
        fits,
        note="Rows marked (paper)"
        " are the paper's fits on its own neck and records, for orientation.",
    )
    errors = maes.reset_index().set_axis(
        ["model", *(f"{e}, MAE [deg]" for e in EXPERIMENTS)], axis=1
    )
    report.add_table("Mean absolute error [deg]", errors, float_format="{:.3f}")
    if loop is not None:
        _add_loop_table(report, table, loop)


def _add_loop_table(report: Report, table: pd.DataFrame, loop: dict[str, pd.DataFrame]) -> None:
    """The table of tests 1-3: free-run fit against the fits of each model in the loop."""
    tests = list(loop["fit"].columns)
    free = table.loc[list(loop["fit"].index), tests]
    both = pd.concat(
        {
            "free run, fit [%]": free,
            "in the loop, fit [%]": loop["fit"],
            "in the loop, command fit [%]": loop["command_fit"],
        },
        axis=1,
    )
    both.columns = [f"{column[1]}: {column[0]}" for column in both.columns]
    report.add_table(
        "Models in the loop: tests 1-3, fit [%]",
        both.reset_index(names="model"),
        note="Free run: the model driven by the motor signal recorded in the neck's closed"
        " loop. In the loop: the model in place of the neck, with the same PI controller and"
        " references; the command fit compares the controller's velocity command [rad/s]"
        " with the one recorded on the neck. Fits skip each model's initial samples.",
    )


def _add_settings(
    report: Report, settings: DemoSettings, chirp: Any, lags: Lags, sensor_delay: int
) -> None:
    """The report's settings table (with the values the demo derives) and library versions."""
    from neckid.report.html import library_versions, settings_frame

    derived = {
        "bandwidth (measured)": round(float(chirp.bandwidth), 2),
        "regressor (NARX)": repr(lags),
        "sensor delay (simulated neck)": sensor_delay,
    }
    frame = settings_frame({**asdict(settings), **derived}, SETTING_UNITS, ts=settings.ts)
    report.add_table("Settings", frame)
    report.add_mapping("Versions", library_versions())


def _extrapolation_text(narx_models: dict[str, Any], results: dict[str, ModelResult]) -> str:
    """A sentence on the share of a record outside the NARX models' training range, if any."""
    name = next(iter(narx_models))
    share = results[name].extras.get("extrapolation", {}).get(OUTPUT, 0.0)
    ranges = getattr(narx_models[name], "training_ranges_", {})
    if share < 0.01 or OUTPUT not in ranges:
        return ""
    return (
        f" {share:.0%} of the measured inclination lies outside {ranges[OUTPUT][0]:.1f}–"
        f"{ranges[OUTPUT][1]:.1f} deg, the range the NARX models were identified on: they"
        " extrapolate there."
    )


def _selection_display(selection: pd.DataFrame) -> pd.DataFrame:
    """The lag-selection table reduced to what a reader needs, units in the headers."""
    paper = repr(PAPER_LAGS)
    return pd.DataFrame(
        {
            "candidate lags": [f"{v} (paper)" if v == paper else str(v) for v in selection["lags"]],
            "terms [count]": selection["n_terms"].to_numpy(dtype=np.float64),
            "max lag [samples]": selection["max_lag"].to_numpy(dtype=np.float64),
            "one-step fit [%]": selection["fit_prediction"].to_numpy(dtype=np.float64),
            "free-run fit [%]": selection["fit_simulation"].to_numpy(dtype=np.float64),
            "error": [str(v) if isinstance(v, str) else "" for v in selection["error"]],
        }
    )


def _paper_lags_note(selection: pd.DataFrame, ts: float, sensor_delay: int) -> str:
    """Sentences on why the paper's regressor scores as it does on the simulated neck."""
    input_lags = [v for v in PAPER_LAGS.inputs if isinstance(v, int)]  # one input: 8, 9, 10
    first, last = min(input_lags), max(input_lags)
    best, rows = selection.iloc[0], selection[selection["lags"] == repr(PAPER_LAGS)]
    text = (
        "Fits are in % on the validation record (100 % = perfect; below 0 %: further from the"
        f" measurement than its mean). The best candidate, {best['lags']}, scores"
        f" {float(best['fit_simulation']):.2f} % in free run."
    )
    if rows.empty:
        return text
    row = rows.iloc[0]
    failed = isinstance(row["error"], str) and row["error"]
    result = (
        f"fails ({row['error']})"
        if failed
        else f"scores {float(row['fit_simulation']):.2f} % in free run and"
        f" {float(row['fit_prediction']):.2f} % one step ahead"
    )
    return (
        f"{text} The paper's regressor y(t−1..3), u(t−{first}..{last}) {result}. Its input lags,"
        f" {first}–{last} samples ({first * ts:.2f}–{last * ts:.2f} s at {1 / ts:.0f} Hz), were"
        " chosen on the paper's own neck and do not match the simulated neck's delay: its tilt"
        f" sensor lags {sensor_delay} samples ({sensor_delay * ts:.2f} s), so the motor positions"
        f" of the last {first - 1} samples, which drive the inclination, are missing from that"
        " regressor. One step ahead, the measured past inclinations make up for them; in free run"
        " they cannot."
    )
