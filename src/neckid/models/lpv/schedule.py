r"""The scheduling of an LPV-ARX: its variables, its monomials and the model frozen at one value.

An LPV-ARX over the regressor :math:`w(t)` of a :class:`~neckid.Lags` is

.. math::

    y(t) = c(p) + \sum_j a_j(p)\, w_j(t),

every coefficient a polynomial of total degree ``degree`` in the scheduling variables
:math:`p(t)`. The model is written as a :class:`~neckid.PolynomialNARX` over the same
standardised regressor that keeps only the monomials of that form (:func:`lpv_monomials`): at
most one factor that is not a scheduling term, times a monomial of the scheduling terms.

A scheduling variable is one of

* a *condition* (``IOData`` conditions, e.g. the payload): its constant input of lag 0 (a label
  condition: its one-hot indicators). It is no dynamic term of its own: with it frozen, its
  monomials are part of the offset :math:`c(p)`;
* a *measured channel*, an output (the inclination, as in the seed paper's
  :math:`G(z, i) = N(i) / (z − P(i))`) or an input: its most recent term in the regressor
  (``y(t−1)`` for the lags ``[1, 2]``). That term is a dynamic regressor too, so the monomials of
  it alone reach degree ``degree + 1``: :math:`a(p)\,y(t−1)` with :math:`p = y(t−1)`
  (a quasi-LPV model; in a free run it reads the model's own output).

Frozen at a value of :math:`p` the model is a linear ARX (:func:`frozen_coefficients`), whose
poles say whether it is stable there (:func:`frozen_radius`).

References
----------
R. Tóth, *Modeling and Identification of Linear Parameter-Varying Systems*, Lecture Notes in
Control and Information Sciences 403, Springer, 2010 (ch. 3 and 6: LPV-ARX with static
polynomial dependence).
B. Bamieh, L. Giarré, "Identification of linear parameter varying models", *Int. J. Robust and
Nonlinear Control* 12(9), 841-853, 2002 (LPV-ARX by least squares on the scheduling products).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from neckid.regressors import ResolvedLags
from neckid.utils.types import FloatArray, IntArray

__all__ = [
    "KINDS",
    "MAX_GRID_POINTS",
    "ScheduleVariable",
    "carriers",
    "frozen_coefficients",
    "frozen_radius",
    "lpv_monomials",
    "raw_coefficients",
    "resolve_scheduling",
    "scheduling_grid",
]

#: The kinds of scheduling variable.
KINDS = ("condition", "output", "input")

#: Most points of the grid the stability of a fit is checked on (over every scheduling term).
MAX_GRID_POINTS = 4096

#: Points per scheduling term of that grid (fewer when there are several terms).
GRID_POINTS = 41


@dataclass(frozen=True)
class ScheduleVariable:
    """One scheduling variable bound to the regressor terms it reads.

    Attributes
    ----------
    name : str
        As the user named it: a condition (``"payload"``) or a channel (``"inclination"``).
    kind : {"condition", "output", "input"}
    terms : tuple of int
        Rows of the regressor (``lags_.names``) it is: one for a channel or a numeric condition,
        the indicators of a label condition.
    """

    name: str
    kind: str
    terms: tuple[int, ...]

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable (for model files)."""
        return {"name": self.name, "kind": self.kind, "terms": list(self.terms)}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], n_terms: int) -> ScheduleVariable:
        """Inverse of :meth:`to_dict`, checked against a regressor of ``n_terms`` terms."""
        kind, terms = str(d["kind"]), tuple(int(t) for t in d["terms"])
        if kind not in KINDS:
            raise ValueError(f"scheduling kind must be one of {list(KINDS)}; got {kind!r}")
        if not terms or any(not 0 <= t < n_terms for t in terms):
            raise ValueError(
                f"scheduling {d['name']!r} names regressor terms {list(terms)}, outside the"
                f" {n_terms} terms of the model"
            )
        if kind != "condition" and len(terms) != 1:
            raise ValueError(f"a measured scheduling channel reads one term; got {list(terms)}")
        return cls(str(d["name"]), kind, terms)


def _names(scheduling: str | Sequence[str] | None, lags: ResolvedLags) -> list[str]:
    """The scheduling names: given (``"a,b"`` or a list), else the conditions or the first output."""
    if scheduling is None:
        ordered = list(dict.fromkeys(c.split("=")[0] for c in lags.conditions))
        return ordered or [lags.output_names[0]]
    names = scheduling.split(",") if isinstance(scheduling, str) else list(scheduling)
    if not names or not all(isinstance(n, str) and n.strip() for n in names):
        raise ValueError(f"scheduling must name one variable or more; got {scheduling!r}")
    names = [n.strip() for n in names]
    if len(set(names)) != len(names):
        raise ValueError(f"scheduling names a variable twice: {names}")
    return names


