"""Figures that compare models with measurements (the seed paper's Figs. 5 and 7–9)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData
from neckid.models.bands import band_label
from neckid.models.base import ModelResult

__all__ = ["output_unit", "plot_outputs", "plot_simulation"]


#: Model values farther from the measured range than this many times its span are not drawn
#: (a diverging run kept by ``--keep-diverged``: 1e300 would break the figure's layout).
DRAWN_SPANS = 10.0


def _drawable(values: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """``values`` with NaN where they are not finite or beyond ``DRAWN_SPANS`` of ``measured``."""
    finite = measured[np.isfinite(measured)]
    low, high = (float(finite.min()), float(finite.max())) if finite.size else (-1.0, 1.0)
    reach = DRAWN_SPANS * ((high - low) or max(abs(high), 1.0))
    with np.errstate(invalid="ignore"):
        keep = np.isfinite(values) & (values >= low - reach) & (values <= high + reach)
    return np.where(keep, values, np.nan)


def output_unit(data: IOData, results: Mapping[str, ModelResult], output: int) -> str:
    """The unit of an output: the log's, else the first result's; ``"-"`` when neither has one."""
    unit = data.output_units[output] if data.output_units[output] else ""
    if not unit:
        unit = next((r.output_units[output] for r in results.values() if r.output_units), "")
    return unit or "-"


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

    if not 0 <= output < data.n_outputs:
        raise ValueError(f"output must be in [0, {data.n_outputs}); got {output}")
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
    unit = output_unit(data, results, output)
    measured = data.y[:, output]
    ax.plot(t, measured, color="black", lw=1.4, label="measured")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    shown = [measured]
    n_initial = max((r.n_initial for r in results.values()), default=0)
    for k, (name, result) in enumerate(results.items()):
        color = colors[k % len(colors)]
        y = _drawable(result.y[:, output], measured)
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
            lo = _drawable(result.lower[:, output], measured)
            hi = _drawable(result.upper[:, output], measured)
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
    ax.set_ylabel(f"{data.output_names[output]} [{unit}]")
    if title:
        ax.set_title(title)
    ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    ax.grid(alpha=0.3)
    if ax_res is not None:
        ax_res.axhline(0.0, color="black", lw=0.8)
        ax_res.set_ylabel(f"error y − ŷ [{unit}]")
        ax_res.set_xlabel("time [s]")
        ax_res.grid(alpha=0.3)
    else:
        ax.set_xlabel("time [s]")
    return fig


def plot_outputs(
    data: IOData,
    results: Mapping[str, ModelResult],
    axes: Any = None,
    *,
    title: str | None = None,
    bounds: bool = True,
    residuals: bool = False,
    outside: ArrayLike | None = None,
) -> Any:
    """Every output in its own axes: :func:`plot_simulation` of output 0, 1, ... stacked.

    Parameters
    ----------
    data : IOData
        The measured record.
    results : mapping of str to ModelResult
        Model name to its simulation of ``data`` (the same outputs).
    axes : sequence of matplotlib Axes, optional
        One per output, where to draw; a new figure is made when ``None`` (then with
        ``residuals``, each output's axes is followed by the axes of its errors ``y − ŷ``).
    title : str, optional
        Above the first axes.
    bounds : bool, default True
        Each output's band on its own axes.
    residuals : bool, default False
        Add each output's errors (new figure only).
    outside : array_like of bool, shape (n_samples,), optional
        Samples whose regressor lies outside the model's domain; the regressor is every
        output's (each reads all the lags), so the marks go on every output's axes.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import numpy as np, matplotlib
    >>> matplotlib.use("Agg")
    >>> from neckid import IOData, Lags, LinearARX
    >>> u = np.sin(np.arange(200) / 7.0)
    >>> y = np.column_stack([np.roll(u, 1), 0.5 * np.roll(u, 2)])
    >>> data = IOData(u, y, ts=0.1, output_names=["a", "b"], output_units=["deg", "deg"])
    >>> fig = plot_outputs(data, {"arx": LinearARX(Lags.arx(1, 2)).fit(data).simulate(data)})
    >>> [ax.get_ylabel() for ax in fig.axes]
    ['a [deg]', 'b [deg]']
    """
    import matplotlib.pyplot as plt

    n = data.n_outputs
    if axes is None:
        per = 2 if residuals else 1
        ratios = (3, 1.2) * n if residuals else (1,) * n
        fig, grid = plt.subplots(
            per * n,
            1,
            figsize=(10, (5.2 if residuals else 3.4) * n),
            sharex=True,
            height_ratios=ratios,
            layout="constrained",
            squeeze=False,
        )
        targets = list(grid[::per, 0])
        errors = list(grid[1::per, 0]) if residuals else [None] * n
    else:
        targets, errors = list(axes), [None] * n
        if len(targets) != n:
            raise ValueError(f"axes must hold one Axes per output ({n}); got {len(targets)}")
        fig = targets[0].figure
    for j, (ax, ax_res) in enumerate(zip(targets, errors, strict=True)):
        plot_simulation(
            data,
            results,
            output=j,
            ax=ax,
            title=title if j == 0 else None,
            bounds=bounds,
            outside=outside,
        )
        if ax_res is not None:
            _draw_errors(ax_res, data, results, j)
    drawn = [ax for pair in zip(targets, errors, strict=True) for ax in pair if ax is not None]
    for ax in drawn:
        ax.set_xlabel("")
    drawn[-1].set_xlabel("time [s]")
    return fig


def _draw_errors(ax: Any, data: IOData, results: Mapping[str, ModelResult], output: int) -> None:
    """The errors ``y − ŷ`` of one output, each result past its initial samples."""
    import matplotlib.pyplot as plt

    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, result in enumerate(results.values()):
        error = data.y[:, output] - _drawable(result.y[:, output], data.y[:, output])
        start = result.n_initial
        ax.plot(result.time[start:], error[start:], lw=0.8, color=colors[k % len(colors)])
    ax.axhline(0.0, color="black", lw=0.8)
    ax.set_ylabel(f"error y − ŷ [{output_unit(data, results, output)}]")
    ax.grid(alpha=0.3)
