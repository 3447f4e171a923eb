r"""LPVARX: an ARX whose coefficients are polynomials in scheduling variables (LPV-ARX).

.. math::

    y(t) = c(p(t)) + \sum_j a_j(p(t))\, w_j(t),

with :math:`w(t)` the regressor of ``lags`` and every :math:`a_j`, :math:`c` a polynomial of
total degree ``degree`` in the scheduling variables :math:`p` (conditions such as the payload,
or measured channels such as the inclination; :mod:`neckid.models.lpv.schedule`). Degree 0 is
the ARX; the seed paper's :math:`G(z, i) = N(i) / (z − P(i))` is the first-order case scheduled
on the inclination.

The fit is Bamieh & Giarré's: least squares on the regressor terms times the monomials of
:math:`p` (the products, standardised), then, with ``fit_for="simulation"``, Levenberg–Marquardt
on the free-run error of the training runs from that start, as :class:`~neckid.PolynomialNARX`
does (an LPV-ARX is the polynomial NARX that keeps only the monomials of that form). On a
lightly damped plant the equation-error fit alone is biased (the noise enters through the
output lags); the free-run fit removes most of that. A fitted model is stable at every frozen
scheduling value of its range (checked on a grid; the check falls back to a stable start or
refuses the fit, see :meth:`LPVARX.fit`).

References
----------
R. Tóth, *Modeling and Identification of Linear Parameter-Varying Systems*, Springer, 2010.
B. Bamieh, L. Giarré, "Identification of linear parameter varying models", *Int. J. Robust and
Nonlinear Control* 12(9), 841-853, 2002.
"""

from __future__ import annotations

import logging
import warnings
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from neckid.data.iodata import IOData
from neckid.models.base import check_is_fitted
from neckid.models.linear.arx import LinearARX
from neckid.models.lpv.schedule import (
    ScheduleVariable,
    frozen_coefficients,
    frozen_radius,
    lpv_monomials,
    resolve_scheduling,
    scheduling_grid,
)
from neckid.models.lpv.summary import schedule_lines
from neckid.models.polynomial.narx import PolynomialNARX
from neckid.regressors import Lags, ResolvedLags
from neckid.utils.checks import Interval, Options
from neckid.utils.types import FloatArray

__all__ = ["BACKTRACK", "LPVARX", "MEASURED_MARGIN", "STABILITY_MARGIN"]

logger = logging.getLogger(__name__)

#: A frozen model counts as stable when its largest pole modulus is below this.
STABILITY_MARGIN = 1.0 - 1e-9

#: ``hold_margin`` of a measured scheduling channel by default (the polynomial NARX's).
MEASURED_MARGIN = 0.5

#: How far from a stable start towards an unstable free-run fit the stable points tried lie.
BACKTRACK = (0.99, 0.97, 0.93, 0.85, 0.7, 0.5, 0.3, 0.1, 0.0)


