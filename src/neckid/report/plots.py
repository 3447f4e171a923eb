"""Figures that compare models with measurements (the seed paper's Figs. 5 and 7–9)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from neckid.data import IOData
from neckid.models.base import ModelResult

__all__ = ["plot_simulation"]


def plot_simulation(
    data: IOData,
    results: Mapping[str, ModelResult],
    output: int = 0,
    ax: Any = None,
    title: str | None = None,
    bounds: bool = True,
) -> Any:
    """Measured output against each model's free-run output (with Set Membership bounds).

    Parameters
    ----------
    data : IOData
        The measured record.
    results : mapping of str to ModelResult
        Model name to its simulation of ``data``.
    output : int, default 0
        Which output channel to draw.
    ax : matplotlib Axes, optional
        Where to draw; a new figure is made when ``None``.
    title : str, optional
    bounds : bool, default True
        Shade ``[lower, upper]`` for results that carry bounds.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(figsize=(9, 3.6), layout="constrained")
    else:
        fig = ax.figure
    t = data.time
    unit = data.output_units[output]
    ax.plot(t, data.y[:, output], color="black", lw=1.4, label="measured")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (name, result) in enumerate(results.items()):
        color = colors[k % len(colors)]
        ax.plot(result.time, result.y[:, output], lw=1.0, color=color, label=name)
        if bounds and result.lower is not None and result.upper is not None:
            lo, hi = result.lower[:, output], result.upper[:, output]
            ok = np.isfinite(lo) & np.isfinite(hi)
            ax.fill_between(result.time[ok], lo[ok], hi[ok], color=color, alpha=0.15, lw=0)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"{data.output_names[output]}" + (f" [{unit}]" if unit else ""))
    if title:
        ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    return fig
