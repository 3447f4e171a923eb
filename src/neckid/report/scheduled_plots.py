"""The seed paper's Fig. 6: gain and pole of the first-order model against inclination."""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.models.base import check_is_fitted
from neckid.models.scheduled import GainScheduledModel

__all__ = ["plot_gain_schedule"]


def plot_gain_schedule(
    model: GainScheduledModel,
    ax: Any = None,
    title: str | None = None,
    inclination_range: tuple[float, float] | None = None,
) -> Any:
    """Operating points (markers) and fitted lines of the gain ``N(i)`` and the pole ``P(i)``.

    Parameters
    ----------
    model : GainScheduledModel
        A fitted model; its points (``inclinations_``, ``gains_``, ``poles_``) are drawn as markers
        and its polynomials as lines.
    ax : matplotlib Axes, optional
        Where to draw (both curves share it, as in the paper); a new figure is made when ``None``.
    title : str, optional
    inclination_range : (float, float), optional
        Inclinations [deg] spanned by the lines; default the range of the points (0–40° when the
        model has none, e.g. one built with ``from_coefficients``).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> fig = plot_gain_schedule(GainScheduledModel.from_coefficients())
    >>> [line.get_label() for line in fig.axes[0].get_lines()][:2]
    ['N(i) = -0.059 i + 1.857', 'P(i) = 0.01175 i - 0.4797']
    """
    import matplotlib.pyplot as plt

    check_is_fitted(model)
    if ax is None:
        fig, ax = plt.subplots(figsize=(6, 3.6), layout="constrained")
    else:
        fig = ax.figure
    if inclination_range is None:
        if model.inclinations_.size:
            inclination_range = (
                float(model.inclinations_.min()),
                float(model.inclinations_.max()),
            )
        else:
            inclination_range = (0.0, 40.0)
    grid = np.linspace(inclination_range[0], inclination_range[1], 200)
    for label, coefficients, points, color, marker in (
        ("N", model.gain_coefficients_, model.gains_, "tab:blue", "o"),
        ("P", model.pole_coefficients_, model.poles_, "tab:red", "s"),
    ):
        ax.plot(
            grid,
            np.polyval(coefficients, grid),
            color=color,
            lw=1.4,
            label=f"{label}(i) = {_polynomial_text(coefficients)}",
        )
        if points.size:
            ax.scatter(
                model.inclinations_, points, color=color, marker=marker, zorder=3, label=label
            )
    ax.set_xlabel("inclination i [deg]")
    ax.set_ylabel("gain N, pole P")
    if title:
        ax.set_title(title)
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def _polynomial_text(coefficients: Any) -> str:
    """``[-0.059, 1.857]`` -> ``"-0.059 i + 1.857"`` (highest power first)."""
    terms: list[str] = []
    degree = len(coefficients) - 1
    for k, c in enumerate(coefficients):
        power = degree - k
        var = "" if power == 0 else ("i" if power == 1 else f"i^{power}")
        value = f"{abs(float(c)):.4g}"
        body = f"{value} {var}".strip()
        if not terms:
            terms.append(f"-{body}" if c < 0 else body)
        else:
            terms.append(f"- {body}" if c < 0 else f"+ {body}")
    return " ".join(terms)
