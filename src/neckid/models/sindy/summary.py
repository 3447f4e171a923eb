"""The identified equation in words and units (``neckid info``), the export describer, file checks.

Each kept function's coefficient has the unit that makes its term an output: the output's unit
over the product of its factors' units (a sine or cosine is unitless), with equal units cancelled
(``deg / (deg·V)`` is ``1/V``).
"""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np

from neckid.models.sindy.library import KIND_NAMES, build_library

__all__ = ["check_library", "coefficient_unit", "describe_sindy", "equation_summary"]


def _term_units(model: Any) -> list[str]:
    """The unit of every regressor term (its channel's)."""
    r = model.lags_
    inputs = list(getattr(model, "input_units_", ())) or [""] * len(r.input_names)
    outputs = list(model.output_units_)
    return [
        (outputs if s == 0 else inputs)[int(c)] if (outputs if s == 0 else inputs) else ""
        for s, c in zip(r.source, r.channel, strict=True)
    ]


def coefficient_unit(output_unit: str, factors: Counter[str]) -> str:
    """The unit of a coefficient: ``output_unit`` over the factors' units (equal ones cancelled).

    Examples
    --------
    >>> coefficient_unit("deg", Counter({"deg": 1, "V": 1})), coefficient_unit("deg", Counter())
    ('1/V', 'deg')
    >>> coefficient_unit("deg", Counter({"deg": 3}))
    '1/deg^2'
    """
    powers: Counter[str] = Counter()
    if output_unit:
        powers[output_unit] += 1
    for unit, p in factors.items():
        if unit:
            powers[unit] -= p

    def shown(unit: str, p: int) -> str:
        return unit if p == 1 else f"{unit}^{p}"

    top = "·".join(shown(u, p) for u, p in powers.items() if p > 0)
    bottom = [shown(u, -p) for u, p in powers.items() if p < 0]
    if not bottom:
        return top or "-"
    below = bottom[0] if len(bottom) == 1 else f"({'·'.join(bottom)})"
    return f"{top or '1'}/{below}"


def _factors(model: Any, k: int, units: list[str]) -> Counter[str]:
    lib = model.library_
    if int(lib.kind[k]) != 0:
        return Counter()
    out: Counter[str] = Counter()
    for j, p in enumerate(lib.powers[k]):
        if p and units[j]:
            out[units[j]] += int(p)
    return out


def equation_summary(model: Any) -> dict[str, Any]:
    """The equation per output, and each kept term's coefficient, unit and (with bags) interval."""
    names = model.library_.names(model.lags_.names)
    units = _term_units(model)
    equations, terms = [], []
    for o, output in enumerate(model.output_names_):
        kept = np.flatnonzero(model.coef_[:, o])
        parts = [
            f"{'-' if model.coef_[k, o] < 0 else '+'} {abs(model.coef_[k, o]):.4g}"
            + ("" if names[k] == "1" else f" {names[k]}")
            for k in kept
        ]
        text = " ".join(parts).removeprefix("+ ") or "0"
        unit = model.output_units_[o]
        equations.append(f"{output}(t){f' [{unit}]' if unit else ''} = {text}")
        for k in kept:
            row: dict[str, Any] = {
                "output": output,
                "term": names[k],
                "coef": float(model.coef_[k, o]),
                "unit": coefficient_unit(unit, _factors(model, int(k), units)),
            }
            if model.coef_interval_ is not None:
                row["interval"] = [float(v) for v in model.coef_interval_[:, k, o]]
                row["inclusion"] = float(model.inclusion_[k, o])
            terms.append(row)
    return {
        "equations": equations,
        "terms": terms,
        "threshold": float(model.threshold_),
        "library_size": int(model.library_.size),
        "chosen_by": model.selection_.get("rule", "given"),
        "refined": bool(model.fit_report_.get("refined", False)),
        "bags": int(model.coef_bags_.shape[0]),
    }


def describe_sindy(model: Any) -> tuple[str, dict[str, Any]]:
    """``(structure, parameters)`` of a fitted SparseNARX (its registry entry's describer)."""
    lib = model.library_
    names = lib.names(model.lags_.names)
    return "sparse_narx", {
        "equation": "y_o(t) = sum_k coef(k, o) theta_k(w(t)), w the raw regressor terms;"
        " theta_k = prod_j w_j^powers(k, j) (kind 0), sin(frequency_k w_var(k)) (kind 1),"
        " cos(frequency_k w_var(k)) (kind 2); functions names row k; inside the monomials of"
        " degree >= 2 each w_j is held in [hold_low_j, hold_high_j] (the degree-1 ones use w_j)",
        "functions": names,
        "kind": [KIND_NAMES[int(v)] for v in lib.kind],
        "powers": np.array(lib.powers, dtype=np.int64),
        "var": np.array(lib.var, dtype=np.int64),
        "frequency": np.array(lib.frequency, dtype=np.float64),
        "coef": np.array(model.coef_, dtype=np.float64),
        "hold_low": np.array(model.hold_low_, dtype=np.float64),
        "hold_high": np.array(model.hold_high_, dtype=np.float64),
        "threshold": float(model.threshold_),
        "terms": equation_summary(model)["terms"],
    }


def check_library(model: Any) -> None:
    """Raise ``ValueError`` when a loaded model's arrays do not fit its lags and parameters."""
    n_terms = model.lags_.n_terms
    frequencies = [float(v) for v in np.asarray(model.trigonometric, dtype=np.float64).ravel()]
    expected = build_library(n_terms, int(model.degree), frequencies)
    lib = model.library_
    for name in ("kind", "powers", "var", "frequency"):
        got, want = getattr(lib, name), getattr(expected, name)
        if got.shape != want.shape or not np.array_equal(got, want):
            raise ValueError(
                f"library {name} does not list the degree-{model.degree} library of {n_terms}"
                f" terms and frequencies {frequencies}"
            )
    p, n_out = lib.size, model.n_outputs_
    model._check_shape("coef", model.coef_, (p, n_out))
    model._check_shape("allowed", model.allowed_, (p,))
    model._check_shape("scale", model.scale_, (p,))
    model._check_shape("y_scale", model.y_scale_, (n_out,))
    model._check_shape("hold_low", model.hold_low_, (n_terms,))
    model._check_shape("sums_gram", model.sums_.gram, (p, p))
    model._check_shape("sums_rhs", model.sums_.rhs, (p, n_out))
    model._check_shape("sums_y_sum", model.sums_.y_sum, (n_out,))
    model._check_shape("sums_y_square", model.sums_.y_square, (n_out,))
    model._check_shape("hold_high", model.hold_high_, (n_terms,))
    if not np.all(model.hold_low_ <= model.hold_high_):
        raise ValueError("hold_low must be <= hold_high")
    if model.coef_bags_.ndim != 3 or model.coef_bags_.shape[1:] != (p, n_out):
        raise ValueError(
            f"coef_bags must have shape (bags, {p}, {n_out}); got {model.coef_bags_.shape}"
        )
    for name in ("coef", "scale", "y_scale", "coef_bags"):
        if not np.all(np.isfinite(getattr(model, f"{name}_"))):
            raise ValueError(f"{name} must be finite")
    if not (np.all(model.scale_ > 0) and np.all(model.y_scale_ > 0)):
        raise ValueError("scale and y_scale must be > 0")
    if np.any(model.coef_[~model.allowed_] != 0):
        raise ValueError("coef must be zero outside the allowed functions")
