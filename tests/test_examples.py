"""The experiment scripts of docs/examples import, say how to run them, and answer --help.

The experiments themselves need the real logs and minutes each: they are not run here.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "docs" / "examples").glob("*.py"))
PAGE = ROOT / "docs" / "examples.md"


def load(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"neckid_example_{path.stem}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_there_are_examples() -> None:
    assert len(EXAMPLES) >= 12


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_imports_and_answers_help(path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    module = load(path)
    doc = module.__doc__ or ""
    assert f"docs/examples/{path.name}" in doc, "the docstring says how to run it"
    assert callable(getattr(module, "main", None))
    with pytest.raises(SystemExit) as exit_info:
        module.main(["--help"])
    assert exit_info.value.code == 0
    assert "usage:" in capsys.readouterr().out


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_has_no_machine_paths(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    assert '__name__ == "__main__"' in text
    assert not re.search(r"/work/|shared/data|parents\[2\]|sys\.path", text)


def test_examples_page_lists_every_example() -> None:
    page = PAGE.read_text(encoding="utf-8")
    for path in EXAMPLES:
        assert f"docs/examples/{path.name}" in page, path.name
