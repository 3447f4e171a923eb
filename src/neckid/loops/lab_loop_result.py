"""What an identified model does in the lab's loop, beside the logged loop: :class:`LabLoopResult`.

:func:`~neckid.loops.lab_loop.in_loop_on_log` builds one; :func:`loop_figures` computes the
control engineer's figures (:mod:`neckid.loops.loop_measures`) of a loop and of the log.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from neckid.data.iodata import IOData
from neckid.loops.loop_measures import (
    Oscillation,
    oscillation,
    reference_segments,
    stair_responses,
    tracking_error_rms,
)
from neckid.utils.types import FloatArray

__all__ = ["LabLoopResult", "loop_figures"]


def loop_figures(
    inclination: FloatArray,
    nominal: FloatArray,
    ts: float,
    *,
    settle: float = 3.0,
    band: float = 1.0,
) -> tuple[float, Oscillation, pd.DataFrame]:
    """Tracking-error RMS [deg], the oscillation and the stair table of one loop.

    Parameters
    ----------
    inclination : ndarray, shape (n,)
        The loop's inclination [deg] (non-finite rows, after a divergence, give NaN figures).
    nominal : ndarray, shape (n,)
        The nominal reference [deg]; its constant stretches of 2 s or more are the segments.
    ts : float
        Period, s.
    settle : float, default 3.0
        Seconds of each segment left out of the oscillation (:func:`~.loop_measures.oscillation`).
    band : float, default 1.0
        Settling band, deg (:func:`~.loop_measures.stair_responses`).

    Returns
    -------
    rms : float
    oscillation : Oscillation
    stairs : pandas.DataFrame
    """
    segments = reference_segments(nominal, ts)
    if not np.all(np.isfinite(inclination)):
        empty = stair_responses(nominal, nominal, ts, band=band, segments=segments)
        empty.loc[:, ["overshoot_percent", "settling_time_s"]] = math.nan
        return math.nan, Oscillation(math.nan, math.nan, math.nan), empty
    rms = tracking_error_rms(inclination, nominal, ts, segments)
    found = oscillation(inclination, nominal, ts, settle=settle, segments=segments)
    stairs = stair_responses(inclination, nominal, ts, band=band, segments=segments)
    return rms, found, stairs


def _ratio(a: float, b: float) -> float:
    return a / b if b and math.isfinite(a) and math.isfinite(b) else math.nan


@dataclass(frozen=True)
class LabLoopResult:
    """An identified model in the lab's loop on one log, beside its free run and the logged loop.

    Attributes
    ----------
    log : str
        The log's name.
    controller : str
        Which controller ran (``"int"``, ``"fra"``, ``"ada (replay adacon200.csv)"``,
        ``"ada (re-implemented tuner)"``, or the object's class name).
    loop : pandas.DataFrame
        The loop, one row per log row: ``reference`` (with the dither) and
        ``reference_nominal`` [deg], ``velocity_command`` [rad/s], ``motor_position`` [rad] and
        ``motor_velocity`` [rad/s] of the drive model, ``inclination`` [deg] (NaN from a
        divergence on).
    measured : IOData
        The log (the same channels, measured).
    free_run : ndarray, shape (n,)
        The model's free run on the log's own inputs [deg] (NaN where it diverged).
    n_initial : int
        Rows left out of every fit (the model's ``max_lag_``; the loop replays them from the log).
    free_run_fit, inclination_fit, command_fit : float
        NRMSE fit [%] (MATLAB's ``compare``) of the free run and of the loop's inclination and
        command against the log's; −inf when the run diverged.
    tracking_rms, logged_tracking_rms : float
        RMS of nominal reference − inclination over the constant stretches of the reference
        (the stairs; an ``ada`` log's warm-up multisine is left out), deg.
    oscillation, logged_oscillation : Oscillation
        Period [s] and amplitude [deg] of the settled tracking error's dominant oscillation.
    stairs, logged_stairs : pandas.DataFrame
        Overshoot [%] and settling time [s] on each stair.
    controller_check : float
        Largest ``|reconstructed − logged|`` command [rad/s] when the controller is fed the
        logged raw inclination (NaN when the log has no command), over every row but an
        adaptive replay's first stair row (:func:`~neckid.loops.loop_checks.controller_check`).
    controller_check_first_stair_row : float
        That row's difference [rad/s] (its starting gains no log holds); NaN for the others.
    diverged_at : int or None
        The first row where the loop's inclination was not finite (or beyond 1000 deg).
    settings : dict
        The drive and what else the run used, for the report.
    """

    log: str
    controller: str
    loop: pd.DataFrame
    measured: IOData
    free_run: FloatArray
    n_initial: int
    free_run_fit: float
    inclination_fit: float
    command_fit: float
    tracking_rms: float
    logged_tracking_rms: float
    oscillation: Oscillation
    logged_oscillation: Oscillation
    stairs: pd.DataFrame
    logged_stairs: pd.DataFrame
    controller_check: float
    controller_check_first_stair_row: float = math.nan
    diverged_at: int | None = None
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def tracking_ratio(self) -> float:
        """In-loop tracking-error RMS over the logged one."""
        return _ratio(self.tracking_rms, self.logged_tracking_rms)

    @property
    def period_ratio(self) -> float:
        """In-loop oscillation period over the logged one."""
        return _ratio(self.oscillation.period, self.logged_oscillation.period)

    def summary(self) -> dict[str, Any]:
        """The figures as a flat dict (a report row, or JSON): units in the key names."""
        return {
            "log": self.log,
            "controller": self.controller,
            "free_run_fit_percent": self.free_run_fit,
            "inclination_fit_percent": self.inclination_fit,
            "command_fit_percent": self.command_fit,
            "tracking_rms_deg": self.tracking_rms,
            "logged_tracking_rms_deg": self.logged_tracking_rms,
            "tracking_ratio": self.tracking_ratio,
            "period_s": self.oscillation.period,
            "logged_period_s": self.logged_oscillation.period,
            "period_ratio": self.period_ratio,
            "amplitude_deg": self.oscillation.amplitude,
            "logged_amplitude_deg": self.logged_oscillation.amplitude,
            "oscillation_share": self.oscillation.share,
            "logged_oscillation_share": self.logged_oscillation.share,
            "mean_overshoot_percent": _mean(self.stairs["overshoot_percent"]),
            "logged_mean_overshoot_percent": _mean(self.logged_stairs["overshoot_percent"]),
            "controller_check_rad_s": self.controller_check,
            "controller_check_first_stair_row_rad_s": self.controller_check_first_stair_row,
            "diverged_at": self.diverged_at,
            "n_initial": self.n_initial,
        }

    def stair_table(self) -> pd.DataFrame:
        """Per stair: level and step [deg], overshoot [%] and settling time [s], loop and log."""
        loop = self.stairs
        logged = self.logged_stairs[["overshoot_percent", "settling_time_s"]].add_prefix("logged_")
        return pd.concat([loop.reset_index(drop=True), logged.reset_index(drop=True)], axis=1)

    def to_frame(self) -> pd.DataFrame:
        """Time and, per channel, ``<name>_loop`` and ``<name>_measured`` (and the free run)."""
        columns: dict[str, FloatArray] = {
            "time": self.measured.time,
            "reference": self.loop["reference"].to_numpy(),
            "reference_nominal": self.loop["reference_nominal"].to_numpy(),
        }
        for name in ("inclination", "velocity_command", "motor_position", "motor_velocity"):
            columns[f"{name}_loop"] = self.loop[name].to_numpy()
            if name in (*self.measured.input_names, *self.measured.output_names):
                columns[f"{name}_measured"] = self.measured.channel(name)
        columns["inclination_free_run"] = self.free_run
        return pd.DataFrame(columns)

    def to_dict(self) -> dict[str, Any]:
        """:meth:`summary`, the stair table and the settings, JSON-ready (NaN as None)."""
        stairs = self.stair_table().astype(object)
        return _json_ready(
            {
                **self.summary(),
                "stairs": stairs.where(stairs.notna(), None).to_dict(orient="records"),
                "settings": self.settings,
            }
        )


def _mean(values: pd.Series) -> float:
    finite = values[np.isfinite(values.to_numpy(dtype=np.float64))]
    return float(finite.mean()) if len(finite) else math.nan


def _json_ready(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_ready(v) for v in value]
    if isinstance(value, float | np.floating):
        number = float(value)
        return number if math.isfinite(number) else None
    if isinstance(value, np.integer):
        return int(value)
    return value