def resolve_scheduling(
    scheduling: str | Sequence[str] | None, lags: ResolvedLags
) -> tuple[ScheduleVariable, ...]:
    """Bind the scheduling names to the regressor ``lags`` (see the module docstring).

    Raises
    ------
    ValueError
        For a name that is neither a condition of the lags nor a channel with a term in them.
    """
    out: list[ScheduleVariable] = []
    for name in _names(scheduling, lags):
        condition = [c for c in lags.conditions if c == name or c.startswith(f"{name}=")]
        if condition:
            columns = [lags.input_names.index(c) for c in condition]
            terms = [
                j for j in range(lags.n_terms) if lags.source[j] == 1 and lags.channel[j] in columns
            ]
            out.append(ScheduleVariable(name, "condition", tuple(terms)))
            continue
        for source, kind, channels in (
            (0, "output", lags.output_names),
            (1, "input", lags.input_names),
        ):
            if name in channels:
                rows = [
                    j
                    for j in range(lags.n_terms)
                    if lags.source[j] == source and lags.channel[j] == channels.index(name)
                ]
                if not rows:
                    raise ValueError(
                        f"scheduling {name!r} is an {kind} with no term in the lags"
                        f" {list(lags.names)}; give it a lag (its most recent term schedules)"
                    )
                latest = min(rows, key=lambda j: int(lags.lag[j]))
                out.append(ScheduleVariable(name, kind, (latest,)))
                break
        else:
            raise ValueError(
                f"scheduling {name!r} is neither a condition of the lags"
                f" ({[c.split('=')[0] for c in lags.conditions] or 'none'}) nor a channel"
                f" (inputs {list(lags.input_names)}, outputs {list(lags.output_names)});"
                " add it with Lags(..., conditions=[...]) or name a channel"
            )
    taken = [t for v in out for t in v.terms]
    if len(set(taken)) != len(taken):
        raise ValueError(f"scheduling reads one regressor term twice: {[v.name for v in out]}")
    return tuple(out)


def _term_kinds(variables: Sequence[ScheduleVariable], n_terms: int) -> IntArray:
    """Per regressor term: 0 not scheduling, 1 a condition's, 2 a measured channel's."""
    kind = np.zeros(n_terms, dtype=np.int64)
    for v in variables:
        kind[list(v.terms)] = 1 if v.kind == "condition" else 2
    return kind


def lpv_monomials(
    powers: NDArray[np.int64], variables: Sequence[ScheduleVariable], degree: int
) -> NDArray[np.bool_]:
    """Which monomials (rows of ``powers``) an LPV-ARX of schedule ``degree`` holds.

    At most one factor of power 1 that is not a scheduling term, times scheduling terms of total
    power ``<= degree``; without such a factor, one more for a monomial that holds a measured
    scheduling term (that term is then the dynamic factor).
    """
    kind = _term_kinds(variables, powers.shape[1])
    dynamic = powers[:, kind == 0].sum(axis=1)
    scheduled = powers[:, kind > 0].sum(axis=1)
    measured = powers[:, kind == 2].sum(axis=1)
    bound = degree + ((dynamic == 0) & (measured > 0))
    return np.asarray((dynamic <= 1) & (scheduled <= bound), dtype=bool)


def carriers(
    powers: NDArray[np.int64], variables: Sequence[ScheduleVariable]
) -> tuple[IntArray, NDArray[np.int64]]:
    """Per monomial: the regressor term its coefficient multiplies, and its scheduling powers.

    Returns
    -------
    carrier : ndarray of int, shape (n_monomials,)
        The dynamic factor (a term that is not scheduling, else the first measured scheduling
        term of the monomial), ``-1`` for a monomial of the offset ``c(p)``.
    schedule : ndarray of int, shape (n_monomials, n_terms)
        The powers without the carrier's: the other scheduling terms' factor.
    """
    kind = _term_kinds(variables, powers.shape[1])
    carrier = np.full(powers.shape[0], -1, dtype=np.int64)
    schedule = np.array(powers, dtype=np.int64)
    for m, row in enumerate(powers):
        for wanted in (0, 2):
            found = np.flatnonzero((row > 0) & (kind == wanted))
            if found.size:
                carrier[m] = found[0]
                schedule[m, found[0]] = 0
                break
    return carrier, schedule


