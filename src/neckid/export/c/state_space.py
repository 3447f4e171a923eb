"""C exports of the state-space models: ``ss`` (linear) and ``pnlss`` (polynomial).

The state is the model's own ``x``. ``NAME_reset(s, y0, u0)`` is the models' ``initial_state``:
the least-squares state of the ``M = max_lag`` past samples (``x(0) = S (y0 - y_forced)``, ``S``
the pseudo-inverse of the free response ``C A^k`` written out as a constant, then ``x(M) =
A^M x(0) + x_forced(M)``), and ``y0 = NULL`` the state 0. A step is the compiled run's, sum by
sum: ``y = offset + C x + D u`` (``+ F zeta`` for pnlss), ``x <- A x + B u`` (``+ E zeta``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.export.c.literals import c_array, c_int_array
from neckid.export.c.program import CModel

__all__ = ["c_pnlss", "c_subspace"]

# The least-squares state of M past rows, run on to the present (estimate_state, sum by sum):
# the start model's matrices are NAME_sA ... NAME_soffset and the solver NAME_solver.
_ESTIMATE = r"""
static void NAME_estimate(const double *yr, const double *ur, double *x)
{
    double xf[NAME_N_STATES], nxt[NAME_N_STATES], r[NAME_M * NAME_N_OUTPUTS], x0[NAME_N_STATES];
    int t, o, k, j, i;
    for (k = 0; k < NAME_N_STATES; ++k) xf[k] = 0.0;
    for (t = 0; t < NAME_M; ++t) {
        const double *ut = ur + t * NAME_N_INPUTS;
        for (o = 0; o < NAME_N_OUTPUTS; ++o) {
            double total = NAME_soffset[o];
            for (k = 0; k < NAME_N_STATES; ++k) total += NAME_sC[o][k] * xf[k];
            for (j = 0; j < NAME_N_INPUTS; ++j) total += NAME_sD[o][j] * ut[j];
            r[t * NAME_N_OUTPUTS + o] = yr[t * NAME_N_OUTPUTS + o] - total;
        }
        for (i = 0; i < NAME_N_STATES; ++i) {
            double total = 0.0;
            for (k = 0; k < NAME_N_STATES; ++k) total += NAME_sA[i][k] * xf[k];
            for (j = 0; j < NAME_N_INPUTS; ++j) total += NAME_sB[i][j] * ut[j];
            nxt[i] = total;
        }
        for (i = 0; i < NAME_N_STATES; ++i) xf[i] = nxt[i];
    }
    for (i = 0; i < NAME_N_STATES; ++i) {
        double total = 0.0;
        for (k = 0; k < NAME_M * NAME_N_OUTPUTS; ++k) total += NAME_solver[i][k] * r[k];
        x0[i] = total;
    }
    for (t = 0; t < NAME_M; ++t) {
        for (i = 0; i < NAME_N_STATES; ++i) {
            double total = 0.0;
            for (k = 0; k < NAME_N_STATES; ++k) total += NAME_sA[i][k] * x0[k];
            nxt[i] = total;
        }
        for (i = 0; i < NAME_N_STATES; ++i) x0[i] = nxt[i];
    }
    for (i = 0; i < NAME_N_STATES; ++i) x[i] = x0[i] + xf[i];
}
"""


def _start_constants(start: tuple[Any, ...], m: int) -> list[str]:
    from neckid.models.linear.subspace_steps import initial_state_solver

    a, b, c, d, offset = (np.asarray(v, dtype=np.float64) for v in start)
    solver = initial_state_solver(a, c, m) if m else np.zeros((a.shape[0], 0))
    return [
        f"#define NAME_M {max(m, 1)}",
        c_array("NAME_sA", a),
        c_array("NAME_sB", b),
        c_array("NAME_sC", c),
        c_array("NAME_sD", d),
        c_array("NAME_soffset", offset),
        "/* pinv of the free response C A^k, k = 0 .. M-1 (rows time first) */",
        c_array("NAME_solver", solver),
        _ESTIMATE,
    ]


def _reset(m: int, scaled: bool) -> str:
    if m == 0:
        return "    (void)y0; (void)u0;\n    memset(s->x, 0, sizeof s->x);\n"
    head = (
        "    double yr[NAME_M * NAME_N_OUTPUTS], ur[NAME_M * NAME_N_INPUTS];\n"
        "    int t, k;\n"
        "    if (y0 == NULL) {\n"
        "        memset(s->x, 0, sizeof s->x);\n"
        "        return;\n"
        "    }\n"
    )
    if scaled:
        fill = (
            "    for (t = 0; t < NAME_M; ++t) {\n"
            "        for (k = 0; k < NAME_N_OUTPUTS; ++k)\n"
            "            yr[t * NAME_N_OUTPUTS + k] = (y0[t * NAME_N_OUTPUTS + k]"
            " - NAME_y_center[k]) / NAME_y_scale[k];\n"
            "        for (k = 0; k < NAME_N_INPUTS; ++k)\n"
            "            ur[t * NAME_N_INPUTS + k] = ((u0 != NULL ? u0[t * NAME_N_INPUTS + k]"
            " : 0.0) - NAME_u_center[k]) / NAME_u_scale[k];\n"
            "    }\n"
        )
    else:
        fill = (
            "    for (t = 0; t < NAME_M; ++t) {\n"
            "        for (k = 0; k < NAME_N_OUTPUTS; ++k)"
            " yr[t * NAME_N_OUTPUTS + k] = y0[t * NAME_N_OUTPUTS + k];\n"
            "        for (k = 0; k < NAME_N_INPUTS; ++k)\n"
            "            ur[t * NAME_N_INPUTS + k] = u0 != NULL ? u0[t * NAME_N_INPUTS + k] : 0.0;\n"
            "    }\n"
        )
    return head + fill + "    NAME_estimate(yr, ur, s->x);\n"


_SS_STEP = (
    "    double nxt[NAME_N_STATES];\n"
    "    int o, k, j, i;\n"
    "    for (o = 0; o < NAME_N_OUTPUTS; ++o) {\n"
    "        double total = NAME_offset[o];\n"
    "        for (k = 0; k < NAME_N_STATES; ++k) total += NAME_C[o][k] * s->x[k];\n"
    "        for (j = 0; j < NAME_N_INPUTS; ++j) total += NAME_D[o][j] * u[j];\n"
    "        y[o] = total;\n"
    "    }\n"
    "    for (i = 0; i < NAME_N_STATES; ++i) {\n"
    "        double total = 0.0;\n"
    "        for (k = 0; k < NAME_N_STATES; ++k) total += NAME_A[i][k] * s->x[k];\n"
    "        for (j = 0; j < NAME_N_INPUTS; ++j) total += NAME_B[i][j] * u[j];\n"
    "        nxt[i] = total;\n"
    "    }\n"
    "    for (i = 0; i < NAME_N_STATES; ++i) s->x[i] = nxt[i];\n"
)


def _sizes(model: Any, order: int) -> list[str]:
    return [
        f"#define NAME_N_STATES {max(order, 1)}",
    ]


def c_subspace(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.SubspaceStateSpace` (``ss``)."""
    a, b, c, d, offset = model.matrices_
    order, m = int(model.order_), int(model.max_lag_)
    constants = "\n".join(
        [
            *_sizes(model, order),
            c_array("NAME_A", a),
            c_array("NAME_B", b),
            c_array("NAME_C", c),
            c_array("NAME_D", d),
            c_array("NAME_offset", offset),
            *_start_constants(model.matrices_, m),
        ]
    )
    notes = [
        "y(t) = C x(t) + D u(t) + offset, x(t+1) = A x(t) + B u(t)",
        f"State: x, {order} values (x1 ... x{order}); NAME_reset takes M = {max(m, 1)} past rows"
        " (the least-squares state, as initial_state), y0 = NULL: x = 0.",
        f"Initial rows: simulate's first max_lag = {m} samples give the state.",
    ]
    return CModel(
        title="Linear state space (neckid SubspaceStateSpace)",
        notes=notes,
        state=[(f"double x[{max(order, 1)}]", "the model's state x(t)")],
        constants=constants,
        reset=_reset(m, scaled=False),
        step=_SS_STEP,
        n_inputs=len(model.input_names_),
        n_outputs=len(model.output_names_),
        reset_rows=max(m, 1),
        ts=float(model.ts_),
        initial_rows=m,
    )


