"""The package's layout: no import cycles, layers that only look down, modules of a readable size.

Imports are read from the source with :mod:`ast`: every ``import`` statement, inside functions
and under ``if TYPE_CHECKING:`` too, so neither a lazy nor a type-only import can hide a cycle.
Importing ``a.b.c`` runs the ``__init__`` of ``a.b`` first, so it counts as importing that package
too. Model families (``neckid.models.<family>``) keep their private names to themselves.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "neckid"

#: Lines of code (docstrings, comments and blank lines excluded) a module may have.
MAX_CODE_LINES = 500

#: Lines of code (docstring, comments and blank lines excluded) a function or method may have.
MAX_FUNCTION_LINES = 80

#: What a layer must never import.
FORBIDDEN = {
    "neckid.data": (
        "neckid.models",
        "neckid.loops",
        "neckid.experiments",
        "neckid.report",
        "neckid.cli",
        "neckid.plant",
    ),
    "neckid.models": (
        "neckid.loops",
        "neckid.experiments",
        "neckid.report",
        "neckid.cli",
        "neckid.plant",
    ),
    "neckid.plant": (
        "neckid.loops",
        "neckid.experiments",
        "neckid.report",
        "neckid.cli",
        "neckid.models",
    ),
    "neckid.loops": ("neckid.experiments", "neckid.report", "neckid.cli"),
    "neckid.design": ("neckid.experiments", "neckid.report", "neckid.cli"),
    "neckid.report": ("neckid.experiments", "neckid.cli"),
    "neckid.experiments": ("neckid.cli",),
    "neckid.selection": (
        "neckid.loops",
        "neckid.design",
        "neckid.experiments",
        "neckid.report",
        "neckid.cli",
    ),
    "neckid.export": (
        "neckid.loops",
        "neckid.design",
        "neckid.experiments",
        "neckid.report",
        "neckid.cli",
    ),
    "neckid.frequency": (
        "neckid.plant",
        "neckid.loops",
        "neckid.design",
        "neckid.selection",
        "neckid.experiments",
        "neckid.report",
        "neckid.cli",
    ),
}

#: The model families: each a subpackage of neckid.models with its private names.
FAMILIES = (
    "greybox",
    "koopman",
    "linear",
    "lpv",
    "neural",
    "pnlss",
    "polynomial",
    "scheduled",
    "set_membership",
    "sindy",
)

#: The only modules directly under src/neckid/: the vocabulary a user imports (issue 41).
TOP_LEVEL = {"__init__", "_version", "metrics", "registry", "regressors", "systems"}
MAX_TOP_LEVEL = 7


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = _module_name(path)
    if path.name != "__init__.py":
        package = package.rpartition(".")[0]
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.startswith("neckid"))
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            if base.startswith("neckid"):
                found.add(base)
                # `from neckid.models import io` imports the submodule neckid.models.io
                for alias in node.names:
                    candidate = f"{base}.{alias.name}"
                    if (PACKAGE.parent / Path(*candidate.split("."))).with_suffix(".py").exists():
                        found.add(candidate)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return found


def _graph() -> dict[str, set[str]]:
    modules = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        targets = set()
        for imported in _imports(path):
            parts = imported.split(".")
            # Importing a.b.c runs a.b's __init__ first, unless a.b is the importer's own package
            # (already being imported when the importer runs).
            for end in range(2, len(parts) + 1):
                candidate = ".".join(parts[:end])
                if candidate in modules and not name.startswith(candidate + "."):
                    targets.add(candidate)
        # A submodule importing its own package's names is the package's business: keep edges to
        # modules other than oneself.
        graph[name] = targets - {name}
    return graph


def _imported_names(path: Path) -> list[tuple[str, str]]:
    """``(module, name)`` for every ``from module import name`` in the file (name '' for ``import``)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = _module_name(path)
    if path.name != "__init__.py":
        package = package.rpartition(".")[0]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.extend((a.name, "") for a in node.names if a.name.startswith("neckid"))
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            if base.startswith("neckid"):
                found.extend((base, alias.name) for alias in node.names)
    return found


