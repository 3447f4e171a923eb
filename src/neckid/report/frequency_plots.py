"""Figures of frequency responses: a BLA with its noise and distortion levels, an FRF with its band.

Magnitudes are in dB (20 log10 of output unit per input unit), phases in degrees, frequencies in
rad/s on a log axis.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from neckid.frequency import BestLinearApproximation, FrequencyResponse

__all__ = ["plot_bla", "plot_frf"]


def _db(value: Any) -> Any:
    with np.errstate(divide="ignore"):
        return 20 * np.log10(np.abs(value))


def _gain_unit(output_unit: str, input_unit: str) -> str:
    if not output_unit and not input_unit:
        return "dB"
    return f"dB re 1 {output_unit or '1'}/({input_unit or '1'})"


def _tidy(fig: Any) -> None:
    """``tight_layout`` on a figure of its own (a subfigure is laid out by its parent)."""
    from matplotlib.figure import Figure

    if isinstance(fig, Figure) and fig.get_layout_engine() is None:
        fig.tight_layout()


def _limit(ax: Any, frf: Any) -> None:
    """Magnitude axis from the estimate's range: a band reaching 0 (-inf dB) is cut off."""
    values = _db(frf)
    values = values[np.isfinite(values)]
    if values.size:
        ax.set_ylim(values.min() - 30, values.max() + 15)


def _overlays(axes: Any, overlays: Sequence[tuple[Any, Any, str]]) -> None:
    for omega, frf, label in overlays:
        axes[0].semilogx(omega, _db(frf), "-", lw=1.4, label=label)
        axes[1].semilogx(omega, np.degrees(np.unwrap(np.angle(frf))), "-", lw=1.4, label=label)


def plot_bla(
    bla: BestLinearApproximation,
    pair: tuple[int, int] = (0, 0),
    *,
    overlays: Sequence[tuple[Any, Any, str]] = (),
    fig: Any = None,
) -> Any:
    """The BLA of one pair, its noise, total and nonlinear levels, and the non-excited lines.

    Parameters
    ----------
    bla : BestLinearApproximation
    pair : (output index, input index), default (0, 0)
    overlays : sequence of (omega [rad/s], complex frf, label)
        Other responses drawn over it (a model's).
    fig : matplotlib.figure.Figure, optional
        Drawn into (two axes); a new figure when None.

    Returns
    -------
    matplotlib.figure.Figure
        Top: ``|G_BLA|`` and the standard deviations of the estimate (noise, total, nonlinear)
        in dB, and at the non-excited lines the output's level and its noise level divided by
        the input's line amplitude (so in the FRF's unit too). Bottom: the phase in degrees.
    """
    import matplotlib.pyplot as plt

    out, inp = pair
    fig = fig or plt.figure(figsize=(11, 6))
    axes = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    frf = bla.frf[:, out, inp]
    axes[0].semilogx(bla.omega, _db(frf), "k.-", lw=1, ms=3, label="BLA")
    radius = bla.band_radius(0.95)[:, out, inp]
    lower = np.maximum(np.abs(frf) - radius, 1e-300)
    axes[0].fill_between(
        bla.omega, _db(lower), _db(np.abs(frf) + radius), color="0.8", label="BLA 95 % band"
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        levels = {
            "noise (std of BLA)": np.sqrt(bla.noise_variance[:, out, inp]),
            "total (std of BLA)": np.sqrt(bla.total_variance[:, out, inp]),
            "nonlinear (std of one block)": np.sqrt(bla.distortion_variance[:, out, inp]),
        }
    for (label, value), style in zip(levels.items(), ("b.", "g.", "r."), strict=True):
        axes[0].semilogx(bla.omega, _db(value), style, ms=3, label=label)
    lines = bla.levels
    if lines.lines.size:
        even = lines.parity == "even"
        scale = bla.input_amplitude[inp]  # output level per input line amplitude: FRF units
        power = np.sqrt(lines.output_power[:, out]) / scale
        axes[0].semilogx(
            lines.omega[even],
            _db(power[even]),
            "mo",
            mfc="none",
            ms=4,
            label="even lines (output / input amplitude)",
        )
        axes[0].semilogx(
            lines.omega[~even],
            _db(power[~even]),
            "cx",
            ms=4,
            label="left-out odd lines (output / input amplitude)",
        )
        axes[0].semilogx(
            lines.omega,
            _db(np.sqrt(lines.noise_power[:, out]) / scale),
            "_",
            color="0.4",
            ms=5,
            label="noise at those lines (same scale)",
        )
    _overlays(axes, overlays)
    _limit(axes[0], np.concatenate([frf, np.sqrt(bla.noise_variance[:, out, inp])]))
    axes[1].semilogx(bla.omega, np.degrees(np.unwrap(np.angle(frf))), "k.-", lw=1, ms=3)
    name = f"{bla.output_names[out]} / {bla.input_names[inp]}"
    unit = _gain_unit(bla.output_units[out], bla.input_units[inp])
    axes[0].set(ylabel=f"magnitude [{unit}]", title=f"{bla.estimate}: {name}")
    axes[1].set(ylabel="phase [deg]", xlabel="angular frequency ω [rad/s]")
    axes[0].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    _tidy(fig)
    return fig


def plot_frf(
    response: FrequencyResponse,
    *,
    overlays: Sequence[tuple[Any, Any, str]] = (),
    units: tuple[str, str] = ("", ""),
    title: str = "",
    fig: Any = None,
) -> Any:
    """A frequency response with its 95 % band, its phase and its coherence.

    Parameters
    ----------
    response : FrequencyResponse
    overlays : sequence of (omega [rad/s], complex frf, label)
    units : (output unit, input unit)
    title : str
    fig : matplotlib.figure.Figure, optional

    Returns
    -------
    matplotlib.figure.Figure
        Magnitude [dB] with the band, phase [deg], squared coherence [-].
    """
    import matplotlib.pyplot as plt

    fig = fig or plt.figure(figsize=(11, 7))
    axes = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1, 1]})
    frf, radius = response.frf, response.band_radius
    axes[0].semilogx(response.omega, _db(frf), "k-", lw=1, label=response.estimate)
    if np.isfinite(radius).any():
        lower = np.maximum(np.abs(frf) - radius, 1e-300)
        axes[0].fill_between(
            response.omega, _db(lower), _db(np.abs(frf) + radius), color="0.8", label="95 % band"
        )
    _overlays(axes, overlays)
    _limit(axes[0], frf)
    axes[1].semilogx(response.omega, np.degrees(np.unwrap(np.angle(frf))), "k-", lw=1)
    axes[2].semilogx(response.omega, response.coherence, "k-", lw=1)
    axes[0].set(ylabel=f"magnitude [{_gain_unit(*units)}]", title=title or response.estimate)
    axes[1].set(ylabel="phase [deg]")
    axes[2].set(ylabel="coherence γ² [-]", xlabel="angular frequency ω [rad/s]", ylim=(0, 1.05))
    axes[0].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    _tidy(fig)
    return fig
