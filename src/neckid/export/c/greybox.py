r"""C export of the grey-box neck (``greybox-neck``): the slack and hysteresis plays, the dynamics.

A step is :class:`~neckid.models.greybox.model.GreyBoxSimulator`'s: every motor's plays move
(``z <- min(max(z, x - r), x + r)``, radii the play's plus half the slack), the operator output
``v = W phi`` over the plays, the plays times each condition, the conditions and 1, and each
output's stable denominator ``y_o = sum(A_o) v_o(t - d) - sum_i A_o[i] y_o(t - i)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.export.c.literals import c_array
from neckid.export.c.program import CModel

__all__ = ["c_greybox"]

_ADVANCE = r"""
/* the plays moved by the inputs u; v = W phi, this sample's operator outputs */
static void NAME_advance(double plays[NAME_MOTORS][NAME_PLAYS], const double *u, double *v)
{
    double phi[NAME_FEATURES];
    int j, p, c, o, k = 0;
    for (j = 0; j < NAME_MOTORS; ++j)
        for (p = 0; p < NAME_PLAYS; ++p) {
            double z = plays[j][p], low = u[j] - NAME_radii[j][p], high = u[j] + NAME_radii[j][p];
            z = z > low ? z : low;
            plays[j][p] = z < high ? z : high;
        }
    for (j = 0; j < NAME_MOTORS; ++j)
        for (p = 0; p < NAME_PLAYS; ++p) phi[k++] = plays[j][p];
    for (c = 0; c < NAME_CONDITIONS; ++c)
        for (j = 0; j < NAME_MOTORS; ++j)
            for (p = 0; p < NAME_PLAYS; ++p) phi[k++] = plays[j][p] * u[NAME_MOTORS + c];
    for (c = 0; c < NAME_CONDITIONS; ++c) phi[k++] = u[NAME_MOTORS + c];
    phi[k] = 1.0;
    for (o = 0; o < NAME_N_OUTPUTS; ++o) {
        double total = 0.0;
        for (k = 0; k < NAME_FEATURES; ++k) total += phi[k] * NAME_weights[o][k];
        v[o] = total;
    }
}
"""

_RESET = r"""    double rows_y[NAME_M][NAME_N_OUTPUTS], rows_u[NAME_M][NAME_N_INPUTS];
    int t, j, p;
    if (y0 != NULL) memcpy(rows_y, y0, sizeof rows_y);
    else memset(rows_y, 0, sizeof rows_y);
    if (u0 != NULL) memcpy(rows_u, u0, sizeof rows_u);
    else memset(rows_u, 0, sizeof rows_u);
    memcpy(s->y, rows_y, sizeof s->y);
    for (j = 0; j < NAME_MOTORS; ++j)  /* the plays relaxed at the oldest row */
        for (p = 0; p < NAME_PLAYS; ++p) s->plays[j][p] = rows_u[0][j];
    for (t = 0; t < NAME_M; ++t) NAME_advance(s->plays, rows_u[t], s->v[t]);
"""

_STEP = r"""    double now[NAME_N_OUTPUTS], drive[NAME_N_OUTPUTS];
    int o, i;
    NAME_advance(s->plays, u, now);
    for (o = 0; o < NAME_N_OUTPUTS; ++o)  /* history[M - delay]: M rows of v, then now */
        drive[o] = NAME_DELAY == 0 ? now[o] : s->v[NAME_M - NAME_DELAY][o];
    memmove(s->v[0], s->v[1], sizeof s->v - sizeof s->v[0]);
    memcpy(s->v[NAME_M - 1], now, sizeof now);
    for (o = 0; o < NAME_N_OUTPUTS; ++o) {
        double past = 0.0;
        for (i = 1; i < NAME_ORDER1; ++i) past += NAME_A[o][i] * s->y[NAME_M - i][o];
        y[o] = NAME_gain[o] * drive[o] - past;
    }
    memmove(s->y[0], s->y[1], sizeof s->y - sizeof s->y[0]);
    memcpy(s->y[NAME_M - 1], y, sizeof s->y[0]);
"""


def c_greybox(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.GreyBoxNeck` (``greybox-neck``)."""
    polynomials = np.asarray(model.denominators_, dtype=np.float64)
    m = int(model.max_lag_)
    n_in, n_out = len(model.input_names_), len(model.output_names_)
    motors = n_in - int(model.n_conditions_)
    radii = np.asarray(model.slack_, dtype=np.float64)[:, None] / 2.0 + model.radii_
    weights = np.asarray(model.weights_, dtype=np.float64)
    constants = "\n".join(
        [
            f"#define NAME_M {m}",
            f"#define NAME_MOTORS {motors}",
            f"#define NAME_PLAYS {int(radii.shape[1])}",
            f"#define NAME_CONDITIONS {int(model.n_conditions_)}",
            f"#define NAME_FEATURES {int(weights.shape[1])}",
            f"#define NAME_DELAY {int(model.delay)}",
            f"#define NAME_ORDER1 {int(polynomials.shape[1])}",
            c_array("NAME_radii", radii),
            c_array("NAME_weights", weights),
            c_array("NAME_A", polynomials),
            c_array("NAME_gain", [np.sum(a) for a in polynomials]),
            _ADVANCE,
        ]
    )
    notes = [
        "Grey-box neck: each motor's plays z <- min(max(z, x - r), x + r) (radii: the play's",
        "plus half the slack); v = W [plays, plays * conditions, conditions, 1];",
        "y_o(t) = sum(A_o) v_o(t - delay) - sum_i A_o[i] y_o(t - i)",
        f"State: the plays, the last M = {m} operator outputs and outputs; NAME_reset takes M"
        " rows (the plays start relaxed at the oldest input row and run over the rows).",
    ]
    return CModel(
        title="Grey-box neck: slack, hysteresis, dynamics (neckid GreyBoxNeck)",
        notes=notes,
        state=[
            (f"double plays[{motors}][{int(radii.shape[1])}]", "the plays' outputs"),
            (f"double v[{m}][{n_out}]", "the last M operator outputs, oldest first"),
            (f"double y[{m}][{n_out}]", "the last M outputs, oldest first"),
        ],
        constants=constants,
        reset=_RESET,
        step=_STEP,
        n_inputs=n_in,
        n_outputs=n_out,
        reset_rows=m,
        ts=float(model.ts_),
        initial_rows=m,
    )
