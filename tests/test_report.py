"""The demo's report as a reader meets it, and the figures of the scheduled and SM models.

The demo runs once in quick mode; ``report.html`` is parsed with the standard library's
:class:`html.parser.HTMLParser` and checked for numbered figures, units in the table headers, no
empty column, working links to the files beside it, and a chirp run ``neckid bandwidth`` reads.
"""

from __future__ import annotations

import json
import re
import warnings
from dataclasses import dataclass, field
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import urlparse

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from neckid import load_model
from neckid.cli import app
from neckid.experiments.demo_outputs import BANDWIDTH_COMMAND, CHIRP_RUN
from neckid.experiments.paper import DemoSettings, run_demo
from neckid.models.base import ExtrapolationWarning
from neckid.models.scheduled.model import GainScheduledModel
from neckid.models.set_membership.narx import GammaCurve
from neckid.report.html import Figure, Report
from neckid.report.scheduled_plots import plot_gain_schedule
from neckid.report.sm_plots import plot_gamma_curve

runner = CliRunner()

#: A cell that shows nothing (pandas writes missing values as an en dash).
EMPTY_CELLS = {"", "–"}
FIGURE_NUMBER = re.compile(r"^Fig\. (\d+|S\d+)\. \S")
NUMBER = re.compile(r"^[-+]?(\d+(\.\d*)?|\.\d+)([eE][-+]?\d+)?%?$|^[-+]?inf$")


# ---------------------------------------------------------------------------- parsing the page
@dataclass
class Table:
    headers: list[str]
    rows: list[list[str]]
    note: str = ""

    def column(self, header: str) -> list[str]:
        k = self.headers.index(header)
        return [row[k] for row in self.rows]


@dataclass
class Page:
    figures: list[dict[str, str]] = field(default_factory=list)
    tables: dict[str, Table] = field(default_factory=dict)
    links: list[str] = field(default_factory=list)
    codes: list[str] = field(default_factory=list)


class ReportParser(HTMLParser):
    """Headings, tables (with the note under each), figures, links and code of the report."""

    def __init__(self) -> None:
        super().__init__()
        self.page = Page()
        self.heading = ""
        self.text: list[str] | None = None
        self.table: Table | None = None
        self.in_head = False
        self.row: list[str] | None = None
        self.figure: dict[str, str] | None = None
        self.last_table: Table | None = None
        self.in_note = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        values = dict(attrs)
        if tag in ("h2", "th", "td", "figcaption", "code"):
            self.text = []
        if tag == "table":
            self.table = Table([], [])
        elif tag == "thead":
            self.in_head = True
        elif tag == "tr":
            self.row = []
        elif tag == "figure":
            self.figure = {"id": values.get("id") or ""}
        elif tag == "img" and self.figure is not None:
            self.figure["src"] = values.get("src") or ""
        elif tag == "a":
            self.page.links.append(values.get("href") or "")
        elif tag == "p" and values.get("class") == "note":
            self.in_note = True
            self.text = []

    def handle_data(self, data: str) -> None:
        if self.text is not None:
            self.text.append(data)

    def handle_endtag(self, tag: str) -> None:
        content = " ".join("".join(self.text or []).split())
        if tag == "h2":
            self.heading = content
        elif tag in ("th", "td") and self.row is not None:
            self.row.append(content)
        elif tag == "tr" and self.table is not None and self.row is not None:
            if self.in_head:
                self.table.headers = self.row
            else:
                self.table.rows.append(self.row)
            self.row = None
        elif tag == "thead":
            self.in_head = False
        elif tag == "table" and self.table is not None:
            self.page.tables[self.heading] = self.table
            self.last_table, self.table = self.table, None
        elif tag == "figcaption" and self.figure is not None:
            self.figure["caption"] = content
        elif tag == "figure" and self.figure is not None:
            self.page.figures.append(self.figure)
            self.figure = None
        elif tag == "code":
            self.page.codes.append(content)
        elif tag == "p" and self.in_note and self.last_table is not None:
            self.last_table.note = content
            self.in_note = False
        if tag in ("h2", "th", "td", "figcaption", "code", "p"):
            self.text = None


