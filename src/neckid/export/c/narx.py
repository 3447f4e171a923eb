"""C exports of the NARX models: the shared history shell, and the ARX and polynomial maps.

Every NARX model steps the same way (:class:`neckid.models.base.NarxSimulator`): the state is
the last ``M = max(max_lag, 1)`` outputs and inputs; a step builds the regressor ``w(t)`` from
them and the new input, evaluates the model's map ``f(w)`` and shifts the history.
:func:`narx_model` writes that shell around a family's map; :func:`c_arx`, :func:`c_rls` and
:func:`c_polynomial` (``poly`` and ``lpv``, an LPV-ARX being the polynomial NARX that keeps the
monomials of its form) are the registry's ``c_export`` functions.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.export.c.literals import c_array, c_int_array
from neckid.export.c.program import CModel

__all__ = ["c_arx", "c_polynomial", "c_rls", "narx_model", "regressor_lines"]


def _term_names(model: Any) -> list[str]:
    return list(model.lags_.names)


def regressor_lines(model: Any, target: str = "w") -> str:
    """C lines filling ``w[j]`` from the history (``s->y``, ``s->u``) and the new input ``u``."""
    lags = model.lags_
    m = max(int(lags.max_lag), 1)
    lines = []
    for j, (source, channel, lag, name) in enumerate(
        zip(lags.source.tolist(), lags.channel.tolist(), lags.lag.tolist(), lags.names, strict=True)
    ):
        if source == 0:
            value = f"s->y[{m - lag}][{channel}]"
        elif lag == 0:
            value = f"u[{channel}]"
        else:
            value = f"s->u[{m - lag}][{channel}]"
        lines.append(f"    {target}[{j}] = {value};  /* {name} */\n")
    return "".join(lines)


def _shift_lines(m: int) -> str:
    """Drop the oldest row of the history and append the new input and output."""
    text = ""
    if m > 1:
        text += "    memmove(s->y[0], s->y[1], sizeof s->y - sizeof s->y[0]);\n"
        text += "    memmove(s->u[0], s->u[1], sizeof s->u - sizeof s->u[0]);\n"
    text += f"    memcpy(s->y[{m - 1}], out, sizeof out);\n"
    text += f"    memcpy(s->u[{m - 1}], u, sizeof s->u[{m - 1}]);\n"
    text += "    memcpy(y, out, sizeof out);\n"
    return text


def narx_model(
    model: Any,
    title: str,
    notes: list[str],
    constants: str,
    map_code: str,
    *,
    bounded: bool = False,
) -> CModel:
    """The history shell around ``map_code``.

    ``map_code`` reads ``w[]`` and writes ``out[]`` (and, when ``bounded``, ``lower[]`` and
    ``upper[]``).
    """
    m = max(int(model.max_lag_), 1)
    n_in, n_out = len(model.input_names_), len(model.output_names_)
    n_terms = int(model.lags_.n_terms)
    reset = (
        "    if (y0 != NULL) memcpy(s->y, y0, sizeof s->y);\n"
        "    else memset(s->y, 0, sizeof s->y);\n"
        "    if (u0 != NULL) memcpy(s->u, u0, sizeof s->u);\n"
        "    else memset(s->u, 0, sizeof s->u);\n"
    )
    step = (
        f"    double w[{max(n_terms, 1)}];\n"
        f"    double out[{n_out}];\n" + regressor_lines(model) + map_code + _shift_lines(m)
    )
    lags = model.lags_
    terms = [f"  w[{j}] = {name}" for j, name in enumerate(_term_names(model))] or ["  (no terms)"]
    shell = [
        "",
        f"Regressor w(t) of {n_terms} terms (s->y[M - l] is y(t - l), u the new input):",
        *terms,
        f"State: the last M = {m} outputs and inputs, oldest first (s->y[M - 1] = y(t - 1));",
        f"NAME_reset takes M = {m} rows of each (a constant history: repeat one row).",
        f"Initial rows: simulate's first max_lag = {int(lags.max_lag)} samples are the history.",
    ]
    return CModel(
        title=title,
        notes=[*notes, *shell],
        state=[
            (f"double y[{m}][{n_out}]", "past outputs y(t-M) ... y(t-1), oldest first"),
            (f"double u[{m}][{n_in}]", "past inputs u(t-M) ... u(t-1), oldest first"),
        ],
        constants=constants,
        reset=reset,
        step=step,
        n_inputs=n_in,
        n_outputs=n_out,
        reset_rows=m,
        ts=float(model.ts_),
        bounded=bounded,
        initial_rows=int(model.max_lag_),
    )


_LINEAR_MAP = (
    "    {\n"
    "        int o, k;\n"
    "        for (o = 0; o < NAME_N_OUTPUTS; ++o) {\n"
    "            double acc = 0.0;\n"
    "            for (k = 0; k < NAME_N_TERMS; ++k) acc += w[k] * NAME_coef[k][o];\n"
    "            out[o] = acc + NAME_intercept[o];\n"
    "        }\n"
    "    }\n"
)


def _linear(model: Any, title: str, coef: Any, intercept: Any) -> CModel:
    n_terms = int(model.lags_.n_terms)
    constants = "\n".join(
        [
            f"#define NAME_N_TERMS {n_terms}",
            c_array("NAME_coef", np.asarray(coef, dtype=np.float64).reshape(n_terms, -1)),
            c_array("NAME_intercept", np.asarray(intercept, dtype=np.float64).reshape(-1)),
        ]
    )
    notes = ["y(t) = coef' w(t) + intercept (summed term by term, then the intercept)"]
    return narx_model(model, title, notes, constants, _LINEAR_MAP)


def c_arx(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.LinearARX` (its registry entry's ``c_export``)."""
    return _linear(model, "Linear ARX (neckid LinearARX)", model.coef_, model.intercept_)


