"""The seed paper's Fig. 6: gain and pole of the first-order model against inclination."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from neckid.models.base import check_is_fitted
from neckid.models.scheduled.model import GainScheduledModel

if TYPE_CHECKING:
    from neckid.loops.operating_points import OperatingPointResult

__all__ = ["GAIN_UNIT", "POSITION_GAIN_UNIT", "operating_points_frame", "plot_gain_schedule"]

#: Unit of the gain ``N`` in the rate form: inclination rate per velocity command.
GAIN_UNIT = "(deg/s)/(rad/s)"
#: Unit of the gain ``N`` in the position form: inclination per motor position.
POSITION_GAIN_UNIT = "deg/rad"
#: Label of the hollow markers of points that did not converge and were left out of the fit.
NOT_CONVERGED_LABEL = "not converged (left out of the fit)"

_PANELS = (
    ("N", "gain", "gain N", "gain N [{unit}]", "tab:blue", "o"),
    ("P", "pole", "pole P", "pole P [-] (dimensionless)", "tab:red", "s"),
)


def plot_gain_schedule(
    model: GainScheduledModel,
    ax: Any = None,
    title: str | None = None,
    inclination_range: tuple[float, float] | None = None,
    *,
    points: pd.DataFrame | OperatingPointResult | None = None,
) -> Any:
    """Operating points (markers) and fitted lines of the gain ``N(i)`` and the pole ``P(i)``.

    Two panels against the inclination ``i`` [deg]: the gain ``N`` [(deg/s)/(rad/s) in the rate
    form, deg/rad in the position form] and the pole ``P`` (dimensionless) of
    ``G(z, i) = N(i) / (z − P(i))``, each with its fitted line and the line's equation in the
    legend. The curves are what the model uses: held at their end values outside the model's
    ``schedule_range_`` (dotted lines mark its ends when they fall inside the plot), the pole
    within ``±pole_bound``.

    Parameters
    ----------
    model : GainScheduledModel
        A fitted model; its points (``inclinations_``, ``gains_``, ``poles_``: the points the lines
        were fitted through) are drawn as filled markers and its polynomials as lines.
    ax : matplotlib Axes or pair of Axes, optional
        Where to draw. A pair: ``N`` in the first, ``P`` in the second. One Axes: both curves
        share it, as in the paper. ``None`` (default): a new figure with two panels.
    title : str, optional
        Title of the figure (of the single Axes when one is given); default
        ``"Gain schedule G(z, i) = N(i) / (z − P(i))"``.
    inclination_range : (float, float), optional
        Inclinations [deg] spanned by the lines; default the range of the points (0–40° when the
        model has none, e.g. one built with ``from_coefficients``).
    points : pandas.DataFrame or OperatingPointResult, optional
        The operating-point table (columns ``inclination`` [deg], ``gain``, ``pole`` and
        optionally ``converged``), e.g. ``OperatingPointResult.table``. Its rows that are not
        among the model's points are drawn as hollow markers, labelled
        ``"not converged (left out of the fit)"`` (or ``"left out of the fit"`` for a converged
        one); points that did not converge but were used are drawn with a cross.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        If ``points`` lacks one of the columns ``inclination``, ``gain``, ``pole``.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> fig = plot_gain_schedule(GainScheduledModel.from_coefficients())
    >>> [ax.get_lines()[0].get_label() for ax in fig.axes]
    ['N(i) = -0.059 i + 1.857', 'P(i) = 0.01175 i - 0.4797']
    >>> [ax.get_ylabel() for ax in fig.axes]
    ['gain N [(deg/s)/(rad/s)]', 'pole P [-] (dimensionless)']
    """
    import matplotlib.pyplot as plt

    check_is_fitted(model)
    table = _points_table(points)
    if ax is None:
        fig, axes = plt.subplots(1, 2, figsize=(10, 4), layout="constrained", sharex=True)
        panels = list(axes)
    elif isinstance(ax, Sequence | np.ndarray):
        panels = list(ax)
        if len(panels) != 2:
            raise ValueError(f"ax must be one Axes or a pair of Axes; got {len(panels)} Axes")
        fig = panels[0].figure
    else:
        panels = [ax, ax]
        fig = ax.figure
    shared = panels[0] is panels[1]
    if inclination_range is None:
        inclination_range = _default_range(model, table)
    grid = np.linspace(inclination_range[0], inclination_range[1], 200)
    used = _used_rows(model, table)
    fitted_values = {"gain": model.gains_, "pole": model.poles_}
    coefficients = {"gain": model.gain_coefficients_, "pole": model.pole_coefficients_}
    curves = {"gain": model.gain(grid), "pole": model.pole(grid)}
    unit = POSITION_GAIN_UNIT if model.form == "position" else GAIN_UNIT
    for panel, (symbol, column, panel_title, ylabel, color, marker) in zip(
        panels, _PANELS, strict=True
    ):
        ylabel = ylabel.format(unit=unit)
        for end in model.schedule_range_:
            if grid[0] < end < grid[-1]:
                panel.axvline(end, color="0.6", lw=0.8, ls=":")
        panel.plot(
            grid,
            curves[column],
            color=color,
            lw=1.4,
            label=f"{symbol}(i) = {_polynomial_text(coefficients[column])}",
        )
        values = fitted_values[column]
        if values.size:
            panel.scatter(
                model.inclinations_,
                values,
                color=color,
                marker=marker,
                zorder=3,
                label=f"{symbol}: operating points (in the fit)",
            )
        if table is not None:
            _draw_table_points(panel, table, used, column, symbol, color, marker)
        if not shared:
            panel.set_title(panel_title)
            panel.set_ylabel(ylabel)
            _pad_limits(panel)
        panel.set_xlabel("inclination i [deg]")
        panel.grid(alpha=0.3)
        panel.legend(loc="best", fontsize=8)
    heading = title if title is not None else "Gain schedule G(z, i) = N(i) / (z − P(i))"
    if shared:
        panels[0].axhline(0.0, color="0.6", lw=0.6)
        panels[0].set_ylabel(f"gain N [{unit}], pole P [-]")
        if heading:
            panels[0].set_title(heading)
    elif heading:
        fig.suptitle(heading)
    return fig


def operating_points_frame(points: pd.DataFrame | OperatingPointResult) -> pd.DataFrame:
    """The operating-point table as text for a report, with the units in its headers.

    Parameters
    ----------
    points : pandas.DataFrame or OperatingPointResult
        ``OperatingPointResult.table`` (columns ``target``, ``inclination``, ``gain``, ``pole``,
        ``converged``, ``settled_at``, ``n_samples``) or the result itself.

    Returns
    -------
    pandas.DataFrame
        Columns ``target [deg]``, ``inclination [deg]``, ``gain N [(deg/s)/(rad/s)]``,
        ``pole P [-]``, ``converged`` (yes/no), ``settled at [sample]`` (empty when never) and
        ``log length [samples]``, numbers formatted as text.

    Examples
    --------
    >>> table = pd.DataFrame({"target": [10.0], "inclination": [9.81], "gain": [2.87846],
    ...     "pole": [0.54], "converged": [False], "settled_at": [-1], "n_samples": [999]})
    >>> operating_points_frame(table).iloc[0].tolist()
    ['10.0', '9.81', '2.8785', '0.5400', 'no', '', '999']
    """
    table = _points_table(points)
    if table is None:
        raise TypeError("points must be a pandas DataFrame or an OperatingPointResult; got None")
    return pd.DataFrame(
        {
            "target [deg]": [f"{v:.1f}" for v in table["target"]],
            "inclination [deg]": [f"{v:.2f}" for v in table["inclination"]],
            f"gain N [{GAIN_UNIT}]": [f"{v:.4f}" for v in table["gain"]],
            "pole P [-]": [f"{v:.4f}" for v in table["pole"]],
            "converged": ["yes" if v else "no" for v in table["converged"]],
            "settled at [sample]": [f"{v:.0f}" if v >= 0 else "" for v in table["settled_at"]],
            "log length [samples]": [f"{v:.0f}" for v in table["n_samples"]],
        }
    )


def _points_table(points: pd.DataFrame | OperatingPointResult | None) -> pd.DataFrame | None:
    """The operating-point table from a table, an ``OperatingPointResult`` or ``None``."""
    if points is None:
        return None
    table = points if isinstance(points, pd.DataFrame) else getattr(points, "table", None)
    if not isinstance(table, pd.DataFrame):
        raise TypeError(
            "points must be a pandas DataFrame or an OperatingPointResult;"
            f" got {type(points).__name__}"
        )
    missing = [c for c in ("inclination", "gain", "pole") if c not in table.columns]
    if missing:
        raise ValueError(
            f"points must have the columns inclination, gain, pole; missing {missing}"
            f" (columns: {list(table.columns)})"
        )
    return table


def _default_range(model: GainScheduledModel, table: pd.DataFrame | None) -> tuple[float, float]:
    """Inclinations [deg] spanned by the points of the model and of the table."""
    values = [model.inclinations_]
    if table is not None:
        values.append(table["inclination"].to_numpy(dtype=np.float64))
    merged = np.concatenate(values)
    merged = merged[np.isfinite(merged)]
    if merged.size == 0:
        return (0.0, 40.0)
    return (float(merged.min()), float(merged.max()))


def _used_rows(model: GainScheduledModel, table: pd.DataFrame | None) -> Any:
    """For each table row, whether it is one of the model's points (same i, N and P)."""
    if table is None:
        return np.zeros(0, dtype=bool)
    fitted = np.column_stack([model.inclinations_, model.gains_, model.poles_])
    rows = table[["inclination", "gain", "pole"]].to_numpy(dtype=np.float64)
    if fitted.size == 0:
        return np.zeros(len(rows), dtype=bool)
    close = np.isclose(rows[:, None, :], fitted[None, :, :], rtol=1e-9, atol=1e-12)
    return close.all(axis=2).any(axis=1)