def raw_coefficients(model: Any, coef: FloatArray | None = None) -> FloatArray:
    """The model's polynomial over the raw regressor terms (rows of ``powers_``).

    The model stores it over the standardised terms ``x_i = (w_i − center_i) / scale_i``; each
    monomial ``Π x_i^k_i`` expands binomially into monomials of ``w`` of no higher powers (all
    in the LPV form when it is). Exact inside the held range, where no term is held.
    """
    powers = np.asarray(model.powers_, dtype=np.int64)
    theta = np.asarray(model.coef_ if coef is None else coef, dtype=np.float64)
    row_of = {tuple(int(v) for v in row): m for m, row in enumerate(powers)}
    a, b = 1.0 / model.scale_, -model.center_ / model.scale_
    raw = np.zeros_like(theta)
    for m in np.flatnonzero(model.active_):
        exponents = powers[m]
        for kept in itertools.product(*(range(int(k) + 1) for k in exponents)):
            weight = 1.0
            for i, (k, r) in enumerate(zip(exponents, kept, strict=True)):
                if k:
                    weight *= math.comb(int(k), r) * a[i] ** r * b[i] ** (int(k) - r)
            raw[row_of[kept]] += weight * theta[m]
    return raw


def frozen_coefficients(
    model: Any, points: FloatArray, coef: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """The ARX an LPV-ARX is at scheduling values ``points``, in the regressor's units.

    Each raw monomial (:func:`raw_coefficients`) goes to its carrier (:func:`carriers`): a term
    that does not schedule, times the scheduling values; a measured scheduling term ``s`` of
    power ``k``, ``s^k = s^(k−1) · s``; or the offset. Scheduling values beyond the held range
    are taken at its edge.

    Parameters
    ----------
    model : LPVARX
        Fitted.
    points : ndarray, shape (n_points, n_terms)
        Raw regressor values; only the scheduling terms' columns are read.
    coef : ndarray, optional
        Monomial coefficients in place of ``model.coef_``.

    Returns
    -------
    coef : ndarray, shape (n_points, n_terms, n_outputs)
        ``a_j(p)`` of ``y(t) = c(p) + Σ_j a_j(p) w_j(t)`` (zero for a condition's terms).
    offset : ndarray, shape (n_points, n_outputs)
        ``c(p)``.
    """
    powers = np.asarray(model.powers_, dtype=np.int64)
    carrier, schedule = carriers(powers, model.scheduling_)
    raw = raw_coefficients(model, coef)
    terms = [t for v in model.scheduling_ for t in v.terms]
    low = model.center_[terms] + model.scale_[terms] * model.low_[terms]
    high = model.center_[terms] + model.scale_[terms] * model.high_[terms]
    values = np.ones_like(np.asarray(points, dtype=np.float64))
    values[:, terms] = np.clip(np.asarray(points, dtype=np.float64)[:, terms], low, high)
    n_points, n_terms = values.shape
    frozen = np.zeros((n_points, n_terms, raw.shape[1]))
    offset = np.zeros((n_points, raw.shape[1]))
    for m in np.flatnonzero(np.any(raw != 0.0, axis=1)):
        factor = np.prod(values ** schedule[m], axis=1)
        j = int(carrier[m])
        if j < 0:
            offset += factor[:, None] * raw[m]
            continue
        factor = factor * values[:, j] ** (int(powers[m, j]) - 1)  # 1 for a dynamic term
        frozen[:, j] += factor[:, None] * raw[m]
    return frozen, offset


def frozen_radius(lags: ResolvedLags, coef: FloatArray) -> FloatArray:
    """The largest pole modulus of each frozen ARX (``coef`` from :func:`frozen_coefficients`)."""
    n_points, _, n_out = coef.shape
    outputs = np.flatnonzero(lags.source == 0)
    order = int(lags.lag[outputs].max()) if outputs.size else 0
    if order == 0:
        return np.zeros(n_points)
    companion = np.zeros((n_points, order * n_out, order * n_out))
    for j in outputs:  # y_o(t) += coef[j, o] y_c(t − l): block row 0, block column l − 1
        column = (int(lags.lag[j]) - 1) * n_out + int(lags.channel[j])
        companion[:, :n_out, column] += coef[:, j, :]
    companion[:, n_out:, :-n_out] = np.eye((order - 1) * n_out)
    return np.asarray(np.abs(np.linalg.eigvals(companion)).max(axis=1), dtype=np.float64)


def scheduling_grid(model: Any) -> FloatArray:
    """Raw regressor rows over the held range of every scheduling term (a product grid).

    ``GRID_POINTS`` values per term, fewer when there are several, at most
    ``MAX_GRID_POINTS`` rows; the terms that do not schedule sit at their training mean.
    """
    terms = [t for v in model.scheduling_ for t in v.terms]
    per_term = max(2, min(GRID_POINTS, int(MAX_GRID_POINTS ** (1.0 / len(terms)))))
    axes = [
        model.center_[t] + model.scale_[t] * np.linspace(model.low_[t], model.high_[t], per_term)
        for t in terms
    ]
    rows = np.array(list(itertools.product(*axes)), dtype=np.float64)
    grid = np.tile(model.center_, (rows.shape[0], 1))
    grid[:, terms] = rows
    return grid
