"""Figures of Set Membership identification: the γ*(ε) curve."""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.models.set_membership import GammaCurve, choose_epsilon

__all__ = ["plot_gamma_curve"]


def plot_gamma_curve(curve: GammaCurve, ax: Any = None, unit: str = "output unit") -> Any:
    """Plot γ*(ε) per output with the chosen ε (the knee) circled; returns the figure.

    Parameters
    ----------
    curve : GammaCurve
        From :func:`neckid.gamma_curve` or ``SetMembership.gamma_curve_``.
    ax : matplotlib Axes, optional
        Where to draw; a new figure when omitted.
    unit : str, default "output unit"
        Unit of the outputs (``"deg"``), for the axis labels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(figsize=(6, 4))
    else:
        fig = ax.figure
    knees = curve.knee()
    for c, name in enumerate(curve.output_names):
        finite = np.isfinite(curve.gamma[:, c])
        (line,) = ax.plot(curve.epsilons[finite, c], curve.gamma[finite, c], ".-", label=name)
        k = choose_epsilon(curve.epsilons[:, c], curve.gamma[:, c])
        ax.plot([knees[c]], [curve.gamma[k, c]], "o", mfc="none", ms=10, color=line.get_color())
    ax.set_xlabel(f"noise bound ε [{unit}]")
    ax.set_ylabel(f"γ*(ε) [{unit} per unit of scaled regressor]")
    ax.set_yscale("log")
    ax.legend(title="output (circle: chosen ε)")
    return fig
