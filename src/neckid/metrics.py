"""Figures of merit: NRMSE fit, RMSE, MAE, maximum error, band coverage and width, residual tests.

Every function takes measured and model outputs with time down the rows, returns one value per
output channel, and skips the first ``skip`` samples (the initial conditions of a free run).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import linalg, stats

from neckid.utils.checks import check_number, check_vector
from neckid.utils.types import FloatArray

__all__ = [
    "CorrelationTest",
    "coverage",
    "fit_percent",
    "mae",
    "max_abs_error",
    "mean_width",
    "residual_autocorrelation",
    "residual_input_correlation",
    "rmse",
]


def _pair(y_true: ArrayLike, y_pred: ArrayLike, skip: int) -> tuple[FloatArray, FloatArray]:
    a = np.asarray(y_true, dtype=np.float64)
    b = np.asarray(y_pred, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if b.ndim == 1:
        b = b[:, None]
    if a.ndim != 2 or b.ndim != 2:
        raise ValueError(
            f"y_true and y_pred must be 1-D or 2-D; got shapes {np.shape(y_true)}, {np.shape(y_pred)}"
        )
    if a.shape != b.shape:
        raise ValueError(f"y_true and y_pred must have the same shape; got {a.shape} and {b.shape}")
    skip = check_number(skip, "skip", low=0, integer=True)
    if skip >= a.shape[0]:
        raise ValueError(f"skip={skip} leaves no sample of {a.shape[0]}")
    a, b = a[skip:], b[skip:]
    for arr, argument in ((a, "y_true"), (b, "y_pred")):
        bad = ~np.isfinite(arr)
        if bad.any():
            row, col = (int(i) for i in np.argwhere(bad)[0])
            raise ValueError(
                f"{argument} has a non-finite value {float(arr[row, col])!r} at row {row + skip}, output {col}"
            )
    return a, b


def fit_percent(y_true: ArrayLike, y_pred: ArrayLike, skip: int = 0) -> FloatArray:
    """NRMSE fit in percent, as MATLAB's ``compare``: ``100 (1 - ||y - ŷ|| / ||y - mean(y)||)``.

    Parameters
    ----------
    y_true, y_pred : array_like, shape (n_samples,) or (n_samples, n_outputs)
        Measured and model outputs.
    skip : int, default 0
        Samples at the start left out of both norms and of the mean (initial conditions).

    Returns
    -------
    ndarray, shape (n_outputs,)
        100 for a perfect model, 0 for one no better than the mean, negative for worse.

    Raises
    ------
    ValueError
        If a measured output is constant over the samples used: the fit is then undefined
        (division by zero), and a NaN is not returned in its place.

    Examples
    --------
    >>> fit_percent([0.0, 1.0, 2.0, 3.0], [0.0, 1.0, 2.0, 2.0])
    array([55.27864045])
    """
    a, b = _pair(y_true, y_pred, skip)
    spread = np.linalg.norm(a - a.mean(axis=0), axis=0)
    constant = np.flatnonzero(spread == 0)
    if constant.size:
        j = int(constant[0])
        raise ValueError(
            f"fit_percent is undefined for output {j}: the measured output is constant"
            f" ({float(a[0, j])!r}) over the {a.shape[0]} samples used, so ||y - mean(y)|| = 0;"
            " use rmse or mae instead"
        )
    return np.asarray(100.0 * (1.0 - np.linalg.norm(a - b, axis=0) / spread), dtype=np.float64)


def rmse(y_true: ArrayLike, y_pred: ArrayLike, skip: int = 0) -> FloatArray:
    """Root-mean-square error per output: ``sqrt(mean((y - ŷ)^2))``, in the outputs' units.

    Examples
    --------
    >>> rmse([0.0, 1.0], [0.0, 3.0])
    array([1.41421356])
    """
    a, b = _pair(y_true, y_pred, skip)
    return np.asarray(np.sqrt(np.mean((a - b) ** 2, axis=0)), dtype=np.float64)


def mae(y_true: ArrayLike, y_pred: ArrayLike, skip: int = 0) -> FloatArray:
    """Mean absolute error per output: ``mean(|y - ŷ|)``, in the outputs' units.

    Examples
    --------
    >>> mae([0.0, 1.0], [0.0, 3.0])
    array([1.])
    """
    a, b = _pair(y_true, y_pred, skip)
    return np.asarray(np.mean(np.abs(a - b), axis=0), dtype=np.float64)


def max_abs_error(y_true: ArrayLike, y_pred: ArrayLike, skip: int = 0) -> FloatArray:
    """Largest absolute error per output: ``max(|y - ŷ|)``, in the outputs' units.

    Examples
    --------
    >>> max_abs_error([0.0, 1.0], [0.5, 3.0])
    array([2.])
    """
    a, b = _pair(y_true, y_pred, skip)
    return np.asarray(np.max(np.abs(a - b), axis=0), dtype=np.float64)


def _band_arrays(
    arrays: tuple[ArrayLike, ...], names: tuple[str, ...], skip: int
) -> tuple[FloatArray, ...]:
    """2-D float arrays of one shape, the first ``skip`` rows dropped; NaN refused (±inf allowed).

    A band may be infinite (a conformal band calibrated on too few samples), but it is never NaN
    past the initial conditions, and its lower edge never lies above its upper edge.
    """
    out = []
    for value, name in zip(arrays, names, strict=True):
        a = np.asarray(value, dtype=np.float64)
        if a.ndim == 1:
            a = a[:, None]
        if a.ndim != 2:
            raise ValueError(f"{name} must be 1-D or 2-D; got shape {np.shape(value)}")
        out.append(a)
    shapes = {a.shape for a in out}
    if len(shapes) != 1:
        listed = ", ".join(f"{n} {a.shape}" for n, a in zip(names, out, strict=True))
        raise ValueError(f"{', '.join(names)} must have the same shape; got {listed}")
    skip = check_number(skip, "skip", low=0, integer=True)
    if skip >= out[0].shape[0]:
        raise ValueError(f"skip={skip} leaves no sample of {out[0].shape[0]}")
    out = [a[skip:] for a in out]
    for a, name in zip(out, names, strict=True):
        bad = np.isnan(a)
        if bad.any():
            row, col = (int(i) for i in np.argwhere(bad)[0])
            raise ValueError(
                f"{name} is NaN at row {row + skip}, output {col}; skip the rows without a band"
                " (the initial conditions: skip=result.n_initial)"
            )
    lower, upper = out[-2], out[-1]
    crossed = lower > upper
    if crossed.any():
        row, col = (int(i) for i in np.argwhere(crossed)[0])
        raise ValueError(
            f"lower > upper at row {row + skip}, output {col} ({lower[row, col]!r} >"
            f" {upper[row, col]!r}): not a band"
        )
    return tuple(out)


def coverage(y: ArrayLike, lower: ArrayLike, upper: ArrayLike, skip: int = 0) -> FloatArray:
    r"""Share of the samples inside the band, per output: ``mean(lower <= y <= upper)``.

    .. math:: C_j = \frac{1}{N - s} \sum_{t=s}^{N-1} \mathbf{1}\left[l_j(t) \le y_j(t) \le u_j(t)\right]

    with ``s = skip``. The edges count as inside.

    Parameters
    ----------
    y : array_like, shape (n_samples,) or (n_samples, n_outputs)
        Measured (or noise-free) outputs.
    lower, upper : array_like, same shape as ``y``
        The band (may be ±inf, never NaN past ``skip``).
    skip : int, default 0
        Samples at the start left out (initial conditions, where a band is NaN).

    Returns
    -------
    ndarray, shape (n_outputs,)
        Shares in [0, 1].

    Raises
    ------
    ValueError
        If the shapes differ, ``skip`` leaves no sample, a value is NaN past ``skip`` (``y``
        must be finite), or ``lower > upper`` somewhere.

    Examples
    --------
    >>> coverage([0.0, 1.0, 2.0, 3.0], [-1.0, 0.5, 2.0, 3.5], [1.0, 1.5, 2.5, 4.0])
    array([0.75])
    """
    a, low, high = _band_arrays((y, lower, upper), ("y", "lower", "upper"), skip)
    if not np.all(np.isfinite(a)):
        row, col = (int(i) for i in np.argwhere(~np.isfinite(a))[0])
        raise ValueError(f"y has a non-finite value {float(a[row, col])!r} at row {row + skip}")
    return np.asarray(np.mean((low <= a) & (a <= high), axis=0), dtype=np.float64)


def mean_width(lower: ArrayLike, upper: ArrayLike, skip: int = 0) -> FloatArray:
    r"""Mean width of the band per output, ``mean(upper - lower)``, in the outputs' units.

    .. math:: W_j = \frac{1}{N - s} \sum_{t=s}^{N-1} \left(u_j(t) - l_j(t)\right)

    with ``s = skip``; ``inf`` when the band is infinite somewhere.

    Parameters
    ----------
    lower, upper : array_like, shape (n_samples,) or (n_samples, n_outputs)
        The band.
    skip : int, default 0
        Samples at the start left out (initial conditions).

    Returns
    -------
    ndarray, shape (n_outputs,)

    Raises
    ------
    ValueError
        If the shapes differ, ``skip`` leaves no sample, a value is NaN past ``skip``, or
        ``lower > upper`` somewhere.

    Examples
    --------
    >>> mean_width([[0.0, 1.0], [1.0, 1.0]], [[2.0, 1.5], [2.0, 2.5]])
    array([1.5, 1. ])
    """
    low, high = _band_arrays((lower, upper), ("lower", "upper"), skip)
    return np.asarray(np.mean(high - low, axis=0), dtype=np.float64)


@dataclass(frozen=True)
class CorrelationTest:
    """A residual correlation test: the correlations, their band and the chi-square verdict.

    Attributes
    ----------
    lags : ndarray of int, shape (n_lags,)
        Lags [samples] at which the normalised correlation was computed.
    correlation : ndarray, shape (n_lags,)
        Normalised correlation (1 at lag 0 for an autocorrelation).
    bound : float
        Half-width of the per-lag band, ``z_{(1+confidence)/2} / sqrt(N)``: each correlation of
        white residuals independent of the input lies inside it with probability ``confidence``
        (asymptotically, N large).
    confidence : float
        Confidence level of the band and of the chi-square test (e.g. 0.99).
    statistic : float
        The portmanteau statistic (Notes); chi-square with ``degrees_of_freedom`` degrees of
        freedom when the residuals are white (and, for a cross-correlation, independent of the
        input).
    threshold : float
        The chi-square quantile at ``confidence``: the test fails above it.
    degrees_of_freedom : int
        Of the chi-square distribution (the number of lags tested, or the rank of the input's
        correlation matrix when that is lower).
    outside : int
        Number of tested lags whose correlation lies outside the band. Even for white residuals
        about ``(1 - confidence)`` of the lags lie outside, so some lags outside do not reject the
        model; the verdict is the chi-square test's.
    passed : bool
        True when ``statistic <= threshold``: the hypothesis (white; independent of the input) is
        not rejected at ``confidence``.

    Notes
    -----
    Ljung, *System Identification: Theory for the User*, 2nd ed., 1999, section 16.6. The
    whiteness statistic is ``N sum_{k=1}^{M} r_e(k)^2`` (chi-square, M degrees of freedom); the
    independence statistic is ``N r^T R_u^{-1} r`` with ``r = [r_eu(-M), ..., r_eu(M)]`` and
    ``R_u`` the Toeplitz matrix of the input's normalised autocorrelation (chi-square, 2M + 1
    degrees of freedom); for a white input it is ``N sum_k r_eu(k)^2``.
    """

    lags: NDArray[np.int64]
    correlation: FloatArray
    bound: float
    confidence: float
    statistic: float
    threshold: float
    degrees_of_freedom: int
    outside: int
    passed: bool


def _xcorr(a: FloatArray, b: FloatArray, lags: NDArray[np.int64]) -> FloatArray:
    """Normalised cross-correlation r_ab(k) = sum_t a(t+k) b(t) / (N sigma_a sigma_b)."""
    n = a.size
    a = a - a.mean()
    b = b - b.mean()
    scale = n * a.std() * b.std()
    if scale == 0:
        raise ValueError("a residual or input is constant; its correlation is undefined")
    out = np.empty(lags.size)
    for i, k in enumerate(lags):
        if k >= 0:
            out[i] = np.dot(a[k:], b[: n - k]) / scale
        else:
            out[i] = np.dot(a[: n + k], b[-k:]) / scale
    return out


def _band(n: int, confidence: float) -> float:
    level = check_number(confidence, "confidence", low=0, high=1, closed="neither")
    return float(stats.norm.ppf(0.5 + level / 2.0) / np.sqrt(n))


def _verdict(
    lags: NDArray[np.int64],
    r: FloatArray,
    tested: FloatArray,
    statistic: float,
    dof: int,
    n: int,
    confidence: float,
) -> CorrelationTest:
    """The test of ``tested`` (the correlations at the tested lags) against its band and chi-square."""
    bound = _band(n, confidence)
    threshold = float(stats.chi2.ppf(confidence, dof))
    outside = int(np.sum(np.abs(tested) > bound))
    return CorrelationTest(
        lags, r, bound, confidence, statistic, threshold, dof, outside, statistic <= threshold
    )


def residual_autocorrelation(
    residuals: ArrayLike, max_lag: int = 25, confidence: float = 0.99
) -> CorrelationTest:
    """Whiteness test of prediction residuals (Ljung, *System Identification*, 2nd ed., 16.6).

    The normalised autocorrelation at lags ``0..max_lag`` is compared with the band
    ``±z/sqrt(N)`` that white noise stays inside with probability ``confidence`` at each lag,
    and the portmanteau statistic ``N sum_{k=1}^{M} r(k)^2`` with the chi-square quantile
    (M = ``max_lag`` degrees of freedom): the verdict.

    Parameters
    ----------
    residuals : array_like, shape (n_samples,)
        One output's residuals, ``y - ŷ`` of a one-step-ahead prediction.
    max_lag : int, default 25
        M, the largest lag [samples].
    confidence : float, default 0.99

    Returns
    -------
    CorrelationTest

    Examples
    --------
    >>> import numpy as np
    >>> e = np.random.default_rng(1).normal(size=2000)
    >>> test = residual_autocorrelation(e, max_lag=10)
    >>> round(test.bound, 4)  # 2.5758 / sqrt(2000)
    0.0576
    >>> float(test.correlation[0])
    1.0
    >>> round(test.threshold, 2), test.degrees_of_freedom  # chi-square 99 % quantile, 10 lags
    (23.21, 10)
    """
    e = _residual_vector(residuals, "residuals")
    max_lag = check_number(max_lag, "max_lag", low=1, high=e.size - 1, integer=True)
    lags = np.arange(0, max_lag + 1, dtype=np.int64)
    r = _xcorr(e, e, lags)
    statistic = float(e.size * np.sum(r[1:] ** 2))
    return _verdict(lags, r, r[1:], statistic, max_lag, e.size, confidence)


def residual_input_correlation(
    residuals: ArrayLike, u: ArrayLike, max_lag: int = 25, confidence: float = 0.99
) -> CorrelationTest:
    """Independence test of residuals and a past input (Ljung 16.6): r_eu(k), k = -max_lag..max_lag.

    A correlation outside the band at ``k > 0`` means the residual at ``t + k`` still depends on the
    input at ``t``: input dynamics the model missed (at ``k < 0``: the input depends on past
    residuals, as in a closed loop). The verdict is the chi-square test of all ``2M + 1`` lags
    together, ``N r^T R_u^{-1} r``, whose correlation between lags a coloured input brings is
    taken out by its autocorrelation matrix ``R_u`` (:class:`CorrelationTest`, Notes).

    Parameters
    ----------
    residuals : array_like, shape (n_samples,)
        One output's residuals.
    u : array_like, shape (n_samples,)
        One input, sampled with the residuals.
    max_lag : int, default 25
        M, the largest lag [samples]; ``2M`` must be below the number of samples.
    confidence : float, default 0.99

    Returns
    -------
    CorrelationTest

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(2)
    >>> u, e = rng.normal(size=3000), rng.normal(size=3000)
    >>> residual_input_correlation(e, u, max_lag=10).passed
    True
    >>> residual_input_correlation(e + 0.3 * np.roll(u, 2), u, max_lag=10).passed
    False
    """
    e = _residual_vector(residuals, "residuals")
    x = _residual_vector(u, "u")
    if x.size != e.size:
        raise ValueError(f"residuals and u must have the same length; got {e.size} and {x.size}")
    max_lag = check_number(max_lag, "max_lag", low=1, high=(e.size - 1) // 2, integer=True)
    lags = np.arange(-max_lag, max_lag + 1, dtype=np.int64)
    r = _xcorr(e, x, lags)
    r_u = _xcorr(x, x, np.arange(0, 2 * max_lag + 1, dtype=np.int64))
    quadratic, dof = _toeplitz_quadratic(r_u, r)
    return _verdict(lags, r, r, float(e.size * quadratic), dof, e.size, confidence)


def _toeplitz_quadratic(column: FloatArray, r: FloatArray) -> tuple[float, int]:
    """``r' T^-1 r`` for the symmetric Toeplitz ``T`` of ``column``, and the rank it used.

    Levinson's recursion (``scipy.linalg.solve_toeplitz``, O(n^2), no threaded LAPACK call);
    when ``T`` is singular or the solution does not solve it (an input of a few sinusoids), the
    eigen-decomposition on the eigenvalues above ``1e-10`` times the largest, whose count is
    then the degrees of freedom.
    """
    matrix = linalg.toeplitz(column)
    try:
        solution = linalg.solve_toeplitz(column, r)
        if np.linalg.norm(matrix @ solution - r) <= 1e-8 * float(np.linalg.norm(r)) + 1e-300:
            return float(r @ solution), r.size
    except np.linalg.LinAlgError:
        pass
    values, vectors = np.linalg.eigh(matrix)
    kept = values > 1e-10 * values.max()
    projected = vectors[:, kept].T @ r
    return float(np.sum(projected**2 / values[kept])), int(kept.sum())


def _residual_vector(values: ArrayLike, argument: str) -> FloatArray:
    """One channel as a finite 1-D array of at least 3 samples (a single row or column is raveled)."""
    v = np.asarray(values)
    v = check_vector(v.ravel() if v.ndim == 2 and 1 in v.shape else v, argument)
    if v.size < 3:
        raise ValueError(f"{argument} needs at least 3 samples; got {v.size}")
    return v