_PNLSS_STEP = (
    "    double v[NAME_N_INPUTS], z[NAME_N_STATES + NAME_N_INPUTS], phi[NAME_N_MONOMIALS];\n"
    "    double nxt[NAME_N_STATES];\n"
    "    int o, k, j, i;\n"
    "    for (j = 0; j < NAME_N_INPUTS; ++j) v[j] = (u[j] - NAME_u_center[j]) / NAME_u_scale[j];\n"
    "    for (j = 0; j < NAME_N_STATES + NAME_N_INPUTS; ++j) {\n"
    "        double w = j < NAME_N_STATES ? s->x[j] : v[j - NAME_N_STATES];\n"
    "        double value = (w - NAME_center[j]) / NAME_scale[j];\n"
    "        if (!(value >= NAME_low[j])) value = NAME_low[j];\n"
    "        z[j] = value <= NAME_high[j] ? value : NAME_high[j];\n"
    "    }\n"
    "    phi[0] = 1.0;\n"
    "    for (k = 1; k < NAME_N_MONOMIALS; ++k) phi[k] = phi[NAME_parent[k]] * z[NAME_var[k]];\n"
    "    for (o = 0; o < NAME_N_OUTPUTS; ++o) {\n"
    "        double total = NAME_offset[o];\n"
    "        for (k = 0; k < NAME_N_STATES; ++k) total += NAME_C[o][k] * s->x[k];\n"
    "        for (j = 0; j < NAME_N_INPUTS; ++j) total += NAME_D[o][j] * v[j];\n"
    "        for (k = 0; k < NAME_N_NONLINEAR; ++k) total += NAME_F[o][k] * phi[NAME_FIRST + k];\n"
    "        y[o] = total * NAME_y_scale[o] + NAME_y_center[o];\n"
    "    }\n"
    "    for (i = 0; i < NAME_N_STATES; ++i) {\n"
    "        double total = 0.0;\n"
    "        for (k = 0; k < NAME_N_STATES; ++k) total += NAME_A[i][k] * s->x[k];\n"
    "        for (j = 0; j < NAME_N_INPUTS; ++j) total += NAME_B[i][j] * v[j];\n"
    "        for (k = 0; k < NAME_N_NONLINEAR; ++k) total += NAME_E[i][k] * phi[NAME_FIRST + k];\n"
    "        nxt[i] = total;\n"
    "    }\n"
    "    for (i = 0; i < NAME_N_STATES; ++i) s->x[i] = nxt[i];\n"
)