class LPVARX(PolynomialNARX):
    """Linear parameter-varying ARX: coefficients polynomial in conditions or measured channels.

    Parameters
    ----------
    lags : Lags
        The regressor, e.g. ``Lags.arx(2, 2, conditions=...)``: ``Lags([1, 2], [1, 2],
        conditions=["payload"])`` to schedule on the payload.
    scheduling : str or sequence of str, optional
        The scheduling variables: conditions of ``lags`` (``"payload"``) or channels
        (``"inclination"``: its most recent term in the regressor, e.g. ``y(t−1)``); a string
        may list several separated by commas. ``None``: the conditions of ``lags``, or, without
        any, the first output (the seed paper's :math:`G(z, i)`).
    degree : int, default 2
        Total degree of the coefficient polynomials in the scheduling variables (0: an ARX).
    fit_for : {"simulation", "prediction"}, default "simulation"
        ``"prediction"``: the least squares only. ``"simulation"``: then the free-run error.
    ridge : float, default 0.0
        Tikhonov regularisation of the least-squares step (on the standardised products).
    max_iter : int, default 100
        Largest number of free runs the simulation fit may spend.
    hold_margin : float, optional
        Beyond the training range of each scheduling term widened by this fraction of it, the
        schedule holds its edge value (a condition's coefficients stop changing; its degree-1
        offset term goes on). The stability check covers that range. ``None``: 0 for a
        condition, :data:`MEASURED_MARGIN` for a measured channel, whose held monomials hold
        its dynamic factor too (beyond the range only its degree-1 term goes on, which is not
        the model frozen at the edge: give a free run room to leave the training range).

    Attributes
    ----------
    scheduling_ : tuple of ScheduleVariable
        The scheduling variables, their kinds and regressor terms.
    coef_, powers_, active_, center_, scale_, low_, high_, statistics_
        As :class:`~neckid.PolynomialNARX` (the monomials outside the LPV form are inactive).
    fit_report_ : dict
        As :class:`~neckid.PolynomialNARX`, plus ``max_pole_radius`` (the largest frozen pole
        modulus over the grid) and ``max_pole_at`` (where), and ``stability`` when the free-run
        fit was unstable somewhere and a start was kept instead.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> from neckid.models.lpv import LPVARX
    >>> rng = np.random.default_rng(0)
    >>> runs = []
    >>> for m in (0.0, 0.5, 1.0):  # the pole moves with the payload
    ...     u = np.repeat(rng.uniform(-1, 1, 40), 10)
    ...     y = np.zeros(400)
    ...     for t in range(1, 400):
    ...         y[t] = (0.5 + 0.3 * m) * y[t - 1] + u[t - 1]
    ...     runs.append(IOData(u, y, ts=0.05).with_conditions(payload=m))
    >>> model = LPVARX(Lags([1], [1], conditions=["payload"]), degree=1).fit(runs)
    >>> float(np.round(model.frozen(payload=0.25).coef_[0, 0], 4))
    0.575
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "scheduling": [None, str, list, tuple],
        "degree": [Interval("int", 0, 4)],
        "fit_for": [Options({"simulation", "prediction"})],
        "ridge": [Interval("real", 0, None)],
        "max_iter": [Interval("int", 1, None)],
        "hold_margin": [None, Interval("real", 0, None)],
    }

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        scheduling: str | Sequence[str] | None = None,
        degree: int = 2,
        fit_for: str = "simulation",
        ridge: float = 0.0,
        max_iter: int = 100,
        hold_margin: float | None = None,
    ) -> None:
        self.lags = lags
        self.scheduling = scheduling
        self.degree = degree
        self.fit_for = fit_for
        self.ridge = ridge
        self.max_iter = max_iter
        self.hold_margin = hold_margin  # type: ignore[assignment]  # None: by kind, _hold_range

    # ------------------------------------------------------------------ the LPV form
    def _total_degree(self) -> int:
        return int(self.degree) + 1  # a dynamic term times a schedule of degree ``degree``

    def _fit_regression(self, x: FloatArray, y: FloatArray) -> None:
        self.scheduling_ = resolve_scheduling(self.scheduling, self.lags_)
        super()._fit_regression(x, y)

    def _hold_range(self, low: FloatArray, high: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Scheduling terms held at their widened training range; the others never held."""
        never = np.finfo(np.float64).max  # finite, for the model file: never reached
        out_low, out_high = np.full_like(low, -never), np.full_like(high, never)
        for v in self.scheduling_:
            margin = self.hold_margin
            if margin is None:
                margin = 0.0 if v.kind == "condition" else MEASURED_MARGIN
            terms = list(v.terms)
            width = float(margin) * (high[terms] - low[terms])
            out_low[terms], out_high[terms] = low[terms] - width, high[terms] + width
        return out_low, out_high

    def _allowed_monomials(self, powers: NDArray[np.int64]) -> NDArray[np.bool_]:
        return lpv_monomials(powers, self.scheduling_, int(self.degree))

    # ------------------------------------------------------------------ fitting
    def fit(self, data: IOData | Sequence[IOData]) -> LPVARX:
        """Least squares on the scheduling products, then the free-run error; stable or refused.

        Raises
        ------
        ValueError
            For a scheduling name that is neither a condition of ``lags`` nor a channel with a
            term in them; when the model is unstable at some scheduling value of the held range
            and so is every start (the message names the value and the pole modulus).
        """
        super().fit(data)
        radius, where = self.pole_radius()
        if not radius < STABILITY_MARGIN:
            del self.max_lag_  # not a usable fit
            raise ValueError(
                f"the LPV model is unstable at {where}: a frozen pole of modulus {radius:.4f};"
                " try a lower degree, other lags or more training runs"
            )
        self.fit_report_ = {**self.fit_report_, "max_pole_radius": radius, "max_pole_at": where}
        return self

    def _fit_simulation(
        self, experiments: list[IOData], budget: int, linear: FloatArray | None
    ) -> None:
        """The free-run fit, kept stable on the scheduling grid.

        Where the free-run fit ends with a frozen pole on or outside the unit circle somewhere on
        the grid, the coefficients go back along the line from each stable start (the
        least-squares LPV, the linear ARX) towards it (:data:`BACKTRACK` of the way): of the
        stable points, the one with the least training free-run error is kept, and
        ``fit_report_["stability"]`` says so.
        """
        starts = [("least-squares LPV", self.coef_.copy())]
        if linear is not None:
            starts.append(("linear ARX", np.where(self.active_[:, None], linear, 0.0)))
        super()._fit_simulation(experiments, budget, linear)
        radius, where = self.pole_radius()
        if radius < STABILITY_MARGIN:
            return
        refined = self.coef_.copy()
        best: tuple[float, FloatArray, str, float] | None = None
        for label, start in starts:
            if not self.pole_radius(start)[0] < STABILITY_MARGIN:
                continue
            for share in BACKTRACK:
                trial = start + share * (refined - start)
                if self.pole_radius(trial)[0] < STABILITY_MARGIN:
                    cost = self._free_run_cost(experiments, trial)
                    if best is None or cost < best[0]:
                        best = (cost, trial, label, share)
        if best is None:
            return  # fit() refuses the model, naming where it is unstable
        self.coef_ = best[1]
        self.fit_report_["stability"] = (
            f"the free-run fit had a frozen pole of modulus {radius:.4f} at {where}; kept the"
            f" stable point {best[3]:.0%} of the way from the {best[2]} start to it"
        )
        logger.warning("LPV-ARX: %s", self.fit_report_["stability"])

    def _free_run_cost(self, experiments: list[IOData], coef: FloatArray) -> float:
        """The training free-run error of ``coef`` (outputs weighted by 1/std), inf if it fails."""
        saved, self.coef_ = self.coef_, coef
        try:
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore")
                y = np.vstack([d.y for d in experiments])
                weight = 1.0 / np.where(y.std(axis=0) > 0, y.std(axis=0), 1.0)
                total = 0.0
                for d in experiments:
                    error = (self.simulate(d).y - d.y)[self.max_lag_ :] * weight
                    total += float(np.sum(error**2))
        except (ValueError, ArithmeticError):  # a run away (DivergenceError is a ValueError)
            total = np.inf
        finally:
            self.coef_ = saved
        return total if np.isfinite(total) else np.inf

    # ------------------------------------------------------------------ frozen models
    def pole_radius(self, coef: FloatArray | None = None) -> tuple[float, dict[str, float]]:
        """The largest frozen pole modulus over the scheduling grid, and where it is.

        The grid spans the held range of every scheduling term
        (:func:`~neckid.models.lpv.schedule.scheduling_grid`); ``coef`` replaces ``coef_``.
        """
        grid = scheduling_grid(self)
        frozen, _ = frozen_coefficients(self, grid, coef)
        radius = frozen_radius(self.lags_, frozen)
        worst = int(np.argmax(radius))
        names = self.lags_.names
        where = {names[t]: float(grid[worst, t]) for v in self.scheduling_ for t in v.terms}
        return float(radius[worst]), where

    def _point(self, values: Mapping[str, Any]) -> FloatArray:
        """A raw regressor row with the scheduling terms at ``values`` (by variable name)."""
        missing = [v.name for v in self.scheduling_ if v.name not in values]
        unknown = [k for k in values if k not in {v.name for v in self.scheduling_}]
        if missing or unknown:
            raise ValueError(
                f"scheduling values must name {[v.name for v in self.scheduling_]};"
                f" got {sorted(values)}"
            )
        row = np.array(self.center_, dtype=np.float64)
        for v in self.scheduling_:
            value = values[v.name]
            if len(v.terms) == 1 and not isinstance(value, str):
                row[v.terms[0]] = float(value)
                continue
            indicators = [self.lags_.names[t].removesuffix("(t)") for t in v.terms]
            if f"{v.name}={value}" not in indicators:
                raise ValueError(
                    f"{v.name} must be one of {[i.split('=', 1)[1] for i in indicators]};"
                    f" got {value!r}"
                )
            for t, indicator in zip(v.terms, indicators, strict=True):
                row[t] = float(indicator == f"{v.name}={value}")
        return row

    def frozen(self, **values: Any) -> LinearARX:
        """The linear ARX the model is at fixed scheduling values (``frozen(payload=0.4)``).

        A condition that schedules is no input of the frozen model (its value is in the
        coefficients and the intercept); a measured scheduling channel stays a regressor term,
        its coefficient the schedule's value there. Export it with
        :func:`neckid.export.control.to_control`.

        Raises
        ------
        ValueError
            When ``values`` does not name every scheduling variable (and no other), or a label
            condition gets a label it was not trained on.
        """
        check_is_fitted(self)
        coef, offset = frozen_coefficients(self, self._point(values)[None, :])
        dropped = {t for v in self.scheduling_ if v.kind == "condition" for t in v.terms}
        keep = [j for j in range(self.lags_.n_terms) if j not in dropped]
        lags, meta = _reduced(self, keep)
        model = LinearARX(lags.to_lags())
        model._restore_narx_meta({**self._narx_meta(), **meta, "lags": lags.to_dict()})
        model.coef_ = np.ascontiguousarray(coef[0, keep])
        model.intercept_ = np.asarray(offset[0], dtype=np.float64)
        model.statistics_ = None
        return model

    def schedule_summary(self) -> dict[str, Any]:
        """``{"scheduling": describe_scheduling()}``: what ``neckid info`` shows of it."""
        return {"scheduling": self.describe_scheduling()}

    def describe_scheduling(self) -> dict[str, Any]:
        """The scheduling in words (``neckid info``): variables, ranges, polynomials, poles.

        ``polynomials`` has one line per output and coefficient, ``a[term] = ...`` and the offset
        ``c = ...``, in the scheduling terms' own units
        (:func:`~neckid.models.lpv.summary.schedule_lines`).
        """
        check_is_fitted(self)
        variables = []
        for v in self.scheduling_:
            terms = list(v.terms)
            low = self.center_[terms] + self.scale_[terms] * self.low_[terms]
            high = self.center_[terms] + self.scale_[terms] * self.high_[terms]
            variables.append(
                {
                    "name": v.name,
                    "kind": v.kind,
                    "term": ", ".join(self.lags_.names[t] for t in terms),
                    "range": [float(low.min()), float(high.max())],
                }
            )
        return {
            "degree": int(self.degree),
            "variables": variables,
            "max_pole_radius": float(self.pole_radius()[0]),
            "polynomials": schedule_lines(self),
            "stability": self.fit_report_.get("stability", ""),
        }

    # ------------------------------------------------------------------ files
    def _check_state(self) -> None:
        super()._check_state()
        allowed = lpv_monomials(np.asarray(self.powers_), self.scheduling_, int(self.degree))
        if np.any(np.asarray(self.active_) & ~allowed):
            raise ValueError("active marks monomials outside the LPV form of the scheduling")

    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        arrays = {
            "coef": self.coef_,
            "powers": self.powers_,
            "active": self.active_.astype(np.int8),
            "center": self.center_,
            "scale": self.scale_,
            "low": self.low_,
            "high": self.high_,
            **self.statistics_.to_arrays("statistics_"),
        }
        meta: dict[str, Any] = {"fit_report": self.fit_report_, **self._narx_meta()}
        scheduling = self.scheduling
        meta["params"] = {
            "scheduling": scheduling
            if scheduling is None or isinstance(scheduling, str)
            else list(scheduling),
            "degree": int(self.degree),
            "fit_for": str(self.fit_for),
            "ridge": float(self.ridge),
            "max_iter": int(self.max_iter),
            "hold_margin": None if self.hold_margin is None else float(self.hold_margin),
        }
        meta["scheduling"] = [v.to_dict() for v in self.scheduling_]
        return arrays, meta

    @classmethod
    def _from_state(cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]) -> LPVARX:
        model = super()._from_state(arrays, meta)
        if not isinstance(model, LPVARX):  # pragma: no cover - the parent builds ``cls``
            raise TypeError("an LPVARX file did not load as an LPVARX")
        entries = meta.get("scheduling")
        if not isinstance(entries, list) or not entries:
            raise ValueError("an LPVARX file must list its scheduling variables")
        model.scheduling_ = tuple(
            ScheduleVariable.from_dict(d, model.lags_.n_terms) for d in entries
        )
        return model


