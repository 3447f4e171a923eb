"""Figures that compare models with measurements (the seed paper's Figs. 5 and 7–9)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData
from neckid.models.bands import band_label
from neckid.models.base import ModelResult

__all__ = ["plot_simulation"]


def _mark_cut_bands(
    results: Mapping[str, ModelResult], output: int, labels: list[str], low: float, high: float
) -> None:
    """Say in the legend which bands reach beyond the plotted range ``[low, high]``."""
    for name, result in results.items():
        band = f"{name}: {band_label(result.extras)}"
        if result.lower is not None and result.upper is not None and band in labels:
            wider = (
                np.nanmin(result.lower[:, output]) < low
                or np.nanmax(result.upper[:, output]) > high
            )
            if wider:
                labels[labels.index(band)] = f"{band} (cut at the plot edges)"


def plot_simulation(
    data: IOData,
    results: Mapping[str, ModelResult],
    output: int = 0,
    ax: Any = None,
    title: str | None = None,
    bounds: bool = True,
    residuals: bool = False,
    outside: ArrayLike | None = None,
) -> Any:
    """Measured output against each model's output, with bands, initial samples and residuals.

    Parameters
    ----------
    data : IOData
        The measured record.
    results : mapping of str to ModelResult
        Model name to its simulation (or prediction) of ``data``.
    output : int, default 0
        Which output channel to draw.
    ax : matplotlib Axes, optional
        Where to draw; a new figure is made when ``None`` (then with ``residuals``, a second
        panel below shows ``y − ŷ``).
    title : str, optional
    outside : array_like of bool, shape (n_samples,), optional
        Samples outside the model's domain (``Estimator.domain(data).outside``), marked by a
        red tick under the curves.
    bounds : bool, default True
        Shade ``[lower, upper]`` for results that carry bounds; the band is in the legend, and
        the vertical axis follows the outputs, not the band (a band wider than the plot is cut
        and its legend entry says so).
    residuals : bool, default False
        Add a panel of the errors ``y − ŷ`` (new figure only).

    Returns
    -------
    matplotlib.figure.Figure

    Notes
    -----
    The first ``n_initial`` samples of a result are the measured outputs it starts from (initial
    conditions); they are shaded grey and labelled, as the fit skips them.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        if residuals:
            fig, (ax, ax_res) = plt.subplots(
                2, 1, figsize=(10, 5.2), sharex=True, height_ratios=(3, 1.2), layout="constrained"
            )
        else:
            fig, ax = plt.subplots(figsize=(10, 3.8), layout="constrained")
            ax_res = None
    else:
        fig, ax_res = ax.figure, None
    t = data.time
    unit = data.output_units[output] if data.output_units[output] else ""
    if not unit:
        unit = next((r.output_units[output] for r in results.values() if r.output_units), "")
    measured = data.y[:, output]
    ax.plot(t, measured, color="black", lw=1.4, label="measured")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    shown = [measured]
    n_initial = max((r.n_initial for r in results.values()), default=0)
    for k, (name, result) in enumerate(results.items()):
        color = colors[k % len(colors)]
        y = result.y[:, output]
        ax.plot(result.time, y, lw=1.0, color=color, label=name)
        shown.append(y[np.isfinite(y)])
        if ax_res is not None:
            ax_res.plot(
                result.time[result.n_initial :],
                (measured - y)[result.n_initial :],
                lw=0.8,
                color=color,
            )
        if bounds and result.lower is not None and result.upper is not None:
            lo, hi = result.lower[:, output], result.upper[:, output]
            ok = np.isfinite(lo) & np.isfinite(hi)
            if ok.any():
                ax.fill_between(
                    result.time[ok],
                    lo[ok],
                    hi[ok],
                    color=color,
                    alpha=0.15,
                    lw=0,
                    label=f"{name}: {band_label(result.extras)}",
                )
    values = np.concatenate(shown)
    low, high = float(np.min(values)), float(np.max(values))
    margin = 0.08 * (high - low or 1.0)
    ax.set_ylim(low - margin, high + margin)
    handles, labels = ax.get_legend_handles_labels()
    _mark_cut_bands(results, output, labels, low - margin, high + margin)
    if outside is not None and np.any(outside):
        mask = np.asarray(outside, dtype=bool)
        ax.plot(t[mask], np.full(int(mask.sum()), low - 0.5 * margin), "|", color="tab:red", ms=6)
        handles.append(plt.Line2D([], [], marker="|", ls="", color="tab:red"))
        labels.append(f"outside the model's domain ({mask.mean():.0%} of the samples)")
    if n_initial:
        ax.axvspan(t[0], t[min(n_initial, t.size - 1)], color="0.85", lw=0, zorder=0)
        handles.append(plt.Rectangle((0, 0), 1, 1, color="0.85"))
        labels.append("initial samples (measured)")
    ax.set_ylabel(f"{data.output_names[output]}" + (f" [{unit}]" if unit else ""))
    if title:
        ax.set_title(title)
    ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    ax.grid(alpha=0.3)
    if ax_res is not None:
        ax_res.axhline(0.0, color="black", lw=0.8)
        ax_res.set_ylabel("error y − ŷ" + (f" [{unit}]" if unit else ""))
        ax_res.set_xlabel("time [s]")
        ax_res.grid(alpha=0.3)
    else:
        ax.set_xlabel("time [s]")
    return fig
