"""The CFF-RLS recursion: the compiled loop, its plain NumPy reference, and the history buffer.

:class:`~neckid.models.linear.rls.RecursiveARX` runs :func:`_rls_kernel` (numba) over a log or one
sample at a time; :func:`rls_reference` is the same equations written as they read, kept beside
it so that the tests can check that both agree. Both take one or several outputs: the regressor
``φ`` is shared, so one adaptation gain ``F`` serves every output and ``θ̂`` has one column per
output (Ljung 1999, section 11.2). :class:`ParameterHistory` keeps ``θ̂`` and ``ε`` after every
sample in arrays that grow by doubling, and :func:`_rls_online_kernel` takes one sample at a time
without allocating.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.utils.types import FloatArray

__all__ = ["FILLING", "NOT_FINITE", "ParameterHistory", "rls_reference"]


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
    scratch: FloatArray,
) -> int:  # pragma: no cover - compiled; the NumPy reference is tested against it
    """CFF-RLS over the rows of ``phi``; ``theta`` and ``covariance`` are updated in place.

    Shapes: ``phi`` (n, p), ``y`` (n, q), ``theta`` (p, q), ``covariance`` (p, p),
    ``theta_history`` (n, p, q), ``errors`` (n, q), ``resets`` (n,), ``scratch`` (p + q,) (work
    space, so that a call allocates nothing). Returns the number of covariance resets; their row
    indices are written to ``resets``.
    """
    n, p = phi.shape
    q = y.shape[1]
    f_phi = scratch[:p]
    error = scratch[p : p + q]
    n_resets = 0
    for t in range(n):
        # F(t) φ(t)  and  ε(t+1) = y(t+1) − θ̂(t)ᵀ φ(t), one error per output
        for i in range(p):
            acc = 0.0
            for j in range(p):
                acc += covariance[i, j] * phi[t, j]
            f_phi[i] = acc
        for o in range(q):
            prediction = 0.0
            for i in range(p):
                prediction += theta[i, o] * phi[t, i]
            error[o] = y[t, o] - prediction
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
        # θ̂(t+1) = θ̂(t) + F(t+1) φ(t) ε(t+1)ᵀ: the same gain for every output.
        finite = True
        for o in range(q):
            scale = error[o] / denominator
            for i in range(p):
                if not math.isfinite(theta[i, o] + f_phi[i] * scale):
                    finite = False
        if finite:
            for o in range(q):
                scale = error[o] / denominator
                for i in range(p):
                    theta[i, o] += f_phi[i] * scale
        if not finite or not math.isfinite(trace) or trace > max_trace:
            for i in range(p):
                for j in range(p):
                    covariance[i, j] = initial_covariance[i, j]
            resets[n_resets] = t
            n_resets += 1
        for i in range(p):
            for o in range(q):
                theta_history[t, i, o] = theta[i, o]
        for o in range(q):
            errors[t, o] = error[o]
    return n_resets


#: What :func:`_rls_online_kernel` returns when the sample holds a NaN or an infinity.
NOT_FINITE = -2
#: What :func:`_rls_online_kernel` returns while the regressor is still filling.
FILLING = -1


@numba.njit(cache=True, nogil=True)
def _rls_online_kernel(
    y_now: FloatArray,
    u_now: FloatArray,
    window: FloatArray,
    count: int,
    index: NDArray[np.int64],
    sign: FloatArray,
    phi: FloatArray,
    theta: FloatArray,
    covariance: FloatArray,
    forgetting_factor: float,
    initial_covariance: FloatArray,
    max_trace: float,
    theta_history: FloatArray,
    errors: FloatArray,
    row: int,
    resets: NDArray[np.int64],
    scratch: FloatArray,
) -> int:  # pragma: no cover - compiled; tested through RecursiveARX.update against fit
    """One online sample: store it, build ``φ`` and run one CFF-RLS step, allocating nothing.

    ``window`` (flat) holds the last ``L = len(window) / (2 · width)`` samples ``[y, u]`` twice,
    at slots ``k`` and ``k + L`` (``k = count mod L``), so that the latest ``L`` are always the
    contiguous slots ``k + 1 … k + L``, oldest first; ``φ_j = sign_j · window[(k + 1) · width +
    index_j]``. ``θ̂`` and ``ε`` are written to row ``row`` of ``theta_history`` and ``errors``.
    Returns :data:`NOT_FINITE` (nothing changed) for a non-finite value, :data:`FILLING` while
    fewer than ``L`` samples have been seen (the row repeats ``θ̂``, ``ε`` is NaN), else the
    number of covariance resets (0 or 1).
    """
    q = y_now.shape[0]
    n_inputs = u_now.shape[0]
    for o in range(q):
        if not math.isfinite(y_now[o]):
            return NOT_FINITE
    for i in range(n_inputs):
        if not math.isfinite(u_now[i]):
            return NOT_FINITE
    width = q + n_inputs
    length = window.shape[0] // (2 * width)
    slot = count % length
    for start in (slot * width, (slot + length) * width):
        for o in range(q):
            window[start + o] = y_now[o]
        for i in range(n_inputs):
            window[start + q + i] = u_now[i]
    if count + 1 < length:
        for i in range(theta.shape[0]):
            for o in range(q):
                theta_history[row, i, o] = theta[i, o]
        for o in range(q):
            errors[row, o] = np.nan
        return FILLING
    base = (slot + 1) * width
    for j in range(index.shape[0]):
        phi[0, j] = sign[j] * window[base + index[j]]
    return _rls_kernel(
        phi,
        y_now.reshape((1, q)),
        theta,
        covariance,
        forgetting_factor,
        initial_covariance,
        max_trace,
        theta_history[row : row + 1],
        errors[row : row + 1],
        resets,
        scratch,
    )


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
    y : array_like, shape (n_samples,) or (n_samples, n_outputs)
        Targets ``y(t+1)``, one per row (one column per output).
    forgetting_factor : float
        ``λ`` in (0, 1].
    initial_covariance : array_like, shape (n_params, n_params)
        ``F(0)``, symmetric positive definite.
    initial_parameters : array_like, shape (n_params,) or (n_params, n_outputs), optional
        ``θ̂(0)``; zeros by default.
    max_trace : float, default inf
        ``F`` is reset to ``F(0)`` when its trace exceeds this or is not finite.

    Returns
    -------
    theta_history : ndarray, shape (n_samples, n_params) or (n_samples, n_params, n_outputs)
        ``θ̂`` after each row (the second shape when ``y`` is 2-D).
    covariance : ndarray, shape (n_params, n_params)
        The final ``F``.
    errors : ndarray, shape (n_samples,) or (n_samples, n_outputs)
        A priori errors ``ε``.
    resets : list of int
        Rows at which ``F`` was reset.

    Notes
    -----
    Each step computes ``ε = y − θ̂ᵀφ`` (a vector with several outputs),
    ``F ← (F − FφφᵀF / (λ + φᵀFφ)) / λ``, symmetrises ``F``, then ``θ̂ ← θ̂ + F φ εᵀ`` with the
    *updated* ``F`` (Landau et al., 2011, eqs. of CFF-RLS). With several outputs and a common
    regressor the gain ``Fφ`` is the same for every output, so the recursion is that of each
    output on its own, sharing one ``F`` (Ljung, 1999, section 11.2).

    References
    ----------
    .. [1] I. D. Landau, R. Lozano, M. M'Saad, A. Karimi, *Adaptive Control: Algorithms, Analysis
       and Applications*, 2nd ed., Springer, 2011 (chapter 3).
    .. [2] L. Ljung, *System Identification: Theory for the User*, 2nd ed., Prentice Hall, 1999
       (section 11.2, recursive least squares).

    Examples
    --------
    >>> import numpy as np
    >>> phi = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    >>> history, _, _, _ = rls_reference(phi, [2.0, 3.0, 5.0], 1.0, 1e8 * np.eye(2))
    >>> np.round(history[-1], 6)
    array([2., 3.])
    >>> history, _, _, _ = rls_reference(phi, [[2.0, 1.0], [3.0, 0.0], [5.0, 1.0]], 1.0, 1e8 * np.eye(2))
    >>> np.round(history[-1], 6)  # one column per output
    array([[2., 1.],
           [3., 0.]])
    """
    phi_arr = np.asarray(phi, dtype=np.float64)
    y_arr = np.asarray(y, dtype=np.float64)
    single = y_arr.ndim <= 1
    n, p = phi_arr.shape
    targets = y_arr.reshape(n, -1)
    q = targets.shape[1]
    f0 = np.array(initial_covariance, dtype=np.float64)
    f = f0.copy()
    theta = (
        np.zeros((p, q))
        if initial_parameters is None
        else np.array(initial_parameters, dtype=np.float64).reshape(p, q)
    )
    history = np.empty((n, p, q))
    errors = np.empty((n, q))
    resets: list[int] = []
    lam = float(forgetting_factor)
    for t in range(n):
        v = phi_arr[t]
        error = targets[t] - theta.T @ v
        f = (f - np.outer(f @ v, v @ f) / (lam + v @ f @ v)) / lam
        f = 0.5 * (f + f.T)
        new_theta = theta + np.outer(f @ v, error)
        finite = bool(np.all(np.isfinite(new_theta)))
        if finite:
            theta = new_theta
        trace = float(np.trace(f))
        if not finite or not math.isfinite(trace) or trace > max_trace:
            f = f0.copy()
            resets.append(t)
        history[t] = theta
        errors[t] = error
    if single:
        return history[:, :, 0], f, errors[:, 0], resets
    return history, f, errors, resets


