"""The figure of a design: the loop's Bode diagram on the model, the specification marked."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from neckid.design.controllers import DesignedController
from neckid.design.linear_form import LinearForm

__all__ = ["plot_loop"]


def plot_loop(
    controller: DesignedController,
    form: LinearForm,
    *,
    phase_margin: float | None = None,
    crossover: float | None = None,
    inclination: float | None = None,
    axes: Sequence[Any] | None = None,
) -> Any:
    r"""Magnitude and phase of :math:`L = C G e^{-j\omega T d}`, with the specification marked.

    Parameters
    ----------
    controller : DesignedController
    form : LinearForm
        The plant.
    phase_margin, crossover : float, optional
        The specification [deg], [rad/s] (a cross at :math:`(\omega_c, -180° + \varphi_m)`).
    inclination : float, optional
        Where a scheduled controller takes its gains [deg].
    axes : pair of matplotlib Axes, optional
        Magnitude and phase axes (default a new figure with two).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if axes is None:
        fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(6.4, 5.2))
    else:
        top, bottom = axes
        fig = top.figure
    nyquist = math.pi / form.ts
    w = np.geomspace(min(0.01, 0.001 * nyquist), 0.99 * nyquist, 800)
    loop = controller.response(w, inclination) * form.response(w)
    top.semilogx(w, 20 * np.log10(np.abs(loop)), label="loop C G")
    top.axhline(0.0, color="0.6", lw=0.8)
    top.set_ylabel("magnitude [dB]")
    bottom.semilogx(w, np.degrees(np.unwrap(np.angle(loop))), label="loop C G")
    bottom.axhline(-180.0, color="0.6", lw=0.8)
    bottom.set_ylabel("phase [deg]")
    bottom.set_xlabel("frequency [rad/s]")
    if crossover is not None:
        for ax in (top, bottom):
            ax.axvline(crossover, color="C3", lw=0.8, ls="--")
        if phase_margin is not None:
            bottom.plot([crossover], [-180.0 + phase_margin], "x", color="C3", label="spec")
    bottom.legend(loc="lower left")
    top.set_title(f"{controller.kind} controller on {form.source or 'the model'}")
    return fig
