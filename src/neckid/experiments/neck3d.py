"""The 3-D neck: three tendons in, tilt out, end to end on the simulated neck (``neckid demo --3d``).

The planar protocol (:mod:`neckid.experiments.paper`) carried over to the three-tendon neck
(:class:`~neckid.plant.SoftNeck` with ``configuration="three_tendon"``), as the seed paper names
for its next step and as its 3-D sequel does on the real neck (Quevedo et al. 2021):

1. **Bandwidth per direction.** The seed paper's up-chirp ``5 + 4 sin(0.1 t²)`` [deg] as the
   inclination reference of the 3-D PI loop (:class:`~neckid.plant.InclinationController`
   ``configuration="three_tendon"``) at a fixed orientation, for each direction of
   ``settings.directions``; the response is the tilt vector's component along that direction
   (signed, so it does not fold at zero inclination), the bandwidth the 90 % rule of the planar
   protocol. The excitation goes up to the smallest of them.
2. **Excitation in tendon space with a pre-tension.** Two multisines ``x(t)``, ``y(t)`` (random
   phases, ``[band_low, bandwidth]`` rad/s, unit peak) are a desired bending direction; motor
   ``j`` (tendon at ``α_j`` = 0°, 120°, 240°) winds to
   ``q_j = q_0 + A (x cos α_j + y sin α_j)`` [rad]: the linearised inverse kinematics of the
   constant-curvature link (the tendon on the side to lean to winds, the others unwind), so the
   three positions keep their sum ``3 q_0`` and, with the pre-tension ``q_0``, every tendon stays
   taut (the share of slack samples is reported). One identification record and one validation
   record with other phases.
3. **Tilt vector.** Inclination and orientation become ``tilt_x``, ``tilt_y`` [deg]
   (:mod:`neckid.data.tilt`): no wrap at 0/360°, no undefined direction at zero inclination.
4. **Regressor.** Chosen on the identification record only: it is cut in two halves, a linear
   ARX is fitted on one and free-run on the other for each candidate of a small grid (both
   ways, mean fit over the two outputs), the best wins.
5. **Models.** Every MIMO method of the registry, from the three motor positions [rad] to the
   tilt vector [deg]: Set Membership (one ε, γ per output; pure, with a linear part, parallel),
   neural NARX, ARX and CFF-RLS ARX. The inclination-scheduled model stays planar: it is a
   first-order model of one command to one inclination rate, scheduled on a scalar; over the
   tilt plane its schedule would be a function of a 2-D point identified at operating points on
   a grid of inclinations × orientations, which this protocol does not run.
6. **Validation and closed-loop tests** in 3-D on the neck: a circle of constant inclination
   with the orientation going round, orientation steps at constant inclination, and an
   inclination step along a diagonal; every model free-runs on the recorded motor positions and
   is scored per tilt component (fit [%], MAE [deg]) and back in polar form (inclination fit
   [%]; orientation error [deg], circular, on the samples whose measured inclination is at
   least ``orientation_min_inclination``).

References
----------
.. [1] Quevedo, F., Muñoz, J., Castano Pena, J. A., Monje, C. A. "3D Model Identification of a
   Soft Robotic Neck." Mathematics 9(14):1652, 2021.
.. [2] Webster, R. J., Jones, B. A. "Design and kinematic modeling of constant curvature
   continuum robots: a review." Int. J. Robotics Research 29(13), 2010.
"""

from __future__ import annotations

import json
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from neckid.data.iodata import IOData
from neckid.data.tilt import from_tilt
from neckid.experiments.demo_settings import quiet_smoke_run
from neckid.experiments.neck3d_settings import (
    METHODS_3D,
    NARX_INPUTS,
    OUTPUTS,
    TESTS_3D,
    Demo3DSettings,
)
from neckid.models.base import ModelResult
from neckid.plant import InclinationController, SoftNeck, closed_loop
from neckid.plant.calibration import paper_chirp, paper_chirp_frequency
from neckid.registry import methods
from neckid.regressors import Lags
from neckid.selection.lags import lag_grid, select_lags
from neckid.signals import BandwidthResult, bandwidth_from_chirp, multisine
from neckid.utils.files import StagedFolder

