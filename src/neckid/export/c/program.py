"""A model or controller as one C99 header and one source: the parts a family gives, assembled.

A family's exporter (the ``"module:function"`` of its registry entry's
:attr:`~neckid.registry.Method.c_export`) returns a :class:`CModel`: the state's fields with
what each one holds, the constants, the bodies of ``reset`` and ``step``. :func:`render` writes
around them the interface every export shares, so a user's code calls every model the same way:

``NAME_init(&s)``
    the state at rest (``reset`` with no history);
``NAME_reset(&s, y0, u0)``
    the state from ``NAME_RESET_ROWS`` past outputs and inputs (rows oldest first, row-major;
    ``NULL`` for zeros), as the model's ``simulator().reset(y0, u0)``;
``NAME_step(&s, u, y)``
    one sample: the inputs ``u[NAME_N_INPUTS]`` of sample ``t`` in, the outputs
    ``y[NAME_N_OUTPUTS]`` of sample ``t`` out, as ``simulator().step(u)``;
``NAME_step_bounds(&s, u, y, lower, upper)``
    (Set Membership) the same with the band of the step;
``NAME_preprocess(n, u, y)``
    the model's preprocessing applied to a whole log in place (what ``identify`` did to the
    training logs), before the log's samples are stepped.

A controller has ``NAME_init``/``NAME_reset(&s)`` and ``double NAME_step(&s, reference,
measurement)``. Every ``NAME_`` in a family's text is replaced by the export's name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from neckid._version import __version__
from neckid.export.c.literals import c_double, comment_text

__all__ = ["CModel", "render"]


@dataclass
class CModel:
    """What a family's exporter gives: the state, constants and function bodies in C.

    Attributes
    ----------
    title : str
        One line: what the model is (class, method, structure).
    notes : list of str
        The header's description: the equations stepped, the state, the units, the initial rows.
    state : list of (str, str)
        The state's fields: a C declaration (``"double x[3]"``) and what it holds.
    constants : str
        ``static const`` definitions and static helper functions (source file only).
    reset : str
        Body of ``void NAME_reset(NAME_state *s, const double *y0, const double *u0)``
        (controllers: of ``void NAME_reset(NAME_state *s)``).
    step : str
        Body of ``NAME_step_bounds`` when ``bounded``, else of ``NAME_step`` (controllers: of
        ``double NAME_step(NAME_state *s, double reference, double measurement)``).
    n_inputs, n_outputs, reset_rows : int
        Sizes of ``u``, ``y`` and of the history ``reset`` takes.
    types : str
        C type definitions the state needs (the parts' states of a composed model), in the header.
    includes, extra_api, extra_source
        Headers the source includes (``'"osqp.h"'``), more declarations for the header and their
        definitions for the source.
    companion : callable, optional
        ``companion(folder, name) -> files``: writes the files the source needs beside it (the
        solver code OSQP generates for a predictive controller), in ``companion_folder``
        (``NAME_`` replaced by the export's name), which must not exist without ``force``.
    initial_rows : int
        The samples ``simulate`` takes as initial conditions (its ``max_lag_``): a log's first
        ``initial_rows`` rows go to ``reset`` (none: ``init``), the others are stepped.
    ts : float
        The sampling period [s].
    bounded : bool
        Whether the model gives a band (``NAME_step_bounds``).
    controller : bool
        A controller: ``step(reference, measurement) -> command``.
    preprocess : str
        Body of ``int NAME_preprocess(size_t n, double *u, double *y)`` (return 0; -1 when a
        step cannot be applied to the log).
    """

    title: str
    notes: list[str]
    state: list[tuple[str, str]]
    constants: str
    reset: str
    step: str
    n_inputs: int
    n_outputs: int
    reset_rows: int
    ts: float
    bounded: bool = False
    controller: bool = False
    initial_rows: int = 0
    types: str = ""
    includes: list[str] = field(default_factory=list)
    extra_api: list[str] = field(default_factory=list)
    extra_source: str = ""
    companion: Callable[[Path, str], list[Path]] | None = None
    companion_folder: str = ""
    preprocess: str = "    (void)n; (void)u; (void)y;\n    return 0;\n"
    names: dict[str, list[str]] = field(default_factory=dict)


def _state_struct(model: CModel) -> str:
    fields = [f"    {decl};  /* {doc} */" for decl, doc in model.state] or [
        "    int unused;  /* no state */"
    ]
    return "typedef struct {\n" + "\n".join(fields) + "\n} NAME_state;"


def _model_api(model: CModel) -> list[str]:
    lines = [
        "/* The state at rest: NAME_reset(s, NULL, NULL). */",
        "void NAME_init(NAME_state *s);",
        "/* The state from NAME_RESET_ROWS past outputs y0 and inputs u0 (rows oldest first,",
        "   row-major; NULL: zeros), as the model's simulator().reset(y0, u0). */",
        "void NAME_reset(NAME_state *s, const double *y0, const double *u0);",
        "/* One sample: u[NAME_N_INPUTS] of sample t in, y[NAME_N_OUTPUTS] of sample t out. */",
        "void NAME_step(NAME_state *s, const double *u, double *y);",
    ]
    if model.bounded:
        lines += [
            "/* NAME_step with the band: lower[NAME_N_OUTPUTS] <= y <= upper[NAME_N_OUTPUTS]. */",
            "void NAME_step_bounds(NAME_state *s, const double *u, double *y, double *lower,",
            "                      double *upper);",
        ]
    lines += [
        "/* The model's preprocessing on a whole log in place: u[n][NAME_N_INPUTS] and",
        "   y[n][NAME_N_OUTPUTS] (y may be NULL when no step reads an output). Returns 0,",
        "   or -1 when a step cannot be applied (an offset window outside the log). */",
        "int NAME_preprocess(size_t n, double *u, double *y);",
    ]
    return lines


def _cpp_wrapper(model: CModel) -> list[str]:
    if model.controller:
        methods = [
            "    NAME_controller() { NAME_init(&s_); }",
            "    void reset() { NAME_reset(&s_); }",
            "    double step(double reference, double measurement)",
            "    { return NAME_step(&s_, reference, measurement); }",
        ]
        cls = "NAME_controller"
    else:
        methods = [
            "    NAME_model() { NAME_init(&s_); }",
            "    void reset(const double *y0 = 0, const double *u0 = 0)"
            " { NAME_reset(&s_, y0, u0); }",
            "    void step(const double *u, double *y) { NAME_step(&s_, u, y); }",
        ]
        if model.bounded:
            methods.append(
                "    void step_bounds(const double *u, double *y, double *lower, double *upper)"
                " { NAME_step_bounds(&s_, u, y, lower, upper); }"
            )
        cls = "NAME_model"
    return [
        "/* C++: the same functions as a class holding its state. */",
        f"class {cls} {{",
        "public:",
        *methods,
        "    const NAME_state &state() const { return s_; }",
        "private:",
        "    NAME_state s_;",
        "};",
    ]


def _header(model: CModel, name: str, guard: str) -> str:
    notes = [model.title, f"generated by neckid {__version__}; C99, needs only <math.h>", ""]
    notes += model.notes
    for kind, channels in model.names.items():
        notes.append(f"{kind}: {', '.join(channels) if channels else '(none)'}")
    if model.controller:
        api = [
            "/* The controller at rest (no command yet). */",
            "void NAME_init(NAME_state *s);",
            "void NAME_reset(NAME_state *s);",
            "/* One period: the command [rad/s] from the reference and the last measurement [deg]",
            "   (NaN: a failed read, the last command held). */",
            "double NAME_step(NAME_state *s, double reference, double measurement);",
            *model.extra_api,
        ]
    else:
        api = _model_api(model)
    lines = [
        comment_text(notes),
        f"#ifndef {guard}",
        f"#define {guard}",
        "",
        "#include <stddef.h>",
        "",
        f"#define NAME_N_INPUTS {model.n_inputs}",
        f"#define NAME_N_OUTPUTS {model.n_outputs}",
        f"#define NAME_RESET_ROWS {model.reset_rows}",
        f"#define NAME_INITIAL_ROWS {model.initial_rows} /* a log's rows that are the history */",
        f"#define NAME_TS {c_double(model.ts)} /* sampling period [s]: {model.ts!r} */",
        "",
        "#ifdef __cplusplus",
        'extern "C" {',
        "#endif",
        "",
        *([model.types, ""] if model.types else []),
        _state_struct(model),
        "",
        *api,
        "",
        "#ifdef __cplusplus",
        "}",
        "",
        *_cpp_wrapper(model),
        "#endif",
        "",
        f"#endif /* {guard} */",
        "",
    ]
    return "\n".join(lines).replace("NAME_", f"{name}_")


def _source(model: CModel, name: str) -> str:
    parts = [
        f"/* {model.title}: generated by neckid {__version__} (see {name}.h). */",
        "#include <math.h>",
        "#include <string.h>",
        f'#include "{name}.h"',
        *(f"#include {header}" for header in model.includes),
        "",
        "/* The arithmetic is the Python's, operation by operation: no contraction into FMA",
        "   (GCC contracts only outside ISO mode: compile with -std=c99 or -ffp-contract=off). */",
        "#if defined(__clang__) || !defined(__GNUC__)",
        "#pragma STDC FP_CONTRACT OFF",
        "#endif",
        "",
        model.constants,
        "",
    ]
    if model.controller:
        parts += [
            "void NAME_reset(NAME_state *s)\n{\n" + model.reset + "}",
            "",
            "void NAME_init(NAME_state *s)\n{\n    NAME_reset(s);\n}",
            "",
            "double NAME_step(NAME_state *s, double reference, double measurement)\n{\n"
            + model.step
            + "}",
            "",
            model.extra_source,
        ]
    else:
        parts += [
            "void NAME_reset(NAME_state *s, const double *y0, const double *u0)\n{\n"
            + model.reset
            + "}",
            "",
            "void NAME_init(NAME_state *s)\n{\n    NAME_reset(s, NULL, NULL);\n}",
            "",
        ]
        if model.bounded:
            parts += [
                "void NAME_step_bounds(NAME_state *s, const double *u, double *y, double *lower,"
                "\n                      double *upper)\n{\n" + model.step + "}",
                "",
                "void NAME_step(NAME_state *s, const double *u, double *y)\n{\n"
                "    double lower[NAME_N_OUTPUTS], upper[NAME_N_OUTPUTS];\n"
                "    NAME_step_bounds(s, u, y, lower, upper);\n}",
            ]
        else:
            parts.append(
                "void NAME_step(NAME_state *s, const double *u, double *y)\n{\n" + model.step + "}"
            )
        parts += [
            "",
            "int NAME_preprocess(size_t n, double *u, double *y)\n{\n" + model.preprocess + "}",
        ]
    return ("\n".join(parts) + "\n").replace("NAME_", f"{name}_")


def render(model: CModel, name: str) -> tuple[str, str]:
    """``(header, source)`` of ``model`` under the C name ``name`` (``name.h``, ``name.c``)."""
    guard = f"{name.upper()}_H"
    return _header(model, name, guard), _source(model, name)
