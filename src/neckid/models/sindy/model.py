r"""SparseNARX: sparse identification of a discrete-time NARX with inputs (SINDy with control).

.. math::

    y(t) = Θ(w(t))\, ξ, \qquad w(t) = \text{past outputs, inputs and conditions of } \texttt{lags},

with ``Θ`` a library of candidate functions of the raw regressor (monomials of degree <=
``degree``, optionally sines, cosines and user functions: :mod:`neckid.models.sindy.library`)
and ``ξ`` sparse, found by sequentially thresholded least squares (:mod:`neckid.models.sindy.stlsq`).
This is SINDy with control in discrete time (Brunton, Proctor & Kutz 2016; Kaiser, Kutz &
Brunton 2018): the equation it returns has few terms, each readable in the channels' units.

The threshold is chosen on the training data by the selection rule of every neckid selection
(:mod:`neckid.models.sindy.selection`). With ``ensemble`` > 0 the rows are resampled with
replacement and STLSQ is run again on each bag at the chosen threshold (bagging, Fasel et al.
2022): the spread of the bags' coefficients gives an interval per term and the share of bags that
keep it. With ``fit_for="simulation"`` (the default) the kept coefficients are then fitted on
the free-run error of the training experiments, as the polynomial NARX's are (the sparsity is
kept; the refit is taken only when it lowers that error).

References
----------
S. L. Brunton, J. L. Proctor, J. N. Kutz, "Discovering governing equations from data by sparse
identification of nonlinear dynamical systems", PNAS 113(15), 3932-3937, 2016.
E. Kaiser, J. N. Kutz, S. L. Brunton, "Sparse identification of nonlinear dynamics for model
predictive control in the low-data limit", Proc. R. Soc. A 474, 20180335, 2018.
U. Fasel, J. N. Kutz, B. W. Brunton, S. L. Brunton, "Ensemble-SINDy: robust sparse model
discovery in the low-data, high-noise limit, with active learning and control", Proc. R. Soc. A
478, 20210904, 2022.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import ModelResult, NarxModel, check_is_fitted
from neckid.models.cache import remembered_fit
from neckid.models.online import extend_training_ranges, update_experiments, update_rows
from neckid.models.polynomial.monomials import monomial_tables
from neckid.models.sindy._kernels import sparse_free_run
from neckid.models.sindy.library import Library, build_library
from neckid.models.sindy.refine import refit_free_run
from neckid.models.sindy.selection import DEFAULT_THRESHOLDS, choose_threshold
from neckid.models.sindy.stlsq import Normal, Sums, independent_columns, stlsq
from neckid.regressors import Lags
from neckid.utils.checks import Interval, Options
from neckid.utils.progress import task
from neckid.utils.types import FloatArray

__all__ = ["SparseNARX"]

logger = logging.getLogger(__name__)

#: Largest number of thresholding steps of STLSQ.
STLSQ_STEPS = 20
#: A simulated output further than this many output spans from the training range is clipped
#: while fitting on the free run (a diverging trial step shows as a large, finite error).
CLIP_SPANS = 10.0
#: The percentiles of the bags' coefficients an interval spans.
INTERVAL_PERCENTILES = (2.5, 97.5)


class SparseNARX(NarxModel):
    """Sparse NARX with inputs by STLSQ over a function library (discrete-time SINDy with control).

    Parameters
    ----------
    lags : Lags
        The regressor, e.g. ``Lags.arx(1, 1)`` (its conditions, such as the payload, are inputs).
    degree : int, default 3
        Largest total degree of a library monomial of the raw regressor terms.
    trigonometric : sequence of float, default ()
        Frequencies ``ω`` [rad per unit of the term]: ``sin(ω w_j)`` and ``cos(ω w_j)`` of every
        term join the library.
    functions : mapping of str to callable, optional
        User functions ``f(w_j)`` (elementwise on an array) applied to every term. They are code:
        a model with them runs in Python (slower) and cannot be saved to a model file.
    thresholds : sequence of float, optional
        Candidate thresholds on the scaled coefficients (:mod:`neckid.models.sindy.stlsq`); one
        value is used as it is, several are chosen among by the selection rule on the training
        data. Default :data:`~neckid.models.sindy.selection.DEFAULT_THRESHOLDS`.
    ridge : float, default 0.0
        Tikhonov term of each least-squares step (on the scaled problem).
    fit_for : {"simulation", "prediction"}, default "simulation"
        ``"prediction"``: STLSQ on the one-step error only. ``"simulation"``: then the kept
        coefficients are fitted on the free-run error of the training experiments.
    max_iter : int, default 200
        Largest number of free runs the simulation fit may spend.
    ensemble : int, default 0
        Bags of the bootstrap (0: none); they give :attr:`coef_interval_` and :attr:`inclusion_`.
    random_state : int, default 0
        Seed of the bootstrap.
    hold_margin : float, default 0.5
        As for :class:`~neckid.PolynomialNARX`: the monomials of degree >= 2 take each term held
        inside its training range widened by this fraction of it on each side; beyond, only the
        linear terms keep growing (a cubic that leaves the data diverges in free run). Inside
        that range the equation is the identified one.

    Attributes
    ----------
    coef_ : ndarray, shape (n_functions, n_outputs)
        ``ξ`` in raw units; zero for a function not kept.
    library_ : Library
        The candidate functions (:meth:`Library.names` names them).
    allowed_ : ndarray of bool, shape (n_functions,)
        The functions the training data tell apart (the others are never kept).
    scale_ : ndarray, shape (n_functions,)
        Root mean square of each library column on the training rows.
    y_scale_ : ndarray, shape (n_outputs,)
        Standard deviation of each output on the training rows.
    hold_low_, hold_high_ : ndarray, shape (n_terms,)
        Where the monomials of degree >= 2 hold each regressor term (see ``hold_margin``).
    threshold_ : float
        The threshold used (chosen or given).
    selection_ : dict
        The candidates, their functions kept and mean held-out fit, the scheme and the rule
        (empty when one threshold was given).
    coef_bags_ : ndarray, shape (ensemble, n_functions, n_outputs)
        The bags' one-step STLSQ coefficients (empty first axis without an ensemble).
    coef_interval_ : ndarray, shape (2, n_functions, n_outputs) or None
        The 2.5 and 97.5 percentiles of the bags' coefficients.
    inclusion_ : ndarray, shape (n_functions, n_outputs) or None
        Share of the bags that keep each function.
    fit_report_ : dict
        ``rmse_start`` and ``rmse`` (training free run, per output, before and after the
        simulation fit), ``refined``, ``evaluations``.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> from neckid.models.sindy import SparseNARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, 1500)
    >>> y = np.zeros(1500)
    >>> for t in range(1, 1500):
    ...     y[t] = 0.5 * y[t - 1] - 0.1 * y[t - 1] ** 3 + 0.8 * u[t - 1]
    >>> model = SparseNARX(Lags.arx(1, 1), fit_for="prediction").fit(IOData(u, y, ts=0.01))
    >>> {name: round(c, 6) for name, c in model.terms().items()}
    {'y(t-1)': 0.5, 'u(t-1)': 0.8, 'y(t-1)^3': -0.1}
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "degree": [Interval("int", 1, 5)],
        "trigonometric": ["array-like"],
        "functions": [None, Mapping],
        "thresholds": [None, "array-like"],
        "ridge": [Interval("real", 0, None)],
        "fit_for": [Options({"simulation", "prediction"})],
        "max_iter": [Interval("int", 1, None)],
        "ensemble": [Interval("int", 0, None)],
        "random_state": [Interval("int", 0, None)],
        "hold_margin": [Interval("real", 0, None)],
    }

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        degree: int = 3,
        trigonometric: Sequence[float] = (),
        functions: Mapping[str, Callable[..., Any]] | None = None,
        thresholds: Sequence[float] | None = None,
        ridge: float = 0.0,
        fit_for: str = "simulation",
        max_iter: int = 200,
        ensemble: int = 0,
        random_state: int = 0,
        hold_margin: float = 0.5,
    ) -> None:
        self.lags = lags
        self.degree = degree
        self.trigonometric = trigonometric
        self.functions = functions
        self.thresholds = thresholds
        self.ridge = ridge
        self.fit_for = fit_for
        self.max_iter = max_iter
        self.ensemble = ensemble
        self.random_state = random_state
        self.hold_margin = hold_margin

    # ------------------------------------------------------------------ fitting
    def _candidate_thresholds(self) -> list[float]:
        values = DEFAULT_THRESHOLDS if self.thresholds is None else self.thresholds
        found = sorted({float(v) for v in np.asarray(values, dtype=np.float64).ravel()})[::-1]
        if not found or found[-1] < 0:
            raise ValueError(f"thresholds must be one or more numbers >= 0; got {values!r}")
        return found

    def _function_names(self) -> tuple[str, ...]:
        functions = dict(self.functions or {})
        for name, f in functions.items():
            if not isinstance(name, str) or not name or not callable(f):
                raise ValueError(
                    f"functions must map non-empty names to callables; got {name!r}: {f!r}"
                )
        return tuple(functions)

    def fit(self, data: IOData | Sequence[IOData]) -> SparseNARX:
        """STLSQ at the chosen threshold, the bags, then (``"simulation"``) the free-run fit.

        Without ``functions``, the fitted state is remembered per parameters and training data
        in the active ``polynomial_fits`` cache (:func:`neckid.models.cache.remembered_fit`):
        the candidates of ``ParallelSetMembership(base="sindy")`` refit the same model.
        """
        if self.functions:
            return self._fit(data)
        return remembered_fit(self, data, lambda: self._fit(data))

    def _fit(self, data: IOData | Sequence[IOData]) -> SparseNARX:
        x, y = self._prepare_fit(data)
        experiments = as_experiments(self._with_conditions(data, fitting=True))
        frequencies = [float(v) for v in np.asarray(self.trigonometric, dtype=np.float64).ravel()]
        self.library_ = build_library(
            self.lags_.n_terms, int(self.degree), frequencies, self._function_names()
        )
        margin = float(self.hold_margin) * (x.max(axis=0) - x.min(axis=0))
        self.hold_low_, self.hold_high_ = x.min(axis=0) - margin, x.max(axis=0) + margin
        total = self._sums(x, y)
        self.sums_ = total
        self.scale_ = total.column_rms()
        self.y_scale_ = total.y_std()
        normal = total.normal(self.scale_, self.y_scale_)
        self.allowed_ = independent_columns(normal.gram)
        self.allowed_[0] = True  # the constant stays a candidate
        self._mark_fitted()
        degrees = self.library_.degrees()
        thresholds = self._candidate_thresholds()
        candidates = [(int(self.degree), thresholds[0])]
        if len(thresholds) > 1:  # every largest degree up to degree, with every threshold
            candidates = [(d, t) for d in range(1, int(self.degree) + 1) for t in thresholds]
        self.selection_: dict[str, Any] = {}
        chosen = candidates[0]
        if len(candidates) > 1:
            counts = [int(np.count_nonzero(self._solve(normal, c, degrees))) for c in candidates]
            cache: dict[int, Sums] = {}

            def fit_records(records: Sequence[IOData], candidate: tuple[int, float]) -> FloatArray:
                return self._fit_records(records, candidate, degrees, cache)

            chosen, self.selection_ = choose_threshold(
                experiments, candidates, counts, fit_records, self._run, self.max_lag_
            )
        self.allowed_ &= degrees <= chosen[0]
        self.threshold_ = chosen[1]
        self.coef_ = self._solve(normal, chosen, degrees)
        self._fit_bags(x, y)
        self.fit_report_: dict[str, Any] = {"refined": False, "evaluations": 0}
        if self.fit_for == "simulation":
            self._fit_simulation(experiments)
        return self

    def _solve(
        self,
        normal: Normal,
        candidate: tuple[int, float],
        degrees: NDArray[np.int64] | None = None,
    ) -> FloatArray:
        """STLSQ on ``normal`` at ``(largest degree, threshold)``, in raw units."""
        allowed = self.allowed_ if degrees is None else self.allowed_ & (degrees <= candidate[0])
        xi = stlsq(normal, candidate[1], allowed, ridge=float(self.ridge), max_iter=STLSQ_STEPS)
        return np.ascontiguousarray(xi * self.y_scale_[None, :] / self.scale_[:, None])

    def _sums(self, x: FloatArray, y: FloatArray, weights: FloatArray | None = None) -> Sums:
        def columns(rows: FloatArray) -> FloatArray:
            return self.library_.evaluate(rows, self.functions, hold=self._hold())

        return Sums.of_rows(columns, x, y, weights)

    def _fit_records(
        self,
        records: Sequence[IOData],
        candidate: tuple[int, float],
        degrees: NDArray[np.int64],
        cache: dict[int, Sums],
    ) -> FloatArray:
        """STLSQ on the rows of ``records`` (a selection split's fit part; sums kept per record)."""
        total: Sums | None = None
        for record in records:
            if record.n_samples <= self.max_lag_:
                continue
            if id(record) not in cache:
                cache[id(record)] = self._sums(*self.lags_.build_one(record))
            total = cache[id(record)] if total is None else total + cache[id(record)]
        if total is None:
            raise ValueError("a selection split has no record longer than the lags")
        return self._solve(total.normal(self.scale_, self.y_scale_), candidate, degrees)

    def _fit_bags(self, x: FloatArray, y: FloatArray) -> None:
        """STLSQ at the chosen threshold on ``ensemble`` bootstrap resamples of the rows."""
        n_bags = int(self.ensemble)
        shape = self.coef_.shape
        self.coef_bags_ = np.zeros((n_bags, *shape))
        self.coef_interval_: FloatArray | None = None
        self.inclusion_: FloatArray | None = None
        if n_bags == 0:
            return
        rng = np.random.default_rng(int(self.random_state))
        with task("SINDy ensemble (bags)", n_bags) as advance:
            for b in range(n_bags):
                rows = rng.integers(0, x.shape[0], x.shape[0])
                weights = np.bincount(rows, minlength=x.shape[0]).astype(np.float64)
                sums = self._sums(x, y, weights)
                self.coef_bags_[b] = self._solve(
                    sums.normal(self.scale_, self.y_scale_), (int(self.degree), self.threshold_)
                )
                advance()
        self.coef_interval_ = np.percentile(self.coef_bags_, INTERVAL_PERCENTILES, axis=0)
        self.inclusion_ = np.mean(self.coef_bags_ != 0, axis=0)

    def _fit_simulation(self, experiments: list[IOData], budget: int | None = None) -> None:
        """Least squares on the free-run error in the kept coefficients; kept only if better."""
        kept = np.flatnonzero(self.coef_.ravel() != 0)
        y_all = np.vstack([d.y for d in experiments])
        weight = 1.0 / self.y_scale_
        span = np.ptp(y_all, axis=0)
        low, high = y_all.min(axis=0) - CLIP_SPANS * span, y_all.max(axis=0) + CLIP_SPANS * span
        m = self.max_lag_

        def coef_of(theta: FloatArray) -> FloatArray:
            coef = np.zeros(self.coef_.size)
            coef[kept] = theta
            return coef.reshape(self.coef_.shape)

        def residuals(theta: FloatArray) -> FloatArray:
            errors = [
                (self._run(coef_of(theta), d, low, high)[m:] - d.y[m:]) * weight
                for d in experiments
            ]
            return np.nan_to_num(np.concatenate(errors).ravel(), nan=1e6, posinf=1e6, neginf=-1e6)

        start = self.coef_.ravel()[kept]
        n_rows = sum(d.n_samples - m for d in experiments) * weight.size
        if kept.size == 0 or n_rows < kept.size:
            return
        budget = int(self.max_iter if budget is None else budget)
        with task("SINDy free-run fit (free runs, at most)", budget) as advance:
            refit = refit_free_run(residuals, start, budget, advance)
        before = residuals(start)
        improved = bool(refit.cost < float(before @ before))
        if improved:
            self.coef_ = np.ascontiguousarray(coef_of(refit.theta))
        after = refit.errors if improved else before

        def rmse(e: FloatArray) -> list[float]:
            return [
                float(v) for v in np.sqrt(np.mean((e.reshape(-1, weight.size) / weight) ** 2, 0))
            ]

        self.fit_report_ = {
            "refined": improved,
            "rmse_start": rmse(before),
            "rmse": rmse(after),
            "evaluations": int(refit.runs),
        }
        logger.info("SINDy simulation fit: %s", self.fit_report_)

    def partial_fit(self, data: IOData | Sequence[IOData], *, max_iter: int = 20) -> SparseNARX:
        """Take new experiments into the fit.

        The normal equations take the new rows exactly (:attr:`sums_`) and STLSQ is solved again
        at the chosen degree and threshold (the scales of the first fit kept): the refit on the
        old and new data together. With ``fit_for="simulation"`` the free-run fit then continues
        on the new experiments, for at most ``max_iter`` free runs.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            For data on other channels or too short for the lags.
        """
        experiments = update_experiments(self, data)
        x, y = update_rows(self, experiments)
        self.sums_ = self.sums_ + self._sums(x, y)
        self.n_samples_ = int(self.sums_.n)
        self.coef_ = self._solve(
            self.sums_.normal(self.scale_, self.y_scale_), (int(self.degree), self.threshold_)
        )
        if self.fit_for == "simulation":
            self._fit_simulation(experiments, int(max_iter))
        extend_training_ranges(self, experiments)
        return self

    # ------------------------------------------------------------------ use
    def _kept(self) -> NDArray[np.int64]:
        return np.flatnonzero(np.any(self.coef_ != 0, axis=1))

    def _run(
        self,
        coef: FloatArray,
        data: IOData,
        low: FloatArray | None = None,
        high: FloatArray | None = None,
    ) -> FloatArray:
        """Free run of ``data`` from its first ``max_lag_`` outputs with ``coef`` (clipped)."""
        y = np.array(data.y, dtype=np.float64)
        u = np.ascontiguousarray(data.u, dtype=np.float64)
        kept = np.flatnonzero(np.any(coef != 0, axis=1))
        lib, r = self.library_, self.lags_
        unbounded = np.full(y.shape[1], np.inf)
        low = -unbounded if low is None else low
        high = unbounded if high is None else high
        if not lib.compiled:  # user functions: Python, one step at a time
            for t in range(r.max_lag, y.shape[0]):
                w = r.regressor_from_history(y, u, t)[None, :]
                theta = lib.evaluate(w, self.functions, kept, self._hold())
                step = _sum_terms(theta, coef[kept])[0]
                y[t] = np.clip(step, low, high)
            return y
        _, parent, var, _ = monomial_tables(r.n_terms, int(self.degree))
        sparse_free_run(
            u,
            y,
            r.source,
            r.channel,
            r.lag,
            parent,
            var,
            kept,
            lib.kind[kept],
            lib.var[kept],
            lib.frequency[kept],
            np.ascontiguousarray(coef[kept]),
            r.max_lag,
            self.hold_low_,
            self.hold_high_,
            low,
            high,
        )
        return y

    def _predict_rows(self, x: FloatArray) -> FloatArray:
        kept = self._kept()
        theta = self.library_.evaluate(x, self.functions, kept, self._hold())
        return _sum_terms(theta, self.coef_[kept])

    def _hold(self) -> tuple[FloatArray, FloatArray]:
        return self.hold_low_, self.hold_high_

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free-run simulation (compiled unless the library has user functions)."""
        check_is_fitted(self)
        data = self._with_conditions(data)
        y0 = np.asarray(self._initial_outputs(data, initial), dtype=np.float64)
        with np.errstate(all="ignore"):  # divergence is reported by _result
            y = self._run(self.coef_, IOData(data.u, y0, ts=data.ts))
        return self._result("simulation", data, y)

    def terms(self, output: int = 0) -> dict[str, float]:
        """The kept functions of one output and their coefficients (raw units), by name."""
        check_is_fitted(self)
        names = self.library_.names(self.lags_.names)
        return {
            names[k]: float(self.coef_[k, output]) for k in np.flatnonzero(self.coef_[:, output])
        }

    def schedule_summary(self) -> dict[str, Any]:
        """``{"equation": ...}``: the identified equation with units, for ``neckid info``."""
        from neckid.models.sindy.summary import equation_summary

        return {"equation": equation_summary(self)}

    # ------------------------------------------------------------------ files
    def _check_state(self) -> None:
        super()._check_state()
        from neckid.models.sindy.summary import check_library

        check_library(self)

    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        arrays: dict[str, NDArray[Any]]
        if not self.library_.compiled:
            raise ValueError(
                "a SparseNARX with user functions cannot be saved: functions are code, and model"
                " files hold arrays and JSON only; refit it where the functions are defined"
            )
        arrays = {
            "coef": self.coef_,
            "allowed": self.allowed_.astype(np.int8),
            "scale": self.scale_,
            "y_scale": self.y_scale_,
            "coef_bags": self.coef_bags_,
            "hold_low": self.hold_low_,
            "sums_gram": self.sums_.gram,
            "sums_rhs": self.sums_.rhs,
            "sums_y_sum": self.sums_.y_sum,
            "sums_y_square": self.sums_.y_square,
            "hold_high": self.hold_high_,
            **self.library_.to_arrays(),
        }
        meta = {
            "params": {
                "degree": int(self.degree),
                "trigonometric": [float(v) for v in np.asarray(self.trigonometric).ravel()],
                "thresholds": None
                if self.thresholds is None
                else [float(v) for v in np.asarray(self.thresholds).ravel()],
                "ridge": float(self.ridge),
                "fit_for": str(self.fit_for),
                "max_iter": int(self.max_iter),
                "ensemble": int(self.ensemble),
                "random_state": int(self.random_state),
                "hold_margin": float(self.hold_margin),
            },
            "threshold": float(self.threshold_),
            "selection": self.selection_,
            "fit_report": self.fit_report_,
            **self._narx_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]) -> SparseNARX:
        params = dict(meta["params"])
        params["trigonometric"] = tuple(params["trigonometric"])
        if params["thresholds"] is not None:
            params["thresholds"] = tuple(params["thresholds"])
        model = cls(lags=None, **params)
        model._restore_narx_meta(meta)
        model.coef_ = np.ascontiguousarray(arrays["coef"], dtype=np.float64)
        model.allowed_ = np.asarray(arrays["allowed"]) != 0
        model.scale_ = np.asarray(arrays["scale"], dtype=np.float64)
        model.y_scale_ = np.asarray(arrays["y_scale"], dtype=np.float64)
        model.coef_bags_ = np.asarray(arrays["coef_bags"], dtype=np.float64)
        model.hold_low_ = np.asarray(arrays["hold_low"], dtype=np.float64)
        model.sums_ = Sums(
            np.asarray(arrays["sums_gram"], dtype=np.float64),
            np.asarray(arrays["sums_rhs"], dtype=np.float64),
            np.asarray(arrays["sums_y_sum"], dtype=np.float64),
            np.asarray(arrays["sums_y_square"], dtype=np.float64),
            int(meta["n_samples"]),
        )
        model.hold_high_ = np.asarray(arrays["hold_high"], dtype=np.float64)
        n_kind = np.asarray(arrays["library_kind"]).shape[0]
        model.library_ = Library(
            np.asarray(arrays["library_kind"], dtype=np.int64),
            np.ascontiguousarray(arrays["library_powers"], dtype=np.int64),
            np.asarray(arrays["library_var"], dtype=np.int64),
            np.asarray(arrays["library_frequency"], dtype=np.float64),
            ("",) * n_kind,
        )
        model.threshold_ = float(meta["threshold"])
        model.selection_ = dict(meta.get("selection", {}))
        model.fit_report_ = dict(meta.get("fit_report", {}))
        bags = model.coef_bags_
        model.coef_interval_ = (
            np.percentile(bags, INTERVAL_PERCENTILES, axis=0) if bags.shape[0] else None
        )
        model.inclusion_ = np.mean(bags != 0, axis=0) if bags.shape[0] else None
        return model


def _sum_terms(theta: FloatArray, coef: FloatArray) -> FloatArray:
    """``Σ_k θ_k coef_k`` summed function by function from 0, as the compiled free run does."""
    out = np.zeros((theta.shape[0], coef.shape[1]))
    for k in range(theta.shape[1]):
        out += theta[:, k : k + 1] * coef[k][None, :]
    return out