__all__ = [
    "METHODS_3D",
    "NARX_INPUTS",
    "OUTPUTS",
    "TESTS_3D",
    "Demo3DResult",
    "Demo3DSettings",
    "excitation_positions",
    "orientation_error",
    "run_demo3d",
]

_TENDON_ANGLES = np.radians([0.0, 120.0, 240.0])


@dataclass
class Demo3DResult:
    """What :func:`run_demo3d` produced.

    Attributes
    ----------
    fit : pandas.DataFrame
        Free-run fit [%], rows the models, columns ``(record, output)`` with the outputs
        ``tilt_x``, ``tilt_y``.
    mae : pandas.DataFrame
        Mean absolute error [deg], same layout, plus ``inclination`` and ``orientation``
        (circular error) from each model's tilt vector converted back.
    bandwidths : dict of float to float
        Measured bandwidth [rad/s] per chirp direction [deg].
    lags : Lags
    metrics : dict
        Everything machine-readable (also in ``metrics.json``).
    files : dict of str to Path
    wall_time : float
        Seconds for the whole run.
    """

    fit: pd.DataFrame
    mae: pd.DataFrame
    bandwidths: dict[float, float]
    lags: Lags
    metrics: dict[str, Any]
    files: dict[str, Path] = field(default_factory=dict)
    wall_time: float = 0.0


def excitation_positions(
    n_samples: int,
    ts: float,
    *,
    band: tuple[float, float],
    pretension: float,
    amplitude: float,
    seed: int,
) -> np.ndarray:
    """Motor positions [rad], shape (n_samples, 3): a multisine bending direction in tendon space.

    ``q_j = pretension + amplitude (x cos α_j + y sin α_j)`` with two independent unit-peak
    multisines ``x``, ``y`` over ``band`` [rad/s] (random phases from ``seed``, ``seed + 1``)
    and the tendons at α = 0°, 120°, 240°: the three positions always sum to ``3 pretension``.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid.experiments.neck3d import excitation_positions
    >>> q = excitation_positions(500, 0.02, band=(0.1, 3.0), pretension=1.0, amplitude=2.0, seed=0)
    >>> q.shape, bool(np.allclose(q.sum(axis=1), 3.0))
    ((500, 3), True)
    """
    xy = np.column_stack(
        [
            multisine(n_samples, ts, band=band, amplitude=1.0, phases="random", seed=seed + k)
            for k in range(2)
        ]
    )
    return pretension + amplitude * (
        xy[:, [0]] * np.cos(_TENDON_ANGLES) + xy[:, [1]] * np.sin(_TENDON_ANGLES)
    )


def _open_loop_record(
    neck: SoftNeck, settings: Demo3DSettings, duration: float, band_high: float, seed: int
) -> tuple[IOData, float]:
    """Ramp to the pre-tension in 3 s, then the excitation; the log and its share of slack samples."""
    ts = settings.ts
    position = excitation_positions(
        round(duration / ts),
        ts,
        band=(settings.band_low, band_high),
        pretension=settings.pretension,
        amplitude=settings.amplitude,
        seed=seed,
    )
    n_ramp = round(3.0 / ts)
    ramp = np.tile(position[0] / (n_ramp * ts), (n_ramp, 1))
    velocity = np.vstack([ramp, np.diff(position, axis=0, prepend=position[:1]) / ts])
    neck.reset()
    slack = 0
    for k, row in enumerate(velocity):
        neck.step(row)
        slack += int(k >= n_ramp and bool(np.any(neck.tendon_stretch <= 0.0)))
    log = neck.run(velocity)[n_ramp:]
    return log.renamed(f"open loop, seed {seed}"), slack / max(1, len(velocity) - n_ramp)