def parse_report(path: Path) -> Page:
    parser = ReportParser()
    parser.feed(path.read_text(encoding="utf-8"))
    parser.close()
    return parser.page


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Page]:
    """The quick demo, run once: its folder and its parsed report."""
    out = tmp_path_factory.mktemp("report") / "demo"
    with warnings.catch_warnings():
        # The closed-loop tests start at rest, below the identification range: the demo knows.
        warnings.simplefilter("ignore", ExtrapolationWarning)
        run_demo(out, DemoSettings.make(quick=True))
    return out, parse_report(out / "report.html")


# ------------------------------------------------------------------------------- the report
def test_every_figure_is_numbered_and_the_papers_numbers_are_there(
    demo: tuple[Path, Page],
) -> None:
    folder, page = demo
    assert len(page.figures) == len(list(folder.glob("*.png")))
    numbers = []
    for figure in page.figures:
        caption = figure.get("caption", "")
        match = FIGURE_NUMBER.match(caption)
        assert match, caption
        numbers.append(match.group(1))
        assert figure["src"].startswith("data:image/png;base64,")
        assert figure["id"] == f"fig-{match.group(1).lower()}"
    assert numbers == ["3", "5", "6", "7", "8", "9", "S1"]


def test_tables_carry_units_in_their_headers(demo: tuple[Path, Page]) -> None:
    _, page = demo
    headed = {h: t for h, t in page.tables.items() if t.headers}
    assert len(headed) >= 5, list(page.tables)
    for heading, table in headed.items():
        for k, header in enumerate(table.headers):
            cells = [row[k] for row in table.rows if row[k] not in EMPTY_CELLS]
            if cells and all(NUMBER.match(c) for c in cells):
                assert re.search(r"\[[^\]]+\]", header), (heading, header)
    headers = {h for t in headed.values() for h in t.headers}
    for wanted in (
        "validation, fit [%]",
        "validation, MAE [deg]",
        "gain N [(deg/s)/(rad/s)]",
        "pole P [-]",
        "inclination [deg]",
        "free-run fit [%]",
        "max lag [samples]",
    ):
        assert wanted in headers, (wanted, sorted(headers))
    settings = page.tables["Settings"]
    units = dict(zip(settings.column("setting"), settings.column("unit"), strict=True))
    assert units["ts"].startswith("s")
    assert units["train_duration"] == "s (3000 samples)"
    assert units["band_low"] == "rad/s"
    assert units["inclinations"] == "deg"
    assert units["sensor delay (simulated neck)"] == "samples"


def test_no_table_has_an_all_empty_column(demo: tuple[Path, Page]) -> None:
    _, page = demo
    for heading, table in page.tables.items():
        for k, header in enumerate(table.headers):
            assert any(row[k] not in EMPTY_CELLS for row in table.rows), (heading, header)
    selection = page.tables["Lag selection (neural NARX, validation fit)"]
    assert "error" not in selection.headers  # no candidate failed
    assert len(set(selection.headers)) == len(selection.headers)


def test_the_papers_lags_are_explained_with_the_measured_fit(demo: tuple[Path, Page]) -> None:
    _, page = demo
    selection = page.tables["Lag selection (neural NARX, validation fit)"]
    lags = selection.column("candidate lags")
    paper = [k for k, text in enumerate(lags) if text.endswith("(paper)")]
    assert len(paper) == 1, lags
    fit = selection.column("free-run fit [%]")[paper[0]]
    assert f"scores {fit} % in free run" in selection.note
    assert "8–10 samples (0.16–0.20 s at 50 Hz)" in selection.note
    assert "tilt sensor lags 2 samples" in selection.note


def test_links_to_the_model_files_are_relative_and_load(demo: tuple[Path, Page]) -> None:
    folder, page = demo
    models = [href for href in page.links if href.endswith(".npz")]
    assert len(models) == 5
    assert sorted(models) == sorted(p.name for p in folder.glob("*.npz"))
    for href in page.links:
        assert not urlparse(href).scheme and not Path(href).is_absolute(), href
        assert (folder / href).is_file(), href
    for href in models:
        assert f'model = neckid.load_model("{href}")' in page.codes
        load_model(folder / href)


