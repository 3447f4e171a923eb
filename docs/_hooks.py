"""MkDocs hook (mkdocs.yml ``hooks``): Sphinx roles in the docstrings shown as plain code.

The docstrings are numpydoc written for Sphinx: ``:class:`~neckid.IOData```, ``:func:`.arx```.
Markdown has no roles, so the API pages would show ``:class:`` before every name. This hook adds a
Markdown preprocessor that keeps only the code span (``~`` keeps the last component, as in Sphinx).
It changes how the docstrings are displayed, not the docstrings.
"""

from __future__ import annotations

import re
from typing import Any

from markdown import Extension, Markdown
from markdown.preprocessors import Preprocessor

ROLE = re.compile(
    r":(?:py:)?(?:class|func|meth|mod|data|attr|obj|exc|const|term|ref|math):`(~?)([^`]+)`"
)


def _code(match: re.Match[str]) -> str:
    tilde, target = match.groups()
    return f"`{target.rsplit('.', 1)[-1] if tilde else target}`"


class _Roles(Preprocessor):
    def run(self, lines: list[str]) -> list[str]:
        return [ROLE.sub(_code, line) for line in lines]


class SphinxRoles(Extension):
    """Replace ``:role:`target``` by ```target``` before Markdown parses a page or a docstring."""

    def extendMarkdown(self, md: Markdown) -> None:
        """Register the preprocessor ahead of the others."""
        md.preprocessors.register(_Roles(md), "sphinx_roles", 40)


def on_config(config: Any) -> Any:
    """Add the extension to the site's Markdown (mkdocstrings renders docstrings with it too)."""
    config.markdown_extensions.append(SphinxRoles())
    return config
