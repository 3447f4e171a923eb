"""C export of the parallel Set Membership model (``sm-parallel``, ``-poly``, ``-koopman``, ``-sindy``).

Two exports in one: the base model run in parallel (an ARX, a polynomial or sparse NARX, a
state-space or Koopman model: its own ``c_export``) and the SM map over ``v = [u, y_base]``,
each under its own prefix (``NAME_base_``, ``NAME_map_``) with its state inside the model's. A
step is :class:`~neckid.models.set_membership.parallel.ParallelSetMembershipSimulator`'s: the
base steps on ``u``, the map steps on ``[u, y_base]`` with its bounds, and the output is the
central estimate or (``estimate="projection"``) the base's output clipped to the bounds.
"""

from __future__ import annotations

from typing import Any

from neckid.export.c.lookup import exporter_of
from neckid.export.c.program import CModel
from neckid.export.c.set_membership import c_set_membership

__all__ = ["c_parallel"]


def _embedded(sub: CModel, part: str) -> tuple[str, str]:
    """``(type definition, source)`` of a part under the prefix ``NAME_<part>_``.

    The part's text is written with its own ``NAME_`` names, then renamed once.
    """
    tag = f"NAME_{part}_"
    fields = "\n".join(f"    {decl};  /* {doc} */" for decl, doc in sub.state)
    typedef = (
        sub.types + "\n" if sub.types else ""
    ) + f"typedef struct {{\n{fields}\n}} NAME_state;"
    if sub.bounded:
        step = (
            "static void NAME_step_bounds(NAME_state *s, const double *u, double *y,"
            " double *lower, double *upper)"
        )
    else:
        step = "static void NAME_step(NAME_state *s, const double *u, double *y)"
    source = "\n".join(
        [
            f"#define NAME_N_INPUTS {sub.n_inputs}",
            f"#define NAME_N_OUTPUTS {sub.n_outputs}",
            f"#define NAME_RESET_ROWS {sub.reset_rows}",
            f"#define NAME_INITIAL_ROWS {sub.initial_rows}",
            sub.constants,
            "static void NAME_reset(NAME_state *s, const double *y0, const double *u0)\n{\n"
            + sub.reset
            + "}",
            f"{step}\n{{\n{sub.step}}}",
        ]
    )
    renamed = source.replace("NAME_", tag)
    return typedef.replace("NAME_", tag), f"#define {tag}TS NAME_TS\n{renamed}"


def c_parallel(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.ParallelSetMembership`.

    Raises
    ------
    TypeError
        When the base model has no C export (the tanks' grey box, a sparse NARX with user
        functions: ``ValueError``).
    """
    exporter = exporter_of(model.linear_)
    if exporter is None:
        raise TypeError(
            f"the base {type(model.linear_).__name__} of this parallel SM model has no C export"
        )
    if (model.sm_.lags_.source == 0).any():
        raise ValueError("the SM map of this parallel model reads measured outputs: no C export")
    base, sm_map = exporter(model.linear_), c_set_membership(model.sm_)
    base_type, base_source = _embedded(base, "base")
    map_type, map_source = _embedded(sm_map, "map")
    n_in, n_out = len(model.input_names_), len(model.output_names_)
    m = max(int(model.max_lag_), 1)
    reset = (
        "    double zeros_y[NAME_M * NAME_N_OUTPUTS], zeros_u[NAME_M * NAME_N_INPUTS];\n"
        "    double v[NAME_M * (NAME_N_INPUTS + NAME_N_OUTPUTS)];\n"
        "    int t, k;\n"
        "    memset(zeros_y, 0, sizeof zeros_y);\n"
        "    memset(zeros_u, 0, sizeof zeros_u);\n"
        "    if (y0 == NULL) y0 = zeros_y;\n"
        "    if (u0 == NULL) u0 = zeros_u;\n"
        "    NAME_base_reset(&s->base, y0 + (NAME_M - NAME_base_RESET_ROWS) * NAME_N_OUTPUTS,\n"
        "                    u0 + (NAME_M - NAME_base_RESET_ROWS) * NAME_N_INPUTS);\n"
        "    for (t = 0; t < NAME_M; ++t) {  /* the map's history: inputs, then outputs */\n"
        "        double *row = v + t * (NAME_N_INPUTS + NAME_N_OUTPUTS);\n"
        "        for (k = 0; k < NAME_N_INPUTS; ++k) row[k] = u0[t * NAME_N_INPUTS + k];\n"
        "        for (k = 0; k < NAME_N_OUTPUTS; ++k)"
        " row[NAME_N_INPUTS + k] = y0[t * NAME_N_OUTPUTS + k];\n"
        "    }\n"
        "    NAME_map_reset(&s->map, NULL,\n"
        "                   v + (NAME_M - NAME_map_RESET_ROWS) * (NAME_N_INPUTS + NAME_N_OUTPUTS));\n"
    )
    projection = str(model.estimate) == "projection"
    estimate = (
        "    for (k = 0; k < NAME_N_OUTPUTS; ++k) {  /* projection: the base clipped */\n"
        "        double value = v[NAME_N_INPUTS + k];\n"
        "        value = value > lower[k] ? value : lower[k];\n"
        "        y[k] = value < upper[k] ? value : upper[k];\n"
        "    }\n"
        if projection
        else "    for (k = 0; k < NAME_N_OUTPUTS; ++k) y[k] = central[k];\n"
    )
    step = (
        "    double v[NAME_N_INPUTS + NAME_N_OUTPUTS], central[NAME_N_OUTPUTS];\n"
        "    int k;\n"
        "    for (k = 0; k < NAME_N_INPUTS; ++k) v[k] = u[k];\n"
        "    NAME_base_step(&s->base, u, v + NAME_N_INPUTS);\n"
        "    NAME_map_step_bounds(&s->map, v, central, lower, upper);\n" + estimate
    )
    notes = [
        f"Parallel Set Membership: y_base = the base model ({base.title}) run on u;",
        "the SM map on v = [u, y_base] gives the bounds and the central estimate; y = "
        + ("the base's output clipped to the bounds" if projection else "the central estimate"),
        f"State: the base's (s->base) and the map's (s->map); NAME_reset takes M = {m} rows",
        "(the base's history from the last of them; the map's from the inputs and y0 taken as",
        "the base's past outputs), as the model's simulator().",
        "",
        "The base:",
        *[f"  {line}".replace("NAME_", "NAME_base_") for line in base.notes],
        "The map:",
        *[f"  {line}".replace("NAME_", "NAME_map_") for line in sm_map.notes],
    ]
    return CModel(
        title="Parallel Set Membership (neckid ParallelSetMembership)",
        notes=notes,
        state=[
            ("NAME_base_state base", "the base model's state"),
            ("NAME_map_state map", "the SM map's state"),
        ],
        constants="\n".join([f"#define NAME_M {m}", base_source, map_source]),
        reset=reset,
        step=step,
        n_inputs=n_in,
        n_outputs=n_out,
        reset_rows=m,
        ts=float(model.ts_),
        bounded=True,
        initial_rows=int(model.max_lag_),
        types=base_type + "\n" + map_type,
    )