def _closed_loop_test(neck: SoftNeck, reference: np.ndarray, settings: Demo3DSettings) -> IOData:
    """A 3-D closed-loop test from the identification's pre-tension.

    For 3 s the reference holds the neck upright while the three motors wind to ``pretension``
    together (added to the controller's commands), then the test's reference runs; the log
    starts there. The controller's commands sum to zero (it projects one bending command on the
    three tendon directions), so the motors keep the pre-tension of the identification records
    and the tests stay in the tendons' taut regime the models were identified in.
    """
    ts = settings.ts
    n_ramp = round(3.0 / ts)
    upright = np.zeros((n_ramp, 2))
    target = np.vstack([upright, reference])
    wind = np.zeros((target.shape[0], 3))
    wind[:n_ramp] = settings.pretension / (n_ramp * ts)
    neck.reset()
    controller = InclinationController(ts=ts, configuration="three_tendon")
    return closed_loop(neck, controller, target, ts, excitation=wind)[n_ramp:]


def _direction_bandwidth(
    neck: SoftNeck, direction: float, duration: float
) -> tuple[BandwidthResult, np.ndarray, np.ndarray, np.ndarray]:
    """The paper's chirp at one orientation; the response is the tilt along it (signed)."""
    t = np.arange(round(duration / neck.ts), dtype=np.float64) * neck.ts
    reference = paper_chirp(t)
    target = np.column_stack([reference, np.full_like(reference, direction)])
    neck.reset()
    run = closed_loop(
        neck, InclinationController(ts=neck.ts, configuration="three_tendon"), target, neck.ts
    ).with_tilt()
    angle = np.radians(direction)
    along = run.y[:, :2] @ np.array([np.cos(angle), np.sin(angle)])
    result = bandwidth_from_chirp(t, reference, along, frequency=paper_chirp_frequency)
    return result, t, reference, along


def closed_loop_references(duration: float, ts: float) -> dict[str, np.ndarray]:
    """(inclination, orientation) references [deg] of the three 3-D closed-loop tests.

    Test 1: 15° with the orientation going round once every 10 s (after 1 s at 0°); test 2: 15°
    at 0°, then orientation steps of 60° every 4 s; test 3: a 20° step at 1 s towards 45° (the
    diagonal between the x and y axes of the tilt plane).
    """
    t = np.arange(round(duration / ts), dtype=np.float64) * ts
    inclination = np.full_like(t, 15.0)
    circle = np.where(t >= 1.0, np.mod(36.0 * (t - 1.0), 360.0), 0.0)
    steps = np.mod(60.0 * np.floor(t / 4.0), 360.0)
    return {
        TESTS_3D[1]: np.column_stack([inclination, circle]),
        TESTS_3D[2]: np.column_stack([inclination, steps]),
        TESTS_3D[3]: np.column_stack([np.where(t >= 1.0, 20.0, 0.0), np.full_like(t, 45.0)]),
    }


def orientation_error(
    measured: IOData | np.ndarray, simulated: np.ndarray, min_inclination: float, skip: int = 0
) -> float:
    """Mean absolute circular orientation error [deg] where the measured inclination is large enough.

    Parameters
    ----------
    measured : IOData or ndarray, shape (n, 2)
        Measured tilt vector ``tilt_x``, ``tilt_y`` [deg].
    simulated : ndarray, shape (n, 2)
        A model's tilt vector [deg].
    min_inclination : float
        Samples whose measured inclination is below it [deg] are left out.
    skip : int
        Initial samples to leave out (the model's initial conditions).

    Returns
    -------
    float
        Mean of ``|wrap(φ̂ − φ)|`` [deg] in [0, 180], NaN when no sample qualifies.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid.experiments.neck3d import orientation_error
    >>> measured = np.array([[10.0, 0.0], [0.0, 10.0], [0.1, 0.0]])
    >>> simulated = np.array([[10.0, -1.0], [0.0, 10.0], [0.0, 0.1]])   # 354.3° vs 0°: 5.7° apart
    >>> round(orientation_error(measured, simulated, min_inclination=3.0), 4)
    2.8553
    """
    y = measured.y[:, :2] if isinstance(measured, IOData) else np.asarray(measured)[:, :2]
    incl, phi = from_tilt(y[skip:, 0], y[skip:, 1])
    _, phi_hat = from_tilt(simulated[skip:, 0], simulated[skip:, 1])
    keep = incl >= min_inclination
    if not keep.any():
        return float("nan")
    gap = np.abs((phi_hat[keep] - phi[keep] + 180.0) % 360.0 - 180.0)
    return float(np.mean(gap))


