r"""Split-conformal bands for any identified model, calibrated on an experiment not used to fit it.

A fitted model's residuals on a *calibration* experiment give the half-width of a band that
contains a new output with a stated probability, whatever the model (Vovk, Gammerman & Shafer,
2005; Lei, G'Sell, Rinaldo, Tibshirani & Wasserman, 2018). :func:`calibrate` computes it for
one-step prediction, free-run simulation or k-step-ahead prediction (:func:`predict_ahead`,
for any model), and returns a :class:`CalibratedModel` whose results carry the band
(``extras["band"] == "calibrated"``).

References
----------
V. Vovk, A. Gammerman and G. Shafer, *Algorithmic Learning in a Random World*, Springer, 2005.

J. Lei, M. G'Sell, A. Rinaldo, R. J. Tibshirani and L. Wasserman, "Distribution-free predictive
inference for regression", Journal of the American Statistical Association 113(523):1094-1111,
2018.

R. F. Barber, E. J. Candès, A. Ramdas and R. J. Tibshirani, "Conformal prediction beyond
exchangeability", Annals of Statistics 51(2):816-845, 2023.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import ModelResult, check_is_fitted
from neckid.models.kstep import predict_ahead
from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = ["CalibratedModel", "Kind", "calibrate", "conformal_quantile", "predict_ahead"]

Kind = Literal["prediction", "simulation"]


def conformal_quantile(scores: ArrayLike, coverage: float = 0.95) -> FloatArray:
    r"""The split-conformal half-width: the ``⌈(n + 1)(1 − α)⌉``-th smallest score, per column.

    Parameters
    ----------
    scores : array_like, shape (n_samples,) or (n_samples, n_outputs)
        Non-conformity scores of the calibration samples (absolute residuals), finite.
    coverage : float, default 0.95
        The level ``1 − α``, in (0, 1).

    Returns
    -------
    ndarray, shape (n_outputs,)
        ``inf`` where ``⌈(n + 1)(1 − α)⌉ > n`` (fewer than ``1/α − 1`` samples: no finite
        band reaches the level), with a warning.

    Notes
    -----
    With scores ``s_1 … s_n`` of calibration samples exchangeable with a new one ``s``,

    .. math:: \Pr\left(s \le s_{(\lceil (n+1)(1-α) \rceil)}\right) \ge 1 − α,

    and, when the scores have no ties, ``<= 1 − α + 1/(n + 1)`` (Lei et al., 2018, Theorem 2.2):
    the ``n`` ranks of ``s`` among the ``n + 1`` scores are equally likely.

    Examples
    --------
    >>> conformal_quantile(np.arange(1.0, 20.0), coverage=0.95)   # ⌈20 · 0.95⌉ = 19th of 19
    array([19.])
    >>> conformal_quantile(np.arange(1.0, 40.0), coverage=0.9)    # ⌈40 · 0.9⌉ = 36th
    array([36.])
    """
    return _quantile(scores, coverage)


def _quantile(scores: ArrayLike, coverage: float) -> FloatArray:
    """:func:`conformal_quantile`; its warning points at the caller of the public function."""
    level = check_number(coverage, "coverage", low=0, high=1, closed="neither")
    s = np.asarray(scores, dtype=np.float64)
    if s.ndim == 1:
        s = s[:, None]
    if s.ndim != 2 or s.shape[0] == 0:
        raise ValueError(
            f"scores must be a non-empty 1-D or 2-D array; got shape {np.shape(scores)}"
        )
    if not np.all(np.isfinite(s)):
        row = int(np.argwhere(~np.isfinite(s))[0, 0])
        raise ValueError(f"scores must be finite; row {row} is not")
    n = s.shape[0]
    # (n + 1)(1 − α) computed in floating point may land a hair above a whole number.
    rank = math.ceil((n + 1) * level * (1 - 1e-12))
    if rank > n:
        warnings.warn(
            f"{n} calibration samples are too few for coverage {level:g}: the band is infinite;"
            f" calibrate on at least {math.ceil(level / (1 - level) * (1 - 1e-12))} samples",
            stacklevel=3,
        )
        return np.full(s.shape[1], np.inf)
    return np.asarray(np.sort(s, axis=0)[rank - 1], dtype=np.float64)


@dataclass(frozen=True)
class CalibratedModel:
    """A fitted model with a split-conformal band of the kind it was calibrated for.

    Attributes
    ----------
    model : fitted estimator
        The wrapped model (not copied: refit it and the calibration no longer holds).
    kind : {"prediction", "simulation"} or int
        One-step prediction, free run, or a number of steps ahead.
    coverage : float
        The level ``1 − α`` of the band.
    quantile : ndarray, shape (n_outputs,)
        The band's half-width per output (output units).
    n_calibration : int
        Number of calibration samples (scores).
    scores : ndarray, shape (n_calibration, n_outputs)
        The absolute calibration residuals.
    """

    model: Any
    kind: Kind | int
    coverage: float
    quantile: FloatArray
    n_calibration: int
    scores: FloatArray

    def predict(self, data: IOData) -> ModelResult:
        """One-step prediction with the band (calibrated with ``kind="prediction"``)."""
        self._check_kind("prediction", "predict")
        return self._with_band(self.model.predict(data))

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free run with the band (calibrated with ``kind="simulation"``)."""
        self._check_kind("simulation", "simulate")
        return self._with_band(self.model.simulate(data, initial=initial))

    def predict_ahead(self, data: IOData, steps: int | None = None) -> ModelResult:
        """``k``-step prediction with the band (calibrated with ``kind=k``; ``steps`` defaults to it)."""
        if isinstance(self.kind, str) or (steps is not None and steps != self.kind):
            raise ValueError(
                f"this band was calibrated for {self._describe()}; calibrate with kind={steps}"
                " for that horizon"
            )
        return self._with_band(predict_ahead(self.model, data, int(self.kind)))

    def _describe(self) -> str:
        return f"{self.kind}-step prediction" if isinstance(self.kind, int) else repr(self.kind)

    def _check_kind(self, kind: str, method: str) -> None:
        if self.kind != kind:
            raise ValueError(
                f"this band was calibrated for {self._describe()}, not {kind!r}: {method} would"
                f" carry a band of another meaning; calibrate with kind={kind!r}"
            )

    def _with_band(self, result: ModelResult) -> ModelResult:
        extras = dict(result.extras)
        if result.lower is not None and result.upper is not None:
            extras["model_lower"], extras["model_upper"] = result.lower, result.upper
        lower = result.y - self.quantile
        upper = result.y + self.quantile
        lower[: result.n_initial] = np.nan
        upper[: result.n_initial] = np.nan
        extras.update(
            band="calibrated",
            coverage=self.coverage,
            quantile=self.quantile.copy(),
            n_calibration=self.n_calibration,
        )
        return dataclasses.replace(result, lower=lower, upper=upper, extras=extras)


