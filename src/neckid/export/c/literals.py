"""C99 text of numbers, arrays and names: every double exact, every name a valid identifier.

A float is written as a C99 hexadecimal floating constant (:meth:`float.hex`: ``0x1.8p+1`` is
3.0), which a C compiler reads back to the same 64 bits, so the constants of the generated code
are the model's own and its arithmetic can match the Python's to the last bit. Infinities and
NaN are ``HUGE_VAL``, ``-HUGE_VAL`` and ``NAN`` of ``<math.h>``.
"""

from __future__ import annotations

import keyword
import math
import re
from collections.abc import Iterable
from typing import Any

import numpy as np

__all__ = ["c_array", "c_double", "c_identifier", "c_int_array", "comment_text"]

#: Numbers per line in an array initialiser.
PER_LINE = 4

_C_KEYWORDS = frozenset(
    [
        "auto",
        "break",
        "case",
        "char",
        "const",
        "continue",
        "default",
        "do",
        "double",
        "else",
        "enum",
        "extern",
        "float",
        "for",
        "goto",
        "if",
        "inline",
        "int",
        "long",
        "register",
        "restrict",
        "return",
        "short",
        "signed",
        "sizeof",
        "static",
        "struct",
        "switch",
        "typedef",
        "union",
        "unsigned",
        "void",
        "volatile",
        "while",
        "class",
        "namespace",
        "template",
    ]
)


def c_double(value: Any) -> str:
    """A double as an exact C99 literal.

    Examples
    --------
    >>> c_double(3.0), c_double(-0.1), c_double(float("inf")), c_double(float("nan"))
    ('0x1.8000000000000p+1', '-0x1.999999999999ap-4', 'HUGE_VAL', 'NAN')
    >>> float.fromhex(c_double(0.1)) == 0.1
    True
    """
    number = float(value)
    if math.isnan(number):
        return "NAN"
    if math.isinf(number):
        return "HUGE_VAL" if number > 0 else "(-HUGE_VAL)"
    return number.hex()


def _rows(items: list[str], indent: str) -> str:
    lines = [indent + ", ".join(items[k : k + PER_LINE]) for k in range(0, len(items), PER_LINE)]
    return ",\n".join(lines)


def _initialiser(array: Any, kind: str, indent: str) -> str:
    """The braces' content of ``array`` (nested braces for each dimension beyond the first)."""
    if array.ndim <= 1:
        flat = array.reshape(-1)
        items = [c_double(v) if kind == "double" else str(int(v)) for v in flat]
        return _rows(items or ["0"], indent)
    if array.shape[0] == 0:
        return indent + "{0}"
    inner = indent + "    "
    rows = [f"{indent}{{\n{_initialiser(row, kind, inner)}\n{indent}}}" for row in array]
    return ",\n".join(rows)


def c_array(name: str, values: Any, *, kind: str = "double") -> str:
    """``static const double name[...] = {...};`` of an array of any shape (C order), exact.

    An empty dimension is written as one element (0), a C array having at least one; its users
    never read it (the sizes say so).

    Examples
    --------
    >>> print(c_array("gain", [[1.0, 2.0]]))
    static const double gain[1][2] = {
        {
            0x1.0000000000000p+0, 0x1.0000000000000p+1
        }
    };
    """
    array = np.asarray(values, dtype=np.float64 if kind == "double" else np.int64)
    dims = "".join(f"[{max(int(d), 1)}]" for d in array.shape) or "[1]"
    body = _initialiser(array.reshape(1) if array.ndim == 0 else array, kind, "    ")
    return f"static const {kind} {name}{dims} = {{\n{body}\n}};"


def c_int_array(name: str, values: Any) -> str:
    """:func:`c_array` of whole numbers (``static const long``)."""
    return c_array(name, values, kind="long")


def c_identifier(text: str) -> str:
    """A valid C identifier made of ``text`` (other characters become ``_``).

    Examples
    --------
    >>> c_identifier("my-model.v2"), c_identifier("2nd"), c_identifier("int")
    ('my_model_v2', 'm_2nd', 'int_')
    """
    name = re.sub(r"[^A-Za-z0-9_]", "_", text) or "model"
    if name[0].isdigit():
        name = "m_" + name
    if name in _C_KEYWORDS or keyword.iskeyword(name):
        name += "_"
    return name


def comment_text(lines: Iterable[str], indent: str = "") -> str:
    """Lines as one C block comment (``*/`` inside a line is broken up)."""
    body = [f"{indent} * {line}".rstrip().replace("*/", "* /") for line in lines]
    return "\n".join([f"{indent}/*", *body, f"{indent} */"])