def _select_lags(train: IOData, quick: bool) -> tuple[Lags, pd.DataFrame]:
    """Lags by leave-one-half-out ARX free-run fit on the identification record only."""
    half = train.n_samples // 2
    halves = [train[:half].renamed("first half"), train[half:].renamed("second half")]
    grid = [1, 2] if quick else [1, 2, 3]
    candidates = lag_grid(grid, [2, 3], input_delays=[1, 2])
    selection = select_lags(
        halves, None, candidates, methods()["arx"].make(), n_jobs=1, progress=False
    )
    return selection.best_lags, selection.table


def run_demo3d(
    out_dir: str | Path = "neckid-demo-3d",
    settings: Demo3DSettings | None = None,
    on_step: Callable[[str], None] | None = None,
    *,
    force: bool = False,
) -> Demo3DResult:
    """Run the 3-D protocol on the simulated three-tendon neck and write its report.

    Parameters
    ----------
    out_dir : path, default "neckid-demo-3d"
        Folder for ``report.html``, ``metrics.json``, the PNG figures and the model files.
    settings : Demo3DSettings, optional
        Default ``Demo3DSettings.make()``.
    on_step : callable, optional
        Called with a short description as each step starts (the CLI's progress).
    force : bool, default False
        Replace the files of a folder that holds some already.

    Returns
    -------
    Demo3DResult

    Raises
    ------
    neckid.utils.files.OutputError
        Before any computation, as for :func:`neckid.experiments.paper.run_demo` (the folder is
        locked, written in a staging folder and moved in at the end).
    """
    from neckid.utils.files import output_folder

    settings = settings or Demo3DSettings.make()
    with output_folder(out_dir, force=force) as staged, quiet_smoke_run(settings):
        return _run(staged, settings, on_step or (lambda _text: None))


def _run(
    out: StagedFolder, settings: Demo3DSettings, notify: Callable[[str], None]
) -> Demo3DResult:
    from neckid.experiments.neck3d_outputs import write_outputs_3d

    started = time.perf_counter()
    seeds = np.random.default_rng(settings.seed).integers(0, 2**31 - 1, size=6)
    ts = settings.ts

    notify("bandwidth: the paper's up-chirp along each tilt direction")
    neck = SoftNeck(configuration="three_tendon", ts=ts, seed=int(seeds[0]))
    chirps = {
        d: _direction_bandwidth(neck, d, settings.chirp_duration) for d in settings.directions
    }
    bandwidths = {d: float(run[0].bandwidth) for d, run in chirps.items()}
    found = [b for b in bandwidths.values() if np.isfinite(b)]
    band_high = min(min(found) if found else 4.0, 0.5 * np.pi / ts)

    notify("identification data: tendon-space multisine, validation record, tests 1-3")
    train, slack_train = _open_loop_record(
        neck, settings, settings.train_duration, band_high, int(seeds[1])
    )
    validation, slack_validation = _open_loop_record(
        neck, settings, settings.validation_duration, band_high, int(seeds[2])
    )
    records = {TESTS_3D[0]: validation}
    references = closed_loop_references(settings.test_duration, ts)
    for name, reference in references.items():
        records[name] = _closed_loop_test(neck, reference, settings).renamed(name)
    views = {k: v.with_tilt().select(inputs=list(NARX_INPUTS)) for k, v in records.items()}
    train_view = train.with_tilt().select(inputs=list(NARX_INPUTS))

    notify("regressor: ARX over candidate lag sets, halves of the identification record")
    lags, selection_table = _select_lags(train_view, settings.quick)

    notify("models: Set Membership (three forms), neural NARX, ARX, CFF-RLS ARX")
    models: dict[str, Any] = {}
    fit_times: dict[str, float] = {}
    for name in METHODS_3D:
        method = methods()[name]
        seeded = "random_state" in method.estimator_class()._parameter_constraints
        params = {"random_state": int(seeds[3])} if seeded else {}
        model = method.make(lags, quick=settings.quick and name == "nn", **params)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", category=UserWarning)  # unconverged networks
            model.fit(train_view)
        fit_times[method.label] = time.perf_counter() - t0
        models[method.label] = model

    notify("validation and closed-loop tests, per tilt component and in polar form")
    results: dict[str, dict[str, ModelResult]] = {
        k: {n: m.simulate(view) for n, m in models.items()} for k, view in views.items()
    }
    fit, mae = _score(views, results, settings.orientation_min_inclination)

    notify("figures, models, report")
    files = write_outputs_3d(
        out, settings, chirps, views, references, results, models, fit, mae, selection_table, lags
    )
    metrics: dict[str, Any] = {
        "settings": {
            k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(settings).items()
        },
        "bandwidth_rad_s": {f"{d:g} deg": b for d, b in bandwidths.items()},
        "excitation_band_rad_s": [settings.band_low, band_high],
        "slack_share": {"identification": slack_train, "validation": slack_validation},
        "lags": repr(lags),
        "fit_percent": _nested(fit),
        "mae_deg": _nested(mae),
        "fit_time_s": fit_times,
        "set_membership": {
            name: {"epsilon": model.epsilon_.tolist(), "gamma": model.gamma_.tolist()}
            for name, model in models.items()
            if model.set_membership_prior() is not None
        },
        "files": {k: v.name for k, v in files.items()},
    }
    wall = time.perf_counter() - started
    metrics["wall_time_s"] = wall
    out.path("metrics.json").write_text(json.dumps(_json_ready(metrics), indent=2, allow_nan=False))
    files["metrics"] = out.final("metrics.json")
    return Demo3DResult(fit, mae, bandwidths, lags, metrics, files, wall)