def test_chirp_run_is_saved_listed_and_read_by_the_bandwidth_command(
    demo: tuple[Path, Page],
) -> None:
    folder, page = demo
    path = folder / CHIRP_RUN
    frame = pd.read_csv(path)
    assert list(frame.columns) == ["time", "reference", "inclination"]
    assert frame["time"].iloc[0] == 0.0
    np.testing.assert_allclose(np.diff(frame["time"]), 0.02, atol=1e-9)
    metrics = json.loads((folder / "metrics.json").read_text())
    assert metrics["files"]["chirp_run"] == CHIRP_RUN
    assert CHIRP_RUN in page.links
    assert BANDWIDTH_COMMAND in page.codes

    arguments = BANDWIDTH_COMMAND.split()[1:]
    arguments[arguments.index(CHIRP_RUN)] = str(path)
    result = runner.invoke(app, arguments)
    assert result.exit_code == 0, result.output
    found = re.search(r"bandwidth: ([0-9.]+) rad/s", result.output)
    assert found, result.output
    assert float(found.group(1)) == pytest.approx(metrics["bandwidth_rad_s"], abs=2e-3)


# ------------------------------------------------------------------------ the Report itself
def test_report_numbers_figures_drops_empty_columns_and_writes_notes(tmp_path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1])
    fig.savefig(tmp_path / "a.png")
    report = Report("test")
    report.add_figures(
        "Figures",
        [Figure(tmp_path / "a.png", "first"), Figure(tmp_path / "a.png", "second", "Fig. 9")],
    )
    report.add_figures("More", [Figure(tmp_path / "a.png", "third")])
    table = pd.DataFrame({"x [s]": [1.0, np.nan], "empty": [np.nan, np.nan], "blank": ["", ""]})
    report.add_table("T", table, note="A note.")
    page = parse_report(report.write(tmp_path / "r.html"))
    assert [f["caption"] for f in page.figures] == [
        "Fig. 1. first",
        "Fig. 9. second",
        "Fig. 3. third",
    ]
    assert page.tables["T"].headers == ["x [s]"]
    assert page.tables["T"].rows == [["1.00"], ["–"]]
    assert page.tables["T"].note == "A note."


# ------------------------------------------------------------------------- Fig. 6
INCLINATIONS = np.array([5.0, 10.0, 15.0, 20.0, 25.0])
GAINS = -0.05 * INCLINATIONS + 3.0
POLES = 0.002 * INCLINATIONS + 0.5


def _points(converged: list[bool]) -> pd.DataFrame:
    gains = GAINS.copy()
    gains[~np.asarray(converged)] += 0.4  # a point that did not converge sits off the line
    return pd.DataFrame(
        {"inclination": INCLINATIONS, "gain": gains, "pole": POLES, "converged": converged}
    )


def _schedule(points: pd.DataFrame) -> GainScheduledModel:
    used = points[points["converged"]]
    return GainScheduledModel.from_points(used["inclination"], used["gain"], used["pole"], ts=0.02)


def test_gain_schedule_has_two_labelled_panels_with_equations() -> None:
    points = _points([True] * 5)
    fig = plot_gain_schedule(_schedule(points))
    assert len(fig.axes) == 2
    gain_ax, pole_ax = fig.axes
    assert (gain_ax.get_title(), pole_ax.get_title()) == ("gain N", "pole P")
    assert gain_ax.get_ylabel() == "gain N [(deg/s)/(rad/s)]"
    assert pole_ax.get_ylabel().startswith("pole P [-]")
    assert "dimensionless" in pole_ax.get_ylabel()
    for ax in fig.axes:
        assert ax.get_xlabel() == "inclination i [deg]"
    assert fig.get_suptitle() == "Gain schedule G(z, i) = N(i) / (z − P(i))"
    gain_line, pole_line = gain_ax.get_lines()[0], pole_ax.get_lines()[0]
    assert gain_line.get_label() == "N(i) = -0.05 i + 3"
    assert pole_line.get_label() == "P(i) = 0.002 i + 0.5"
    np.testing.assert_allclose(gain_line.get_ydata(), -0.05 * gain_line.get_xdata() + 3.0)
    np.testing.assert_allclose(gain_ax.collections[0].get_offsets()[:, 1], GAINS)
    np.testing.assert_allclose(pole_ax.collections[0].get_offsets()[:, 1], POLES)


