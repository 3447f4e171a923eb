"""Figures of excitation-signal analyses: the amplitude envelopes of a chirp run (paper's Fig. 3)."""

from __future__ import annotations

from typing import Any

from neckid.signals import BandwidthResult

__all__ = ["plot_bandwidth"]


def plot_bandwidth(result: BandwidthResult, ax: Any = None, *, unit: str = "") -> Any:
    """Draw the amplitude envelopes of a chirp run against frequency, like the paper's Fig. 3.

    The command's amplitude, ``threshold`` times it (dashed), the response's amplitude, and a
    vertical line at the bandwidth where the response falls below the dashed line for good. The
    leading windows the rule does not use (start transient, too fast a sweep) are shaded; when
    the ratio is below the threshold from the first measured window on, a dotted line marks that
    frequency, below which the bandwidth lies (``result.reason`` says which chirp measures it).

    Parameters
    ----------
    result : BandwidthResult
        What :func:`neckid.signals.bandwidth_from_chirp` returned.
    ax : matplotlib.axes.Axes, optional
        Where to draw; a new figure is made when ``None``.
    unit : str, optional
        Unit of the command and the response (``"deg"`` for the paper's inclination), for the
        amplitude axis.

    Returns
    -------
    matplotlib.figure.Figure
        The figure holding ``ax`` (never shown; call ``savefig`` or ``plt.show`` yourself).

    Raises
    ------
    TypeError
        If ``result`` is not a :class:`~neckid.signals.BandwidthResult`.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid.signals import bandwidth_from_chirp, paper_chirp, paper_chirp_frequency
    >>> t = np.arange(0.0, 60.0, 0.01)
    >>> command = paper_chirp(t)
    >>> response = 5.0 + 4.0 / np.sqrt(1 + (0.1 * paper_chirp_frequency(t)) ** 2) * np.sin(0.1 * t**2)
    >>> result = bandwidth_from_chirp(t, command, response, frequency=paper_chirp_frequency)
    >>> fig = plot_bandwidth(result)
    >>> fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel()
    ('frequency [rad/s]', 'amplitude [unit of the command]')
    >>> import matplotlib.pyplot as plt
    >>> plt.close(fig)
    """
    if not isinstance(result, BandwidthResult):
        raise TypeError(f"result must be a BandwidthResult; got {type(result).__name__}")
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(figsize=(8, 3.6), layout="constrained")
    else:
        fig = ax.figure
    ax.plot(result.frequency, result.command_amplitude, color="black", lw=1.2, label="command")
    ax.plot(
        result.frequency,
        result.threshold * result.command_amplitude,
        color="black",
        lw=1.0,
        ls="--",
        label=f"{result.threshold:g} x command",
    )
    ax.plot(result.frequency, result.response_amplitude, color="C0", lw=1.2, label="response")
    first = min(result.first_measured, result.frequency.size - 1)
    if first > 0:
        ax.axvspan(
            float(result.frequency[0]),
            float(result.frequency[first]),
            color="0.85",
            zorder=0,
            label="not measured (start transient, fast sweep)",
        )
    if result.status == "found":
        ax.axvline(
            result.bandwidth,
            color="C3",
            lw=1.0,
            label=f"bandwidth {result.bandwidth:.3g} rad/s",
        )
        title = f"bandwidth {result.bandwidth:.3g} rad/s"
    elif result.status == "below_at_start":
        below = float(result.frequency[first])
        ax.axvline(below, color="C3", lw=1.0, ls=":", label=f"bandwidth below ~{below:.3g} rad/s")
        title = f"no bandwidth (below {below:.3g} rad/s: start the chirp lower, sweep slower)"
    else:
        title = f"no bandwidth (not below {result.threshold:g} x command for good: chirp further)"
    ax.set_xlabel("frequency [rad/s]")
    ax.set_ylabel(f"amplitude [{unit}]" if unit else "amplitude [unit of the command]")
    ax.set_title(f"chirp amplitude envelopes: {title}", fontsize="medium")
    ax.legend(loc="best", fontsize="small")
    return fig