def _score(
    views: dict[str, IOData], results: dict[str, dict[str, ModelResult]], min_inclination: float
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Fit [%] per model and (record, tilt component); MAE [deg] also in polar form.

    The inclination is not scored by fit: on the circle and the orientation steps it is nearly
    constant, and a fit relative to its variance says nothing there.
    """
    columns = pd.MultiIndex.from_product([list(views), list(OUTPUTS)])
    fit = pd.DataFrame(index=list(next(iter(results.values()))), columns=columns, dtype=float)
    mae_columns = pd.MultiIndex.from_product(
        [list(views), [*OUTPUTS, "inclination", "orientation"]]
    )
    mae = pd.DataFrame(index=fit.index, columns=mae_columns, dtype=float)
    for record, view in views.items():
        measured_incl, _ = from_tilt(view.y[:, 0], view.y[:, 1])
        for name, result in results[record].items():
            skip = result.n_initial
            fit.loc[name, (record, OUTPUTS[0])] = float(result.fit_percent(view)[0])
            fit.loc[name, (record, OUTPUTS[1])] = float(result.fit_percent(view)[1])
            mae.loc[name, (record, OUTPUTS[0])] = float(result.mae(view)[0])
            mae.loc[name, (record, OUTPUTS[1])] = float(result.mae(view)[1])
            incl, _ = from_tilt(result.y[:, 0], result.y[:, 1])
            mae.loc[name, (record, "inclination")] = float(
                np.mean(np.abs(measured_incl[skip:] - incl[skip:]))
            )
            mae.loc[name, (record, "orientation")] = orientation_error(
                view, result.y, min_inclination, skip
            )
    return fit, mae


def _nested(frame: pd.DataFrame) -> dict[str, dict[str, dict[str, float | None]]]:
    out: dict[str, dict[str, dict[str, float | None]]] = {}
    for row in frame.index:
        per_record: dict[str, dict[str, float | None]] = {}
        for (record, output), value in frame.loc[row].items():
            per_record.setdefault(str(record), {})[str(output)] = (
                float(value) if np.isfinite(value) else None
            )
        out[str(row)] = per_record
    return out


def _json_ready(value: Any) -> Any:
    from neckid.experiments.paper import _json_ready as ready

    return ready(value)
