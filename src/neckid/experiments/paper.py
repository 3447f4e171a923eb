"""The seed paper's whole protocol on the simulated neck: what ``neckid demo`` runs.

Steps (numbers as in the paper, "Model Identification of a Soft Robotic Neck", UC3M):

1. **Bandwidth.** The up-chirp ``5 + 4 sin(0.1 t²)`` [deg] (eq. 14–15) as the inclination
   reference of the PI loop; the bandwidth is where the inclination's amplitude stays below 90 % of
   the reference's (the paper: 4.2 rad/s, used as 4 rad/s).
2. **Identification data.** In open loop, the motor is driven by a velocity command whose integral
   (the motor position) is a sum of sinusoids over ``[0.05, bandwidth]`` rad/s with random phases,
   around a pre-tension; one record to identify, a second with other phases to validate.
   The CFF-RLS runs at 5°, 10°, …, 35° reached in closed loop with a PRBS on the command.
3. **Regressor.** Chosen the paper's way: neural networks trained over candidate lag sets, the
   best free-run fit on the validation record wins; or the paper's own ``[y(t−1..3), u(t−8..10)]``.
4. **Models.** Set Membership (pure, and with a linear part), neural NARX 2×25, linear ARX, all
   from measured motor position [rad] to inclination [deg]; and the inclination-scheduled
   first-order model ``G(z, i) = N(i)/(z − P(i))`` from velocity command [rad/s] to inclination
   rate, integrated.
5. **Validation** by free-run fit on the validation record.
6. **Tests 1–3** in closed loop on the neck: a 2 rad/s sine (15° ± 5°), 5° steps every 3 s up to
   30°, and a 20° step; every model is simulated with the recorded inputs and compared with the
   measured inclination (fit and mean absolute error in degrees).
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from neckid.data import IOData
from neckid.models.base import ModelResult
from neckid.models.scheduled import GainScheduledModel
from neckid.outputs import StagedFolder
from neckid.plant import InclinationController, SoftNeck, closed_loop
from neckid.plant.calibration import chirp_bandwidth
from neckid.registry import methods
from neckid.regressors import Lags
from neckid.selection import lag_grid, select_lags
from neckid.signals import multisine, sine, staircase, step

__all__ = ["PAPER_FITS", "DemoResult", "DemoSettings", "run_demo"]

logger = logging.getLogger(__name__)

#: Columns of the results table: the validation record and the three closed-loop tests.
EXPERIMENTS = ("validation", "test 1: sine 2 rad/s", "test 2: 5° staircase", "test 3: 20° step")

#: The seed paper's NRMSE fits [%] on its own neck, same columns (NaN: not reported).
PAPER_FITS: dict[str, tuple[float, float, float, float]] = {
    "Set Membership (paper)": (88.75, 91.0, 84.65, 67.87),
    "Neural NARX 2x25 (paper)": (93.75, 92.0, 86.25, 75.16),
    "MATLAB nlarx default (paper)": (58.0, float("nan"), float("nan"), float("nan")),
}

#: The seed paper's regressor with one motor: [y(t-1..t-3), u(t-8..t-10)].
PAPER_LAGS = Lags(outputs=3, inputs=[8, 9, 10])
#: The NARX methods of the demo (registry names), in the order of its table; the scheduled
#: CFF-RLS model follows, identified by the operating-point protocol on the plant.
DEMO_METHODS = ("sm", "sm-linear", "nn", "arx")

NARX_INPUT = "motor_position"
SCHEDULED_INPUT = "velocity_command"
OUTPUT = "inclination"


@dataclass(frozen=True)
class DemoSettings:
    """Everything that shapes the demo's numbers (written into the report).

    Attributes
    ----------
    seed : int
        Seeds the neck's sensor noise, the multisine phases, the PRBS and the networks.
    quick : bool
        Shorter records and fewer lag candidates (for the test suite).
    paper_regressor : bool
        Use the paper's ``[y(t-1..3), u(t-8..10)]`` instead of selecting the lags.
    ts : float
        Sampling period [s] of the neck and of every record.
    train_duration, validation_duration, test_duration : float
        Record lengths [s].
    chirp_duration : float
        Length of the bandwidth chirp [s] (its frequency reaches ``0.2 * chirp_duration`` rad/s).
    position_center, position_amplitude : float
        Motor-position excitation: centre and peak deviation [rad].
    band_low : float
        Lowest excited frequency [rad/s]; the highest is the measured bandwidth.
    inclinations : tuple of float
        Operating points of the CFF-RLS protocol [deg].
    forgetting_factor : float
        CFF-RLS λ.
    """

    seed: int = 0
    quick: bool = False
    paper_regressor: bool = False
    ts: float = 0.02
    train_duration: float = 120.0
    validation_duration: float = 60.0
    test_duration: float = 20.0
    chirp_duration: float = 60.0
    position_center: float = 2.5
    position_amplitude: float = 2.5
    band_low: float = 0.05
    inclinations: tuple[float, ...] = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0)
    forgetting_factor: float = 0.98

    @classmethod
    def make(
        cls, *, quick: bool = False, seed: int = 0, paper_regressor: bool = False
    ) -> DemoSettings:
        """Default settings, or the shorter ``quick`` ones."""
        if quick:
            return cls(
                seed=seed,
                quick=True,
                paper_regressor=paper_regressor,
                train_duration=60.0,
                validation_duration=30.0,
                test_duration=12.0,
                chirp_duration=50.0,
                inclinations=(10.0, 20.0, 30.0),
            )
        return cls(seed=seed, paper_regressor=paper_regressor)


@dataclass
class DemoResult:
    """What :func:`run_demo` produced.

    Attributes
    ----------
    table : pandas.DataFrame
        Fit [%] per model (rows) and experiment (columns), the paper's rows below ours.
    mae : pandas.DataFrame
        Mean absolute error [deg], same layout (our models only).
    metrics : dict
        Everything machine-readable (also written to ``metrics.json``).
    bandwidth : float
        Measured bandwidth [rad/s].
    lags : Lags
        The regressor used by the NARX models.
    files : dict of str to Path
        Report, metrics, figures and model files written.
    wall_time : float
        Seconds for the whole run.
    """

    table: pd.DataFrame
    mae: pd.DataFrame
    metrics: dict[str, Any]
    bandwidth: float
    lags: Lags
    files: dict[str, Path] = field(default_factory=dict)
    wall_time: float = 0.0


def _open_loop_record(
    neck: SoftNeck, settings: DemoSettings, duration: float, band_high: float, seed: int
) -> IOData:
    """Open-loop run: velocity command = derivative of a motor-position multisine, after a pre-tension."""
    ts = settings.ts
    n = round(duration / ts)
    position = settings.position_center + settings.position_amplitude * multisine(
        n, ts, band=(settings.band_low, band_high), amplitude=1.0, phases="random", seed=seed
    )
    n_ramp = round(3.0 / ts)
    ramp = np.full(n_ramp, position[0] / (n_ramp * ts))
    velocity = np.concatenate([ramp, np.diff(position, prepend=position[0]) / ts])
    neck.reset()
    return neck.run(velocity)[n_ramp:]


def _closed_loop_tests(neck: SoftNeck, settings: DemoSettings) -> dict[str, IOData]:
    ts = settings.ts
    t = np.arange(round(settings.test_duration / ts)) * ts
    references = {
        EXPERIMENTS[1]: sine(t, amplitude=5.0, omega=2.0, offset=15.0),
        EXPERIMENTS[2]: staircase(t, step=5.0, step_duration=3.0, start_time=1.0, maximum=30.0),
        EXPERIMENTS[3]: step(t, amplitude=20.0, step_time=1.0),
    }
    logs = {}
    for name, reference in references.items():
        neck.reset()
        logs[name] = closed_loop(neck, InclinationController(ts=ts), reference, ts)
    return logs


def _narx_view(data: IOData) -> IOData:
    return data.select(inputs=[NARX_INPUT], outputs=[OUTPUT])


def run_demo(
    out_dir: str | Path = "neckid-demo",
    settings: DemoSettings | None = None,
    on_step: Callable[[str], None] | None = None,
    *,
    force: bool = False,
) -> DemoResult:
    """Run the paper's protocol on the simulated neck and write the report.

    Parameters
    ----------
    out_dir : path, default "neckid-demo"
        Folder for ``report.html``, ``metrics.json``, the PNG figures and the model files; created if
        missing.
    settings : DemoSettings, optional
        Default ``DemoSettings.make()``.
    on_step : callable, optional
        Called with a short description as each step starts (the CLI's progress bar).
    force : bool, default False
        Replace the files of a folder that holds some already.

    Returns
    -------
    DemoResult

    Raises
    ------
    neckid.outputs.OutputError
        Before any computation: ``out_dir`` is a file, holds files (without ``force``), or another
        run is writing into it. The folder is locked for the run; its files are written in a
        hidden staging folder and moved in together at the end, so an interrupted run changes
        nothing.
    """
    from neckid.outputs import output_folder

    with output_folder(out_dir, force=force) as staged:
        return _run_protocol(staged, settings, on_step)


def _run_protocol(
    out: StagedFolder, settings: DemoSettings | None, on_step: Callable[[str], None] | None
) -> DemoResult:
    from neckid.experiments.operating_points import identify_operating_points

    started = time.perf_counter()
    settings = settings if settings is not None else DemoSettings.make()
    notify = on_step if on_step is not None else (lambda _text: None)
    rng = np.random.default_rng(settings.seed)
    seeds = rng.integers(0, 2**31 - 1, size=8)

    # 1. bandwidth --------------------------------------------------------------------------
    notify("bandwidth: the paper's up-chirp in closed loop")
    neck = SoftNeck(ts=settings.ts, seed=int(seeds[0]))
    chirp, chirp_time, chirp_reference, chirp_response = chirp_bandwidth(
        neck, duration=settings.chirp_duration
    )
    bandwidth = float(chirp.bandwidth) if np.isfinite(chirp.bandwidth) else 4.0
    band_high = min(bandwidth, 0.5 * np.pi / settings.ts)

    # 2. identification data -----------------------------------------------------------------
    notify("identification data: open-loop multisine, validation record, tests 1-3")
    train = _open_loop_record(neck, settings, settings.train_duration, band_high, int(seeds[1]))
    validation = _open_loop_record(
        neck, settings, settings.validation_duration, band_high, int(seeds[2])
    )
    tests = _closed_loop_tests(neck, settings)
    records = {EXPERIMENTS[0]: validation, **tests}

    # 3. regressor -----------------------------------------------------------------------------
    notify(
        "regressor: networks over candidate lag sets"
        if not settings.paper_regressor
        else "regressor: the paper's"
    )
    selection_table = None
    network = methods()["nn"].make(PAPER_LAGS, random_state=int(seeds[3]))
    if settings.paper_regressor:
        lags = PAPER_LAGS
    else:
        if settings.quick:
            candidates = [*lag_grid([1, 2], [3], input_delays=[1]), PAPER_LAGS]
        else:
            candidates = [*lag_grid([1, 2, 3], [2, 3], input_delays=[1]), PAPER_LAGS]
        selection = select_lags(
            _narx_view(train), _narx_view(validation), candidates, network, n_jobs=2, progress=False
        )
        selection_table = selection.table
        lags = selection.best_lags

    # 4. models ----------------------------------------------------------------------------------
    notify("models: Set Membership, neural NARX, ARX")
    narx_models: dict[str, Any] = {}
    for name in DEMO_METHODS:
        method = methods()[name]
        seeded = "random_state" in method.estimator_class()._parameter_constraints
        params: dict[str, Any] = {"random_state": int(seeds[3])} if seeded else {}
        narx_models[method.label] = method.make(lags, **params)
    fit_times = {}
    for name, model in narx_models.items():
        t0 = time.perf_counter()
        model.fit(_narx_view(train))
        fit_times[name] = time.perf_counter() - t0

    notify("CFF-RLS at each inclination, scheduled model")
    t0 = time.perf_counter()
    rls_neck = SoftNeck(ts=settings.ts, seed=int(seeds[4]))
    points = identify_operating_points(
        rls_neck,
        inclinations=settings.inclinations,
        ts=settings.ts,
        # The tilt sensor's latency (2 samples on the simulated neck, as on the bench) plus the
        # one sample of the paper's G(z) = N / (z - P).
        delay=rls_neck.delay_samples + 1,
        forgetting_factor=settings.forgetting_factor,
        seed=int(seeds[5]),
    )
    scheduled = points.fit_schedule(converged_only=int(points.converged.sum()) >= 2)
    fit_times["Scheduled CFF-RLS"] = time.perf_counter() - t0

    # 5-6. validation and tests ------------------------------------------------------------------
    notify("validation and closed-loop tests")
    results: dict[str, dict[str, ModelResult]] = {e: {} for e in records}
    for experiment, record in records.items():
        view = _narx_view(record)
        for name, model in narx_models.items():
            results[experiment][name] = model.simulate(view)
        results[experiment]["Scheduled CFF-RLS"] = scheduled.simulate(
            record.select(inputs=[SCHEDULED_INPUT], outputs=[OUTPUT])
        )
    model_names = [*narx_models, "Scheduled CFF-RLS"]
    fits = pd.DataFrame(index=model_names, columns=list(EXPERIMENTS), dtype=float)
    maes = pd.DataFrame(index=model_names, columns=list(EXPERIMENTS), dtype=float)
    rmses = pd.DataFrame(index=model_names, columns=list(EXPERIMENTS), dtype=float)
    for experiment, record in records.items():
        for name in model_names:
            result = results[experiment][name]
            fits.loc[name, experiment] = float(
                result.fit_percent(record.select(outputs=[OUTPUT]).y)[0]
            )
            maes.loc[name, experiment] = float(result.mae(record.select(outputs=[OUTPUT]).y)[0])
            rmses.loc[name, experiment] = float(result.rmse(record.select(outputs=[OUTPUT]).y)[0])
    paper = pd.DataFrame(PAPER_FITS, index=list(EXPERIMENTS)).T
    table = pd.concat([fits, paper])
    table.index.name = "model"
    maes.index.name = "model"

    # 7-8. files -----------------------------------------------------------------------------------
    notify("figures, models, report")
    files = _write_outputs(
        out,
        settings,
        chirp,
        (chirp_time, chirp_reference, chirp_response),
        records,
        results,
        narx_models,
        scheduled,
        points,
        table,
        maes,
        selection_table,
        lags,
        sensor_delay=neck.delay_samples,
    )
    metrics: dict[str, Any] = {
        "settings": {
            k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(settings).items()
        },
        "bandwidth_rad_s": bandwidth,
        "bandwidth_status": chirp.status,
        "paper_bandwidth_rad_s": 4.2,
        "lags": repr(lags),
        "fit_percent": _nested(fits),
        "mae_deg": _nested(maes),
        "rmse_deg": _nested(rmses),
        "paper_fit_percent": {
            k: dict(zip(EXPERIMENTS, v, strict=True)) for k, v in PAPER_FITS.items()
        },
        "fit_time_s": fit_times,
        "set_membership": {
            name: {"epsilon": float(model.epsilon_[0]), "gamma": float(model.gamma_[0])}
            for name, model in narx_models.items()
            if hasattr(model, "gamma_")
        },
        "schedule": {
            "gain_coefficients": scheduled.gain_coefficients_.tolist(),
            "pole_coefficients": scheduled.pole_coefficients_.tolist(),
            "points": json.loads(points.table.to_json(orient="records")),
        },
        "files": {k: str(v.name) for k, v in files.items()},
    }
    wall = time.perf_counter() - started
    metrics["wall_time_s"] = wall
    out.path("metrics.json").write_text(json.dumps(_json_ready(metrics), indent=2, allow_nan=False))
    files["metrics"] = out.final("metrics.json")
    return DemoResult(table, maes, metrics, bandwidth, lags, files, wall)


def _nested(frame: pd.DataFrame) -> dict[str, dict[str, float | None]]:
    return {
        str(row): {
            str(col): (None if not np.isfinite(v) else float(v))
            for col, v in frame.loc[row].items()
        }
        for row in frame.index
    }


def _json_ready(value: Any) -> Any:
    """Plain JSON values: NumPy scalars as Python numbers, NaN and inf as null."""
    if isinstance(value, dict):
        return {str(k): _json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_ready(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


#: Figures of the free-run simulations: file name and the paper's figure number, per experiment.
SIMULATION_FIGURES = {
    EXPERIMENTS[0]: ("fig5_validation", "Fig. 5"),
    EXPERIMENTS[1]: ("fig7_sine", "Fig. 7"),
    EXPERIMENTS[2]: ("fig8_staircase", "Fig. 8"),
    EXPERIMENTS[3]: ("fig9_step", "Fig. 9"),
}

#: The chirp run of step 1, saved for ``neckid bandwidth``.
CHIRP_RUN = "chirp_run.csv"
#: The command that finds the bandwidth in :data:`CHIRP_RUN` (run in the demo folder).
BANDWIDTH_COMMAND = (
    f"neckid bandwidth {CHIRP_RUN} --command reference --response inclination --rate 0.1"
)

#: Unit and meaning of each :class:`DemoSettings` field, for the report's settings table.
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
}


def _write_outputs(
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
) -> dict[str, Path]:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from neckid.report.html import Figure, Link, Report, library_versions
    from neckid.report.plots import plot_simulation
    from neckid.report.scheduled_plots import GAIN_UNIT, plot_gain_schedule
    from neckid.report.signal_plots import plot_bandwidth
    from neckid.report.sm_plots import plot_gamma_curve

    files: dict[str, Path] = {}
    figures: list[Figure] = []

    def save(fig: Any, name: str, number: str, caption: str) -> None:
        path = out.path(f"{name}.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        files[name] = out.final(path.name)
        figures.append(Figure(path, caption, number))

    # The chirp run, so that `neckid bandwidth` can be tried on a log.
    chirp_time, chirp_reference, chirp_response = (np.ravel(a) for a in chirp_run)
    pd.DataFrame(
        {"time": chirp_time, "reference": chirp_reference, "inclination": chirp_response}
    ).to_csv(out.path(CHIRP_RUN), index=False, float_format="%.10g")
    files["chirp_run"] = out.final(CHIRP_RUN)

    save(
        plot_bandwidth(chirp),
        "fig3_bandwidth",
        "Fig. 3",
        "Amplitude of the up-chirp reference and of the inclination; bandwidth"
        f" {chirp.bandwidth:.2f} rad/s (paper: 4.2 rad/s).",
    )

    def save_simulation(experiment: str) -> None:
        name, number = SIMULATION_FIGURES[experiment]
        view = records[experiment].select(outputs=[OUTPUT])
        fig = plot_simulation(
            view,
            results[experiment],
            title=f"{number} — {experiment}: measured inclination and free-run simulations",
            residuals=True,
        )
        save(
            fig,
            name,
            number,
            f"{experiment[0].upper()}{experiment[1:]}: measured inclination and each model's free"
            " run (top; Set Membership bounds shaded), and each model's error y − ŷ [deg]"
            f" (bottom).{_extrapolation_text(narx_models, results[experiment])}",
        )

    save_simulation(EXPERIMENTS[0])
    left_out = len(points.table) - scheduled.inclinations_.size
    save(
        plot_gain_schedule(
            scheduled,
            points=points.table,
            title="Fig. 6 — CFF-RLS first-order models G(z, i) = N(i) / (z − P(i))",
        ),
        "fig6_schedule",
        "Fig. 6",
        f"Gain N [{GAIN_UNIT}] (left) and pole P [-] (right) of the CFF-RLS first-order models"
        " against the inclination [deg], with the fitted lines and their equations"
        + (
            f"; {left_out} operating point(s) whose estimate did not converge are drawn hollow"
            " and left out of the fit."
            if left_out
            else "."
        ),
    )
    for experiment in EXPERIMENTS[1:]:
        save_simulation(experiment)
    sm = narx_models["Set Membership"]
    if sm.gamma_curve_ is not None:
        save(
            plot_gamma_curve(
                sm.gamma_curve_,
                unit="deg",
                chosen=(sm.epsilon_, sm.gamma_),
                title="Fig. S1 — γ*(ε) of the Set Membership model (not in the paper)",
            ),
            "gamma_curve",
            "Fig. S1",
            "γ*(ε): the smallest Lipschitz constant consistent with the training data, per noise"
            " bound ε [deg] (log axes; ε = 0 is drawn on the left edge). The star marks the ε and"
            " γ the Set Membership model uses"
            f" (ε = {float(sm.epsilon_[0]):.3g} deg, γ = {float(sm.gamma_[0]):.3g}). Not a"
            " figure of the paper.",
        )

    links: list[Link] = []
    for name, model in narx_models.items():
        slug = name.lower().replace(" + ", "_").replace(" ", "_")
        path = out.final(model.save(out.path(f"model_{slug}.npz")).name)
        files[f"model_{slug}"] = path
        links.append(
            Link(
                path.name,
                f"{name}: motor position [rad] → inclination [deg]. Load it with",
                f'model = neckid.load_model("{path.name}")',
            )
        )
    scheduled.save(out.path("model_scheduled_cff_rls.npz"))
    files["model_scheduled_cff_rls"] = out.final("model_scheduled_cff_rls.npz")
    links.append(
        Link(
            "model_scheduled_cff_rls.npz",
            "Scheduled CFF-RLS: velocity command [rad/s] → inclination [deg]. Load it with",
            'model = neckid.load_model("model_scheduled_cff_rls.npz")',
        )
    )
    links.append(
        Link(
            CHIRP_RUN,
            "the bandwidth chirp run of Fig. 3: time [s], reference [deg], inclination [deg],"
            f" {1 / settings.ts:.0f} Hz. Find its bandwidth (about {chirp.bandwidth:.2f} rad/s,"
            " as in Fig. 3) with",
            BANDWIDTH_COMMAND,
        )
    )
    links.append(
        Link(
            "metrics.json",
            "every number of this report, machine-readable. Read it with",
            'json.loads(pathlib.Path("metrics.json").read_text())',
        )
    )

    report = Report("neckid demo: the soft-neck paper's protocol on the simulated neck")
    report.add_text(
        "What ran",
        "The simulated tendon-driven neck (neckid.plant.SoftNeck, planar) stands in for the real one."
        f" Bandwidth from the paper's up-chirp: {chirp.bandwidth:.2f} rad/s (paper: 4.2 rad/s,"
        " Fig. 3)."
        f" NARX models map motor position [rad] to inclination [deg] with the regressor {lags!r}"
        " (lags in samples);"
        " the scheduled model maps velocity command [rad/s] to inclination rate, integrated."
        " Fit is MATLAB's compare fit, 100 (1 - ||y - ŷ|| / ||y - mean(y)||) [%], of the free-run"
        " simulation, skipping the initial-condition samples (Figs. 5, 7-9).",
    )
    fit_table = table.reset_index()
    fit_table.columns = ["model", *(f"{e}, fit [%]" for e in table.columns)]
    report.add_table(
        "Fit [%] (free run), ours and the paper's",
        fit_table,
        note="Rows marked (paper) are the paper's fits on its own neck and records, for"
        " orientation; the other rows are this run's models on the simulated neck.",
    )
    mae_table = maes.reset_index()
    mae_table.columns = ["model", *(f"{e}, MAE [deg]" for e in maes.columns)]
    report.add_table("Mean absolute error [deg]", mae_table, float_format="{:.3f}")
    report.add_table(
        f"Operating points (CFF-RLS, λ = {settings.forgetting_factor:.2f}), Fig. 6",
        _points_display(points.table, GAIN_UNIT),
        formats={
            "target [deg]": "{:.1f}",
            "inclination [deg]": "{:.2f}",
            f"gain N [{GAIN_UNIT}]": "{:.4f}",
            "pole P [-]": "{:.4f}",
            "settled at [sample]": "{:.0f}",
            "log length [samples]": "{:.0f}",
        },
        note=(
            "converged: the estimate stayed in its band over the last window of the log"
            " (settled at: the sample from which it did)."
            + (
                f" {left_out} point(s) did not converge and are left out of the lines N(i), P(i)."
                if left_out
                else ""
            )
        ),
    )
    if selection_table is not None:
        report.add_table(
            "Lag selection (neural NARX, validation fit)",
            _selection_display(selection_table),
            formats={"terms [count]": "{:.0f}", "max lag [samples]": "{:.0f}"},
            note=_paper_lags_note(selection_table, settings.ts, sensor_delay),
        )
    report.add_figures("Figures", figures)
    report.add_links(
        "Files in this folder",
        links,
        intro="The report's neighbours, with how to use each (Python: import neckid, json,"
        " pathlib first; the command runs in a shell in this folder).",
    )
    report.add_table(
        "Settings",
        _settings_display(settings, chirp.bandwidth, lags, sensor_delay),
    )
    report.add_mapping("Versions", library_versions())
    report.write(out.path("report.html"))
    files["report"] = out.final("report.html")
    return files


def _extrapolation_text(narx_models: dict[str, Any], results: dict[str, ModelResult]) -> str:
    """A sentence on the share of a record outside the NARX models' training range, if any."""
    name = next(iter(narx_models))
    shares = results[name].extras.get("extrapolation", {})
    ranges = getattr(narx_models[name], "training_ranges_", {})
    share = shares.get(OUTPUT, 0.0)
    if share < 0.01 or OUTPUT not in ranges:
        return ""
    low, high = ranges[OUTPUT]
    return (
        f" {share:.0%} of the measured inclination lies outside {low:.1f}–{high:.1f} deg, the range"
        " the NARX models were identified on: they extrapolate there."
    )


def _points_display(points: pd.DataFrame, gain_unit: str) -> pd.DataFrame:
    """The operating-point table with units in its headers, for the report."""
    settled = points["settled_at"].to_numpy(dtype=np.float64)
    return pd.DataFrame(
        {
            "target [deg]": points["target"].to_numpy(dtype=np.float64),
            "inclination [deg]": points["inclination"].to_numpy(dtype=np.float64),
            f"gain N [{gain_unit}]": points["gain"].to_numpy(dtype=np.float64),
            "pole P [-]": points["pole"].to_numpy(dtype=np.float64),
            "converged": ["yes" if c else "no" for c in points["converged"]],
            "settled at [sample]": np.where(settled >= 0, settled, np.nan),
            "log length [samples]": points["n_samples"].to_numpy(dtype=np.float64),
        }
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
    """A sentence on why the paper's regressor scores as it does on the simulated neck."""
    input_lags = [v for v in PAPER_LAGS.inputs if isinstance(v, int)]  # one input: 8, 9, 10
    first, last = min(input_lags), max(input_lags)
    best = selection.iloc[0]
    text = (
        "Fits are in % on the validation record (100 % = perfect; below 0 %: further from the"
        " measurement than its mean). The best candidate, "
        f"{best['lags']}, scores {float(best['fit_simulation']):.2f} % in free run."
    )
    rows = selection[selection["lags"] == repr(PAPER_LAGS)]
    if rows.empty:
        return text
    row = rows.iloc[0]
    result = (
        f"fails ({row['error']})"
        if isinstance(row["error"], str) and row["error"]
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


def _settings_display(
    settings: DemoSettings, bandwidth: float, lags: Lags, sensor_delay: int
) -> pd.DataFrame:
    """The settings with their units (and durations in samples), and what they derive."""
    rows = []
    for key, value in asdict(settings).items():
        unit, meaning = SETTING_UNITS.get(key, ("", ""))
        if isinstance(value, tuple | list):
            shown = ", ".join(f"{v:g}" for v in value)
        elif isinstance(value, float):
            shown = f"{value:g}"
        else:
            shown = str(value)
        if unit == "s" and key.endswith("_duration"):
            unit = f"s ({round(value / settings.ts)} samples)"
        elif key == "ts":
            unit = f"s ({1 / settings.ts:g} Hz)"
        rows.append((key, shown, unit, meaning))
    rows.append(("bandwidth (measured)", f"{bandwidth:.3g}", "rad/s", "Fig. 3; highest excited"))
    rows.append(("regressor (NARX)", repr(lags), "samples", "output and input lags"))
    rows.append(("sensor delay (simulated neck)", str(sensor_delay), "samples",
                 f"tilt-sensor latency, {sensor_delay * settings.ts:g} s"))  # fmt: skip
    return pd.DataFrame(rows, columns=["setting", "value", "unit", "meaning"])
