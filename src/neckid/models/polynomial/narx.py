r"""PolynomialNARX: a polynomial NARX fitted for simulation (output error), not only one step ahead.

.. math::

    y_c(t) = \sum_m θ_{m c}\, φ_m(x̃(t)), \qquad x̃(t) = (w(t) − \text{center}) / \text{scale},

with ``φ`` every monomial of degree <= ``degree`` of the standardised regressor ``x̃`` of
``lags`` (the constant included). The monomials of degree >= 2 take ``x̃`` held inside its
training range widened by ``hold_margin``: a polynomial grows like its highest power outside
the data, so beyond that the model continues with its linear terms only. Least squares on the one-step error gives the usual
polynomial NARX (the model class of Billings' NARMAX, without term selection). With
``fit_for="simulation"`` (the default) those coefficients are only the start: Levenberg–Marquardt
then minimises the *free-run* error over the training experiments, with the exact Jacobian from
the model's sensitivity recursion (:mod:`neckid.models.polynomial._kernels`). A model that is good one
step ahead can drift in free run, where its small one-step errors are fed back; fitting the
simulation error removes most of that (on the Silverbox benchmark, degree 3: 0.32 mV free-run
RMSE by least squares, 0.25 mV after the simulation fit; ``docs/benchmarks/silverbox.md``).

The start is whichever of two least-squares fits simulates the training experiments better: all
monomials, or the linear ones only (an ARX, the safer start where the full polynomial diverges in
free run). The simulation fit never ends worse than its start.

References
----------
S. A. Billings, *Nonlinear System Identification: NARMAX Methods in the Time, Frequency, and
Spatio-Temporal Domains*, Wiley, 2013 (polynomial NARX).
L. Ljung, *System Identification: Theory for the User*, 2nd ed., Prentice Hall, 1999, §7.3 and
§10.3 (output-error criteria and their gradient).
J. J. Moré, "The Levenberg-Marquardt algorithm: implementation and theory", Numerical Analysis,
Lecture Notes in Mathematics 630, 105-116, 1978.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import ModelResult, NarxModel, check_is_fitted
from neckid.models.cache import remembered_fit
from neckid.models.levenberg import fit_least_squares
from neckid.models.linear.arx import least_squares, linear_sum
from neckid.models.linear.ls_statistics import LeastSquaresStatistics
from neckid.models.online import extend_training_ranges, update_experiments, update_rows
from neckid.models.polynomial._kernels import poly_free_run, poly_sensitivity
from neckid.models.polynomial.monomials import monomial_tables
from neckid.regressors import Lags
from neckid.utils.checks import Interval, Options
from neckid.utils.progress import counting, task
from neckid.utils.types import FloatArray

__all__ = ["PolynomialNARX"]

logger = logging.getLogger(__name__)


#: Largest Jacobian (bytes) the simulation fit builds; beyond it, fit on fewer samples.
MAX_JACOBIAN_BYTES = 2 * 1024**3
#: Relative size below which a monomial's column counts as a combination of the ones before it.
RANK_TOLERANCE = 1e-7
#: A simulated output further than this many output spans from the training range is clipped
#: while fitting (a diverging trial step shows as a large, finite error).
CLIP_SPANS = 10.0


class PolynomialNARX(NarxModel):
    """Polynomial NARX of any degree, fitted by least squares and then for free-run simulation.

    Parameters
    ----------
    lags : Lags
        The regressor, e.g. ``Lags(outputs=[1, 2], inputs=[0, 1, 2, 3])``.
    degree : int, default 3
        Largest total degree of a monomial (1 gives an ARX). With ``n`` regressor terms there
        are ``C(n + degree, degree)`` monomials per output.
    fit_for : {"simulation", "prediction"}, default "simulation"
        ``"prediction"``: least squares on the one-step error only. ``"simulation"``: then
        Levenberg–Marquardt on the free-run error of every training experiment (each started
        from its first ``max_lag`` measured outputs), outputs weighted by ``1/std``.
    ridge : float, default 0.0
        Tikhonov regularisation of the least-squares step (on standardised monomials).
    max_iter : int, default 100
        Largest number of free runs the simulation fit may spend (each iteration costs one
        free run and one sensitivity run).
    hold_margin : float, default 0.5
        How far beyond the training range of each standardised regressor term, as a fraction of
        that range on each side, the monomials of degree >= 2 still follow it; further out
        they hold their value and only the linear terms continue. A polynomial grows like its
        highest power outside the data (a cubic free run that leaves the data range
        diverges); the margin keeps moderate extrapolation polynomial (on the Silverbox arrow
        head, 0.1 already gives the unheld result).

    Attributes
    ----------
    coef_ : ndarray, shape (n_monomials, n_outputs)
        θ; row ``m`` multiplies monomial ``powers_[m]``.
    powers_ : ndarray of int, shape (n_monomials, n_terms)
        Exponents of each monomial in the standardised regressor (row 0: the constant).
    active_ : ndarray of bool, shape (n_monomials,)
        The monomials the training data tell apart (see :func:`_independent_monomials`); the
        others have a zero coefficient.
    center_, scale_ : ndarray, shape (n_terms,)
        Mean and standard deviation of the training regressors (``x̃ = (w − center) / scale``).
    low_, high_ : ndarray, shape (n_terms,)
        The training range of ``x̃`` widened by ``hold_margin``: the monomials of degree >= 2
        hold each term inside it, so beyond it only the linear terms keep growing.
    statistics_ : LeastSquaresStatistics
        Of the one-step least-squares problem (what :meth:`partial_fit` updates).
    fit_report_ : dict
        ``start`` (``"polynomial"`` or ``"linear"``), the training free-run RMSE per output of the
        start (``rmse_start``) and of the result (``rmse``), ``evaluations``, ``message``.
    lags_ : ResolvedLags
    n_inputs_, n_outputs_, n_samples_ : int
    ts_ : float

    Raises
    ------
    ValueError
        In ``fit``: fewer training rows than monomials, or a Jacobian above 2 GiB (fit on fewer
        samples, or ``fit_for="prediction"``).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, PolynomialNARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, 2000)
    >>> y = np.zeros(2000)
    >>> for t in range(1, 2000):
    ...     y[t] = 0.6 * y[t - 1] - 0.2 * y[t - 1] ** 3 + 0.5 * u[t - 1]
    >>> data = IOData(u, y, ts=0.01)
    >>> model = PolynomialNARX(Lags.arx(1, 1), degree=3).fit(data)
    >>> float(np.round(model.simulate(data).fit_percent(data)[0], 3))
    100.0
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "degree": [Interval("int", 1, 6)],
        "fit_for": [Options({"simulation", "prediction"})],
        "ridge": [Interval("real", 0, None)],
        "max_iter": [Interval("int", 1, None)],
        "hold_margin": [Interval("real", 0, None)],
    }

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        degree: int = 3,
        fit_for: str = "simulation",
        ridge: float = 0.0,
        max_iter: int = 100,
        hold_margin: float = 0.5,
    ) -> None:
        self.lags = lags
        self.degree = degree
        self.fit_for = fit_for
        self.ridge = ridge
        self.max_iter = max_iter
        self.hold_margin = hold_margin

    # ------------------------------------------------------------------ fitting
    def fit(self, data: IOData | Sequence[IOData]) -> PolynomialNARX:
        """Least squares on the one-step error, then (``fit_for="simulation"``) on the free run.

        The simulation fit is deterministic and costs seconds to minutes on a large record; the
        results are remembered per parameters and training data (a digest of their values) in
        the active ``polynomial_fits`` cache (:mod:`neckid.models.cache`), so a selection that refits the same polynomial on the same
        data (the candidates of ``ParallelSetMembership(parallel_degree=3)``) gets a copy of it.
        """
        return remembered_fit(self, data, lambda: self._fit(data))

    def _fit(self, data: IOData | Sequence[IOData]) -> None:
        x, y = self._prepare_fit(data)
        self._fit_regression(x, y)
        self._mark_fitted()
        if self.fit_for == "simulation":
            experiments = as_experiments(self._with_conditions(data, fitting=True))
            self._fit_simulation(experiments, int(self.max_iter), self._linear_start(x, y))

    def _fit_regression(self, x: FloatArray, y: FloatArray) -> None:
        n_terms = x.shape[1]
        powers, _, _, _ = monomial_tables(n_terms, self._total_degree())
        if x.shape[0] < powers.shape[0]:
            raise ValueError(
                f"a degree-{self._total_degree()} polynomial of {n_terms} regressor terms has"
                f" {powers.shape[0]} monomials but the training data give {x.shape[0]} rows;"
                " use a lower degree, fewer lags or more data"
            )
        self.powers_ = powers
        self.center_ = x.mean(axis=0)
        scale = x.std(axis=0)
        self.scale_ = np.where(scale > 0, scale, 1.0)
        standard = (x - self.center_) / self.scale_
        low, high = standard.min(axis=0), standard.max(axis=0)
        self.low_, self.high_ = self._hold_range(low, high)
        self.statistics_ = LeastSquaresStatistics.from_rows(self._features(x), y, centred=True)
        self.active_ = _independent_monomials(self.statistics_, self._allowed_monomials(powers))
        self._solve_statistics()
        self.fit_report_: dict[str, Any] = {"start": "polynomial", "evaluations": 0}

    def _total_degree(self) -> int:
        """The largest total degree of a monomial (``degree``; a subclass may derive it)."""
        return int(self.degree)

    def _hold_range(self, low: FloatArray, high: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Where the monomials of degree >= 2 hold each standardised term, from its range."""
        margin = float(self.hold_margin) * (high - low)
        return low - margin, high + margin

    def _allowed_monomials(self, powers: NDArray[np.int64]) -> NDArray[np.bool_]:
        """Which rows of ``powers`` the model may use (all; a subclass may keep fewer)."""
        return np.ones(powers.shape[0], dtype=bool)

    def _solve_statistics(self) -> None:
        """Least squares over the active monomials (the others keep a zero coefficient)."""
        stats = self.statistics_
        k = stats.n_terms
        keep = np.flatnonzero(self.active_[1:])
        columns = np.concatenate([keep, k + np.arange(stats.y_mean.size)])
        factor = np.asarray(np.linalg.qr(stats.factor[:, columns], mode="r"), dtype=np.float64)
        sub = LeastSquaresStatistics(stats.n_rows, stats.x_mean[keep], stats.y_mean, factor, True)
        coef, intercept = sub.solve(float(self.ridge))
        full = np.zeros((k + 1, stats.y_mean.size))
        full[0] = intercept
        full[1 + keep] = coef
        self.coef_ = np.ascontiguousarray(full)

    def _features(self, x: FloatArray) -> FloatArray:
        """The monomials of ``x`` without the constant: ``(n_rows, n_monomials − 1)``."""
        _, parent, var, _ = monomial_tables(x.shape[1], self._total_degree())
        xs = (x - self.center_) / self.scale_
        held = np.clip(xs, self.low_, self.high_)
        phi = np.empty((x.shape[0], parent.shape[0]))
        phi[:, 0] = 1.0
        for m in range(1, parent.shape[0]):
            phi[:, m] = phi[:, parent[m]] * held[:, var[m]]
        phi[:, 1 : 1 + x.shape[1]] = xs  # the linear terms are never held
        return phi[:, 1:]

    def _fit_simulation(
        self, experiments: list[IOData], budget: int, linear: FloatArray | None
    ) -> None:
        """Levenberg–Marquardt on the free-run error of ``experiments`` from ``coef_`` (or better)."""
        problem = _FreeRunProblem(self, experiments, budget)
        free, weight = problem.free, problem.weight
        start, label = self.coef_.ravel()[free], "polynomial"
        errors = problem.residuals(start)
        cost = float(np.sum(errors**2))
        if linear is not None:
            linear_errors = problem.residuals(linear.ravel()[free])
            linear_cost = float(np.sum(linear_errors**2))
            if linear_cost < cost or not np.isfinite(cost):
                start, label, cost, errors = (
                    linear.ravel()[free],
                    "linear",
                    linear_cost,
                    linear_errors,
                )
        with task("polynomial NARX free-run fit (evaluations, at most)", budget) as advance:
            advance()  # the start's free run (above) is the first of the evaluations
            solution = fit_least_squares(
                counting(problem.residuals, advance),
                start,
                problem.jacobian,
                max_nfev=budget,
                f0=errors,
            )
        improved = 2 * solution.cost <= cost  # least_squares' cost is half the sum of squares
        theta = solution.x if improved else start
        self.coef_ = problem.full(theta)
        self.fit_report_ = {
            "start": label,
            "rmse_start": self._rmse(errors, weight),
            "rmse": self._rmse(solution.fun if improved else errors, weight),
            "evaluations": int(solution.nfev),
            "message": str(solution.message),
        }
        logger.info("polynomial NARX simulation fit: %s", self.fit_report_)

    def _linear_start(self, x: FloatArray, y: FloatArray) -> FloatArray:
        """``coef_`` of the linear least squares (constant and degree-1 monomials; others 0)."""
        coef, intercept = least_squares(x, y, True, float(self.ridge))
        start = np.zeros_like(self.coef_)
        start[0] = intercept + self.center_ @ coef
        start[1 : x.shape[1] + 1] = coef * self.scale_[:, None]
        return start

    def _rmse(self, residuals: FloatArray, weight: FloatArray) -> list[float]:
        e = residuals.reshape(-1, self.n_outputs_) / weight
        return [float(v) for v in np.sqrt(np.mean(e**2, axis=0))]

    def partial_fit(self, data: IOData | Sequence[IOData], *, max_iter: int = 20) -> PolynomialNARX:
        """Take new experiments into the fit.

        The one-step least-squares statistics take the new rows exactly (:attr:`statistics_`).
        With ``fit_for="prediction"`` the coefficients are solved again from them: the refit on
        the old and new data together. With ``fit_for="simulation"`` the simulation fit
        continues from the current coefficients on the new experiments, for at most
        ``max_iter`` free runs: an update that follows the new data, not a refit.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            For data on other channels or too short for the lags.
        """
        experiments = update_experiments(self, data)
        x, y = update_rows(self, experiments)
        new = LeastSquaresStatistics.from_rows(self._features(x), y, centred=True)
        self.statistics_ = self.statistics_.merge(new)
        self.n_samples_ = self.statistics_.n_rows
        if self.fit_for == "simulation":
            self._fit_simulation(experiments, int(max_iter), None)
        else:
            self._solve_statistics()
        extend_training_ranges(self, experiments)
        return self

    # ------------------------------------------------------------------ use
    def _predict_rows(self, x: FloatArray) -> FloatArray:
        # Summed monomial by monomial from 0, as the compiled free run does, so that stepping
        # the simulator and ``simulate`` agree to the last bit.
        return linear_sum(self._features(x), self.coef_[1:], self.coef_[0])

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free-run simulation (compiled loop): the regressor holds the model's own past outputs.

        The first ``max_lag_`` outputs of ``data`` (or ``initial``) are the initial conditions;
        the same values as stepping :meth:`simulator`, to rounding.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y = np.array(self._initial_outputs(data, initial), dtype=np.float64)
        r = self.lags_
        _, parent, var, _ = monomial_tables(r.n_terms, self._total_degree())
        unbounded = np.full(self.n_outputs_, np.inf)
        with np.errstate(all="ignore"):  # divergence is reported by _result
            poly_free_run(
                np.ascontiguousarray(data.u, dtype=np.float64),
                y,
                r.source,
                r.channel,
                r.lag,
                self.center_,
                self.scale_,
                self.low_,
                self.high_,
                parent,
                var,
                self.coef_,
                r.max_lag,
                -unbounded,
                unbounded,
            )
        return self._result("simulation", data, y)

    # ------------------------------------------------------------------ files
    def _check_state(self) -> None:
        super()._check_state()
        n_terms = self.lags_.n_terms
        powers, _, _, _ = monomial_tables(n_terms, self._total_degree())
        if self.powers_.shape != powers.shape or not np.array_equal(self.powers_, powers):
            raise ValueError(
                f"powers do not list the degree-{self._total_degree()} monomials of {n_terms} terms"
            )
        self._check_shape("coef", self.coef_, (powers.shape[0], self.n_outputs_))
        self._check_shape("active", self.active_, (powers.shape[0],))
        if not self.active_[0]:
            raise ValueError("active must keep the constant monomial (its first entry)")
        self._check_shape("center", self.center_, (n_terms,))
        self._check_shape("scale", self.scale_, (n_terms,))
        self._check_shape("low", self.low_, (n_terms,))
        self._check_shape("high", self.high_, (n_terms,))
        if not np.all(self.low_ <= self.high_):
            raise ValueError(
                f"low must be <= high; got {self.low_.tolist()} and {self.high_.tolist()}"
            )
        if not np.all(self.scale_ > 0):
            raise ValueError(f"scale must be > 0; got {self.scale_.tolist()}")

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
        meta = {
            "params": {
                "degree": int(self.degree),
                "fit_for": str(self.fit_for),
                "ridge": float(self.ridge),
                "max_iter": int(self.max_iter),
                "hold_margin": float(self.hold_margin),
            },
            "fit_report": self.fit_report_,
            **self._narx_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
    ) -> PolynomialNARX:
        model = cls(lags=None, **meta["params"])
        model._restore_narx_meta(meta)
        model.coef_ = np.ascontiguousarray(arrays["coef"], dtype=np.float64)
        model.powers_ = np.asarray(arrays["powers"], dtype=np.int64)
        model.active_ = np.asarray(arrays["active"]) != 0
        model.center_ = np.asarray(arrays["center"], dtype=np.float64)
        model.scale_ = np.asarray(arrays["scale"], dtype=np.float64)
        model.low_ = np.asarray(arrays["low"], dtype=np.float64)
        model.high_ = np.asarray(arrays["high"], dtype=np.float64)
        model.fit_report_ = dict(meta.get("fit_report", {}))
        statistics = LeastSquaresStatistics.from_arrays(
            arrays,
            "statistics_",
            model.n_samples_,
            True,
            (model.powers_.shape[0] - 1, len(model.output_names_)),
        )
        if statistics is None:
            raise ValueError("a PolynomialNARX file must hold its least-squares statistics")
        model.statistics_ = statistics
        return model


class _FreeRunProblem:
    """The weighted free-run errors of a PolynomialNARX and their Jacobian, in its free coefficients."""

    def __init__(self, model: PolynomialNARX, experiments: list[IOData], budget: int) -> None:
        r = model.lags_
        self.m = m = r.max_lag
        _, parent, var, self.lower = monomial_tables(r.n_terms, model._total_degree())
        self.n_rows = n_rows = sum(d.n_samples - m for d in experiments)
        self.n_out = n_out = model.n_outputs_
        self.free = (np.flatnonzero(model.active_)[:, None] * n_out + np.arange(n_out)).ravel()
        size = n_rows * n_out * model.coef_.size * 8  # the sensitivities of every coefficient
        if size > MAX_JACOBIAN_BYTES:
            raise ValueError(
                f"the simulation fit needs a {n_rows * n_out} x {model.coef_.size} Jacobian"
                f" ({size / 1024**3:.1f} GiB, above 2 GiB); fit on fewer samples, a lower degree"
                " or fewer lags, or use fit_for='prediction'"
            )
        y_all = np.vstack([d.y for d in experiments])
        self.weight = 1.0 / np.where(y_all.std(axis=0) > 0, y_all.std(axis=0), 1.0)
        span = np.ptp(y_all, axis=0)
        self.low = y_all.min(axis=0) - CLIP_SPANS * span
        self.high = y_all.max(axis=0) + CLIP_SPANS * span
        self.tables = (
            r.source,
            r.channel,
            r.lag,
            model.center_,
            model.scale_,
            model.low_,
            model.high_,
            parent,
            var,
        )
        self.powers = model.powers_
        self.coef_shape = model.coef_.shape
        self.coef_size = model.coef_.size
        self.experiments = experiments
        self.budget = budget
        self.evaluations = 0

    def full(self, theta: FloatArray) -> FloatArray:
        """The whole coefficient array, zero outside the free coefficients ``theta``."""
        coef = np.zeros(self.coef_size)
        coef[self.free] = theta
        return np.ascontiguousarray(coef.reshape(self.coef_shape))

    def run(self, theta: FloatArray, jacobian: FloatArray | None) -> FloatArray:
        """Free-run every experiment; the weighted errors (and the sensitivities into ``jacobian``)."""
        coef = self.full(theta)
        m, low, high, tables = self.m, self.low, self.high, self.tables
        errors, row = [], 0
        for d in self.experiments:
            u = np.ascontiguousarray(d.u, dtype=np.float64)
            ysim = np.array(d.y, dtype=np.float64)
            n = d.n_samples - m
            if jacobian is None:
                with np.errstate(all="ignore"):
                    poly_free_run(u, ysim, *tables, coef, m, low, high)
            else:
                block = jacobian[row : row + n]
                poly_sensitivity(
                    u, ysim, *tables, self.powers, self.lower, coef, m, low, high, block
                )
            errors.append((ysim[m:] - d.y[m:]) * self.weight)
            row += n
        return np.concatenate(errors).ravel()

    def residuals(self, theta: FloatArray) -> FloatArray:
        """The weighted free-run errors, logging each evaluation."""
        errors = self.run(theta, None)
        self.evaluations += 1
        logger.info(
            "polynomial NARX simulation fit: free run %d of at most %d, weighted RMS error %.4g",
            self.evaluations,
            self.budget,
            float(np.sqrt(np.mean(errors**2))),
        )
        return errors

    def jacobian(self, theta: FloatArray) -> FloatArray:
        """The Jacobian of :meth:`residuals` in the free coefficients."""
        jac = np.zeros((self.n_rows, self.n_out, self.coef_size))
        self.run(theta, jac)
        jac *= self.weight[None, :, None]
        flat = jac.reshape(self.n_rows * self.n_out, -1)
        return flat if self.free.size == self.coef_size else flat[:, self.free]


def _independent_monomials(
    statistics: LeastSquaresStatistics, allowed: NDArray[np.bool_] | None = None
) -> NDArray[np.bool_]:
    """Which monomials the training data tell apart, as a mask over ``powers_``.

    The constant and every monomial whose column is not (to 1e-7 relative) a combination of the
    ones before it, in graded order; with ``allowed`` (a mask over ``powers_``), among the
    allowed monomials only (the others are not in the model).

    Read off the triangular factor: ``|R_kk|`` is the part of column ``k`` orthogonal to the
    columns before it. A condition that takes two values in training (a payload of 0 or 0.6 kg)
    makes its square such a combination; without this, the simulation fit could move along
    that direction freely and the model would be arbitrary between the two values.
    """
    k = statistics.n_terms
    keep = np.arange(k) if allowed is None else np.flatnonzero(allowed[1:])
    r = statistics.factor[:k, :k]
    if keep.size < k:  # the triangular factor of the allowed columns alone
        r = np.asarray(np.linalg.qr(statistics.factor[:, keep], mode="r"), dtype=np.float64)
    # compared with the column's uncentred size, so that a column constant in the data (a
    # centred column of rounding errors) counts as dependent on the constant monomial
    mean = np.abs(statistics.x_mean[keep])
    size = np.sqrt(np.sum(r**2, axis=0)) + np.sqrt(statistics.n_rows) * mean
    independent = np.zeros(k, dtype=bool)
    independent[keep] = np.abs(np.diag(r)[: keep.size]) > RANK_TOLERANCE * size
    return np.concatenate([[True], independent])
