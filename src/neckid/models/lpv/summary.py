"""An LPV-ARX's schedule in the scheduling variables' own units: for ``neckid info`` and export.

Every coefficient ``a_j(p)`` and the offset ``c(p)`` of a fitted
:class:`~neckid.models.lpv.model.LPVARX` is a polynomial of degree ``degree`` in the raw
scheduling terms (kg, deg, ...). The model stores it over standardised terms
(:mod:`neckid.models.lpv.schedule`); :func:`schedule_polynomials` gives it back in raw units,
read off the frozen models on the stability grid by least squares (exact to rounding inside the
held range, where the coefficients are those polynomials).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.models.lpv.schedule import frozen_coefficients, scheduling_grid
from neckid.models.polynomial.monomials import monomial_tables
from neckid.utils.types import FloatArray, IntArray

__all__ = ["describe_lpv", "schedule_lines", "schedule_polynomials"]


def _scheduling_terms(model: Any) -> list[int]:
    return [t for v in model.scheduling_ for t in v.terms]


def _monomial_text(powers: IntArray, names: list[str]) -> str:
    factors = [n if p == 1 else f"{n}^{int(p)}" for n, p in zip(names, powers, strict=True) if p]
    return "*".join(factors) or "1"


def schedule_polynomials(model: Any) -> tuple[IntArray, list[str], list[str], FloatArray]:
    """The coefficient polynomials in the raw scheduling terms.

    Returns
    -------
    powers : ndarray of int, shape (n_monomials, n_scheduling_terms)
        The monomials of ``p`` (graded order, the constant first).
    monomials : list of str
        Their names (``"payload^2"``; terms as named in ``lags_.names`` without ``(t)``).
    rows : list of str
        What each coefficient multiplies: the regressor terms with a non-zero schedule, then
        ``"offset"``.
    coef : ndarray, shape (n_rows, n_monomials, n_outputs)
        ``a_row(p) = Σ_k coef[row, k] Π p^powers[k]``.
    """
    terms = _scheduling_terms(model)
    powers, _, _, _ = monomial_tables(len(terms), int(model.degree))
    grid = scheduling_grid(model)
    frozen, offset = frozen_coefficients(model, grid)
    values = np.concatenate([frozen, offset[:, None, :]], axis=1)  # (points, terms + 1, out)
    design = np.prod(grid[:, terms][:, None, :] ** powers[None, :, :], axis=2)
    flat = values.reshape(values.shape[0], -1)
    solution, *_ = np.linalg.lstsq(design, flat, rcond=None)
    coef = solution.reshape(powers.shape[0], values.shape[1], values.shape[2]).transpose(1, 0, 2)
    coef[np.abs(coef) < 1e-12 * max(1.0, float(np.abs(coef).max()))] = 0.0
    names = [model.lags_.names[t].removesuffix("(t)") for t in terms]
    keep = [j for j in range(model.lags_.n_terms) if np.any(coef[j])] + [model.lags_.n_terms]
    rows = [*model.lags_.names, "offset"]
    return (
        np.asarray(powers, dtype=np.int64),
        [_monomial_text(p, names) for p in powers],
        [rows[j] for j in keep],
        np.ascontiguousarray(coef[keep]),
    )


def schedule_lines(model: Any, digits: int = 4) -> list[str]:
    """One line per output and coefficient: ``inclination: a[y(t-1)] = 1.6 - 0.2*payload``."""
    _, monomials, rows, coef = schedule_polynomials(model)
    lines = []
    for o, output in enumerate(model.output_names_):
        for r, row in enumerate(rows):
            terms = [
                f"{value:+.{digits}g}" + ("" if name == "1" else f"*{name}")
                for value, name in zip(coef[r, :, o], monomials, strict=True)
                if value != 0.0
            ]
            text = " ".join(terms).lstrip("+") or "0"
            label = "c" if row == "offset" else f"a[{row}]"
            lines.append(f"{output}: {label} = {text}")
    return lines


def describe_lpv(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted LPVARX (its registry entry's describer)."""
    powers, monomials, rows, coef = schedule_polynomials(model)
    terms = _scheduling_terms(model)
    radius = model.fit_report_.get("max_pole_radius")
    return "lpv_arx", {
        "equation": "y_o(t) = c_o(p) + sum_j a_jo(p) w_j(t); a_jo(p) = sum_k"
        " schedule_coef{o}(j, k) prod_i p_i^schedule_powers(k, i), p the scheduling terms"
        " (rows of schedule_rows: regressor terms, then the offset c); stored as the polynomial"
        " NARX coef over powers (x_k = (w_k - center_k) / scale_k, the scheduling terms held in"
        " [low_k, high_k] inside the monomials of degree >= 2)",
        "degree": int(model.degree),
        "scheduling": [v.name for v in model.scheduling_],
        "scheduling_kind": [v.kind for v in model.scheduling_],
        "scheduling_terms": [model.lags_.names[t] for t in terms],
        "schedule_powers": powers,
        "schedule_monomials": monomials,
        "schedule_rows": rows,
        "schedule_coef": [np.array(coef[:, :, o]) for o in range(coef.shape[2])],
        "max_pole_radius": float(radius) if radius is not None else float("nan"),
        "powers": np.array(model.powers_, dtype=np.int64),
        "coef": np.array(model.coef_, dtype=np.float64),
        "active": np.array(model.active_, dtype=bool),
        "center": np.array(model.center_, dtype=np.float64),
        "scale": np.array(model.scale_, dtype=np.float64),
        "low": np.array(model.low_, dtype=np.float64),
        "high": np.array(model.high_, dtype=np.float64),
    }
