"""A single self-contained HTML report: figures embedded as base64 PNG, tables, settings, versions.

Figures are numbered (``Fig. 3``, as in the paper, or in order of appearance), tables drop their
all-empty columns and may carry a note, and files that sit beside the report are linked by
relative links with one line on how to use each.
"""

from __future__ import annotations

import base64
import html
import platform
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from neckid._version import __version__

__all__ = ["Figure", "Link", "Report", "library_versions", "settings_frame"]


def library_versions() -> dict[str, str]:
    """Versions of Python, neckid and the libraries that shape its numbers."""
    import matplotlib
    import numba
    import numpy
    import scipy
    import sklearn

    return {
        "python": platform.python_version(),
        "neckid": __version__,
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "pandas": pd.__version__,
        "scikit-learn": sklearn.__version__,
        "numba": numba.__version__,
        "matplotlib": matplotlib.__version__,
    }


def settings_frame(
    values: Mapping[str, Any],
    units: Mapping[str, tuple[str, str]],
    ts: float | None = None,
) -> pd.DataFrame:
    """Settings as a table for a report: name, value, unit and meaning.

    Parameters
    ----------
    values : mapping of str to object
        Setting name to value (numbers, text, or sequences of numbers).
    units : mapping of str to (str, str)
        Setting name to its unit (``"s"``, ``"rad/s"``, ``""`` for none) and a few words on what
        it is; a name missing here gets neither.
    ts : float, optional
        Sampling period [s]: then a setting in seconds also says how many samples it spans.

    Returns
    -------
    pandas.DataFrame
        Columns ``setting``, ``value``, ``unit``, ``meaning``, one row per setting, as text.

    Examples
    --------
    >>> settings_frame({"ts": 0.02, "duration": 60.0, "bands": (1, 2.5)},
    ...                {"duration": ("s", "record length"), "bands": ("rad/s", "")},
    ...                ts=0.02).to_dict("list")["unit"]
    ['', 's (3000 samples)', 'rad/s']
    """
    rows = []
    for key, value in values.items():
        unit, meaning = units.get(key, ("", ""))
        if isinstance(value, tuple | list):
            shown = ", ".join(f"{v:g}" for v in value)
        else:
            shown = f"{value:g}" if isinstance(value, float) else str(value)
        if unit == "s" and ts is not None and isinstance(value, int | float):
            count = round(value / ts)
            unit = f"s ({count} samples)" if count != 1 else f"s (1 sample, {1 / ts:g} Hz)"
        rows.append((key, shown, unit, meaning))
    return pd.DataFrame(rows, columns=["setting", "value", "unit", "meaning"])


@dataclass(frozen=True)
class Figure:
    """A PNG figure on disk with its caption and number.

    Attributes
    ----------
    path : Path
        The PNG file (embedded in the page).
    caption : str
        Caption text, without the number.
    number : str, optional
        Label shown before the caption, e.g. ``"Fig. 3"``; default ``"Fig. k"`` with ``k`` the
        figure's position in the report.
    """

    path: Path
    caption: str
    number: str | None = None


@dataclass(frozen=True)
class Link:
    """A file beside the report: a relative link, what it holds, and how to use it.

    Attributes
    ----------
    href : str
        The file's path relative to the report (its name when it sits in the same folder).
    description : str
        One line on what the file holds.
    usage : str, optional
        Code or a command that uses it (shown as code), e.g. ``neckid.load_model("model.npz")``.
    """

    href: str
    description: str
    usage: str | None = None


