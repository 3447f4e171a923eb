"""Figures of Set Membership identification: the γ*(ε) curve."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.models.set_membership.narx import GammaCurve, choose_epsilon

__all__ = ["plot_gamma_curve"]


def plot_gamma_curve(
    curve: GammaCurve,
    ax: Any = None,
    unit: str = "output unit",
    *,
    chosen: tuple[ArrayLike, ArrayLike] | None = None,
    title: str | None = None,
) -> Any:
    """Plot γ*(ε) per output on a log ε axis, with the chosen ε and γ marked; returns the figure.

    Parameters
    ----------
    curve : GammaCurve
        From :func:`neckid.gamma_curve` or ``SetMembership.gamma_curve_``.
    ax : matplotlib Axes, optional
        Where to draw; a new figure when omitted.
    unit : str, default "output unit"
        Unit of the outputs (``"deg"``), for the axis labels and the text.
    chosen : (epsilon, gamma), optional
        The noise bound ε [``unit``] and Lipschitz constant γ the model uses, one value or one per
        output (e.g. ``(model.epsilon_, model.gamma_)`` of a fitted
        :class:`~neckid.SetMembership`): drawn as a filled marker with the text
        ``"ε = … unit, γ = …"``. When omitted, the knee of the curve
        (:func:`~neckid.models.set_membership.narx.choose_epsilon`) is marked instead.
    title : str, optional
        Axes title; default ``"γ*(ε): smallest Lipschitz constant consistent with the data"``.

    Returns
    -------
    matplotlib.figure.Figure

    Notes
    -----
    The ε grid is geometric, so the ε axis is logarithmic. The grid's first point, ε = 0, cannot
    sit on it: its γ*(0) is drawn as a triangle on the left edge of the axes, and the legend says
    so.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> eps = np.array([[0.0], [0.01], [0.02], [0.05], [0.1], [0.2]])
    >>> curve = GammaCurve(eps, np.array([[80.0], [40.0], [6.0], [5.0], [4.5], [4.0]]),
    ...                    ("inclination",), 100)
    >>> fig = plot_gamma_curve(curve, unit="deg", chosen=(0.02, 6.0))
    >>> fig.axes[0].get_xscale(), fig.axes[0].texts[0].get_text()
    ('log', 'inclination: ε = 0.02 deg, γ = 6')
    """
    import matplotlib.pyplot as plt
    import matplotlib.transforms as mtransforms

    if ax is None:
        fig, ax = plt.subplots(figsize=(7, 4.2), layout="constrained")
    else:
        fig = ax.figure
    n_outputs = curve.gamma.shape[1]
    picks = None if chosen is None else _per_output(chosen, n_outputs)
    edge = mtransforms.blended_transform_factory(ax.transAxes, ax.transData)
    zero_noted = False
    for c, name in enumerate(curve.output_names):
        eps, gamma = curve.epsilons[:, c], curve.gamma[:, c]
        shown = np.isfinite(gamma) & (eps > 0)
        (line,) = ax.plot(eps[shown], gamma[shown], ".-", label=name)
        color = line.get_color()
        zero_noted = _mark_gamma_at_zero(ax, edge, eps, gamma, color, zero_noted)
        if picks is None:
            _mark_knee(ax, eps, gamma, color, name)
        else:
            epsilon, lipschitz = float(picks[0][c]), float(picks[1][c])
            _mark_chosen(ax, edge, c, name, color, (epsilon, lipschitz), unit)
    _format_gamma_axes(ax, unit, title)
    return fig


def _mark_gamma_at_zero(
    ax: Any, edge: Any, eps: Any, gamma: Any, color: Any, zero_noted: bool
) -> bool:
    """γ*(0) as a triangle on the left edge (labelled once); whether the label is given now."""
    at_zero = (eps == 0) & np.isfinite(gamma) & (gamma > 0)
    if at_zero.any():
        ax.plot(
            [0.0],
            [gamma[at_zero][0]],
            marker=">",
            color=color,
            ms=8,
            transform=edge,
            clip_on=False,
            ls="none",
            label=None if zero_noted else "γ*(0) (ε = 0 is off the log axis)",
        )
        zero_noted = True
    return zero_noted


def _mark_knee(ax: Any, eps: Any, gamma: Any, color: Any, name: str) -> None:
    """The knee of one output's curve as a hollow circle (when its ε is above 0)."""
    k = choose_epsilon(eps, gamma)
    if eps[k] > 0:
        ax.plot(
            [eps[k]],
            [gamma[k]],
            "o",
            mfc="none",
            ms=10,
            color=color,
            label=f"{name}: knee of the curve",
        )


