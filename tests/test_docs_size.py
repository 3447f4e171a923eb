"""The user guide stays readable: no user page of the documentation, and not the README, over
12,000 characters (issue 41). Results belong on the benchmark pages (docs/benchmarks/), the history
in CHANGELOG.md, the docstrings on the API pages (docs/api/); a page that grows past the limit is
split or moved there."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LIMIT = 12_000

#: Pages generated from a test's table rather than written: docs/reliability.md is rendered from
#: the cases of tests/test_reliability.py, one row per case, and grows with them.
GENERATED = {"reliability.md"}

USER_PAGES = sorted(p for p in (ROOT / "docs").glob("*.md") if p.name not in GENERATED)


def test_there_are_user_pages() -> None:
    assert len(USER_PAGES) > 20
    assert ROOT / "docs" / "tutorial.md" in USER_PAGES


@pytest.mark.parametrize("page", USER_PAGES, ids=lambda p: p.name)
def test_a_user_page_is_short(page: Path) -> None:
    n = len(page.read_text(encoding="utf-8"))
    assert n <= LIMIT, (
        f"docs/{page.name} holds {n} characters (limit {LIMIT}): split it or move its measurements to docs/benchmarks/"
    )


def test_the_readme_is_short() -> None:
    n = len((ROOT / "README.md").read_text(encoding="utf-8"))
    assert n <= LIMIT, f"README.md holds {n} characters (limit {LIMIT})"