@dataclass
class Report:
    """Collects sections (text, tables, figures) and writes them as one HTML file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> r = Report("Demo")
    >>> r.add_text("Hello", "A paragraph.")
    >>> r.add_table("Numbers", pd.DataFrame({"a [s]": [1.0], "error": [""]}), note="No error.")
    >>> r.add_links("Files", [Link("a.csv", "a log", "neckid bandwidth a.csv")])
    >>> page = r.write(pathlib.Path(tempfile.mkdtemp()) / "report.html").read_text()
    >>> "<table" in page, "<th>error</th>" in page, "<a href='a.csv'>" in page
    (True, False, True)
    """

    title: str
    sections: list[str] = field(default_factory=list)
    n_figures: int = 0

    def add_text(self, heading: str, text: str) -> None:
        """A heading and a paragraph of plain text (escaped)."""
        paragraphs = "".join(f"<p>{html.escape(p)}</p>" for p in text.split("\n\n") if p.strip())
        self.sections.append(f"<h2>{html.escape(heading)}</h2>{paragraphs}")

    def add_table(
        self,
        heading: str,
        table: pd.DataFrame,
        float_format: str = "{:.2f}",
        *,
        formats: Mapping[str, str] | None = None,
        note: str | None = None,
        drop_empty: bool = True,
    ) -> None:
        """A heading, a table and an optional note under it.

        Parameters
        ----------
        heading : str
        table : pandas.DataFrame
            Written without its index; its column names are the headers (put the units there).
        float_format : str, default "{:.2f}"
            Format of the float cells.
        formats : mapping of str to str, optional
            Per-column format strings (``{"pole P [-]": "{:.4f}"}``) that override
            ``float_format``; missing values stay missing.
        note : str, optional
            A paragraph under the table (plain text, escaped).
        drop_empty : bool, default True
            Leave out the columns whose every cell is missing or an empty string.
        """
        if drop_empty and len(table):
            table = table.loc[:, [not _is_empty(table[c]) for c in table.columns]]
        if formats:
            table = table.copy()
            for column, spec in formats.items():
                if column in table.columns:
                    table[column] = [None if _missing(v) else spec.format(v) for v in table[column]]
        body = table.to_html(
            index=False, border=0, classes="table", float_format=float_format.format, na_rep="–"
        )
        text = f"<p class='note'>{html.escape(note)}</p>" if note else ""
        self.sections.append(f"<h2>{html.escape(heading)}</h2>{body}{text}")

    def add_mapping(self, heading: str, values: Mapping[str, Any]) -> None:
        """A heading and a two-column key/value table."""
        rows = "".join(
            f"<tr><th>{html.escape(str(k))}</th><td>{html.escape(str(v))}</td></tr>"
            for k, v in values.items()
        )
        self.sections.append(f"<h2>{html.escape(heading)}</h2><table class='table'>{rows}</table>")

    def add_figures(self, heading: str, figures: Sequence[Figure]) -> None:
        """A heading and numbered figures, each embedded in the page as a base64 PNG."""
        parts = [f"<h2>{html.escape(heading)}</h2>"]
        for fig in figures:
            self.n_figures += 1
            number = fig.number if fig.number else f"Fig. {self.n_figures}"
            anchor = "fig-" + "".join(
                ch if ch.isalnum() else "-" for ch in number.lower().removeprefix("fig.").strip()
            )
            data = base64.b64encode(Path(fig.path).read_bytes()).decode("ascii")
            parts.append(
                f"<figure id='{html.escape(anchor)}'>"
                f"<img alt='{html.escape(number)}: {html.escape(fig.path.name)}'"
                f" src='data:image/png;base64,{data}'/>"
                f"<figcaption><b>{html.escape(number)}.</b> {html.escape(fig.caption)}"
                "</figcaption></figure>"
            )
        self.sections.append("".join(parts))

    def add_links(self, heading: str, links: Sequence[Link], intro: str | None = None) -> None:
        """A heading, an optional paragraph and a list of relative links to files, with usage."""
        items = []
        for link in links:
            usage = f"<br/><code>{html.escape(link.usage)}</code>" if link.usage is not None else ""
            items.append(
                f"<li><a href='{html.escape(link.href)}'>{html.escape(link.href)}</a>:"
                f" {html.escape(link.description)}{usage}</li>"
            )
        text = f"<p>{html.escape(intro)}</p>" if intro else ""
        self.sections.append(f"<h2>{html.escape(heading)}</h2>{text}<ul>{''.join(items)}</ul>")

    def write(self, path: str | Path) -> Path:
        """Write the page; returns its path."""
        path = Path(path)
        style = (
            "body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}"
            "table.table{border-collapse:collapse;margin:1em 0}"
            ".table th,.table td{border-bottom:1px solid #ccc;padding:4px 10px;text-align:right}"
            "figure{margin:1.5em 0}img{max-width:100%}figcaption{font-size:90%;color:#555}"
            "p.note{font-size:90%;color:#444;max-width:900px}li{margin:0.4em 0}"
            "code{background:#f3f3f3;padding:1px 4px}"
        )
        page = (
            "<!DOCTYPE html><html><head><meta charset='utf-8'>"
            f"<title>{html.escape(self.title)}</title><style>{style}</style></head><body>"
            f"<h1>{html.escape(self.title)}</h1>{''.join(self.sections)}</body></html>"
        )
        path.write_text(page, encoding="utf-8")
        return path


def _missing(value: Any) -> bool:
    """A missing cell: ``None``, NaN, or an empty string."""
    if value is None:
        return True
    if isinstance(value, str):
        return not value.strip()
    try:
        return bool(pd.isna(value))
    except (TypeError, ValueError):
        return False


def _is_empty(column: pd.Series) -> bool:
    """Whether every cell of a column is missing (an empty column has nothing to show)."""
    return all(_missing(v) for v in column)
