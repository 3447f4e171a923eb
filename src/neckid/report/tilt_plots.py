"""Figures of the 3-D neck: trajectories in the tilt plane, measured against each model."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from neckid.data.iodata import IOData
from neckid.models.base import ModelResult

__all__ = ["plot_tilt_plane"]


def plot_tilt_plane(
    data: IOData,
    results: Mapping[str, ModelResult],
    ax: Any = None,
    *,
    title: str | None = None,
    reference: np.ndarray | None = None,
) -> Any:
    """The measured tilt-vector trajectory and each model's in the tilt plane, equal axes [deg].

    Parameters
    ----------
    data : IOData
        The measured record; its first two outputs are ``tilt_x``, ``tilt_y`` [deg].
    results : mapping of str to ModelResult
        Model name to its simulation of ``data`` (same two outputs first).
    ax : matplotlib Axes, optional
        Where to draw; a new square figure is made when ``None``.
    title : str, optional
    reference : ndarray, shape (n_samples, 2), optional
        (inclination, orientation) references [deg] of a closed-loop test, drawn dotted.

    Returns
    -------
    matplotlib.figure.Figure

    Notes
    -----
    Circles of constant inclination (every 10°) and the three tendon directions (0°, 120°, 240°)
    are drawn light grey; each model's initial samples (measured initial conditions) are left
    out of its line.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(figsize=(8.4, 6.0), layout="constrained")
    else:
        fig = ax.figure
    y = data.y[:, :2]
    reach = float(np.max(np.hypot(y[:, 0], y[:, 1]))) if y.size else 10.0
    limit = 1.12 * max(reach, 1.0)
    angles = np.linspace(0.0, 2 * np.pi, 181)
    for radius in np.arange(10.0, limit, 10.0):
        ax.plot(radius * np.cos(angles), radius * np.sin(angles), color="0.88", lw=0.7, zorder=0)
        ax.annotate(f"{radius:.0f}°", (radius * 0.707, radius * 0.707), color="0.6", fontsize=7)
    for k, alpha in enumerate(np.radians([0.0, 120.0, 240.0])):
        end = limit * np.array([np.cos(alpha), np.sin(alpha)])
        ax.plot([0, end[0]], [0, end[1]], color="0.8", lw=0.7, ls="--", zorder=0)
        ax.annotate(f"tendon {k + 1}", end * 0.85, color="0.55", fontsize=7, ha="center")
    if reference is not None:
        phi = np.radians(reference[:, 1])
        ax.plot(
            reference[:, 0] * np.cos(phi),
            reference[:, 0] * np.sin(phi),
            color="0.4",
            lw=1.0,
            ls=":",
            label="reference",
        )
    ax.plot(y[:, 0], y[:, 1], color="black", lw=1.4, label="measured")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (name, result) in enumerate(results.items()):
        start = result.n_initial
        ax.plot(
            result.y[start:, 0],
            result.y[start:, 1],
            lw=0.9,
            color=colors[k % len(colors)],
            label=name,
        )
    ax.set_xlim(-limit, limit)
    ax.set_ylim(-limit, limit)
    ax.set_aspect("equal")
    names, units = data.output_names, data.output_units
    ax.set_xlabel(f"{names[0]} [{units[0] or 'deg'}]")
    ax.set_ylabel(f"{names[1]} [{units[1] or 'deg'}]")
    if title:
        ax.set_title(title)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    ax.grid(alpha=0.2)
    return fig
