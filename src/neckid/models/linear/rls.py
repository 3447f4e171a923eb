"""RecursiveARX: ARX parameters estimated by recursive least squares with a constant forgetting factor.

The estimator is the CFF-RLS of Landau et al. (2011) used by the seed paper (section IV) to identify
a first-order model of the soft neck at each operating point, here for one output or several
sharing one regressor. The per-sample loop is compiled with numba
(:func:`neckid.models.linear.rls_kernels._rls_kernel`); :func:`rls_reference` is the plain NumPy
transcription of the same equations, kept beside it (in :mod:`neckid.models.linear.rls_kernels`) so that
the tests can check that both agree.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import ModelResult, NarxModel, check_is_fitted
from neckid.models.linear.arx import linear_free_run
from neckid.models.linear.rls_kernels import (
    NOT_FINITE,
    ParameterHistory,
    _rls_kernel,
    _rls_online_kernel,
    rls_reference,
)
from neckid.regressors import Lags, ResolvedLags
from neckid.utils.checks import Interval, check_finite, check_number
from neckid.utils.types import FloatArray

__all__ = ["Convergence", "RecursiveARX", "rls_reference"]


#: Default blow-up limit on ``trace(F)``, as a multiple of ``trace(F0)``.
DEFAULT_TRACE_FACTOR = 1e6


class Convergence(NamedTuple):
    """Result of :meth:`RecursiveARX.converged`: unpacks as ``(converged, settled_at)``.

    Attributes
    ----------
    converged : bool
        True when the estimates stayed inside the tolerance band for at least ``window`` samples.
    settled_at : int or None
        Row of ``theta_history_`` (sample index) from which every later estimate stays within the
        band around the final one; ``None`` when not even the last two samples agree.
    """

    converged: bool
    settled_at: int | None


# ---------------------------------------------------------------------- estimator
class RecursiveARX(NarxModel):
    """ARX model whose parameters are estimated online by CFF-RLS (constant forgetting factor).

    The model (seed paper, section IV; Landau et al., 2011) over the regressor of ``lags`` is, for
    the usual ``lags = Lags.arx(na, nb, d)``,

    ``y(t) = −a1 y(t−1) − … − a_na y(t−na) + b1 u(t−d) + … + b_nb u(t−d−nb+1)``

    with ``θ = [a1 … a_na, b1 … b_nb]`` and ``φ(t−1) = [−y(t−1) … −y(t−na), u(t−d) … u(t−d−nb+1)]``,
    so that ``y(t) = θᵀφ(t−1)``. Any other :class:`~neckid.Lags` works the same way: one ``a``
    per output term (named by its lag, ``a3`` for ``y(t−3)``) and one ``b`` per input term, in
    the order of ``lags_.names``; with several inputs the ``b`` names carry the input name.

    With several outputs the regressor ``φ`` (past values of every output and input) is shared,
    ``θ`` has one column per output and ``y_o(t) = θ[:, o]ᵀφ(t−1)``: the ``a`` of a past output
    ``y_k(t−l)`` in column ``o`` says how ``y_k`` feeds into ``y_o`` (its name carries the
    output, ``a1[roll]``). One adaptation gain ``F`` serves all outputs (see Notes).

    Parameters
    ----------
    lags : Lags
        The regressor, e.g. ``Lags.arx(na=1, nb=1, delay=1)`` (the seed paper's first-order model).
    forgetting_factor : float, default 0.98
        ``λ`` in (0, 1]. ``λ = 1`` is ordinary RLS; the seed paper uses 0.98. Past samples weigh
        ``λ^k``; the memory is about ``1 / (1 − λ)`` samples.
    initial_covariance : float or array_like of shape (n_params, n_params), default 1e4
        ``F(0)``: a scalar ``s`` means ``s·I``; a matrix must be symmetric positive definite. Large
        values mean little trust in ``initial_parameters``.
    initial_parameters : array_like of shape (n_params,) or (n_params, n_outputs), optional
        ``θ̂(0)``, in the order of ``θ`` above (``n_params`` = number of regressor terms); one
        column per output when there are several. Zeros by default.
    max_covariance_trace : float, optional
        Blow-up limit: when ``trace(F)`` exceeds it (or ``F`` or ``θ̂`` stop being finite) ``F`` is
        reset to ``F(0)`` and a warning is issued. Default ``1e6 · trace(F(0))``.

    Attributes
    ----------
    theta_ : ndarray, shape (n_params,), or (n_params, n_outputs) with several outputs
        The latest estimate ``θ̂`` (after the last sample).
    theta_history_ : ndarray, shape (n_samples, n_params), or (n_samples, n_params, n_outputs)
        ``θ̂`` after every sample seen (row ``t`` for sample ``t``). The first ``max_lag`` samples of
        each experiment only fill the regressor; their rows repeat the estimate held then.
    prediction_errors_ : ndarray, shape (n_samples,), or (n_samples, n_outputs)
        A priori errors ``ε(t) = y(t) − θ̂(t−1)ᵀφ(t−1)``; NaN on the initial-condition rows.
    covariance_ : ndarray, shape (n_params, n_params)
        The adaptation gain ``F`` after the last sample.
    n_covariance_resets_ : int
        How many times the blow-up guard reset ``F``.
    parameter_names_ : tuple of str
        One per row of ``θ``: ``("a1", …, "b1", …)``; with several inputs ``b`` names carry the
        input name, with several outputs ``a`` names the output.
    lags_ : ResolvedLags
        The regressor, as for the other NARX models.
    n_inputs_, n_outputs_, n_samples_ : int
    ts_ : float

    Raises
    ------
    ValueError
        From ``fit`` / ``update``: a hyper-parameter out of range (the message names it and its
        value), non-finite data, or a record shorter than the regressor needs.

    See Also
    --------
    neckid.LinearARX : the batch least-squares estimate on the same regressor.

    Notes
    -----
    CFF-RLS (Landau et al., 2011), for each new sample:

    - ``ε(t+1) = y(t+1) − θ̂(t)ᵀ φ(t)``
    - ``F(t+1) = (1/λ) [F(t) − F(t) φ(t) φ(t)ᵀ F(t) / (λ + φ(t)ᵀ F(t) φ(t))]``
    - ``θ̂(t+1) = θ̂(t) + F(t+1) φ(t) ε(t+1)ᵀ``

    With several outputs ``ε`` is the vector of the outputs' errors and ``θ̂`` the matrix
    ``(n_params, n_outputs)``: the standard multi-output RLS with a common regressor (Ljung,
    1999, section 11.2). The gain ``K = F(t+1) φ(t)`` does not depend on the outputs, so one ``F``
    serves them all and each column of ``θ̂`` follows exactly the recursion of its output alone.

    The compiled loop uses the identity ``F(t+1) φ(t) = F(t) φ(t) / (λ + φ(t)ᵀF(t)φ(t))``, computes
    the upper triangle of ``F(t+1)`` and mirrors it, so ``F`` stays exactly symmetric. With ``λ = 1``
    the estimate after ``n`` samples is the regularised least-squares solution
    ``(ΦᵀΦ + F(0)⁻¹)⁻¹ (ΦᵀY + F(0)⁻¹ θ̂(0))``, i.e. batch least squares when ``F(0)`` is large.

    ``predict`` and ``simulate`` (and ``simulator``) use the *final* estimate ``theta_`` as a fixed
    linear ARX model, with the conventions of :class:`~neckid.models.base.NarxModel`: the first
    ``max_lag_`` samples (``max(na, delay + nb − 1)`` for ``Lags.arx``) are initial conditions.
    The free run is a linear filter (:func:`neckid.models.linear.arx.linear_free_run`).

    The histories live in arrays that double when full, so a call to :meth:`update` costs the
    same however many samples came before (no per-sample re-allocation).

    References
    ----------
    .. [1] I. D. Landau, R. Lozano, M. M'Saad, A. Karimi, *Adaptive Control: Algorithms, Analysis and
       Applications*, 2nd ed., Springer, 2011 (chapter 3, parameter adaptation algorithms).
    .. [2] UC3M Robotics Lab, "Model Identification of a Soft Robotic Neck", section IV.
    .. [3] L. Ljung, *System Identification: Theory for the User*, 2nd ed., Prentice Hall, 1999
       (section 11.2, recursive least squares).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> from neckid.models.linear.rls import RecursiveARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=2000)
    >>> y = np.zeros(2000)
    >>> for t in range(1, 2000):
    ...     y[t] = 0.8 * y[t - 1] + 0.5 * u[t - 1]
    >>> model = RecursiveARX(Lags.arx(1, 1), forgetting_factor=1.0).fit(IOData(u, y, ts=0.02))
    >>> np.round(model.theta_, 6)  # a1 = -0.8, b1 = 0.5
    array([-0.8,  0.5])
    >>> model.converged(window=100, tolerance=1e-3).converged
    True

    Online use, one sample at a time:

    >>> online = RecursiveARX(Lags.arx(1, 1), forgetting_factor=1.0)
    >>> for yt, ut in zip(y, u):
    ...     _ = online.update(yt, ut)
    >>> np.allclose(online.theta_, model.theta_)
    True

    Two outputs, one regressor:

    >>> y2 = np.zeros(2000)
    >>> for t in range(1, 2000):
    ...     y2[t] = 0.5 * y2[t - 1] + 0.2 * y[t - 1] - u[t - 1]
    >>> both = IOData(u, np.column_stack([y, y2]), ts=0.02, output_names=["pitch", "roll"])
    >>> mimo = RecursiveARX(Lags.arx(1, 1), forgetting_factor=1.0).fit(both)
    >>> mimo.parameter_names_
    ('a1[pitch]', 'a1[roll]', 'b1')
    >>> np.round(mimo.theta_, 6)  # one column per output
    array([[-0.8, -0.2],
           [ 0. , -0.5],
           [ 0.5, -1. ]])
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "forgetting_factor": [Interval("real", 0, 1, closed="right")],
        "initial_covariance": [Interval("real", 0, None, closed="neither"), "array-like"],
        "initial_parameters": [None, "array-like"],
        "max_covariance_trace": [None, Interval("real", 0, None, closed="neither")],
    }

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        forgetting_factor: float = 0.98,
        initial_covariance: float | ArrayLike = 1e4,
        initial_parameters: ArrayLike | None = None,
        max_covariance_trace: float | None = None,
    ) -> None:
        self.lags = lags
        self.forgetting_factor = forgetting_factor
        self.initial_covariance = initial_covariance
        self.initial_parameters = initial_parameters
        self.max_covariance_trace = max_covariance_trace

    # ------------------------------------------------------------------ checks
    def _check_params(self, p: int, q: int = 1) -> tuple[float, FloatArray, FloatArray, float]:
        """Validate the hyper-parameters for ``p`` parameters and ``q`` outputs.

        Returns ``(λ, F0, θ0, max_trace)``, with ``θ0`` of shape ``(p, q)``.
        """
        self._validate_params()
        lam = float(self.forgetting_factor)
        f0 = np.asarray(self.initial_covariance, dtype=np.float64)
        if f0.ndim == 0:
            if not float(f0) > 0:
                raise ValueError(
                    "initial_covariance must be a number > 0 or a positive definite matrix; got"
                    f" {self.initial_covariance!r}"
                )
            f0 = float(f0) * np.eye(p)
        else:
            if f0.shape != (p, p):
                raise ValueError(
                    f"initial_covariance must be a scalar or a ({p}, {p}) matrix for {p} parameters;"
                    f" got shape {f0.shape}"
                )
            if not np.allclose(f0, f0.T, rtol=1e-12, atol=0.0):
                raise ValueError("initial_covariance must be symmetric; got an asymmetric matrix")
            smallest = float(np.linalg.eigvalsh(f0).min())
            if smallest <= 0:
                raise ValueError(
                    f"initial_covariance must be positive definite; its smallest eigenvalue is"
                    f" {smallest!r}"
                )
            f0 = np.ascontiguousarray(0.5 * (f0 + f0.T))
        if self.initial_parameters is None:
            theta0 = np.zeros((p, q))
        else:
            theta0 = np.array(self.initial_parameters, dtype=np.float64)
            if q == 1 and theta0.size != p:
                raise ValueError(
                    f"initial_parameters must have {p} values (one per regressor term); got"
                    f" {theta0.size}"
                )
            if q > 1 and theta0.shape != (p, q):
                raise ValueError(
                    f"initial_parameters must have shape ({p}, {q}): one row per regressor term,"
                    f" one column per output; got shape {theta0.shape}"
                )
            theta0 = np.ascontiguousarray(theta0.reshape(p, q))
        if self.max_covariance_trace is None:
            max_trace = DEFAULT_TRACE_FACTOR * float(np.trace(f0))
        else:
            max_trace = float(self.max_covariance_trace)
            if not (max_trace > np.trace(f0)):
                raise ValueError(
                    f"max_covariance_trace must exceed trace(initial_covariance) = {np.trace(f0)!r};"
                    f" got {self.max_covariance_trace!r}"
                )
        return lam, f0, theta0, max_trace

    def _regressor(self, data: IOData) -> tuple[FloatArray, FloatArray]:
        """``φ`` (output terms with their sign flipped) and ``y`` for one experiment.

        ``y`` is ``(n_rows,)`` for one output, ``(n_rows, n_outputs)`` for several.
        """
        x, y = self.lags_.build_one(data)
        x[:, self._output_terms] *= -1.0
        return np.ascontiguousarray(x), np.ascontiguousarray(y[:, 0] if y.shape[1] == 1 else y)

    def _start(self, resolved: ResolvedLags, data: IOData) -> None:
        """Set the learned state to the initial one (the start of ``fit`` or of online use)."""
        p, q = resolved.n_terms, len(resolved.output_names)
        lam, f0, theta0, max_trace = self._check_params(p, q)
        self.lags_ = resolved
        self._set_channels(data)
        self.max_lag_ = resolved.max_lag
        self.n_samples_ = 0
        self.theta_ = self._public(theta0.copy())
        self.covariance_ = f0.copy()
        self.n_covariance_resets_ = 0
        self._output_terms = resolved.source == 0
        names = []
        count: dict[int, int] = {}
        for source, channel, lag in zip(
            resolved.source, resolved.channel, resolved.lag, strict=True
        ):
            if source == 0:
                suffix = f"[{resolved.output_names[int(channel)]}]" if q > 1 else ""
                names.append(f"a{int(lag)}{suffix}")
                continue
            count[int(channel)] = count.get(int(channel), 0) + 1
            suffix = (
                f"[{resolved.input_names[int(channel)]}]" if len(resolved.input_names) > 1 else ""
            )
            names.append(f"b{count[int(channel)]}{suffix}")
        self.parameter_names_ = tuple(names)
        self._lambda = lam
        self._f0 = f0
        self._max_trace = max_trace
        self._history = ParameterHistory(p, q)
        self._online: dict[str, Any] | None = None

    def _public(self, theta: FloatArray) -> FloatArray:
        """``θ̂`` as stored in ``theta_``: ``(p,)`` for one output, ``(p, q)`` for several."""
        return theta.reshape(-1) if theta.shape[1] == 1 else theta

    def _theta_matrix(self) -> FloatArray:
        """``theta_`` as a ``(p, q)`` matrix sharing its memory (the kernels update it in place)."""
        if not (self.theta_.flags.c_contiguous and self.theta_.dtype == np.float64):
            self.theta_ = np.ascontiguousarray(self.theta_, dtype=np.float64)
        return self.theta_.reshape(self.lags_.n_terms, self.n_outputs_)

    # ------------------------------------------------------------------ batch
    def fit(self, data: IOData | Sequence[IOData]) -> RecursiveARX:
        """Run CFF-RLS over one log, or several one after the other, from the initial state.

        Parameters
        ----------
        data : IOData or sequence of IOData
            One output channel or several (sharing the regressor); every channel gets the terms
            of ``lags``. With several experiments the estimate and ``F`` carry over from one to
            the next, but no regressor straddles two.

        Returns
        -------
        RecursiveARX
            ``self``.

        Raises
        ------
        ValueError
            If a hyper-parameter is out of range, the data hold no output, an experiment is
            shorter than ``max_lag + 1`` samples, or the logs give fewer equations (regressor
            rows) than the regressor has unknowns: the estimate would stay near its start,
            with a perfect training fit that means nothing.
        """
        self._validate_params()
        experiments = as_experiments(self._with_conditions(data, fitting=True))
        resolved = self._lags().resolve(experiments)
        self._check_training(experiments)
        _check_equations(resolved, experiments)
        self._start(resolved, experiments[0])
        for experiment in experiments:
            self._run_batch(experiment)
        return self

    def partial_fit(self, data: IOData | Sequence[IOData]) -> RecursiveARX:
        """Continue the estimation over more logs, from the current ``θ̂`` and ``F``.

        Starts from the initial state when the model is not fitted yet. Returns ``self``.
        """
        if not hasattr(self, "theta_"):
            return self.fit(data)
        for experiment in as_experiments(self._with_conditions(data)):
            self._check_inputs(experiment)
            self._online = None
            self._run_batch(experiment)
        return self

    def _run_batch(self, experiment: IOData) -> None:
        phi, y = self._regressor(experiment)
        m = self.lags_.max_lag
        rows, p = phi.shape
        q = self.n_outputs_
        theta = np.array(self._theta_matrix())  # a copy: a theta_ held by the caller stays put
        history, errors = self._history.append(m + rows)
        history[:m] = theta
        errors[:m] = np.nan
        resets = np.empty(rows, dtype=np.int64)
        n_resets = _rls_kernel(
            phi,
            y.reshape(rows, q),
            theta,
            self.covariance_,
            self._lambda,
            self._f0,
            self._max_trace,
            history[m:],
            errors[m:],
            resets,
            np.empty(p + q),
        )
        self.theta_ = self._public(theta)
        self.n_samples_ += experiment.n_samples
        # Warn at the caller of fit / partial_fit.
        self._warn_resets(n_resets, resets[:n_resets] + m, experiment.name, stacklevel=4)
        self._online = None

    def _warn_resets(
        self, count: int, rows: NDArray[np.int64], label: str | None, stacklevel: int
    ) -> None:
        if count == 0:
            return
        self.n_covariance_resets_ += count
        where = f" of {label!r}" if label else ""
        warnings.warn(
            f"RecursiveARX: the adaptation gain F blew up (trace above {self._max_trace:.3g}, or a"
            f" non-finite value) {count} time(s), first at sample {int(rows[0])}{where}; F was reset"
            " to initial_covariance each time. Excite the system persistently, raise"
            " forgetting_factor, or raise max_covariance_trace.",
            RuntimeWarning,
            stacklevel=stacklevel,
        )

    # ------------------------------------------------------------------ online
    def _online_buffers(self) -> dict[str, Any]:
        """Work arrays of :meth:`update`, allocated once (not per sample).

        ``window`` holds the last ``max_lag + 1`` samples ``[y, u]`` twice over (slots ``k`` and
        ``k + max_lag + 1``), so that they are always one contiguous slice, oldest first;
        ``index`` gives each regressor term's place in that slice (see
        :func:`~neckid.models.linear.rls_kernels._rls_online_kernel`).
        """
        lags = self.lags_
        length = lags.max_lag + 1
        q = self.n_outputs_
        width = q + self.n_inputs_
        column = np.where(lags.source == 0, lags.channel, q + lags.channel)
        p = lags.n_terms
        return {
            "window": np.zeros(2 * length * width),
            "count": 0,
            "index": np.ascontiguousarray((length - 1 - lags.lag) * width + column, dtype=np.int64),
            "sign": np.where(lags.source == 0, -1.0, 1.0),
            "phi": np.empty((1, p)),
            "resets": np.empty(1, dtype=np.int64),
            "scratch": np.empty(p + q),
        }

    def update(self, y: float | ArrayLike, u: float | ArrayLike) -> float | FloatArray:
        """Take one new sample ``(y(t), u(t))`` and update ``θ̂`` and ``F`` (true online use).

        The first call starts from the initial state (as ``fit`` does; the number of outputs is
        that of ``y``); later calls continue from the current estimate, also after
        ``fit``/``partial_fit`` (then with an empty history: the next ``max_lag`` samples only fill
        the regressor).

        Parameters
        ----------
        y : float or array_like of shape (n_outputs,)
            Output(s) measured at time ``t``.
        u : float or array_like of shape (n_inputs,)
            Input applied at time ``t`` (used now only by terms of lag 0).

        Returns
        -------
        float or ndarray of shape (n_outputs,)
            The a priori error ``ε(t) = y(t) − θ̂(t−1)ᵀφ(t−1)``: a float for one output, one per
            output for several; NaN while the regressor fills.

        Raises
        ------
        ValueError
            If a value is not finite, or the number of inputs or outputs changes between calls.
        """
        y_now = np.ascontiguousarray(y, dtype=np.float64).reshape(-1)
        u_now = np.ascontiguousarray(u, dtype=np.float64).reshape(-1)
        if not hasattr(self, "theta_"):
            check_finite(y_now[None, :], "y")
            check_finite(u_now[None, :], "u")
            template = IOData(np.zeros((1, u_now.size)), np.zeros((1, y_now.size)), ts=1.0)
            self._start(self._lags().resolve(template), template)
        q = self.n_outputs_
        if y_now.size != q:
            raise ValueError(
                f"y must have {q} value(s), one per output {list(self.output_names_)}; got"
                f" {y_now.size}"
            )
        if u_now.size != self.n_inputs_:
            raise ValueError(
                f"u must have {self.n_inputs_} values (one per input); got {u_now.size}"
            )
        if self._online is None:
            self._online = self._online_buffers()
        online = self._online
        history, errors = self._history.reserve(1)
        row = self._history.size
        status = _rls_online_kernel(
            y_now,
            u_now,
            online["window"],
            online["count"],
            online["index"],
            online["sign"],
            online["phi"],
            self._theta_matrix(),
            self.covariance_,
            self._lambda,
            self._f0,
            self._max_trace,
            history,
            errors,
            row,
            online["resets"],
            online["scratch"],
        )
        if status == NOT_FINITE:  # the kernel changed nothing; the message names the value
            check_finite(y_now[None, :], "y")
            check_finite(u_now[None, :], "u")
        online["count"] += 1
        self._history.size += 1
        self.n_samples_ += 1
        if status > 0:
            self._warn_resets(status, np.array([self.n_samples_ - 1]), None, stacklevel=3)
        return float(errors[row, 0]) if q == 1 else errors[row].copy()

    # ------------------------------------------------------------------ results
    @property
    def theta_history_(self) -> FloatArray:
        """``θ̂`` after every sample seen, shape ``(n_samples, n_params[, n_outputs])``."""
        check_is_fitted(self)
        history = self._history.theta
        return history[:, :, 0] if self.n_outputs_ == 1 else history

    @property
    def prediction_errors_(self) -> FloatArray:
        """A priori errors ``ε(t)`` for every sample seen (NaN on initial-condition rows)."""
        check_is_fitted(self)
        errors = self._history.errors
        return errors[:, 0] if self.n_outputs_ == 1 else errors

    def converged(
        self, window: int = 100, tolerance: float = 0.02, atol: float = 1e-12
    ) -> Convergence:
        """Whether the estimates have settled within a tolerance over the last ``window`` samples.

        Parameters
        ----------
        window : int, default 100
            How many samples (at least) the estimates must have stayed inside the band.
        tolerance : float, default 0.02
            Relative half-width of the band around the settled estimate, per parameter (and per
            output, with several).
        atol : float, default 1e-12
            Absolute floor of the band (for parameters near zero).

        Returns
        -------
        Convergence
            ``(converged, settled_at)``: with ``θ̄`` the mean estimate over the last ``window``
            samples, ``settled_at`` is the first sample from which every estimate ``θ̂_j(t)`` stays
            within ``atol + tolerance·|θ̄_j|`` of ``θ̄_j``; ``converged`` is
            ``n_samples − settled_at >= window``. (The mean, not the last value, is the centre so
            that a noisy last sample does not decide; on noise-free data both agree.)

        Raises
        ------
        NotFittedError
            Before ``fit`` or ``update``.
        ValueError
            If ``window < 1`` or a tolerance is negative.
        """
        check_is_fitted(self)
        window = check_number(window, "window", low=1, integer=True)
        if not (tolerance >= 0) or not (atol >= 0):
            raise ValueError(
                f"tolerance and atol must be >= 0; got tolerance={tolerance!r}, atol={atol!r}"
            )
        history = self.theta_history_.reshape(self._history.size, -1)
        settled_value = history[-window:].mean(axis=0)
        band = atol + tolerance * np.abs(settled_value)
        outside = np.any(np.abs(history - settled_value) > band, axis=1)
        bad_rows = np.flatnonzero(outside)
        settled = 0 if bad_rows.size == 0 else int(bad_rows[-1]) + 1
        stayed = history.shape[0] - settled
        if stayed < 2 and history.shape[0] >= 2:
            return Convergence(False, None)
        return Convergence(stayed >= window, settled)

    # ------------------------------------------------------------------ NARX map
    @property
    def coef_(self) -> FloatArray:
        """Coefficients on the :class:`~neckid.Lags` regressor ``[y(t−1)…, u(t−d)…]``: ``[−a, b]``.

        Shape ``(n_params, n_outputs)``, as :attr:`neckid.LinearARX.coef_`.
        """
        check_is_fitted(self)
        coef = self._theta_matrix().copy()
        coef[self._output_terms] *= -1.0
        return coef

    @property
    def intercept_(self) -> FloatArray:
        """Zeros, one per output: CFF-RLS fits no intercept (as a ``LinearARX`` without one)."""
        check_is_fitted(self)
        return np.zeros(len(self.output_names_))

    def _predict_rows(self, x: FloatArray) -> FloatArray:
        return np.asarray(x @ self.coef_, dtype=np.float64)

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free-run simulation with the final estimate: the regressor holds the model's own outputs.

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
            Of kind ``"simulation"``; the generic NARX free run's values, computed as a linear
            filter (:func:`neckid.models.linear.arx.linear_free_run`).
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y0 = self._initial_outputs(data, initial)
        with np.errstate(over="ignore", invalid="ignore"):  # divergence is reported below
            y = linear_free_run(self.lags_, self.coef_, np.zeros(self.n_outputs_), data.u, y0)
        return self._result("simulation", data, y)

    def _check_state(self) -> None:
        super()._check_state()
        p, q = self.lags_.n_terms, self.n_outputs_
        self._check_shape("theta", self.theta_, (p,) if q == 1 else (p, q))
        self._check_shape("covariance", self.covariance_, (p, p))
        self._check_shape("theta_history", self._history.theta, (self._history.size, p, q))

    # ------------------------------------------------------------------ files
    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        arrays = {
            "theta": self.theta_,
            "theta_history": self.theta_history_,
            "prediction_errors": self.prediction_errors_,
            "covariance": self.covariance_,
            "initial_covariance": self._f0,
        }
        if self.initial_parameters is not None:
            arrays["initial_parameters"] = np.asarray(self.initial_parameters, dtype=np.float64)
        meta = {
            "params": {
                "forgetting_factor": float(self.forgetting_factor),
                "max_covariance_trace": None
                if self.max_covariance_trace is None
                else float(self.max_covariance_trace),
            },
            "initial_covariance_scalar": (
                float(np.asarray(self.initial_covariance))
                if np.ndim(self.initial_covariance) == 0
                else None
            ),
            "n_covariance_resets": int(self.n_covariance_resets_),
            **self._narx_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
    ) -> RecursiveARX:
        scalar = meta.get("initial_covariance_scalar")
        initial_covariance: float | FloatArray = (
            float(scalar)
            if scalar is not None
            else np.asarray(arrays["initial_covariance"], dtype=np.float64)
        )
        initial_parameters = (
            np.asarray(arrays["initial_parameters"], dtype=np.float64)
            if "initial_parameters" in arrays
            else None
        )
        params = dict(meta["params"])
        legacy = {k: params.pop(k) for k in ("na", "nb", "delay") if k in params}  # format 1 files
        model = cls(
            None,
            **params,
            initial_covariance=initial_covariance,
            initial_parameters=initial_parameters,
        )
        resolved = ResolvedLags.from_dict(meta["lags"])
        model.lags = resolved.to_lags() if not legacy else Lags.arx(**legacy)
        template = IOData(
            np.zeros((1, len(resolved.input_names))),
            np.zeros((1, len(resolved.output_names))),
            ts=float(meta["ts"]),
            input_names=resolved.input_names,
            output_names=resolved.output_names,
            output_units=meta.get("output_units"),
        )
        model._start(resolved, template)
        model.n_samples_ = int(meta["n_samples"])
        # One output: theta (p,), theta_history (n, p), prediction_errors (n,), as in every file
        # written before several outputs were supported. Several: a trailing axis of outputs.
        p, q = resolved.n_terms, len(resolved.output_names)
        shape = (p,) if q == 1 else (p, q)
        theta = np.array(arrays["theta"], dtype=np.float64, order="C")
        history = np.array(arrays["theta_history"], dtype=np.float64, order="C")
        errors = np.array(arrays["prediction_errors"], dtype=np.float64, order="C")
        n = history.shape[0] if history.ndim else -1
        for name, array, expected in (
            ("theta", theta, shape),
            ("theta_history", history, (n, *shape)),
            ("prediction_errors", errors, (n, *shape[1:])),
        ):
            if array.shape != expected:
                raise ValueError(
                    f"{name} must have shape {expected} for {p} parameters and {q} output(s);"
                    f" got {array.shape}"
                )
        model.theta_ = theta
        model.covariance_ = np.array(arrays["covariance"], dtype=np.float64, order="C")
        model._history = ParameterHistory(p, q, history.reshape(n, p, q), errors.reshape(n, q))
        model.n_covariance_resets_ = int(meta["n_covariance_resets"])
        return model


def _check_equations(lags: ResolvedLags, experiments: Sequence[IOData]) -> None:
    """Refuse a regressor with more unknowns than the training logs give equations."""
    if any(d.n_samples <= lags.max_lag for d in experiments):
        return  # too short for one regressor row: refused with its own message when read
    rows = sum(d.n_samples - lags.max_lag for d in experiments)
    unknowns = int(lags.n_terms)
    if rows < unknowns:
        samples = sum(d.n_samples for d in experiments)
        raise ValueError(
            f"the regressor has {unknowns} unknowns per output but the training logs give only"
            f" {rows} equations ({samples} samples less the largest lag {lags.max_lag} per log):"
            " RLS cannot identify them (its training fit would mean nothing); use fewer or"
            " shorter lags, or a longer record"
        )