def _base_result(model: Any, data: IOData, kind: Kind | int) -> ModelResult:
    if kind == "simulation":
        result: ModelResult = model.simulate(data)
        return result
    if kind == "prediction":
        result = model.predict(data)
        return result
    return predict_ahead(model, data, int(kind))


def calibrate(
    model: Any,
    calibration_data: IOData | Sequence[IOData],
    *,
    coverage: float = 0.95,
    kind: Kind | int = "simulation",
) -> CalibratedModel:
    r"""Split-conformal band of a fitted model, from experiments it was not fitted on.

    Parameters
    ----------
    model : fitted estimator
        Any neckid model (every registered method).
    calibration_data : IOData or list of IOData
        Experiments **not used to fit the model** (nor to choose its settings).
    coverage : float, default 0.95
        The level ``1 − α`` in (0, 1).
    kind : {"simulation", "prediction"} or int, default "simulation"
        Which result the band goes with: the free run (residuals of ``simulate`` from each
        experiment's first outputs), the one-step prediction, or the ``k``-step-ahead prediction
        (:func:`predict_ahead`) for an int ``k >= 1``.

    Returns
    -------
    CalibratedModel
        Its ``simulate`` / ``predict`` / ``predict_ahead`` give results with ``lower`` and
        ``upper`` and ``extras["band"] == "calibrated"``, ``extras["coverage"]``.

    Raises
    ------
    NotFittedError
        If the model is not fitted.
    ValueError
        For a ``coverage`` outside (0, 1), an unknown ``kind``, or calibration data the model
        cannot run on.

    Notes
    -----
    The scores are the absolute residuals ``s_i = |y_i − ŷ_i|`` of every calibration sample
    after each experiment's ``n_initial`` ones, per output; the half-width is
    :func:`conformal_quantile`, the ``⌈(n + 1)(1 − α)⌉``-th smallest score, and the band is
    ``ŷ ± q``. If a new sample's score is exchangeable with the calibration scores, it falls in
    the band with probability at least ``1 − α`` (Vovk et al., 2005; Lei et al., 2018).
    Residuals of one log are correlated in time, so they are not exchangeable: the level then
    holds on average over samples from the same conditions (Barber et al., 2023, bound the
    loss), while a single log's share may differ, the more so for a free run, whose residuals
    drift slowly. Calibrate on experiments like the ones the band will be used on (payload,
    controller, range): a band cannot cover what the calibration data did not show.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> def log(seed):
    ...     rng = np.random.default_rng(seed)
    ...     u, y = rng.normal(size=2000), np.zeros(2000)
    ...     for t in range(1, 2000):
    ...         y[t] = 0.5 * y[t - 1] + u[t - 1] + 0.1 * rng.normal()
    ...     return IOData(u, y, ts=0.1)
    >>> model = LinearARX(Lags.arx(1, 1)).fit(log(0))
    >>> bands = calibrate(model, log(1), coverage=0.9, kind="prediction")
    >>> result = bands.predict(log(2))
    >>> result.extras["band"], result.extras["coverage"]
    ('calibrated', 0.9)
    >>> from neckid.metrics import coverage
    >>> bool(0.87 < coverage(log(2).y, result.lower, result.upper, skip=1)[0] < 0.93)
    True
    """
    check_is_fitted(model)
    level = check_number(coverage, "coverage", low=0, high=1, closed="neither")
    if isinstance(kind, str):
        if kind not in ("simulation", "prediction"):
            raise ValueError(
                f"kind must be 'simulation', 'prediction' or a number of steps >= 1; got {kind!r}"
            )
    else:
        kind = check_number(kind, "kind", low=1, integer=True)
    scores = []
    for d in as_experiments(calibration_data):
        result = _base_result(model, d, kind)
        scores.append(np.abs(d.y[result.n_initial :] - result.y[result.n_initial :]))
    all_scores = np.vstack(scores)
    quantile = _quantile(all_scores, level)
    return CalibratedModel(model, kind, level, quantile, int(all_scores.shape[0]), all_scores)