def c_rls(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.RecursiveARX`: the final estimate, no intercept."""
    zeros = np.zeros(len(model.output_names_))
    return _linear(model, "CFF-RLS ARX, final estimate (neckid RecursiveARX)", model.coef_, zeros)


_POLY_MAP = (
    "    {\n"
    "        double x[NAME_N_TERMS], held[NAME_N_TERMS], phi[NAME_N_MONOMIALS];\n"
    "        int j, k, c;\n"
    "        for (j = 0; j < NAME_N_TERMS; ++j) {\n"
    "            double v = (w[j] - NAME_center[j]) / NAME_scale[j];\n"
    "            x[j] = v;\n"
    "            if (!(v >= NAME_low[j])) v = NAME_low[j];\n"
    "            held[j] = v <= NAME_high[j] ? v : NAME_high[j];\n"
    "        }\n"
    "        phi[0] = 1.0;\n"
    "        for (k = 1; k < NAME_N_MONOMIALS; ++k) phi[k] = phi[NAME_parent[k]] * held[NAME_var[k]];\n"
    "        for (j = 0; j < NAME_N_TERMS; ++j) phi[1 + j] = x[j];\n"
    "        for (c = 0; c < NAME_N_OUTPUTS; ++c) {\n"
    "            double value = 0.0;\n"
    "            for (k = 0; k < NAME_N_MONOMIALS; ++k) value += phi[k] * NAME_coef[k][c];\n"
    "            if (!(value <= HUGE_VAL)) value = HUGE_VAL;  /* NaN: as the free run */\n"
    "            out[c] = value;\n"
    "        }\n"
    "    }\n"
)


def c_polynomial(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.PolynomialNARX` or :class:`~neckid.LPVARX`."""
    from neckid.models.polynomial.monomials import monomial_tables

    n_terms = int(model.lags_.n_terms)
    coef = np.asarray(model.coef_, dtype=np.float64)
    degree = 0  # the total degree whose graded monomials are the rows of coef_
    while monomial_tables(n_terms, degree)[1].shape[0] < coef.shape[0]:
        degree += 1
    _, parent, var, _ = monomial_tables(n_terms, degree)
    if parent.shape[0] != coef.shape[0]:
        raise ValueError(
            f"coef_ has {coef.shape[0]} rows, not the monomials of any degree in {n_terms} terms"
        )
    constants = "\n".join(
        [
            f"#define NAME_N_TERMS {n_terms}",
            f"#define NAME_N_MONOMIALS {int(parent.shape[0])}",
            c_array("NAME_coef", coef),
            c_array("NAME_center", model.center_),
            c_array("NAME_scale", model.scale_),
            c_array("NAME_low", model.low_),
            c_array("NAME_high", model.high_),
            c_int_array("NAME_parent", np.maximum(parent, 0)),
            c_int_array("NAME_var", np.maximum(var, 0)),
        ]
    )
    kind = type(model).__name__
    notes = [
        f"y(t) = coef' phi(x(t)), phi the {int(parent.shape[0])} monomials of degree <= {degree}"
        " of x = (w - center) ./ scale (graded; phi_k = phi_parent[k] * x_var[k]), those of",
        "degree >= 2 built from x held in [low, high], the linear ones from x itself",
    ]
    return narx_model(model, f"Polynomial NARX (neckid {kind})", notes, constants, _POLY_MAP)