def c_pnlss(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.PolynomialStateSpace` (``pnlss``)."""
    from neckid.models.polynomial.monomials import monomial_tables

    a, b, c, d, offset, e, f = model.matrices_
    order, m = int(model.order_), int(model.max_lag_)
    n_in = len(model.input_names_)
    _, parent, var, _ = monomial_tables(order + n_in, int(model.degree))
    n_nl = int(np.shape(e)[1])
    start = (model.start_A_, model.start_B_, model.start_C_, model.start_D_)
    constants = "\n".join(
        [
            *_sizes(model, order),
            f"#define NAME_N_MONOMIALS {int(parent.shape[0])}",
            f"#define NAME_N_NONLINEAR {n_nl}",
            f"#define NAME_FIRST {int(parent.shape[0]) - n_nl}",
            *(
                c_array(f"NAME_{key}", value)
                for key, value in zip("ABCDEF", (a, b, c, d, e, f), strict=True)
            ),
            c_array("NAME_offset", offset),
            *(
                c_array(f"NAME_{key}", getattr(model, f"{key}_"))
                for key in ("u_center", "u_scale", "y_center", "y_scale")
            ),
            *(
                c_array(f"NAME_{key}", getattr(model, f"{key}_"))
                for key in ("center", "scale", "low", "high")
            ),
            c_int_array("NAME_parent", np.maximum(parent, 0)),
            c_int_array("NAME_var", np.maximum(var, 0)),
            *_start_constants((*start, model.start_intercept_), m),
        ]
    )
    notes = [
        "v = (u - u_center) ./ u_scale; zeta = the monomials of degree >= 2 of",
        "z = ([x; v] - center) ./ scale held in [low, high];",
        "w = C x + D v + offset + F zeta, y = w .* y_scale + y_center,",
        "x(t+1) = A x + B v + E zeta (internal units)",
        f"State: x, {order} values; NAME_reset takes M = {max(m, 1)} past rows (the linear start's"
        " least-squares state, as initial_state), y0 = NULL: x = 0.",
        f"Initial rows: simulate's first max_lag = {m} samples give the state.",
    ]
    return CModel(
        title="Polynomial state space (neckid PolynomialStateSpace)",
        notes=notes,
        state=[(f"double x[{max(order, 1)}]", "the model's state x(t), internal units")],
        constants=constants,
        reset=_reset(m, scaled=True),
        step=_PNLSS_STEP,
        n_inputs=n_in,
        n_outputs=len(model.output_names_),
        reset_rows=max(m, 1),
        ts=float(model.ts_),
        initial_rows=m,
    )