def _reduced(model: LPVARX, keep: list[int]) -> tuple[ResolvedLags, dict[str, Any]]:
    """The regressor of ``model`` with only the terms ``keep``, its unused inputs dropped."""
    r = model.lags_
    used = sorted({int(r.channel[j]) for j in keep if r.source[j] == 1})
    dropped = {n for c, n in enumerate(r.input_names) if c not in used and n in r.conditions}
    inputs = [c for c in range(len(r.input_names)) if r.input_names[c] not in dropped]
    index = {c: k for k, c in enumerate(inputs)}
    channel = [int(r.channel[j]) if r.source[j] == 0 else index[int(r.channel[j])] for j in keep]
    names = tuple(r.input_names[c] for c in inputs)
    lags = ResolvedLags(
        source=r.source[keep],
        channel=np.asarray(channel, dtype=np.int64),
        lag=r.lag[keep],
        names=tuple(r.names[j] for j in keep),
        input_names=names,
        output_names=r.output_names,
        max_lag=int(r.lag[keep].max()),
        conditions=tuple(c for c in r.conditions if c not in dropped),
    )
    units = list(getattr(model, "input_units_", ())) or [""] * len(r.input_names)
    ranges = getattr(model, "training_ranges_", {})
    terms = getattr(model, "regressor_ranges_", {})
    meta = {
        "input_names": list(names),
        "input_units": [units[c] for c in inputs],
        "training_ranges": {k: list(v) for k, v in ranges.items() if k not in dropped},
        "regressor_ranges": {k: list(v) for k, v in terms.items() if k in lags.names},
    }
    return lags, meta