def _is_module(dotted: str) -> bool:
    path = PACKAGE.parent / Path(*dotted.split("."))
    return path.with_suffix(".py").exists() or (path / "__init__.py").exists()


def _private_offences(importer: str, module: str, name: str) -> list[str]:
    """The private parts of ``module.name`` that ``importer`` reaches from outside their owner."""
    parts = [*module.split("."), *([name] if name and name != "*" else [])]
    offences = []
    for index, part in enumerate(parts):
        # A private module belongs to its package; a private name in a module belongs to the
        # module's package (its siblings may share it).
        is_name = bool(name) and index == len(parts) - 1 and not _is_module(".".join(parts))
        owner = ".".join(parts[: index - 1] if is_name else parts[:index])
        private = part.startswith("_") and not part.startswith("__")
        if private and owner and not (importer == owner or importer.startswith(owner + ".")):
            offences.append(f"{importer} imports {'.'.join(parts[: index + 1])}")
    return offences


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []
    counter = [0]

    def connect(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            connect(v)
    return components


def test_the_import_walker_sees_lazy_and_type_only_imports() -> None:
    graph = _graph()
    # workflow imports the registry inside a function only.
    assert "neckid.registry" in graph["neckid.cli.workflow"]
    # the sidecar reader imports IOData under TYPE_CHECKING only.
    assert "neckid.data.iodata" in graph["neckid.data.sidecar"]
    # importing a family's module runs the family's __init__ (from outside the family).
    assert "neckid.models.scheduled" in graph["neckid.export.control"]
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycles() -> None:
    graph = _graph()
    # The package __init__ re-exports everything (lazily); leave it out, as every module
    # "imports" it by being inside it.
    inner = {k: v - {"neckid"} for k, v in graph.items() if k != "neckid"}
    assert _cycles(inner) == []


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_layers_only_look_down(layer: str) -> None:
    graph = _graph()
    offences = [
        f"{module} imports {target}"
        for module, targets in graph.items()
        if module == layer or module.startswith(layer + ".")
        for target in sorted(targets)
        if target.startswith(FORBIDDEN[layer])
    ]
    assert offences == []


def _code_lines(path: Path) -> int:
    source = path.read_text(encoding="utf-8")
    docstrings: set[int] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if (
                body
                and isinstance(body[0], ast.Expr)
                and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)
            ):
                end = body[0].end_lineno or body[0].lineno
                docstrings.update(range(body[0].lineno, end + 1))
    return sum(
        1
        for number, line in enumerate(source.splitlines(), start=1)
        if line.strip() and not line.strip().startswith("#") and number not in docstrings
    )


def test_no_module_is_a_god_module() -> None:
    sizes = {_module_name(p): _code_lines(p) for p in PACKAGE.rglob("*.py")}
    assert {k: v for k, v in sizes.items() if v > MAX_CODE_LINES} == {}


def _has_docstring(body: list[ast.stmt]) -> bool:
    return (
        bool(body)
        and isinstance(body[0], ast.Expr)
        and isinstance(body[0].value, ast.Constant)
        and isinstance(body[0].value.value, str)
    )


def _function_sizes(source: str) -> dict[str, int]:
    """Lines of code of every function and method, by ``name:line``: from the first statement
    after the docstring to the function's last line, blank and comment-only lines excluded
    (a nested function counts in its parent too)."""
    lines = source.splitlines()
    sizes: dict[str, int] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = f"{prefix}{child.name}"
                body = child.body[1:] if _has_docstring(child.body) else child.body
                if body:
                    sizes[f"{name}:{child.lineno}"] = sum(
                        1
                        for line in lines[body[0].lineno - 1 : child.end_lineno]
                        if line.strip() and not line.strip().startswith("#")
                    )
                visit(child, f"{name}.")
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.")
            else:
                visit(child, prefix)

    visit(ast.parse(source), "")
    return sizes