class ParameterHistory:
    """``θ̂`` and the a priori errors after every sample, in arrays that double when full.

    Appending ``k`` rows costs ``O(k)`` amortised: the arrays are re-allocated only when their
    capacity is exhausted, to twice the size (or what is needed), never per sample.

    Parameters
    ----------
    n_params, n_outputs : int
        Shape of one ``θ̂``: ``(n_params, n_outputs)``.
    theta, errors : ndarray, optional
        Rows to start from, shapes ``(n, n_params, n_outputs)`` and ``(n, n_outputs)`` (a loaded
        model's history); empty by default.
    """

    #: Smallest capacity allocated once rows are added.
    MIN_CAPACITY = 64

    def __init__(
        self,
        n_params: int,
        n_outputs: int,
        theta: FloatArray | None = None,
        errors: FloatArray | None = None,
    ) -> None:
        self._theta = np.empty((0, n_params, n_outputs)) if theta is None else theta
        self._errors = np.empty((0, n_outputs)) if errors is None else errors
        self.size = int(self._theta.shape[0])

    @property
    def capacity(self) -> int:
        """Rows that fit before the next re-allocation."""
        return int(self._theta.shape[0])

    def reserve(self, count: int) -> tuple[FloatArray, FloatArray]:
        """Make room for ``count`` more rows; return the whole buffers ``(theta, errors)``.

        Rows from :attr:`size` on are free; a caller that fills them advances :attr:`size`.
        """
        needed = self.size + count
        if needed > self.capacity:
            capacity = max(needed, 2 * self.capacity, self.MIN_CAPACITY)
            theta = np.empty((capacity, *self._theta.shape[1:]))
            errors = np.empty((capacity, *self._errors.shape[1:]))
            theta[: self.size] = self._theta[: self.size]
            errors[: self.size] = self._errors[: self.size]
            self._theta, self._errors = theta, errors
        return self._theta, self._errors

    def append(self, count: int) -> tuple[FloatArray, FloatArray]:
        """Add ``count`` rows and return them as views ``(theta, errors)`` to fill."""
        theta, errors = self.reserve(count)
        start, self.size = self.size, self.size + count
        return theta[start : self.size], errors[start : self.size]

    @property
    def theta(self) -> FloatArray:
        """``θ̂`` after every row, shape ``(size, n_params, n_outputs)`` (a view)."""
        return self._theta[: self.size]

    @property
    def errors(self) -> FloatArray:
        """A priori errors of every row, shape ``(size, n_outputs)`` (a view)."""
        return self._errors[: self.size]
