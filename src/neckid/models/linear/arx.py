"""LinearARX: the batch least-squares ARX baseline over any :class:`~neckid.Lags` regressor.

Its free run (:func:`linear_free_run`) is a linear filter, not a per-sample Python loop: for one
output the FIR part of each input (summed tap by tap in a fixed order) and the all-pole part
(``lfilter``'s direct form II transposed) in one compiled pass, :mod:`neckid.models.linear._arx_kernels`, which in
``LinearARX.simulate`` also counts what every free run checks (channels and regressor terms
outside their training ranges, non-finite outputs, the divergence envelope); a small compiled
loop (:func:`_linear_free_run_kernel`) when several outputs feed back into each other. The
generic NARX loop (``neckid.models.base._free_run``) is the reference both are tested against.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.data.iodata import IOData
from neckid.models._domain_kernels import channels_of
from neckid.models.base import ModelResult, NarxModel, check_is_fitted
from neckid.models.envelope import impulse_l1
from neckid.models.linear._arx_kernels import checked_free_run
from neckid.models.linear._arx_plan import filter_coefficients, filter_state, plan_of
from neckid.models.linear.ls_statistics import LeastSquaresStatistics
from neckid.models.online import extend_training_ranges, update_experiments, update_rows
from neckid.models.results import RunChecks
from neckid.regressors import Lags, ResolvedLags
from neckid.utils.checks import Interval
from neckid.utils.types import FloatArray, IntArray

__all__ = ["LinearARX", "least_squares", "linear_free_run", "linear_sum"]

#: No regressor terms for the compiled checks to count.
_NO_TERMS: tuple[list[str], IntArray, FloatArray] = (
    [],
    np.empty((0, 3), np.int64),
    np.empty((0, 2)),
)


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


def linear_free_run(
    resolved: ResolvedLags,
    coef: ArrayLike,
    intercept: ArrayLike,
    u: ArrayLike,
    y_initial: ArrayLike,
) -> FloatArray:
    """Free run of the linear ARX map ``y(t) = intercept + coefᵀ w(t)`` as a filter.

    Gives what the generic NARX loop gives (``neckid.models.base._free_run`` with
    ``x @ coef + intercept``), to rounding, without a Python loop over the samples.

    Parameters
    ----------
    resolved : ResolvedLags
        The regressor ``w(t)``: which lag of which output or input each row of ``coef`` weighs.
        Lags may be sparse; inputs (and conditions) may have lag 0.
    coef : array_like, shape (n_terms, n_outputs)
        Coefficients on ``w(t)``, in the order of ``resolved.names``.
    intercept : array_like, shape (n_outputs,)
        Constant term (zeros for a model without one).
    u : array_like, shape (n_samples, n_inputs)
        The inputs, all of them measured: input terms at ``t >= max_lag`` only reach back to
        row 0.
    y_initial : array_like, shape (n_samples, n_outputs)
        Its first ``max_lag`` rows are the initial outputs (oldest first); the other rows are
        ignored.

    Returns
    -------
    ndarray, shape (n_samples, n_outputs)
        The first ``max_lag`` rows copied from ``y_initial``, then the free run.

    Raises
    ------
    ValueError
        If there are no more than ``max_lag`` samples.

    Notes
    -----
    With ``A_l`` the coefficients of the outputs at lag ``l`` (an ``n_outputs × n_outputs``
    matrix, zero for lags not in the regressor), ``B_l`` those of the inputs and ``c`` the
    intercept,

    ``y(t) = c + Σ_{l=1..L} A_l y(t − l) + Σ_{l=0..max_lag} B_l u(t − l)``,
    ``t = max_lag, …, n_samples − 1``.

    With one output the input part ``x(t) = c + Σ_l B_l u(t − l)`` does not feed back: it is a
    FIR filter per input, and ``y`` is the IIR filter ``1 / (1 − Σ_l a_l z^{-l})`` applied to
    ``x``, as :func:`scipy.signal.lfilter` runs them (the IIR in direct form II transposed),
    here in one compiled pass over the samples without its overhead. The FIR is summed tap by
    tap in a fixed order, the same floats on every CPU; ``np.convolve`` (inside ``lfilter``)
    sums in an order that depends on the CPU's SIMD and the BLAS core, so the two agree to
    rounding (``2·γ_w·Σ|products|`` for ``w`` taps), and bit for bit only where that order
    happens to be the same (``np.convolve`` itself for an input with more than
    ``MAX_FIR_TAPS`` taps). The IIR filter
    starts from the state that :func:`scipy.signal.lfiltic` builds from the last ``L`` initial
    outputs, so that its first output is ``x(m) + Σ_l a_l y(m − l)`` exactly as in the loop
    ([1]_, sections 6.5 and 6.6). With several outputs the ``A_l`` couple them and the whole
    recursion runs in the compiled :func:`_linear_free_run_kernel`. Only the order of the
    floating-point additions differs from the generic loop.

    References
    ----------
    .. [1] A. V. Oppenheim, R. W. Schafer, *Discrete-Time Signal Processing*, 3rd ed., Pearson,
       2010.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> data = IOData(np.ones(5), np.zeros(5), ts=0.1)
    >>> resolved = Lags.arx(1, 1).resolve(data)  # y(t) = 0.5 y(t-1) + u(t-1) + 0.1
    >>> linear_free_run(resolved, [[0.5], [1.0]], [0.1], data.u, [[2.0]] * 5).ravel()
    array([2.    , 2.1   , 2.15  , 2.175 , 2.1875])
    """
    y = np.array(y_initial, dtype=np.float64, order="C", ndmin=2)
    return _linear_free_run(resolved, coef, intercept, u, y)


def _linear_free_run(
    resolved: ResolvedLags, coef: ArrayLike, intercept: ArrayLike, u: ArrayLike, y: FloatArray
) -> FloatArray:
    """:func:`linear_free_run` in place on ``y`` (C-contiguous float64, ``(n_samples, n_outputs)``)."""
    y = np.require(y, dtype=np.float64, requirements="C")
    u_arr = np.ascontiguousarray(u, dtype=np.float64)
    coef_arr = np.asarray(coef, dtype=np.float64).reshape(resolved.n_terms, -1)
    n, n_out = y.shape
    m = resolved.max_lag
    if n <= m:
        raise ValueError(
            f"data has {n} samples, too few for lags up to {m}: it needs at least {m + 1}"
        )
    if n_out > 1:
        outputs = np.flatnonzero(resolved.source == 0)
        inputs = np.flatnonzero(resolved.source == 1)
        _linear_free_run_kernel(
            y,
            u_arr,
            np.ascontiguousarray(resolved.channel[outputs], dtype=np.int64),
            np.ascontiguousarray(resolved.lag[outputs], dtype=np.int64),
            np.ascontiguousarray(coef_arr[outputs]),
            np.ascontiguousarray(resolved.channel[inputs], dtype=np.int64),
            np.ascontiguousarray(resolved.lag[inputs], dtype=np.int64),
            np.ascontiguousarray(coef_arr[inputs]),
            np.ascontiguousarray(intercept, dtype=np.float64).reshape(n_out),
            m,
        )
        return y
    fir, denominator, state = _single_output_filter(resolved, coef_arr, intercept, u_arr, y)
    no_terms = (np.empty((0, 3), np.int64), np.empty((0, 2)))
    checked_free_run(
        channels_of(u_arr),
        channels_of(np.empty((n, 0))),
        fir,
        denominator,
        state,
        y[:, 0],
        (np.empty(0), 0.0, 0.0),
        no_terms,
        no_terms,
        np.array([-np.inf, np.inf]),
        m,
    )
    return y


def _single_output_filter(
    resolved: ResolvedLags, coef: FloatArray, intercept: ArrayLike, u: FloatArray, y: FloatArray
) -> tuple[tuple[IntArray, FloatArray, FloatArray, float], FloatArray, FloatArray]:
    """The single-output ARX map as filters: ``(fir, denominator, state)`` of ``checked_free_run``.

    The FIR of each input and the all-pole ``denominator`` ``1 − Σ_l a_l z^{-l}``
    (:func:`~neckid.models.linear._arx_plan.filter_coefficients`) and the state that
    :func:`scipy.signal.lfiltic` builds from the last initial outputs in ``y``
    (:func:`~neckid.models.linear._arx_plan.filter_state`), its arithmetic without its checks.
    """
    filters = filter_coefficients(resolved, coef, intercept)
    fir = filters.fir(u, y.shape[0], resolved.max_lag)
    return fir, filters.denominator, filter_state(filters.denominator, y, resolved.max_lag)


@numba.njit(cache=True, nogil=True)
def _linear_free_run_kernel(
    y: FloatArray,
    u: FloatArray,
    output_channel: NDArray[np.int64],
    output_lag: NDArray[np.int64],
    output_coef: FloatArray,
    input_channel: NDArray[np.int64],
    input_lag: NDArray[np.int64],
    input_coef: FloatArray,
    intercept: FloatArray,
    start: int,
) -> None:  # pragma: no cover - compiled; tested against the generic NARX loop
    """``y(t) = intercept + Σ_j input_coef_j u(t − lag_j) + Σ_j output_coef_j y(t − lag_j)``.

    In place for ``t >= start`` (rows are time); term ``j`` reads column ``channel_j``, and its
    coefficient row holds one value per output.
    """
    n, n_out = y.shape
    for t in range(start, n):
        for o in range(n_out):
            total = intercept[o]
            for j in range(input_lag.shape[0]):
                total += input_coef[j, o] * u[t - input_lag[j], input_channel[j]]
            for j in range(output_lag.shape[0]):
                total += output_coef[j, o] * y[t - output_lag[j], output_channel[j]]
            y[t, o] = total


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
        into :attr:`statistics_` (:class:`~neckid.models.linear.ls_statistics.LeastSquaresStatistics`)
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

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free-run simulation: the regressor holds the model's own past outputs.

        Parameters
        ----------
        data : IOData
            The inputs; its first ``max_lag_`` measured outputs are the initial conditions unless
            ``initial`` is given (then ``data`` may hold inputs only).
        initial : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
            The first outputs (oldest first; one row is repeated).

        Returns
        -------
        ModelResult
            Of kind ``"simulation"``; its first ``max_lag_`` samples are the initial outputs.

        Notes
        -----
        The same values as the generic NARX free run (and as stepping :meth:`simulator`), to
        rounding, computed as a linear filter (:func:`linear_free_run`): some hundred times
        faster than a loop over the samples in Python. With one output the filter and the checks
        of the result (extrapolation warning, divergence errors) are one compiled pass over the
        samples, with the numbers the other models' checks find in passes of their own.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        if self.n_outputs_ == 1:  # one compiled pass: the filter and every check of the run
            y = self._initial_outputs(data, initial, filled=False)  # the run writes the rest
            return self._result("simulation", data, y, checks=self._checked_run(data, y))
        y = self._initial_outputs(data, initial)
        with np.errstate(over="ignore", invalid="ignore"):  # divergence is reported below
            y = _linear_free_run(self.lags_, self.coef_, self.intercept_, data.u, y)
        return self._result("simulation", data, y)

    def _checked_run(self, data: IOData, y: FloatArray) -> RunChecks:
        """The single-output free run in place on ``y``, and what the run's checks found.

        One compiled pass (:func:`~neckid.models.linear._arx_kernels.checked_free_run`) gives
        the outputs of :func:`linear_free_run` and counts what ``_result`` would look for in
        passes of its own: the time stamps, the channels outside their training ranges
        (``extrapolation``), the regressor terms outside the training box (``_domain_shares``),
        the first non-finite output and the first one outside :meth:`divergence_envelope`.
        What it reads of the model is built once per fitted model
        (:func:`~neckid.models.linear._arx_plan.plan_of`). The pass looks for a runaway against
        the envelope for inputs inside their training ranges; only when it finds one is the
        log's envelope (wider when its inputs leave their ranges) worked out, and the first
        row outside that one looked for from there: the same row as a pass with it.
        """
        n, m = data.n_samples, self.max_lag_
        u = np.asarray(data.u, dtype=np.float64)
        plan = plan_of(self)  # what the run reads of the model, built once per fitted model
        filters = plan.filters
        assert filters is not None  # one output
        fir = filters.fir(u, n, m)
        denominator, state = filters.denominator, filter_state(filters.denominator, y, m)
        channel_names, channels, channel_bounds = plan.channel_terms(self, data)
        # as Estimator._warn_extrapolation: no box, or no measured outputs: no terms counted
        box = plan.terms if data.n_outputs == 1 else None
        counted = box is not None
        term_names, terms, term_bounds = box if box is not None else _NO_TERMS
        plain = plan.envelope  # widened only if the log's inputs leave their ranges: see below
        time = np.empty(n)
        channel_counts, term_counts, rows, non_finite, runaway = checked_free_run(
            channels_of(u),
            channels_of(data.y),
            fir,
            denominator,
            state,
            y[:, 0],
            (time, data.t0, data.ts),
            (channels, channel_bounds),
            (terms, term_bounds),
            plain,
            m,
        )
        if runaway >= 0:  # outside the plain envelope: is it outside the log's widened one?
            runaway = _first_outside(y[:, 0], runaway, plan.divergence_envelope(self, data, u))
        by_term = {k: int(c) / (n - m) for k, c in zip(term_names, term_counts, strict=True)}
        return RunChecks(
            time=time,
            extrapolation={
                k: int(c) / n for k, c in zip(channel_names, channel_counts, strict=True)
            },
            domain=(rows / (n - m), by_term) if counted else None,
            first_non_finite=int(non_finite) if non_finite >= 0 else None,
            first_runaway=(int(runaway), 0) if runaway >= 0 else None,
        )

    def _impulse_norms(self) -> FloatArray:
        """``||h_{o,i}||_1`` of the fitted filter per output and input (``inf``: unstable).

        Computed once per fitted model (kept in its plan, :func:`plan_of`).
        """
        plan = plan_of(self)
        if plan.gains is None:
            plan.gains = self._impulse_response_norms()
        return plan.gains.copy()

    def _impulse_response_norms(self) -> FloatArray:
        """:meth:`_impulse_norms` computed from impulse responses of the fitted filter."""
        m = int(self.max_lag_)
        zero = np.zeros(self.n_outputs_)

        def run(u: FloatArray) -> FloatArray:
            shifted = np.vstack([np.zeros((m, u.shape[1])), u])
            y = np.zeros((shifted.shape[0], self.n_outputs_))
            return _linear_free_run(self.lags_, self.coef_, zero, shifted, y)[m:]

        return impulse_l1(run, int(self.n_inputs_), int(self.n_outputs_))

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


def _first_outside(y: FloatArray, start: int, envelope: FloatArray) -> int:
    """The first row of ``y`` from ``start`` on outside ``envelope`` (-1 for none).

    The run looks for a runaway against the plain envelope, which the widened one contains:
    the first row outside the widened one is at or after the first outside the plain one.
    """
    low, high = envelope.tolist()
    rows = y[start:]
    outside = np.flatnonzero((rows < low) | (rows > high))
    return start + int(outside[0]) if outside.size else -1


def linear_sum(x: FloatArray, coef: FloatArray, intercept: FloatArray) -> FloatArray:
    """``intercept + Σ_k x[:, k] coef[k]``, summed term by term as the compiled free run does.

    Element by element (no BLAS), so a row gives the same value whatever the rows around it.
    """
    linear = np.broadcast_to(intercept, (x.shape[0], intercept.size)).copy()
    for k in range(x.shape[1]):
        linear += x[:, k : k + 1] * coef[k]
    return linear
