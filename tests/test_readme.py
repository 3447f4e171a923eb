"""The README stays short, its Python quick start runs as written, and so do the examples that
moved from it to the documentation pages."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"

#: Pages whose Python blocks run as written, in order, in one namespace per page (the README's
#: former sections: the contract and runs that differ, the 3-D neck, control, the polynomial NARX,
#: Dask sweeps). The other pages hold fragments that need the real logs.
RUNNABLE_PAGES = ["getting_started.md", "neck3d.md", "control.md", "polynomial.md", "sweeps.md"]


def python_blocks(path: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), flags=re.DOTALL)


def test_readme_is_short() -> None:
    assert len(README.read_text(encoding="utf-8")) <= 12000


def test_readme_synopsis_names_every_command() -> None:
    """The README's command-line block lists the commands ``neckid --help`` lists, no more."""
    import typer.main

    from neckid.cli import app

    block = README.read_text(encoding="utf-8").split("## Command line", 1)[1].split("```")[1]
    listed = set(re.findall(r"^neckid ([a-z][a-z-]*)", block, flags=re.MULTILINE))
    assert listed == set(typer.main.get_command(app).commands)  # type: ignore[attr-defined]


def test_readme_links_exist() -> None:
    text = README.read_text(encoding="utf-8")
    links = re.findall(r"\]\((docs/[^)#]+)", text)
    assert links, "the README links to the documentation pages"
    for link in links:
        assert (ROOT / link).exists(), link


def test_readme_quick_start_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    blocks = python_blocks(README)
    assert blocks, "the README has no python block"
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        exec(compile(block, str(README), "exec"), {"__name__": "__readme__"})
    fit = float(re.search(r"free-run fit: ([-0-9.]+) %", capsys.readouterr().out).group(1))  # type: ignore[union-attr]
    assert fit > 90.0
    assert (tmp_path / "sm_model.npz").exists()


@pytest.mark.parametrize("page", RUNNABLE_PAGES)
def test_docs_examples_run(
    page: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    path = DOCS / page
    blocks = python_blocks(path)
    assert blocks, f"{page} has no python block"
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__docs__"}
    for block in blocks:
        exec(compile(block, str(path), "exec"), namespace)
    out = capsys.readouterr().out
    if page == "getting_started.md":  # the quick start, as in the README
        fit = float(re.search(r"free-run fit: ([-0-9.]+) %", out).group(1))  # type: ignore[union-attr]
        assert fit > 90.0
        assert (tmp_path / "sm_model.npz").exists()
        assert "10 steps ahead: band" in out
    if page == "control.md":
        assert "python-control vs neckid: 0.0" in out