def test_gain_schedule_draws_points_that_did_not_converge_hollow() -> None:
    points = _points([True, True, False, True, True])
    fig = plot_gain_schedule(_schedule(points), points=points, title="Fig. 6")
    assert fig.get_suptitle() == "Fig. 6"
    for ax, column in zip(fig.axes, ("gain", "pole"), strict=True):
        symbol = "N" if column == "gain" else "P"
        by_label = {c.get_label(): c for c in ax.collections}
        hollow = by_label[f"{symbol}: not converged (left out of the fit)"]
        np.testing.assert_allclose(hollow.get_offsets(), [[15.0, points[column][2]]])
        assert hollow.get_facecolors().size == 0 or np.all(hollow.get_facecolors()[:, 3] == 0)
        used = by_label[f"{symbol}: operating points (in the fit)"]
        assert len(used.get_offsets()) == 4
        legend = [t.get_text() for t in ax.get_legend().get_texts()]
        assert f"{symbol}: not converged (left out of the fit)" in legend


def test_gain_schedule_marks_other_left_out_points_and_shared_axes() -> None:
    import matplotlib.pyplot as plt

    points = _points([True] * 5)
    model = GainScheduledModel.from_points(INCLINATIONS[:4], GAINS[:4], POLES[:4], ts=0.02)
    fig = plot_gain_schedule(model, points=points)
    labels = [c.get_label() for c in fig.axes[0].collections]
    assert "N: left out of the fit" in labels
    assert not any("not converged" in label for label in labels)

    _, own = plt.subplots()
    assert plot_gain_schedule(model, ax=own) is own.figure
    assert own.get_ylabel() == "gain N [(deg/s)/(rad/s)], pole P [-]"
    _, pair = plt.subplots(1, 2)
    fig = plot_gain_schedule(model, ax=pair)
    assert fig is pair[0].figure and pair[1].get_title() == "pole P"


@pytest.mark.parametrize(
    ("points", "error", "match"),
    [
        (pd.DataFrame({"inclination": [1.0], "gain": [1.0]}), ValueError, "missing \\['pole'\\]"),
        ([1.0, 2.0], TypeError, "points must be a pandas DataFrame .*; got list"),
    ],
)
def test_gain_schedule_refuses_bad_points(points: object, error: type, match: str) -> None:
    model = _schedule(_points([True] * 5))
    with pytest.raises(error, match=match):
        plot_gain_schedule(model, points=points)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------- γ*(ε)
def _curve() -> GammaCurve:
    epsilons = np.concatenate([[0.0], np.geomspace(1e-3, 1.0, 12)])
    gamma = 2.0 + 50.0 / (1.0 + 200.0 * epsilons)
    return GammaCurve(epsilons[:, None], gamma[:, None], ("inclination",), 300)


def test_gamma_curve_log_axis_units_and_the_chosen_point() -> None:
    curve = _curve()
    chosen = (np.array([curve.epsilons[5, 0]]), np.array([curve.gamma[5, 0]]))
    fig = plot_gamma_curve(curve, unit="deg", chosen=chosen)
    ax = fig.axes[0]
    assert ax.get_xscale() == "log"
    assert ax.get_xlabel().startswith("noise bound ε [deg]")
    assert "[deg per unit of scaled regressor]" in ax.get_ylabel()
    texts = [t.get_text() for t in ax.texts]
    assert texts == [f"inclination: ε = {chosen[0][0]:.3g} deg, γ = {chosen[1][0]:.3g}"]
    star = next(line for line in ax.get_lines() if line.get_marker() == "*")
    assert star.get_xydata().tolist() == [[chosen[0][0], chosen[1][0]]]
    curve_line = ax.get_lines()[0]
    assert np.all(curve_line.get_xdata() > 0)  # ε = 0 is not on the log axis ...
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "γ*(0) (ε = 0 is off the log axis)" in legend  # ... it is on the edge, labelled


def test_gamma_curve_without_choice_marks_the_knee() -> None:
    fig = plot_gamma_curve(_curve(), unit="deg")
    ax = fig.axes[0]
    assert len(ax.texts) == 0
    assert "inclination: knee of the curve" in [line.get_label() for line in ax.get_lines()]


def test_gamma_curve_refuses_a_chosen_value_of_the_wrong_size() -> None:
    with pytest.raises(ValueError, match="one value or one per output \\(1\\); got 2"):
        plot_gamma_curve(_curve(), chosen=([0.1, 0.2], 3.0))
