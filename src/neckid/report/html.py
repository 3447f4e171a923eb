"""A single self-contained HTML report: figures embedded as base64 PNG, tables, settings, versions."""

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

__all__ = ["Figure", "Report", "library_versions"]


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


@dataclass(frozen=True)
class Figure:
    """A PNG figure on disk with its caption."""

    path: Path
    caption: str


@dataclass
class Report:
    """Collects sections (text, tables, figures) and writes them as one HTML file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> r = Report("Demo")
    >>> r.add_text("Hello", "A paragraph.")
    >>> r.add_table("Numbers", pd.DataFrame({"a": [1.0]}))
    >>> out = r.write(pathlib.Path(tempfile.mkdtemp()) / "report.html")
    >>> "<table" in out.read_text()
    True
    """

    title: str
    sections: list[str] = field(default_factory=list)

    def add_text(self, heading: str, text: str) -> None:
        """A heading and a paragraph of plain text (escaped)."""
        paragraphs = "".join(f"<p>{html.escape(p)}</p>" for p in text.split("\n\n") if p.strip())
        self.sections.append(f"<h2>{html.escape(heading)}</h2>{paragraphs}")

    def add_table(self, heading: str, table: pd.DataFrame, float_format: str = "{:.2f}") -> None:
        """A heading and a table."""
        body = table.to_html(
            index=False, border=0, classes="table", float_format=float_format.format, na_rep="–"
        )
        self.sections.append(f"<h2>{html.escape(heading)}</h2>{body}")

    def add_mapping(self, heading: str, values: Mapping[str, Any]) -> None:
        """A heading and a two-column key/value table."""
        rows = "".join(
            f"<tr><th>{html.escape(str(k))}</th><td>{html.escape(str(v))}</td></tr>"
            for k, v in values.items()
        )
        self.sections.append(f"<h2>{html.escape(heading)}</h2><table class='table'>{rows}</table>")

    def add_figures(self, heading: str, figures: Sequence[Figure]) -> None:
        """A heading and figures, each embedded in the page as a base64 PNG."""
        parts = [f"<h2>{html.escape(heading)}</h2>"]
        for fig in figures:
            data = base64.b64encode(Path(fig.path).read_bytes()).decode("ascii")
            parts.append(
                f"<figure><img alt='{html.escape(fig.path.name)}' src='data:image/png;base64,{data}'/>"
                f"<figcaption>{html.escape(fig.caption)}</figcaption></figure>"
            )
        self.sections.append("".join(parts))

    def write(self, path: str | Path) -> Path:
        """Write the page; returns its path."""
        path = Path(path)
        style = (
            "body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}"
            "table.table{border-collapse:collapse;margin:1em 0}"
            ".table th,.table td{border-bottom:1px solid #ccc;padding:4px 10px;text-align:right}"
            "figure{margin:1.5em 0}img{max-width:100%}figcaption{font-size:90%;color:#555}"
        )
        page = (
            "<!DOCTYPE html><html><head><meta charset='utf-8'>"
            f"<title>{html.escape(self.title)}</title><style>{style}</style></head><body>"
            f"<h1>{html.escape(self.title)}</h1>{''.join(self.sections)}</body></html>"
        )
        path.write_text(page, encoding="utf-8")
        return path
