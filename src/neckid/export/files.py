r"""Writers of a model description: JSON, a MATLAB ``.mat`` file, a MATLAB script of a linear model.

* ``json``: :func:`json_text` of :func:`~neckid.export.export_model`'s description (strict
  JSON: arrays as nested lists, a non-finite number as ``null``, as MATLAB's ``jsonencode``
  writes it).
* ``mat``: one variable ``model``, a struct with the description's keys as its fields
  (:func:`matlab_struct`, written by :func:`scipy.io.savemat`): numbers as ``double``
  matrices, booleans as ``logical``, text as ``char``, a list as a cell array (a list of
  equal-length lists as a 2-D cell array, e.g. ``num{o, j}``), ``None`` as ``[]``.
* ``tf``: :func:`matlab_script`, a script MATLAB (or GNU Octave with ``pkg load control``)
  runs to build ``G = tf(num, den, Ts)`` and, for an ARX, the ``idpoly`` model, for a state
  space the ``ss`` model. Only for a linear model.

:func:`write_export` writes any of them atomically (:func:`neckid.utils.files.atomic_path`).
"""

from __future__ import annotations

import json
import math
import re
import unicodedata
from pathlib import Path
from typing import Any, Literal

import numpy as np

from neckid.export.describe import LINEAR_CLASSES, export_model
from neckid.export.matlab_preprocess import preprocessing_lines

__all__ = [
    "EXPORT_SUFFIXES",
    "MATLAB_FIELD_LENGTH",
    "ExportFormat",
    "json_text",
    "matlab_script",
    "matlab_struct",
    "write_export",
]

ExportFormat = Literal["json", "mat", "tf"]

#: The file extension of each export format.
EXPORT_SUFFIXES: dict[str, str] = {"json": ".json", "mat": ".mat", "tf": ".m"}

#: Longest field name written: MATLAB reads 63 characters since R2006a (``namelengthmax``),
#: older releases and ``scipy.io.savemat``'s default 31.
MATLAB_FIELD_LENGTH = 31

_MATLAB_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")

#: MATLAB's reserved words (``iskeyword``): not usable as field or variable names.
_MATLAB_KEYWORDS = frozenset(
    [
        "break",
        "case",
        "catch",
        "classdef",
        "continue",
        "else",
        "elseif",
        "end",
        "for",
        "function",
        "global",
        "if",
        "otherwise",
        "parfor",
        "persistent",
        "return",
        "spmd",
        "switch",
        "try",
        "while",
    ]
)


