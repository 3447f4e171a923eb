"""Figures of a model in the lab's loop of a log: reference, inclinations, commands, motor position."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from neckid.loops.lab_loop_result import LabLoopResult

__all__ = ["LOOP_PANELS", "plot_lab_loop", "plot_lab_loops"]

#: The axes of one log's loop, top to bottom: (channel of the loop, axis label).
LOOP_PANELS = (
    ("inclination", "inclination [deg]"),
    ("velocity_command", "velocity command [rad/s]"),
    ("motor_position", "motor position [rad]"),
)


def _mark_start(ax: Any, time: np.ndarray, n_initial: int) -> None:
    if n_initial:
        ax.axvspan(time[0], time[min(n_initial, time.size - 1)], color="0.88", lw=0, zorder=0)


def plot_lab_loop(
    result: LabLoopResult, axes: Sequence[Any] | None = None, *, title: str | None = None
) -> Any:
    """One log's loop: the reference and the logged, in-loop and free-run inclinations, the commands.

    Parameters
    ----------
    result : LabLoopResult
        :func:`neckid.loops.lab_loop.in_loop_on_log` of the log.
    axes : sequence of three matplotlib Axes, optional
        Where to draw (:data:`LOOP_PANELS`, top to bottom); a new figure is made when ``None``.
    title : str, optional
        Above the first axes; default the log, the controller and the in-loop fit.

    Returns
    -------
    matplotlib.figure.Figure

    Notes
    -----
    Top: the nominal reference (dashed) and the reference with its dither (thin grey), the
    logged inclination, the model's in the loop and the model's free run (the log's own motor
    signals). Middle: the logged velocity command and the one the controller gave in the
    model's loop. Bottom: the logged motor position and the drive model's. The first
    ``n_initial`` rows (the log's, the model's initial conditions) are shaded; a divergence is
    marked by a red line at its row.
    """
    import matplotlib.pyplot as plt

    if axes is None:
        fig, made = plt.subplots(
            len(LOOP_PANELS), 1, figsize=(10, 7.2), sharex=True, layout="constrained"
        )
        axes = list(made)
    fig = axes[0].figure
    time, loop, measured = result.measured.time, result.loop, result.measured
    top = axes[0]
    top.plot(time, loop["reference"], color="0.75", lw=0.6, label="reference + dither")
    top.plot(time, loop["reference_nominal"], color="0.3", lw=1.0, ls="--", label="reference")
    top.plot(time, measured.channel("inclination"), color="black", lw=1.2, label="logged")
    top.plot(time, loop["inclination"], color="tab:blue", lw=1.0, label="model in the loop")
    top.plot(time, result.free_run, color="tab:orange", lw=0.8, alpha=0.8, label="model, free run")
    for ax, (channel, label) in zip(axes, LOOP_PANELS, strict=True):
        if ax is not top:
            if channel in measured.input_names:
                ax.plot(time, measured.channel(channel), color="black", lw=1.0, label="logged")
            which = (
                "controller in the model's loop" if channel != "motor_position" else "drive model"
            )
            ax.plot(time, loop[channel], color="tab:blue", lw=0.9, label=which)
        _mark_start(ax, time, result.n_initial)
        if result.diverged_at is not None:
            ax.axvline(time[result.diverged_at], color="tab:red", lw=1.0, label="diverged")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fit = result.inclination_fit
    shown = f"{fit:.1f} %" if np.isfinite(fit) else "diverged"
    top.set_title(
        title or f"{result.log}: in the loop with {result.controller} (in-loop fit {shown})"
    )
    return fig


def plot_lab_loops(results: Sequence[LabLoopResult]) -> Any:
    """:func:`plot_lab_loop` of several logs in one figure, three axes per log, stacked.

    Parameters
    ----------
    results : sequence of LabLoopResult

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if not results:
        raise ValueError("plot_lab_loops needs at least one loop")
    rows = len(LOOP_PANELS) * len(results)
    fig, axes = plt.subplots(rows, 1, figsize=(10, 2.4 * rows), layout="constrained", squeeze=False)
    for k, result in enumerate(results):
        panel = axes[k * len(LOOP_PANELS) : (k + 1) * len(LOOP_PANELS), 0]
        for ax in panel[1:]:
            ax.sharex(panel[0])
        plot_lab_loop(result, list(panel))
    return fig
