"""Figures of regressor choice: He & Asada's Lipschitz order index against the model order."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pandas as pd

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["plot_lipschitz_index"]


def plot_lipschitz_index(
    table: pd.DataFrame, output: str | None = None, ax: Axes | None = None
) -> Figure:
    """Plot the Lipschitz order index against the input order, one line per output order.

    Parameters
    ----------
    table : pandas.DataFrame
        The result of :func:`neckid.selection.lags.lipschitz_quotients`.
    output : str, optional
        Which output channel; default the first in the table.
    ax : matplotlib.axes.Axes, optional
        Where to draw; default a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        The figure holding ``ax`` (not shown: call ``plt.show()`` or ``fig.savefig`` yourself).

    Raises
    ------
    ValueError
        If the table lacks the columns of :func:`~neckid.selection.lags.lipschitz_quotients` or does
        not hold ``output``.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> from neckid.selection.lags import lipschitz_quotients
    >>> u = np.random.default_rng(0).normal(size=200)
    >>> table = lipschitz_quotients(IOData(u, np.cumsum(u), ts=0.1), 1, 2)
    >>> fig = plot_lipschitz_index(table)
    >>> fig.axes[0].get_ylabel()
    'Lipschitz index'
    """
    needed = {"output", "output_order", "input_order", "index"}
    missing = needed - set(table.columns)
    if missing:
        raise ValueError(
            f"table must come from lipschitz_quotients; it lacks the columns {sorted(missing)}"
        )
    outputs = list(dict.fromkeys(table["output"]))
    name = outputs[0] if output is None else output
    if name not in outputs:
        raise ValueError(f"output {name!r} is not in the table; it holds {outputs}")
    if ax is None:
        from matplotlib.figure import Figure as _Figure

        fig = _Figure(figsize=(6.0, 4.0))
        ax = fig.add_subplot()
    else:
        fig = ax.get_figure()  # type: ignore[assignment]
    part = table[table["output"] == name]
    for na, rows in part.groupby("output_order", sort=True):
        rows = rows.sort_values("input_order")
        ax.plot(rows["input_order"], rows["index"], marker="o", label=f"output order {na}")
    ax.set_yscale("log")
    ax.set_xlabel("input order (number of input lags)")
    ax.set_ylabel("Lipschitz index")
    ax.set_title(f"He & Asada order index, output {name}")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    return fig