# ============================================================================ JSON
def _plain(value: Any) -> Any:
    """``value`` with arrays as nested lists, NumPy scalars as Python's, non-finite as None."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _render(value: Any, level: int) -> str:
    """JSON text: objects and lists of lists one item per line, lists of numbers on one line."""
    pad, close = "  " * (level + 1), "  " * level
    if isinstance(value, dict) and value:
        items = [f"{pad}{json.dumps(k)}: {_render(v, level + 1)}" for k, v in value.items()]
        return "{\n" + ",\n".join(items) + "\n" + close + "}"
    if isinstance(value, list) and any(isinstance(v, dict | list) for v in value):
        items = [pad + _render(v, level + 1) for v in value]
        return "[\n" + ",\n".join(items) + "\n" + close + "]"
    return json.dumps(value, allow_nan=False, ensure_ascii=False)


def json_text(description: dict[str, Any]) -> str:
    """The description as strict JSON text (arrays as nested lists; NaN and ±Inf as ``null``).

    ``json.loads`` (or MATLAB's ``jsondecode``) reads it back; a ``null`` inside a numeric
    array is NaN for ``jsondecode``. The ``.mat`` export keeps NaN and ±Inf as they are.

    Examples
    --------
    >>> import numpy as np
    >>> print(json_text({"ts": 0.02, "gamma_star": np.array([np.nan, 1.5])}))
    {
      "ts": 0.02,
      "gamma_star": [null, 1.5]
    }
    """
    return _render(_plain(description), 0) + "\n"


# ============================================================================ MAT
def _check_field(key: Any, where: str) -> str:
    if (
        not isinstance(key, str)
        or not _MATLAB_NAME.fullmatch(key)
        or len(key) > MATLAB_FIELD_LENGTH
        or key in _MATLAB_KEYWORDS
    ):
        raise ValueError(
            f"{where}: {key!r} is not a MATLAB field name (a letter, then letters, digits or"
            f" underscores, at most {MATLAB_FIELD_LENGTH} characters, not a keyword)"
        )
    return key


def _cells(items: list[Any], shape: tuple[int, ...]) -> Any:
    cells = np.empty(shape, dtype=object)
    for index, item in zip(np.ndindex(*shape), items, strict=True):
        cells[index] = item
    return cells


def _is_table(value: list[Any]) -> bool:
    """A non-empty list of equal-length lists of non-lists: a 2-D cell array."""
    return (
        bool(value)
        and all(isinstance(row, list) and row for row in value)
        and len({len(row) for row in value}) == 1
        and not any(isinstance(item, list) for row in value for item in row)
    )


def _matlab_value(value: Any, where: str) -> Any:
    """One value of the description as :func:`scipy.io.savemat` writes it for MATLAB."""
    if isinstance(value, dict):
        return {_check_field(k, where): _matlab_value(v, f"{where}.{k}") for k, v in value.items()}
    if value is None:
        return np.zeros((0, 0))
    if isinstance(value, np.ndarray):
        return value.astype(bool) if value.dtype == np.bool_ else value.astype(np.float64)
    if isinstance(value, list | tuple):
        value = list(value)
        if _is_table(value):
            flat = [
                _matlab_value(item, f"{where}{{{i + 1},{j + 1}}}")
                for i, row in enumerate(value)
                for j, item in enumerate(row)
            ]
            return _cells(flat, (len(value), len(value[0])))
        items = [_matlab_value(item, f"{where}{{{i + 1}}}") for i, item in enumerate(value)]
        return _cells(items, (1, len(items)) if items else (0, 0))
    if isinstance(value, bool | np.bool_):
        return np.bool_(value)
    if isinstance(value, int | float | np.number):
        return float(value)
    if isinstance(value, str):
        if not value.isascii():
            # scipy writes the UTF-8 bytes with the length in characters: MATLAB reads it cut.
            raise ValueError(
                f"{where} is {value!r}, which holds non-ASCII characters: a .mat file written"
                " here would be read back cut short by MATLAB; export --to json keeps the text"
                " (UTF-8), or rename the channel in ASCII (--map) and identify the model again"
            )
        return value
    raise TypeError(f"{where}: a {type(value).__name__} cannot be written to a .mat file")


def matlab_struct(description: dict[str, Any]) -> dict[str, Any]:
    """The description as :func:`scipy.io.savemat` writes it into the struct ``model``.

    Numbers become ``double`` (an ``int`` too: MATLAB's default class), boolean arrays
    ``logical``, a list a cell array (``1 × n``; a list of equal-length lists ``n × m``, as
    ``tf`` and ``idpoly`` take ``num{o, j}`` and ``A{o, c}``), ``None`` the empty ``[]``.

    Raises
    ------
    ValueError
        If a key is not a MATLAB field name (at most :data:`MATLAB_FIELD_LENGTH` characters).
    """
    return {
        _check_field(k, "model"): _matlab_value(v, f"model.{k}") for k, v in description.items()
    }


# ============================================================================ MATLAB script
def _number(value: float) -> str:
    if math.isnan(value):
        return "NaN"
    if math.isinf(value):
        return "Inf" if value > 0 else "-Inf"
    return repr(float(value))  # the shortest text that reads back as the same double


def _matrix(values: Any) -> str:
    """A MATLAB literal of a vector (a row) or matrix, exact to the last bit."""
    array = np.atleast_1d(np.asarray(values, dtype=np.float64))
    if array.ndim == 1:
        return "[" + " ".join(_number(v) for v in array) + "]"
    rows, columns = array.shape
    if rows == 0 or columns == 0:
        return f"zeros({rows}, {columns})"
    if rows == 1:
        return _matrix(array[0])
    lines = ["  " + " ".join(_number(v) for v in row) for row in array]
    return "[\n" + "\n".join(lines) + "\n]"


def _text(value: str) -> str:
    """A MATLAB char literal; a control character (a line break would end the statement) refused."""
    bad = [c for c in value if unicodedata.category(c) in ("Cc", "Cf", "Zl", "Zp")]
    if bad:
        raise ValueError(
            f"the name {value!r} holds the control character {bad[0]!r}: a MATLAB script cannot"
            " hold it in a name; rename the channel (--map) and identify the model again"
        )
    return "'" + value.replace("'", "''") + "'"


def _names(values: list[str]) -> str:
    return "{" + ", ".join(_text(v) for v in values) + "}"


def _cell_lines(name: str, table: list[list[Any]]) -> list[str]:
    """``name`` as a row vector (one entry) or an ``n × m`` cell array of row vectors."""
    if len(table) == 1 and len(table[0]) == 1:
        return [f"{name} = {_matrix(table[0][0])};"]
    lines = [f"{name} = cell({len(table)}, {len(table[0])});"]
    for o, row in enumerate(table):
        lines.extend(f"{name}{{{o + 1}, {j + 1}}} = {_matrix(v)};" for j, v in enumerate(row))
    return lines


def _refuse_nonlinear(description: dict[str, Any]) -> None:
    if description["linear"]:
        return
    what = description["label"] or description["model_class"]
    hint = (
        " (a GainScheduledModel is linear only frozen at one inclination:"
        " neckid.export.control.to_control(model, inclination=...))"
        if description["structure"] == "gain_scheduled"
        else ""
    )
    raise TypeError(
        f"a transfer function exists for linear models only ({', '.join(LINEAR_CLASSES)}; methods"
        f" arx, rls, ss); {what} ({description['model_class']}) is nonlinear{hint}: export it"
        " with --to json or --to mat"
    )


def matlab_script(model: Any, *, without_preprocessing: bool = False) -> str:
    """A MATLAB / GNU Octave script that builds a linear model's transfer function and model.

    The script defines ``Ts`` [s], ``input_names``, ``output_names``, ``output_units``,
    ``num`` and ``den`` (``G{o, j}(z) = num{o, j} / den{o, j}``, descending powers of ``z``;
    plain row vectors for one input and one output), ``y0`` (the output offset,
    ``y(t) = y0 + G(q) u(t)``) and ``G = tf(num, den, Ts, ...)``. An ARX adds its ``idpoly``
    polynomials ``A`` and ``B`` (powers of ``q^-1``) and ``sys = idpoly(A, B, [], [], [], [],
    Ts)`` where the System Identification Toolbox is installed; a state-space model adds
    ``A``, ``B``, ``C``, ``D``, ``K`` and ``sys = ss(A, B, C, D, Ts)``. Numbers are written
    exactly (the shortest decimal that reads back as the same double).

    A model identified on preprocessed logs carries its ``relative`` and ``offset`` steps into
    the script as code, applied to ``U`` and ``Y`` when they are in the workspace
    (:func:`neckid.export.matlab_preprocess.preprocessing_lines`); any other step is refused
    unless ``without_preprocessing`` (then the header says which steps are not applied).

    Raises
    ------
    TypeError
        If the model is not linear (the message says which export works instead).
    ValueError
        If a preprocessing step cannot be written as MATLAB code and ``without_preprocessing``
        is False.
    """
    description = export_model(model)
    _refuse_nonlinear(description)
    preprocessing = preprocessing_lines(model, without=without_preprocessing)
    tf = description["transfer_function"]
    parameters = description["parameters"]
    labels = "'InputName', input_names, 'OutputName', output_names"
    lines = [
        f"% {description['label'] or description['model_class']} ({description['model_class']},"
        f" method {description['method']!s}) exported by neckid {description['neckid_version']}.",
        "% Runs in MATLAB (Control System Toolbox; idpoly needs the System Identification",
        "% Toolbox) and in GNU Octave after `pkg load control`.",
        "% G{o, j}(z) = num{o, j} / den{o, j}, descending powers of z; y(t) = y0 + G(q) u(t).",
        f"Ts = {_number(description['ts'])};  % sampling period [s]",
        f"input_names = {_names(description['input_names'])};",
        f"output_names = {_names(description['output_names'])};",
        f"output_units = {_names(description['output_units'])};",
        *preprocessing,
        *_cell_lines("num", tf["num"]),
        *_cell_lines("den", tf["den"]),
        f"y0 = {_matrix(tf['output_offset'])};  % output offset, one column per output",
        f"G = tf(num, den, Ts, {labels});",
    ]
    if description["structure"] == "arx":
        lines += [
            "% ARX polynomials as idpoly takes them: A(q) y(t) = B(q) u(t), powers of q^-1.",
            *_cell_lines("A", parameters["A"]),
            *_cell_lines("B", parameters["B"]),
            "if exist('idpoly')",
            f"  sys = idpoly(A, B, [], [], [], [], Ts, {labels});",
            "end",
        ]
    else:
        lines += [
            "% x(t+1) = A x(t) + B u(t) + K e(t); y(t) = C x(t) + D u(t) + y0 + e(t).",
            *(f"{key} = {_matrix(parameters[key])};" for key in ("A", "B", "C", "D", "K")),
            f"sys = ss(A, B, C, D, Ts, {labels});",
        ]
    return "\n".join(lines) + "\n"


def _check_script_name(path: Path) -> None:
    stem = path.stem
    if not (_MATLAB_NAME.fullmatch(stem) and len(stem) <= 63):
        suggestion = re.sub(r"\W", "_", stem)
        suggestion = suggestion if suggestion[:1].isalpha() else "model_" + suggestion
        raise ValueError(
            f"MATLAB runs a script by its name, which must start with a letter and hold only"
            f" letters, digits and underscores (at most 63); got {path.name!r}: choose e.g."
            f" {suggestion[:63] + '.m'!r}"
        )


def write_export(
    model: Any, path: str | Path, *, to: ExportFormat = "json", without_preprocessing: bool = False
) -> Path:
    """Write a fitted model's description to ``path`` as JSON, a ``.mat`` file or a MATLAB script.

    Parameters
    ----------
    model : fitted estimator
        Any model of :func:`neckid.methods`; ``to="tf"`` needs a linear one (arx, rls, ss).
    path : str or Path
        The file; its extension must be the format's (:data:`EXPORT_SUFFIXES`: ``.json``,
        ``.mat``, ``.m``). Written atomically: whole or not at all.
    to : {"json", "mat", "tf"}, default "json"
        :func:`json_text`, the struct ``model`` of :func:`matlab_struct` (``load(path)``
        in MATLAB), or :func:`matlab_script`.
    without_preprocessing : bool, default False
        ``to="tf"``: write the script even if a preprocessing step of the model cannot be
        written into it (see :func:`matlab_script`).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        An unknown ``to``, an extension that is not the format's, a script name MATLAB cannot
        run (``to="tf"``).
    TypeError
        ``to="tf"`` with a nonlinear model.
    """
    from neckid.utils.files import atomic_path

    if to not in EXPORT_SUFFIXES:
        raise ValueError(f"to must be one of {list(EXPORT_SUFFIXES)}; got {to!r}")
    target = Path(path)
    suffix = EXPORT_SUFFIXES[to]
    if target.suffix.lower() != suffix:
        raise ValueError(
            f"a {to} export is written as {suffix}: the file name must end in {suffix}; got"
            f" {target.name!r}"
        )
    if to == "tf":
        # a nonlinear model is refused before the name is judged
        text = matlab_script(model, without_preprocessing=without_preprocessing)
        _check_script_name(target)
        with atomic_path(target) as temporary:
            temporary.write_text(text, encoding="utf-8")
        return target
    description = export_model(model)
    if to == "json":
        text = json_text(description)
        with atomic_path(target) as temporary:
            temporary.write_text(text, encoding="utf-8")
        return target
    from scipy.io import savemat

    struct = matlab_struct(description)
    with atomic_path(target) as temporary, temporary.open("wb") as handle:
        savemat(handle, {"model": struct}, do_compression=True, oned_as="row")
    return target
