"""LinearARX: the batch least-squares ARX baseline over any :class:`~neckid.Lags` regressor."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from neckid.data import IOData
from neckid.models.base import NarxModel, check_is_fitted
from neckid.models.ls_statistics import LeastSquaresStatistics
from neckid.models.online import extend_training_ranges, update_experiments, update_rows
from neckid.regressors import Lags
from neckid.validation import Interval

__all__ = ["LinearARX", "least_squares"]

FloatArray = NDArray[np.float64]


def least_squares(
    x: FloatArray, y: FloatArray, fit_intercept: bool = True, ridge: float = 0.0
) -> tuple[FloatArray, FloatArray]:
    """Least-squares ``y ≈ x @ coef + intercept``; returns ``(coef (n_terms, n_outputs), intercept)``.

    Columns are centred (when fitting an intercept) and scaled before solving so that regressors
    in very different units do not spoil the conditioning. ``ridge`` adds ``ridge * ||coef_scaled||^2``.
    """
    if x.shape[0] < x.shape[1] + int(fit_intercept):
        raise ValueError(
            f"least squares needs at least as many rows as unknowns: {x.shape[0]} rows for"
            f" {x.shape[1] + int(fit_intercept)} parameters; use a longer record or fewer lags"
        )
    x_mean = x.mean(axis=0) if fit_intercept else np.zeros(x.shape[1])
    y_mean = y.mean(axis=0) if fit_intercept else np.zeros(y.shape[1])
    xc = x - x_mean
    scale = np.sqrt(np.mean(xc**2, axis=0))
    scale[scale == 0] = 1.0
    xs = xc / scale
    yc = y - y_mean
    if ridge > 0:
        k = xs.shape[1]
        xs = np.vstack([xs, np.sqrt(ridge * xs.shape[0]) * np.eye(k)])
        yc = np.vstack([yc, np.zeros((k, y.shape[1]))])
    solution, *_ = np.linalg.lstsq(xs, yc, rcond=None)
    coef = solution / scale[:, None]
    intercept = y_mean - x_mean @ coef
    return np.ascontiguousarray(coef), np.asarray(intercept, dtype=np.float64)


class LinearARX(NarxModel):
    """Linear ARX (or any linear-in-the-regressor) model fitted by batch least squares.

    ``y(t) = intercept + coef.T @ w(t)``, with ``w(t)`` the regressor of ``lags``.

    Parameters
    ----------
    lags : Lags
        The regressor, e.g. ``Lags.arx(na=2, nb=2, delay=1)``.
    fit_intercept : bool, default True
        Estimate a constant term (an offset of the operating point).
    ridge : float, default 0.0
        Tikhonov regularisation on standardised regressors (0 = ordinary least squares).

    Attributes
    ----------
    coef_ : ndarray, shape (n_terms, n_outputs)
    intercept_ : ndarray, shape (n_outputs,)
    statistics_ : LeastSquaresStatistics or None
        Rows, means and square-root scatter of the training regressors and targets: what
        :meth:`partial_fit` updates (``None`` for a model loaded from a file written before
        they were stored).
    lags_ : ResolvedLags
    n_inputs_, n_outputs_, n_samples_ : int
    ts_ : float

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=500)
    >>> y = np.zeros(500)
    >>> for t in range(1, 500):
    ...     y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    >>> model = LinearARX(Lags.arx(na=1, nb=1), fit_intercept=False).fit(IOData(u, y, ts=0.02))
    >>> np.round(model.coef_.ravel(), 6)
    array([0.9, 0.5])
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "fit_intercept": ["boolean"],
        "ridge": [Interval("real", 0, None)],
    }

    def __init__(
        self, lags: Lags | None = None, *, fit_intercept: bool = True, ridge: float = 0.0
    ) -> None:
        self.lags = lags
        self.fit_intercept = fit_intercept
        self.ridge = ridge

    def _fit_regression(self, x: FloatArray, y: FloatArray) -> None:
        self.coef_, self.intercept_ = least_squares(
            x, y, bool(self.fit_intercept), float(self.ridge)
        )
        self.statistics_: LeastSquaresStatistics | None = LeastSquaresStatistics.from_rows(
            x, y, centred=bool(self.fit_intercept)
        )

    def partial_fit(self, data: IOData | Sequence[IOData]) -> LinearARX:
        """Take new experiments into the fit: exactly the refit on the old and new data together.

        Parameters
        ----------
        data : IOData or list of IOData
            New measurements on the model's channels (no regressor straddles two experiments,
            nor an old and a new one).

        Returns
        -------
        LinearARX
            ``self``: ``fit(a).partial_fit(b)`` has the coefficients of ``fit([a, b])`` (to
            rounding), with the current ``ridge``.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            For data on other channels or too short for the lags; for a model loaded from a file
            without least-squares statistics (see Notes), or whose ``fit_intercept`` was changed
            after fitting.

        Notes
        -----
        Recursive least squares in square-root form: the statistics of the new rows are merged
        into :attr:`statistics_` (:class:`~neckid.models.ls_statistics.LeastSquaresStatistics`)
        and the coefficients solved again from them. A model file written before the statistics
        were stored holds the coefficients alone, which do not say how much data stand behind
        them; such a model refuses to update rather than guess a weight for them (a guess would
        make the update differ from a refit by an amount nobody chose): refit it.
        """
        experiments = update_experiments(self, data)
        statistics = getattr(self, "statistics_", None)
        if statistics is None:
            raise ValueError(
                "this LinearARX was loaded from a file written before neckid stored its"
                " least-squares statistics, so an update cannot equal a refit; refit it on its"
                " training data (fit([old, new])) to update it"
            )
        if statistics.centred != bool(self.fit_intercept):
            raise ValueError(
                f"fit_intercept is {self.fit_intercept!r} but the model was fitted with"
                f" {statistics.centred!r}; refit it to change the intercept"
            )
        x, y = update_rows(self, experiments)
        statistics = statistics.merge(LeastSquaresStatistics.from_rows(x, y, statistics.centred))
        self.coef_, self.intercept_ = statistics.solve(float(self.ridge))
        self.statistics_ = statistics
        self.n_samples_ = statistics.n_rows
        extend_training_ranges(self, experiments)
        return self

    def _predict_rows(self, x: FloatArray) -> FloatArray:
        return np.asarray(x @ self.coef_ + self.intercept_, dtype=np.float64)

    def _check_state(self) -> None:
        super()._check_state()
        self._check_shape("coef", self.coef_, (self.lags_.n_terms, self.n_outputs_))
        self._check_shape("intercept", self.intercept_, (self.n_outputs_,))

    # ------------------------------------------------------------------ files
    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        arrays = {"coef": self.coef_, "intercept": self.intercept_}
        statistics = getattr(self, "statistics_", None)
        if statistics is not None:
            arrays.update(statistics.to_arrays("statistics_"))
        meta = {
            "params": {"fit_intercept": bool(self.fit_intercept), "ridge": float(self.ridge)},
            **self._narx_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]) -> LinearARX:
        model = cls(lags=None, **meta["params"])
        model._restore_narx_meta(meta)
        model.coef_ = np.asarray(arrays["coef"], dtype=np.float64)
        model.intercept_ = np.asarray(arrays["intercept"], dtype=np.float64)
        model.statistics_ = LeastSquaresStatistics.from_arrays(
            arrays,
            "statistics_",
            model.n_samples_,
            bool(model.fit_intercept),
            (model.lags_.n_terms, len(model.output_names_)),
        )
        return model