def _draw_table_points(
    panel: Any,
    table: pd.DataFrame,
    used: Any,
    column: str,
    symbol: str,
    color: str,
    marker: str,
) -> None:
    """Hollow markers for the left-out rows, crosses for used rows that did not converge."""
    if "converged" in table.columns:
        converged = table["converged"].to_numpy(dtype=bool)
    else:
        converged = np.ones(len(table), dtype=bool)
    inclination = table["inclination"].to_numpy(dtype=np.float64)
    values = table[column].to_numpy(dtype=np.float64)
    groups = (
        (~used & ~converged, f"{symbol}: {NOT_CONVERGED_LABEL}"),
        (~used & converged, f"{symbol}: left out of the fit"),
    )
    for rows, label in groups:
        if rows.any():
            panel.scatter(
                inclination[rows],
                values[rows],
                facecolors="none",
                edgecolors=color,
                marker=marker,
                s=60,
                linewidths=1.4,
                zorder=3,
                label=label,
            )
    kept = used & ~converged
    if kept.any():
        panel.scatter(
            inclination[kept],
            values[kept],
            color="black",
            marker="x",
            s=40,
            zorder=4,
            label=f"{symbol}: not converged (kept in the fit)",
        )


def _pad_limits(panel: Any) -> None:
    """Give a nearly flat curve some room: at least ±5 % of its level around it."""
    low, high = panel.get_ylim()
    level = max(abs(low), abs(high), 1e-12)
    if high - low < 0.1 * level:
        centre = 0.5 * (low + high)
        panel.set_ylim(centre - 0.05 * level, centre + 0.05 * level)


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