def _mark_chosen(
    ax: Any,
    edge: Any,
    c: int,
    name: str,
    color: Any,
    pick: tuple[float, float],
    unit: str,
) -> None:
    """The chosen (ε, γ) of output ``c`` as a star with its values, or only its values."""
    epsilon, lipschitz = pick
    text = f"{name}: ε = {epsilon:.3g} {unit}, γ = {lipschitz:.3g}"
    if not lipschitz > 0 or not np.isfinite(lipschitz):
        # Nothing to mark on a log axis: the values are still written on the figure.
        ax.text(0.02, 0.04 + 0.07 * c, text, transform=ax.transAxes, fontsize=9)
        return
    # ε = 0 (a noise bound given as 0) sits on the left edge, like γ*(0).
    where = (0.0, edge) if epsilon == 0 else (epsilon, ax.transData)
    ax.plot(
        [where[0]],
        [lipschitz],
        "*",
        ms=14,
        color=color,
        mec="black",
        mew=0.6,
        zorder=4,
        transform=where[1],
        clip_on=False,
        label=f"{name}: chosen (ε, γ)",
    )
    ax.annotate(
        text,
        xy=(where[0], lipschitz),
        xycoords=where[1],
        xytext=(14, 12 + 16 * c),
        textcoords="offset points",
        fontsize=9,
        arrowprops={"arrowstyle": "-", "color": "0.4", "lw": 0.8},
        bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": "0.7"},
    )


def _format_gamma_axes(ax: Any, unit: str, title: str | None) -> None:
    """Log axes with plain-number γ ticks, labels, title, grid and legend."""
    import matplotlib.ticker as mticker

    ax.set_xscale("log")
    ax.set_yscale("log")
    # Plain numbers on the γ axis (1, 2, 3, 5, 10, 20 ...), not a mix of 10^1 and 6x10^0.
    ax.yaxis.set_major_formatter(mticker.FuncFormatter(lambda value, _: f"{value:g}"))
    ax.yaxis.set_minor_formatter(mticker.FuncFormatter(_minor_label))
    ax.set_xlabel(f"noise bound ε [{unit}] (log scale)")
    ax.set_ylabel(f"γ*(ε) [{unit} per unit of scaled regressor]")
    ax.set_title(
        title
        if title is not None
        else "γ*(ε): smallest Lipschitz constant consistent with the data"
    )
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="upper right", fontsize=8)


def _minor_label(value: float, _position: Any) -> str:
    """Label the minor ticks 2, 3 and 5 of each decade of a log axis; leave the others bare."""
    if not value > 0:
        return ""
    mantissa = round(value / 10.0 ** np.floor(np.log10(value)), 6)
    return f"{value:g}" if mantissa in (2.0, 3.0, 5.0) else ""


def _per_output(chosen: tuple[ArrayLike, ArrayLike], n_outputs: int) -> tuple[Any, Any]:
    """``(epsilon, gamma)`` as two float arrays of length ``n_outputs``."""
    if len(chosen) != 2:
        raise ValueError(f"chosen must be a pair (epsilon, gamma); got {len(chosen)} values")
    arrays = []
    for name, value in zip(("epsilon", "gamma"), chosen, strict=True):
        array = np.asarray(value, dtype=np.float64).ravel()
        if array.size not in (1, n_outputs):
            raise ValueError(
                f"chosen {name} must hold one value or one per output ({n_outputs});"
                f" got {array.size}"
            )
        arrays.append(np.broadcast_to(array, (n_outputs,)))
    if not np.all(np.isfinite(arrays[0]) & (arrays[0] >= 0)):
        raise ValueError(f"chosen epsilon must be finite and >= 0; got {arrays[0].tolist()}")
    return arrays[0], arrays[1]
