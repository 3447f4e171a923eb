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
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from neckid.data.iodata import IOData
from neckid.experiments.demo_outputs import write_outputs
from neckid.experiments.demo_settings import (
    DEMO_METHODS,
    EXPERIMENTS,
    NARX_INPUT,
    OUTPUT,
    PAPER_FITS,
    PAPER_LAGS,
    SCHEDULED_INPUT,
    DemoResult,
    DemoSettings,
    quiet_smoke_run,
)
from neckid.loops.model_in_loop import model_in_the_loop
from neckid.models.base import ModelResult
from neckid.plant import InclinationController, SoftNeck, closed_loop
from neckid.plant.calibration import chirp_bandwidth
from neckid.registry import methods
from neckid.regressors import Lags
from neckid.selection.lags import lag_grid, select_lags
from neckid.signals import multisine, sine, staircase, step
from neckid.utils.files import StagedFolder

__all__ = ["EXPERIMENTS", "PAPER_FITS", "DemoResult", "DemoSettings", "run_demo"]

logger = logging.getLogger(__name__)


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
    neckid.utils.files.OutputError
        Before any computation: ``out_dir`` is a file, holds files (without ``force``), or another
        run is writing into it. The folder is locked for the run; its files are written in a
        hidden staging folder and moved in together at the end, so an interrupted run changes
        nothing.
    """
    from neckid.utils.files import output_folder

    with output_folder(out_dir, force=force) as staged, quiet_smoke_run(settings):
        return _run_protocol(staged, settings, on_step)


def _run_protocol(
    out: StagedFolder, settings: DemoSettings | None, on_step: Callable[[str], None] | None
) -> DemoResult:
    """Steps 1-8 of the protocol, the files written into the staged folder."""
    started = time.perf_counter()
    settings = settings if settings is not None else DemoSettings.make()
    notify = on_step if on_step is not None else (lambda _text: None)
    seeds = np.random.default_rng(settings.seed).integers(0, 2**31 - 1, size=8)

    data = _measure(settings, seeds, notify)

    # 3. regressor -----------------------------------------------------------------------------
    notify(
        "regressor: networks over candidate lag sets"
        if not settings.paper_regressor
        else "regressor: the paper's"
    )
    lags, selection_table = _choose_lags(settings, int(seeds[3]), data.train, data.validation)

    # 4. models ----------------------------------------------------------------------------------
    notify("models: Set Membership, neural NARX, ARX")
    narx_models, fit_times = _fit_narx_models(settings, int(seeds[3]), lags, data.train)

    notify("CFF-RLS at each inclination, scheduled model")
    t0 = time.perf_counter()
    points, scheduled = _fit_scheduled(settings, int(seeds[4]), int(seeds[5]))
    fit_times["Scheduled CFF-RLS"] = time.perf_counter() - t0

    # 5-6. validation and tests ------------------------------------------------------------------
    notify("validation and closed-loop tests")
    results, fits, maes, rmses = _validate(data.records, narx_models, scheduled)
    # 6b. the models in the loop: each model in place of the neck, same PI and references ---------
    notify("models in the loop: tests 1-3")
    loop = _models_in_the_loop(
        {**narx_models, "Scheduled CFF-RLS": scheduled}, data.records, settings
    )
    table = _with_paper_fits(fits)
    maes.index.name = "model"

    # 7-8. files -----------------------------------------------------------------------------------
    notify("figures, models, report")
    files = write_outputs(
        out,
        settings,
        data.chirp,
        data.chirp_run,
        data.records,
        results,
        narx_models,
        scheduled,
        points,
        table,
        maes,
        selection_table,
        lags,
        sensor_delay=data.neck.delay_samples,
        loop=loop,
    )
    metrics = _metrics(
        settings, data, lags, (fits, maes, rmses), fit_times, loop, narx_models, scheduled, points
    )
    metrics["files"] = {k: str(v.name) for k, v in files.items()}
    wall = time.perf_counter() - started
    metrics["wall_time_s"] = wall
    out.path("metrics.json").write_text(json.dumps(_json_ready(metrics), indent=2, allow_nan=False))
    files["metrics"] = out.final("metrics.json")
    return DemoResult(table, maes, metrics, data.bandwidth, lags, files, wall)


@dataclass(frozen=True)
class _Measured:
    """What steps 1-2 measure on the neck: the chirp run, its bandwidth and the records."""

    neck: SoftNeck
    chirp: Any
    chirp_run: tuple[Any, Any, Any]
    bandwidth: float
    train: IOData
    validation: IOData
    records: dict[str, IOData]


def _measure(settings: DemoSettings, seeds: Any, notify: Callable[[str], None]) -> _Measured:
    """Steps 1-2: the bandwidth chirp, the identification and validation records, tests 1-3."""
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
    return _Measured(
        neck,
        chirp,
        (chirp_time, chirp_reference, chirp_response),
        bandwidth,
        train,
        validation,
        records,
    )


def _choose_lags(
    settings: DemoSettings, seed: int, train: IOData, validation: IOData
) -> tuple[Lags, pd.DataFrame | None]:
    """Step 3: the paper's regressor, or the best of candidate lag sets; and the selection table."""
    selection_table = None
    # --quick is a smoke run: the registry's small networks there (as the 3-D demo does)
    network = methods()["nn"].make(PAPER_LAGS, quick=settings.quick, random_state=seed)
    if settings.paper_regressor:
        lags = PAPER_LAGS
    else:
        if settings.quick:
            candidates = [*lag_grid([1, 2], [3], input_delays=[1]), PAPER_LAGS]
        else:
            candidates = [*lag_grid([1, 2, 3], [2, 3], input_delays=[1]), PAPER_LAGS]
        # Two worker processes for the full demo; the quick one's small networks fit in less
        # time than starting the processes takes (about 2 s), so it stays in this one.
        selection = select_lags(
            _narx_view(train),
            _narx_view(validation),
            candidates,
            network,
            n_jobs=1 if settings.quick else 2,
            progress=False,
        )
        selection_table = selection.table
        lags = selection.best_lags
    return lags, selection_table


