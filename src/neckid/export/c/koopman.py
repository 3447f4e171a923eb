r"""C export of the Koopman model (``koopman``): the lifted linear system and the lift of its start.

The state is the model's lifted state ``z = [p; φ(r); 1]`` (:meth:`KoopmanEDMD.state_names
<neckid.models.koopman.model.KoopmanEDMD.state_names>`): the standardised output and input
delays ``p``, the standardised observables ``φ`` of the lag terms ``r`` (thin-plate or Gaussian
RBFs, or monomials) and the constant 1. ``NAME_reset(s, y0, u0)`` is ``initial_state``: the
lift of the ``M = max_lag`` past rows (``NULL``: zeros, as ``simulator().reset()``), computed
once; a step is the free run's, ``y = C z + D u`` then ``z <- A z + B u`` (each product summed
in order, then the two added). The observables are never recomputed from the outputs.
"""

from __future__ import annotations

import textwrap
from typing import Any

import numpy as np

from neckid.export.c.literals import c_array, c_double, c_int_array
from neckid.export.c.program import CModel

__all__ = ["c_koopman"]

_DELAYS = r"""
    for (j = 0; j < NAME_N_DELAYS; ++j) {  /* p: the standardised delays */
        long row = NAME_M - NAME_lag[j], c = NAME_channel[j];
        if (NAME_source[j] == 0)
            z[j] = ((y0 != NULL ? y0[row * NAME_N_OUTPUTS + c] : 0.0) - NAME_y_mean[c])
                   / NAME_y_std[c];
        else
            z[j] = ((u0 != NULL ? u0[row * NAME_N_INPUTS + c] : 0.0) - NAME_u_mean[c])
                   / NAME_u_std[c];
    }
"""

# The squared distance as the Python's: |r|^2 - 2 r.c + |c|^2 (|c|^2 a constant), clipped at 0.
_RBF = r"""
    for (j = 0; j < NAME_N_TERMS; ++j) r[j] = z[NAME_terms[j]];
    for (k = 0; k < NAME_N_OBSERVABLES; ++k) {
        double rr = 0.0, rc = 0.0, squared, value;
        for (j = 0; j < NAME_N_TERMS; ++j) rr += r[j] * r[j];
        for (j = 0; j < NAME_N_TERMS; ++j) rc += r[j] * NAME_centres[k][j];
        squared = rr - 2.0 * rc + NAME_centre_square[k];
        if (squared < 0.0) squared = 0.0;
        @VALUE@
        z[NAME_N_DELAYS + k] = (value - NAME_observable_mean[k]) / NAME_observable_std[k];
    }
"""

_THIN_PLATE = "value = squared > 0.0 ? 0.5 * squared * log(squared) : 0.0;  /* d^2 log d */"
_GAUSSIAN = "value = exp(-squared / NAME_two_width_square);"

_MONOMIALS = r"""
    for (j = 0; j < NAME_N_TERMS; ++j) r[j] = z[NAME_terms[j]];
    for (k = 0; k < NAME_N_OBSERVABLES; ++k) {
        double value = 1.0;
        for (j = 0; j < NAME_N_TERMS; ++j) {
            long power = NAME_powers[k][j];
            if (power == 1) value *= r[j];
            else if (power == 2) value *= r[j] * r[j];
            else if (power == 3) value *= pow(r[j], 3.0);
        }
        z[NAME_N_DELAYS + k] = (value - NAME_observable_mean[k]) / NAME_observable_std[k];
    }
"""

_STEP = (
    "    double nxt[NAME_N_STATES];\n"
    "    int o, k, j, i;\n"
    "    for (o = 0; o < NAME_N_OUTPUTS; ++o) {\n"
    "        double cz = 0.0, du = 0.0;\n"
    "        for (k = 0; k < NAME_N_STATES; ++k) cz += NAME_C[o][k] * s->z[k];\n"
    "        for (j = 0; j < NAME_N_INPUTS; ++j) du += NAME_D[o][j] * u[j];\n"
    "        y[o] = cz + du;\n"
    "    }\n"
    "    for (i = 0; i < NAME_N_STATES; ++i) {\n"
    "        double az = 0.0, bu = 0.0;\n"
    "        for (k = 0; k < NAME_N_STATES; ++k) az += NAME_A[i][k] * s->z[k];\n"
    "        for (j = 0; j < NAME_N_INPUTS; ++j) bu += NAME_B[i][j] * u[j];\n"
    "        nxt[i] = az + bu;\n"
    "    }\n"
    "    for (i = 0; i < NAME_N_STATES; ++i) s->z[i] = nxt[i];\n"
)