def test_the_function_size_counts_code_lines_only() -> None:
    source = '''
def f(x):
    """A docstring.

    Over lines.
    """
    # a comment

    y = x + 1


    return (
        y
    )


class C:
    def m(self):
        def inner():
            return 1
        return inner()
'''
    assert _function_sizes(source) == {"f:2": 4, "C.m:18": 3, "C.m.inner:19": 1}


def test_no_function_is_a_god_function() -> None:
    """Split, don't compress: no function or method over ``MAX_FUNCTION_LINES`` lines of code."""
    offenders = {
        f"{_module_name(p)}.{name}": size
        for p in sorted(PACKAGE.rglob("*.py"))
        for name, size in _function_sizes(p.read_text(encoding="utf-8")).items()
        if size > MAX_FUNCTION_LINES
    }
    assert offenders == {}, f"functions over {MAX_FUNCTION_LINES} lines of code: {offenders}"


def test_private_names_stay_in_their_family() -> None:
    """``_name`` (a module or a name in one) is imported only from inside the package that owns it."""
    offences = [
        offence
        for path in PACKAGE.rglob("*.py")
        for module, name in _imported_names(path)
        for offence in _private_offences(_module_name(path), module, name)
    ]
    assert offences == []
    assert _private_offences(
        "neckid.models.polynomial.narx", "neckid.models.set_membership.prior", "_digest"
    )
    assert not _private_offences(
        "neckid.models.set_membership.narx", "neckid.models.set_membership._kernels", "SMTree"
    )


def test_every_family_is_a_subpackage() -> None:
    models = PACKAGE / "models"
    for family in FAMILIES:
        assert (models / family / "__init__.py").exists(), family
    found = {p.name for p in models.iterdir() if (p / "__init__.py").exists()}
    assert found == set(FAMILIES), found


def test_the_top_level_holds_vocabulary_only() -> None:
    """At most ``MAX_TOP_LEVEL`` modules directly under ``src/neckid/`` (the rest in packages)."""
    modules = {p.stem for p in PACKAGE.glob("*.py")}
    assert len(modules) <= MAX_TOP_LEVEL
    assert modules == TOP_LEVEL


def test_utils_imports_nothing_of_neckid() -> None:
    graph = _graph()
    offences = {
        m: sorted(t for t in targets if not t.startswith("neckid.utils"))
        for m, targets in graph.items()
        if m.startswith("neckid.utils")
    }
    assert {m: t for m, t in offences.items() if t} == {}


def test_no_alias_modules() -> None:
    """0.1.0 was never released: no module re-exports another one's names under an old path."""
    aliases = [
        _module_name(p)
        for p in PACKAGE.rglob("*.py")
        if "DeprecationWarning" in p.read_text(encoding="utf-8")
        and "moved to" in p.read_text(encoding="utf-8").lower()
    ]
    assert aliases == []


def test_array_aliases_are_defined_once() -> None:
    defined = [
        _module_name(p)
        for p in PACKAGE.rglob("*.py")
        for node in ast.parse(p.read_text(encoding="utf-8")).body
        if isinstance(node, ast.Assign | ast.AnnAssign)
        for target in (node.targets if isinstance(node, ast.Assign) else [node.target])
        if isinstance(target, ast.Name) and target.id in {"FloatArray", "IntArray", "BoolArray"}
    ]
    assert sorted(set(defined)) == ["neckid.utils.types"]


def test_formatting_exceptions_are_rare() -> None:
    """``# fmt: skip`` is for genuine tables only, not for squeezing a module under the cap."""
    skips = {
        _module_name(p): p.read_text(encoding="utf-8").count("# fmt: skip")
        for p in PACKAGE.rglob("*.py")
    }
    assert sum(skips.values()) <= 5, {k: v for k, v in skips.items() if v}
