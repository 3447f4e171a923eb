"""Figures of excitation-signal analyses: the amplitude envelopes of a chirp run (paper's Fig. 3)."""

from __future__ import annotations

from typing import Any

from neckid.signals import BandwidthResult

__all__ = ["plot_bandwidth"]


def plot_bandwidth(result: BandwidthResult, ax: Any = None) -> Any:
    """Draw the amplitude envelopes of a chirp run against frequency, like the paper's Fig. 3.

    The command's amplitude, ``threshold`` times it (dashed), the response's amplitude, and a
    vertical line at the bandwidth where the response falls below the dashed line for good.

    Parameters
    ----------
    result : BandwidthResult
        What :func:`neckid.signals.bandwidth_from_chirp` returned.
    ax : matplotlib.axes.Axes, optional
        Where to draw; a new figure is made when ``None``.

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
    >>> fig.axes[0].get_xlabel()
    'frequency (rad/s)'
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
    if result.status == "found":
        ax.axvline(
            result.bandwidth,
            color="C3",
            lw=1.0,
            label=f"bandwidth {result.bandwidth:.3g} rad/s",
        )
    ax.set_xlabel("frequency (rad/s)")
    ax.set_ylabel("amplitude")
    ax.set_title(f"chirp amplitude envelopes ({result.status})")
    ax.legend(loc="best", fontsize="small")
    return fig