def _observable_parts(model: Any) -> tuple[list[str], str, str]:
    """The observables' constants, the lift's code for them, and the header's sentence."""
    k = int(model.n_observables_)
    kind = str(model.dictionary)
    if k == 0:
        return [], "", ""
    constants = [
        c_array("NAME_observable_mean", model.observable_mean_),
        c_array("NAME_observable_std", model.observable_std_),
    ]
    if kind == "monomials":
        constants.append(c_int_array("NAME_powers", model.powers_))
        return constants, _MONOMIALS, f"{k} monomials of r (exponents NAME_powers)"
    centres = np.asarray(model.centres_, dtype=np.float64)
    constants += [
        c_array("NAME_centres", centres),
        c_array("NAME_centre_square", np.sum(centres * centres, axis=1)),
    ]
    if kind == "gaussian":
        denominator = 2.0 * float(model.width_) ** 2
        constants.append(f"static const double NAME_two_width_square = {c_double(denominator)};")
        text = f"{k} Gaussian RBFs exp(-|r-c_k|^2/(2w^2)), w = {float(model.width_)!r}"
        return constants, _RBF.replace("@VALUE@", _GAUSSIAN), text
    text = f"{k} thin-plate RBFs |r-c_k|^2 log|r-c_k|"
    return constants, _RBF.replace("@VALUE@", _THIN_PLATE), text


def c_koopman(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.models.koopman.KoopmanEDMD` (``koopman``)."""
    from neckid.models.koopman.lift import Layout

    layout = Layout.of(model.lags_)
    order, m = int(model.order_), int(model.max_lag_)
    n_in, n_out = len(model.input_names_), len(model.output_names_)
    observables, observable_code, sentence = _observable_parts(model)
    lift = (
        "static void NAME_lift(const double *y0, const double *u0, double *z)\n{\n"
        + ("    double r[NAME_N_TERMS];\n    int j, k;\n" if observable_code else "    int j;\n")
        + _DELAYS
        + observable_code
        + "    z[NAME_N_STATES - 1] = 1.0;\n}\n"
    )
    constants = "\n".join(
        [
            f"#define NAME_N_STATES {order}",
            f"#define NAME_N_DELAYS {layout.n_delays}",
            f"#define NAME_N_TERMS {int(layout.terms.size)}",
            f"#define NAME_N_OBSERVABLES {int(model.n_observables_)}",
            f"#define NAME_M {m}",
            *(c_array(f"NAME_{key}", getattr(model, f"{key}_")) for key in "ABCD"),
            *(
                c_array(f"NAME_{key}", getattr(model, f"{key}_"))
                for key in ("y_mean", "y_std", "u_mean", "u_std")
            ),
            c_int_array("NAME_source", layout.source),
            c_int_array("NAME_channel", layout.channel),
            c_int_array("NAME_lag", layout.lag),
            *([c_int_array("NAME_terms", layout.terms)] if observable_code else []),
            *observables,
            lift,
        ]
    )
    parts = "the standardised delays p, "
    parts += f"then {sentence} of the lag terms r, then" if sentence else "no observables, then"
    names = ", ".join(model.state_names())
    notes = [
        "y(t) = C z(t) + D u(t), z(t+1) = A z(t) + B u(t): the lifted linear system",
        *textwrap.wrap(f"State z, {order} values: {parts} the constant 1:", width=92),
        *textwrap.wrap(names, width=92, initial_indent="  ", subsequent_indent="  "),
        f"NAME_reset lifts z from M = {m} past rows (as initial_state; NULL: zeros, the",
        "simulator's reset()); the observables are not recomputed after that.",
        f"Initial rows: simulate's first max_lag = {m} samples give the state.",
    ]
    return CModel(
        title="Koopman model with control, EDMD (neckid KoopmanEDMD)",
        notes=notes,
        state=[(f"double z[{order}]", "the lifted state z(t)")],
        constants=constants,
        reset="    NAME_lift(y0, u0, s->z);\n",
        step=_STEP,
        n_inputs=n_in,
        n_outputs=n_out,
        reset_rows=m,
        ts=float(model.ts_),
        initial_rows=m,
    )
