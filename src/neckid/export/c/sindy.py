r"""C export of the sparse NARX (``sindy``): the NARX history shell around its sparse equation.

The shell (state, reset, history shift) is :func:`neckid.export.c.narx.narx_model`'s, as for
``poly``; the map is the compiled free run's (:func:`neckid.models.sindy._kernels.sparse_free_run`):
every library monomial of the raw regressor ``w`` by one product (``phi_k = phi_parent[k] *
held_var[k]``, the terms held in ``[hold_low, hold_high]`` for degree >= 2, the linear ones
``w`` itself), then ``y = Σ_i coef_i θ_i`` over the kept functions only, in the library's
order, from 0 (a kept ``sin``/``cos`` of one term evaluated there). A model with user functions
has Python code in its equation and no C export.
"""

from __future__ import annotations

import textwrap
from typing import Any

import numpy as np

from neckid.export.c.literals import c_array, c_int_array
from neckid.export.c.narx import narx_model
from neckid.export.c.program import CModel

__all__ = ["c_sindy"]

# Python's min(max(x, low), high): max keeps x unless low > x, min keeps v unless high < v.
_SPARSE_MAP = (
    "    {\n"
    "        double held[NAME_N_TERMS], phi[NAME_N_MONOMIALS];\n"
    "        int j, k, o;\n"
    "        for (j = 0; j < NAME_N_TERMS; ++j) {\n"
    "            double v = NAME_hold_low[j] > w[j] ? NAME_hold_low[j] : w[j];\n"
    "            held[j] = NAME_hold_high[j] < v ? NAME_hold_high[j] : v;\n"
    "        }\n"
    "        phi[0] = 1.0;\n"
    "        for (k = 1; k < NAME_N_MONOMIALS; ++k) phi[k] = phi[NAME_parent[k]] * held[NAME_var[k]];\n"
    "        for (j = 0; j < NAME_N_TERMS && j < NAME_N_MONOMIALS - 1; ++j) phi[1 + j] = w[j];\n"
    "        for (o = 0; o < NAME_N_OUTPUTS; ++o) out[o] = 0.0;\n"
    "        for (k = 0; k < NAME_N_KEPT; ++k) {\n"
    "            double value;\n"
    "            if (NAME_kind[k] == 0) value = phi[NAME_kept[k]];\n"
    "            else if (NAME_kind[k] == 1) value = sin(NAME_frequency[k] * w[NAME_term[k]]);\n"
    "            else value = cos(NAME_frequency[k] * w[NAME_term[k]]);\n"
    "            for (o = 0; o < NAME_N_OUTPUTS; ++o) out[o] += NAME_coef[k][o] * value;\n"
    "        }\n"
    "    }\n"
)


def c_sindy(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.models.sindy.SparseNARX` (``sindy``).

    Raises
    ------
    ValueError
        For a model with user functions (Python code, no C).
    """
    from neckid.models.polynomial.monomials import monomial_tables

    library = model.library_
    if not library.compiled:
        names = sorted({name for name in library.function if name})
        raise ValueError(
            f"a SparseNARX with user functions ({', '.join(names)}) has no C export: they are"
            " Python code; refit it without functions= (sin/cos terms export)"
        )
    n_terms = int(model.lags_.n_terms)
    _, parent, var, _ = monomial_tables(n_terms, int(model.degree))
    kept = np.flatnonzero(np.any(model.coef_ != 0, axis=1))
    constants = "\n".join(
        [
            f"#define NAME_N_TERMS {n_terms}",
            f"#define NAME_N_MONOMIALS {int(parent.shape[0])}",
            f"#define NAME_N_KEPT {int(kept.size)}",
            c_array("NAME_hold_low", model.hold_low_),
            c_array("NAME_hold_high", model.hold_high_),
            c_int_array("NAME_parent", np.maximum(parent, 0)),
            c_int_array("NAME_var", np.maximum(var, 0)),
            c_int_array("NAME_kept", kept),
            c_int_array("NAME_kind", library.kind[kept]),
            c_int_array("NAME_term", np.maximum(library.var[kept], 0)),
            c_array("NAME_frequency", library.frequency[kept]),
            c_array("NAME_coef", np.asarray(model.coef_, dtype=np.float64)[kept]),
        ]
    )
    names = library.names(list(model.lags_.names))
    outputs = list(model.output_names_)
    equation = []
    for o, output in enumerate(outputs):
        terms = [f"{model.coef_[k, o]:+.6g} {names[k]}" for k in kept if model.coef_[k, o] != 0]
        equation += textwrap.wrap(
            f"{output}(t) = {' '.join(terms) or '0'}",
            width=92,
            initial_indent="  ",
            subsequent_indent="      ",
            break_on_hyphens=False,
        )
    notes = [
        f"y(t) = sum of coef_i theta_i(w(t)) over the {int(kept.size)} kept library functions"
        " (NAME_kept:",
        "their library rows; kind 0 a monomial phi, 1 sin, 2 cos of one term); the monomials",
        "of degree >= 2 take the terms held in [hold_low, hold_high], the linear ones w itself",
        "(the coefficients rounded here, exact in the source):",
        *equation,
    ]
    return narx_model(
        model, "Sparse NARX, SINDy (neckid SparseNARX)", notes, constants, _SPARSE_MAP
    )
