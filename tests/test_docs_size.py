"""The user guide stays readable: no user page of the documentation, and not the README, over
12,000 characters (issue 41). Results belong on the benchmark pages (docs/benchmarks/), the history
in CHANGELOG.md, the docstrings on the API pages (docs/api/); a page that grows past the limit is
split or moved there."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LIMIT = 12_000

#: The results pages, where measurement tables belong (they are not held to the limit).
RESULTS = ROOT / "docs" / "benchmarks"

#: Every user page, in docs/ and its folders (docs/reliability/ is generated from the cases of
#: tests/test_reliability.py, a page per class of case, and is held to the limit as well).
USER_PAGES = sorted(p for p in (ROOT / "docs").rglob("*.md") if RESULTS not in p.parents)


def test_there_are_user_pages() -> None:
    assert len(USER_PAGES) > 20
    assert ROOT / "docs" / "tutorial.md" in USER_PAGES


@pytest.mark.parametrize("page", USER_PAGES, ids=lambda p: str(p.relative_to(ROOT / "docs")))
def test_a_user_page_is_short(page: Path) -> None:
    n = len(page.read_text(encoding="utf-8"))
    assert n <= LIMIT, (
        f"{page.relative_to(ROOT)} holds {n} characters (limit {LIMIT}): split it or move its measurements to docs/benchmarks/"
    )


def test_the_readme_is_short() -> None:
    n = len((ROOT / "README.md").read_text(encoding="utf-8"))
    assert n <= LIMIT, f"README.md holds {n} characters (limit {LIMIT})"