def _fit_narx_models(
    settings: DemoSettings, seed: int, lags: Lags, train: IOData
) -> tuple[dict[str, Any], dict[str, float]]:
    """Step 4: the NARX models fitted on the identification record, and each one's fit time [s]."""
    narx_models: dict[str, Any] = {}
    for name in DEMO_METHODS:
        method = methods()[name]
        seeded = "random_state" in method.estimator_class()._parameter_constraints
        params: dict[str, Any] = {"random_state": seed} if seeded else {}
        narx_models[method.label] = method.make(
            lags, quick=settings.quick and name == "nn", **params
        )
    fit_times = {}
    for name, model in narx_models.items():
        t0 = time.perf_counter()
        model.fit(_narx_view(train))
        fit_times[name] = time.perf_counter() - t0
    return narx_models, fit_times


def _fit_scheduled(settings: DemoSettings, neck_seed: int, seed: int) -> tuple[Any, Any]:
    """Step 4, scheduled model: CFF-RLS at each inclination on a fresh neck, then the schedule."""
    from neckid.loops.operating_points import identify_operating_points

    rls_neck = SoftNeck(ts=settings.ts, seed=neck_seed)
    points = identify_operating_points(
        rls_neck,
        inclinations=settings.inclinations,
        ts=settings.ts,
        # The tilt sensor's latency (2 samples on the simulated neck, as on the bench) plus the
        # one sample of the paper's G(z) = N / (z - P).
        delay=rls_neck.delay_samples + 1,
        forgetting_factor=settings.forgetting_factor,
        seed=seed,
    )
    scheduled = points.fit_schedule(converged_only=int(points.converged.sum()) >= 2)
    return points, scheduled


def _validate(
    records: dict[str, IOData], narx_models: dict[str, Any], scheduled: Any
) -> tuple[dict[str, dict[str, ModelResult]], pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Steps 5-6: every model's free run on every record; fit [%], MAE and RMSE [deg] tables."""
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
    return results, fits, maes, rmses


def _with_paper_fits(fits: pd.DataFrame) -> pd.DataFrame:
    """The fit table with the paper's fits as extra rows, its index named "model"."""
    paper = pd.DataFrame(PAPER_FITS, index=list(EXPERIMENTS)).T
    table = pd.concat([fits, paper])
    table.index.name = "model"
    return table


def _metrics(
    settings: DemoSettings,
    data: _Measured,
    lags: Lags,
    scores: tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame],
    fit_times: dict[str, float],
    loop: dict[str, pd.DataFrame],
    narx_models: dict[str, Any],
    scheduled: Any,
    points: Any,
) -> dict[str, Any]:
    """The numbers of ``metrics.json`` but the files and the wall time."""
    fits, maes, rmses = scores
    return {
        "settings": {
            k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(settings).items()
        },
        "bandwidth_rad_s": data.bandwidth,
        "bandwidth_status": data.chirp.status,
        "paper_bandwidth_rad_s": 4.2,
        "lags": repr(lags),
        "fit_percent": _nested(fits),
        "mae_deg": _nested(maes),
        "rmse_deg": _nested(rmses),
        "paper_fit_percent": {
            k: dict(zip(EXPERIMENTS, v, strict=True)) for k, v in PAPER_FITS.items()
        },
        "fit_time_s": fit_times,
        "model_in_the_loop": {
            "fit_percent": _nested(loop["fit"]),
            "command_fit_percent": _nested(loop["command_fit"]),
            "rmse_deg": _nested(loop["rmse"]),
            "band_coverage": _nested(loop["band_coverage"]),
        },
        "set_membership": {
            name: {"epsilon": float(model.epsilon_[0]), "gamma": float(model.gamma_[0])}
            for name, model in narx_models.items()
            if model.set_membership_prior() is not None
        },
        "schedule": {
            "gain_coefficients": scheduled.gain_coefficients_.tolist(),
            "pole_coefficients": scheduled.pole_coefficients_.tolist(),
            "points": json.loads(points.table.to_json(orient="records")),
        },
    }


def _models_in_the_loop(
    models: dict[str, Any], records: dict[str, IOData], settings: DemoSettings
) -> dict[str, pd.DataFrame]:
    """Each model in place of the neck in the PI loop of tests 1-3 (issue: models in the loop).

    Returns tables (model x test) of the inclination's fit [%] and RMSE [deg], the velocity
    command's fit [%], and the SM band's coverage of the measured inclination (NaN without a
    band). NARX models get the motor position from the neck's drive law
    (:class:`~neckid.loops.model_in_loop.VelocityDrive`); the scheduled model takes the
    command itself.
    """
    tests = list(EXPERIMENTS[1:])
    tables = {
        k: pd.DataFrame(index=list(models), columns=tests, dtype=float)
        for k in ("fit", "command_fit", "rmse", "band_coverage")
    }
    for experiment in tests:
        for name, model in models.items():
            scores = model_in_the_loop(
                model, InclinationController(ts=settings.ts), records[experiment]
            ).scores()
            tables["fit"].loc[name, experiment] = scores["output_fit"]
            tables["command_fit"].loc[name, experiment] = scores["command_fit"]
            tables["rmse"].loc[name, experiment] = scores["output_rmse"]
            tables["band_coverage"].loc[name, experiment] = scores["band_coverage"]
    return tables


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
