"""RecursiveARX: ARX parameters estimated by recursive least squares with a constant forgetting factor.

The estimator is the CFF-RLS of Landau et al. (2011) used by the seed paper (section IV) to identify
a first-order model of the soft neck at each operating point. The per-sample loop is compiled with
numba (:func:`_rls_kernel`); :func:`rls_reference` is the plain NumPy transcription of the same
equations, kept beside it so that the tests can check that both agree.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.data import IOData, as_experiments
from neckid.models.base import NarxModel, check_is_fitted
from neckid.regressors import Lags, ResolvedLags
from neckid.validation import Interval, check_finite, check_number

__all__ = ["Convergence", "RecursiveARX", "rls_reference"]

FloatArray = NDArray[np.float64]

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


# ---------------------------------------------------------------------- kernels
@numba.njit(cache=True, nogil=True)
def _rls_kernel(
    phi: FloatArray,
    y: FloatArray,
    theta: FloatArray,
    covariance: FloatArray,
    forgetting_factor: float,
    initial_covariance: FloatArray,
    max_trace: float,
    theta_history: FloatArray,
    errors: FloatArray,
    resets: NDArray[np.int64],
) -> int:  # pragma: no cover - compiled; the NumPy reference is tested against it
    """CFF-RLS over the rows of ``phi``; ``theta`` and ``covariance`` are updated in place.

    Returns the number of covariance resets; their row indices are written to ``resets``.
    """
    n, p = phi.shape
    f_phi = np.empty(p)
    n_resets = 0
    for t in range(n):
        # ε(t+1) = y(t+1) − θ̂(t)ᵀ φ(t)  and  F(t) φ(t)
        prediction = 0.0
        for i in range(p):
            prediction += theta[i] * phi[t, i]
            acc = 0.0
            for j in range(p):
                acc += covariance[i, j] * phi[t, j]
            f_phi[i] = acc
        error = y[t] - prediction
        denominator = forgetting_factor
        for i in range(p):
            denominator += phi[t, i] * f_phi[i]
        # F(t+1) = (F − Fφφᵀ F / (λ + φᵀFφ)) / λ, computed on the upper triangle and mirrored
        # (symmetric by construction); F(t+1) φ(t) = F(t) φ(t) / (λ + φᵀFφ).
        trace = 0.0
        for i in range(p):
            for j in range(i, p):
                value = (covariance[i, j] - f_phi[i] * f_phi[j] / denominator) / forgetting_factor
                covariance[i, j] = value
                covariance[j, i] = value
            trace += covariance[i, i]
        scale = error / denominator
        finite = True
        for i in range(p):
            step = f_phi[i] * scale
            if not math.isfinite(theta[i] + step):
                finite = False
        if finite:
            for i in range(p):
                theta[i] += f_phi[i] * scale
        if not finite or not math.isfinite(trace) or trace > max_trace:
            for i in range(p):
                for j in range(p):
                    covariance[i, j] = initial_covariance[i, j]
            resets[n_resets] = t
            n_resets += 1
        for i in range(p):
            theta_history[t, i] = theta[i]
        errors[t] = error
    return n_resets


def rls_reference(
    phi: ArrayLike,
    y: ArrayLike,
    forgetting_factor: float,
    initial_covariance: ArrayLike,
    initial_parameters: ArrayLike | None = None,
    max_trace: float = math.inf,
) -> tuple[FloatArray, FloatArray, FloatArray, list[int]]:
    """Plain NumPy CFF-RLS, written as the equations read (reference for the compiled kernel).

    Parameters
    ----------
    phi : array_like, shape (n_samples, n_params)
        Regressors ``φ(t)``, one per row.
    y : array_like, shape (n_samples,)
        Targets ``y(t+1)``, one per row.
    forgetting_factor : float
        ``λ`` in (0, 1].
    initial_covariance : array_like, shape (n_params, n_params)
        ``F(0)``, symmetric positive definite.
    initial_parameters : array_like, shape (n_params,), optional
        ``θ̂(0)``; zeros by default.
    max_trace : float, default inf
        ``F`` is reset to ``F(0)`` when its trace exceeds this or is not finite.

    Returns
    -------
    theta_history : ndarray, shape (n_samples, n_params)
        ``θ̂`` after each row.
    covariance : ndarray, shape (n_params, n_params)
        The final ``F``.
    errors : ndarray, shape (n_samples,)
        A priori errors ``ε``.
    resets : list of int
        Rows at which ``F`` was reset.

    Notes
    -----
    Each step computes ``ε = y − θ̂ᵀφ``, ``F ← (F − FφφᵀF / (λ + φᵀFφ)) / λ``, symmetrises ``F``,
    then ``θ̂ ← θ̂ + F φ ε`` with the *updated* ``F`` (Landau et al., 2011, eqs. of CFF-RLS).

    Examples
    --------
    >>> import numpy as np
    >>> phi = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    >>> history, _, _, _ = rls_reference(phi, [2.0, 3.0, 5.0], 1.0, 1e8 * np.eye(2))
    >>> np.round(history[-1], 6)
    array([2., 3.])
    """
    phi_arr = np.asarray(phi, dtype=np.float64)
    y_arr = np.asarray(y, dtype=np.float64).reshape(-1)
    f0 = np.array(initial_covariance, dtype=np.float64)
    f = f0.copy()
    p = phi_arr.shape[1]
    theta = (
        np.zeros(p)
        if initial_parameters is None
        else np.array(initial_parameters, dtype=np.float64).reshape(-1)
    )
    history = np.empty((phi_arr.shape[0], p))
    errors = np.empty(phi_arr.shape[0])
    resets: list[int] = []
    lam = float(forgetting_factor)
    for t in range(phi_arr.shape[0]):
        v = phi_arr[t]
        error = y_arr[t] - theta @ v
        f = (f - np.outer(f @ v, v @ f) / (lam + v @ f @ v)) / lam
        f = 0.5 * (f + f.T)
        new_theta = theta + f @ v * error
        finite = bool(np.all(np.isfinite(new_theta)))
        if finite:
            theta = new_theta
        trace = float(np.trace(f))
        if not finite or not math.isfinite(trace) or trace > max_trace:
            f = f0.copy()
            resets.append(t)
        history[t] = theta
        errors[t] = error
    return history, f, errors, resets


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
    One output only.

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
    initial_parameters : array_like of shape (n_params,), optional
        ``θ̂(0)``, in the order of ``θ`` above (``n_params`` = number of regressor terms); zeros
        by default.
    max_covariance_trace : float, optional
        Blow-up limit: when ``trace(F)`` exceeds it (or ``F`` or ``θ̂`` stop being finite) ``F`` is
        reset to ``F(0)`` and a warning is issued. Default ``1e6 · trace(F(0))``.

    Attributes
    ----------
    theta_ : ndarray, shape (n_params,)
        The latest estimate ``θ̂`` (after the last sample).
    theta_history_ : ndarray, shape (n_samples, n_params)
        ``θ̂`` after every sample seen (row ``t`` for sample ``t``). The first ``max_lag`` samples of
        each experiment only fill the regressor; their rows repeat the estimate held then.
    prediction_errors_ : ndarray, shape (n_samples,)
        A priori errors ``ε(t) = y(t) − θ̂(t−1)ᵀφ(t−1)``; NaN on the initial-condition rows.
    covariance_ : ndarray, shape (n_params, n_params)
        The adaptation gain ``F`` after the last sample.
    n_covariance_resets_ : int
        How many times the blow-up guard reset ``F``.
    parameter_names_ : tuple of str
        ``("a1", …, "b1", …)``; with several inputs ``b`` names carry the input name.
    lags_ : ResolvedLags
        The regressor, as for the other NARX models.
    n_inputs_, n_outputs_, n_samples_ : int
    ts_ : float

    Raises
    ------
    ValueError
        From ``fit`` / ``update``: a hyper-parameter out of range (the message names it and its
        value), non-finite data, several outputs, or a record shorter than the regressor needs.

    See Also
    --------
    neckid.LinearARX : the batch least-squares estimate on the same regressor.

    Notes
    -----
    CFF-RLS (Landau et al., 2011), for each new sample:

    - ``ε(t+1) = y(t+1) − θ̂(t)ᵀ φ(t)``
    - ``F(t+1) = (1/λ) [F(t) − F(t) φ(t) φ(t)ᵀ F(t) / (λ + φ(t)ᵀ F(t) φ(t))]``
    - ``θ̂(t+1) = θ̂(t) + F(t+1) φ(t) ε(t+1)``

    The compiled loop uses the identity ``F(t+1) φ(t) = F(t) φ(t) / (λ + φ(t)ᵀF(t)φ(t))``, computes
    the upper triangle of ``F(t+1)`` and mirrors it, so ``F`` stays exactly symmetric. With ``λ = 1``
    the estimate after ``n`` samples is the regularised least-squares solution
    ``(ΦᵀΦ + F(0)⁻¹)⁻¹ (ΦᵀY + F(0)⁻¹ θ̂(0))``, i.e. batch least squares when ``F(0)`` is large.

    ``predict`` and ``simulate`` (and ``simulator``) use the *final* estimate ``theta_`` as a fixed
    linear ARX model, with the conventions of :class:`~neckid.models.base.NarxModel`: the first
    ``max_lag_`` samples (``max(na, delay + nb − 1)`` for ``Lags.arx``) are initial conditions.

    References
    ----------
    .. [1] I. D. Landau, R. Lozano, M. M'Saad, A. Karimi, *Adaptive Control: Algorithms, Analysis and
       Applications*, 2nd ed., Springer, 2011 (chapter 3, parameter adaptation algorithms).
    .. [2] UC3M Robotics Lab, "Model Identification of a Soft Robotic Neck", section IV.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> from neckid.models.rls import RecursiveARX
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
    def _check_params(self, p: int) -> tuple[float, FloatArray, FloatArray, float]:
        """Validate the hyper-parameters for ``p`` parameters; return ``(λ, F0, θ0, max_trace)``."""
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
            theta0 = np.zeros(p)
        else:
            theta0 = np.array(self.initial_parameters, dtype=np.float64).reshape(-1)
            if theta0.shape != (p,):
                raise ValueError(
                    f"initial_parameters must have {p} values (one per regressor term); got"
                    f" {theta0.size}"
                )
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
        """``φ`` (with the sign of the output terms flipped) and ``y`` for one experiment."""
        x, y = self.lags_.build_one(data)
        x[:, self._output_terms] *= -1.0
        return np.ascontiguousarray(x), np.ascontiguousarray(y[:, 0])

    def _start(self, resolved: ResolvedLags, data: IOData) -> None:
        """Set the learned state to the initial one (the start of ``fit`` or of online use)."""
        lam, f0, theta0, max_trace = self._check_params(resolved.n_terms)
        self.lags_ = resolved
        self._set_channels(data)
        self.max_lag_ = resolved.max_lag
        self.n_samples_ = 0
        self.theta_ = theta0.copy()
        self.covariance_ = f0.copy()
        self.n_covariance_resets_ = 0
        self._output_terms = resolved.source == 0
        names = []
        count: dict[int, int] = {}
        for source, channel, lag in zip(
            resolved.source, resolved.channel, resolved.lag, strict=True
        ):
            if source == 0:
                names.append(f"a{int(lag)}")
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
        self._history_rows: list[FloatArray] = []
        self._error_rows: list[FloatArray] = []
        self._online: dict[str, Any] | None = None

    # ------------------------------------------------------------------ batch
    def fit(self, data: IOData | Sequence[IOData]) -> RecursiveARX:
        """Run CFF-RLS over one log, or several one after the other, from the initial state.

        Parameters
        ----------
        data : IOData or sequence of IOData
            One output channel; every input channel gets ``nb`` terms. With several experiments the
            estimate and ``F`` carry over from one to the next, but no regressor straddles two.

        Returns
        -------
        RecursiveARX
            ``self``.

        Raises
        ------
        ValueError
            If a hyper-parameter is out of range, the data hold several outputs, or an experiment is
            shorter than ``max_lag + 1`` samples.
        """
        self._validate_params()
        experiments = as_experiments(self._with_conditions(data, fitting=True))
        first = experiments[0]
        if first.n_outputs != 1:
            raise ValueError(
                f"RecursiveARX identifies one output; data has {first.n_outputs} outputs"
                f" {list(first.output_names)}; use data.select(outputs=[...])"
            )
        resolved = self._lags().resolve(experiments)
        self._check_training(experiments)
        self._start(resolved, first)
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
        p = phi.shape[1]
        history = np.empty((phi.shape[0], p))
        errors = np.empty(phi.shape[0])
        resets = np.empty(phi.shape[0], dtype=np.int64)
        theta = self.theta_.copy()
        n_resets = _rls_kernel(
            phi,
            y,
            theta,
            self.covariance_,
            self._lambda,
            self._f0,
            self._max_trace,
            history,
            errors,
            resets,
        )
        held = np.broadcast_to(self.theta_, (m, p))
        self._history_rows.extend([held, history])
        self._error_rows.extend([np.full(m, np.nan), errors])
        self.theta_ = theta
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
    def update(self, y: float | ArrayLike, u: float | ArrayLike) -> float:
        """Take one new sample ``(y(t), u(t))`` and update ``θ̂`` and ``F`` (true online use).

        The first call starts from the initial state (as ``fit`` does); later calls continue from
        the current estimate, also after ``fit``/``partial_fit`` (then with an empty history: the
        next ``max_lag`` samples only fill the regressor).

        Parameters
        ----------
        y : float or array_like of shape (1,)
            Output measured at time ``t``.
        u : float or array_like of shape (n_inputs,)
            Input applied at time ``t`` (used now only when ``delay = 0``).

        Returns
        -------
        float
            The a priori error ``ε(t) = y(t) − θ̂(t−1)ᵀφ(t−1)``; NaN while the regressor fills.

        Raises
        ------
        ValueError
            If a value is not finite, or the number of inputs changes between calls.
        """
        y_now = np.asarray(y, dtype=np.float64).reshape(-1)
        u_now = np.asarray(u, dtype=np.float64).reshape(-1)
        if y_now.shape != (1,):
            raise ValueError(f"y must be one value (RecursiveARX has one output); got {y!r}")
        check_finite(y_now[None, :], "y")
        check_finite(u_now[None, :], "u")
        if not hasattr(self, "theta_"):
            names = ("u",) if u_now.size == 1 else tuple(f"u{i + 1}" for i in range(u_now.size))
            template = IOData(np.zeros((1, u_now.size)), np.zeros(1), ts=1.0, input_names=names)
            self._start(self._lags().resolve(template), template)
        if u_now.size != self.n_inputs_:
            raise ValueError(
                f"u must have {self.n_inputs_} values (one per input); got {u_now.size}"
            )
        if self._online is None:
            self._online = {"y": [], "u": []}
        hist_y: list[float] = self._online["y"]
        hist_u: list[FloatArray] = self._online["u"]
        hist_u.append(u_now.copy())
        m = self.lags_.max_lag
        error = math.nan
        if len(hist_u) > m:
            y_rows = np.array([*hist_y, 0.0])[:, None]
            phi = self.lags_.regressor_from_history(y_rows, np.vstack(hist_u), len(hist_u) - 1)
            phi[self._output_terms] *= -1.0
            history = np.empty((1, phi.size))
            errors = np.empty(1)
            resets = np.empty(1, dtype=np.int64)
            n_resets = _rls_kernel(
                np.ascontiguousarray(phi[None, :]),
                y_now,
                self.theta_,
                self.covariance_,
                self._lambda,
                self._f0,
                self._max_trace,
                history,
                errors,
                resets,
            )
            error = float(errors[0])
            self._warn_resets(n_resets, np.array([self.n_samples_]), None, stacklevel=3)
        hist_y.append(float(y_now[0]))
        # Keep only the history the regressor reaches.
        if len(hist_u) > m + 1:
            del hist_u[0]
        if len(hist_y) > m + 1:
            del hist_y[0]
        self._history_rows.append(self.theta_[None, :].copy())
        self._error_rows.append(np.array([error]))
        self.n_samples_ += 1
        return error

    # ------------------------------------------------------------------ results
    @property
    def theta_history_(self) -> FloatArray:
        """``θ̂`` after every sample seen, shape ``(n_samples, n_params)``."""
        check_is_fitted(self)
        if len(self._history_rows) != 1:
            self._history_rows = [np.vstack(self._history_rows)]
        return self._history_rows[0]

    @property
    def prediction_errors_(self) -> FloatArray:
        """A priori errors ``ε(t)`` for every sample seen (NaN on initial-condition rows)."""
        check_is_fitted(self)
        if len(self._error_rows) != 1:
            self._error_rows = [np.concatenate(self._error_rows)]
        return self._error_rows[0]

    def converged(
        self, window: int = 100, tolerance: float = 0.02, atol: float = 1e-12
    ) -> Convergence:
        """Whether the estimates have settled within a tolerance over the last ``window`` samples.

        Parameters
        ----------
        window : int, default 100
            How many samples (at least) the estimates must have stayed inside the band.
        tolerance : float, default 0.02
            Relative half-width of the band around the settled estimate, per parameter.
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
        history = self.theta_history_
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
        """Coefficients on the :class:`~neckid.Lags` regressor ``[y(t−1)…, u(t−d)…]``: ``[−a, b]``."""
        check_is_fitted(self)
        coef = self.theta_.copy()
        coef[self._output_terms] *= -1.0
        return coef[:, None]

    def _predict_rows(self, x: FloatArray) -> FloatArray:
        return np.asarray(x @ self.coef_, dtype=np.float64)

    def _check_state(self) -> None:
        super()._check_state()
        p = self.lags_.n_terms
        self._check_shape("theta", self.theta_, (p,))
        self._check_shape("covariance", self.covariance_, (p, p))
        self._check_shape("theta_history", self.theta_history_, (self.theta_history_.shape[0], p))

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
        model.theta_ = np.asarray(arrays["theta"], dtype=np.float64).copy()
        model.covariance_ = np.asarray(arrays["covariance"], dtype=np.float64).copy()
        model._history_rows = [np.asarray(arrays["theta_history"], dtype=np.float64)]
        model._error_rows = [np.asarray(arrays["prediction_errors"], dtype=np.float64)]
        model.n_covariance_resets_ = int(meta["n_covariance_resets"])
        return model
