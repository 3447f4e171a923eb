r"""The steps of subspace identification, one function each (used by :mod:`.subspace`).

A discrete-time state-space model in innovation form,

.. math::

    x(t+1) = A\,x(t) + B\,u(t) + K\,e(t), \qquad y(t) = C\,x(t) + D\,u(t) + c + e(t),

is identified from input–output records in the order of PO-MOESP (Verhaegen 1994, building on
Verhaegen & Dewilde 1992; Katayama 2005, chapter 9) followed by least squares for what is linear
once :math:`A` and :math:`C` are known (Verhaegen & Verdult 2007, section 9.2.4):

1. :func:`past_future_factor`: block Hankel matrices of ``horizon`` block rows of past inputs
   and outputs (:math:`U_p, Y_p`) and of future ones (:math:`U_f, Y_f`), one column per window
   of :math:`2i` consecutive samples of one experiment (no window straddles two), stacked;
   their LQ factorisation :math:`[U_f; U_p; Y_p; Y_f] = L Q^T`.
2. :func:`observability_basis`: the SVD of the block :math:`L_{32}` of :math:`L` (future
   outputs against past data, with the future inputs projected out) whose column space is that
   of the extended observability matrix :math:`\Gamma_i = [C; CA; …; CA^{i-1}]`, weighted
   as in CVA so that its singular values are canonical correlations; they choose the order
   (:func:`choose_order`).
3. :func:`shift_invariance`: :math:`C` is the first block row of :math:`\Gamma_i`, :math:`A`
   the least-squares solution of :math:`\underline{\Gamma}\,A = \overline{\Gamma}` (the
   matrix without its last, and without its first block row). An unstable estimate is
   replaced by Maciejowski's (1995): :math:`A = \Gamma_i^{+} [\overline{\Gamma}; 0]`, whose
   eigenvalues lie strictly inside the unit circle.
4. :func:`output_error_regression`: :math:`B`, :math:`D`, the output offset :math:`c` and one
   initial state per experiment, by linear least squares on the free-run (output) error, in
   which they enter linearly once :math:`A` and :math:`C` are fixed.
5. :func:`kalman_gain`: :math:`K` by the two-stage regression of Hannan & Rissanen (1982):
   innovations from a long ARX model, then the output error of step 4 regressed on their
   filtered values.

The refinement of the free-run error over all matrices (``scipy.optimize.least_squares``) is
:func:`refine_free_run`. All of it works on signals scaled to unit standard deviation per
channel; :mod:`.subspace` maps the matrices back.
"""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np
import scipy.linalg
from scipy.optimize import least_squares

from neckid._typing import FloatArray

__all__ = [
    "STABILITY_MARGIN",
    "choose_order",
    "estimate_state",
    "innovations",
    "kalman_gain",
    "observability_basis",
    "output_error_regression",
    "past_future_factor",
    "predictor_run",
    "refine_free_run",
    "shift_invariance",
    "spectral_radius",
    "state_space_run",
]

#: Largest spectral radius of ``A`` (and of ``A − K C``) accepted: 1 − 1e-9.
STABILITY_MARGIN = 1e-9

#: Smallest singular value relative to the largest that the order rule looks at.
_FLOOR = 1e-13


# ============================================================================ kernels
@numba.njit(cache=True, nogil=True)
def state_space_run(
    a: FloatArray,
    b: FloatArray,
    c: FloatArray,
    d: FloatArray,
    offset: FloatArray,
    u: FloatArray,
    x0: FloatArray,
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover - compiled; tested against a loop
    """Free run ``y(t) = C x(t) + D u(t) + offset``, ``x(t+1) = A x(t) + B u(t)`` from ``x0``.

    Returns ``(y (n_samples, n_outputs), x after the last sample)``. One sample at a time, in the
    same order of additions whatever the length of ``u``: stepping sample by sample gives the
    same bits as one call over the whole record.
    """
    n_samples, n_in = u.shape
    n, p = a.shape[0], c.shape[0]
    y = np.empty((n_samples, p))
    x = x0.copy()
    following = np.empty(n)
    for t in range(n_samples):
        for o in range(p):
            total = offset[o]
            for k in range(n):
                total += c[o, k] * x[k]
            for j in range(n_in):
                total += d[o, j] * u[t, j]
            y[t, o] = total
        for r in range(n):
            total = 0.0
            for k in range(n):
                total += a[r, k] * x[k]
            for j in range(n_in):
                total += b[r, j] * u[t, j]
            following[r] = total
        x[:] = following
    return y, x


@numba.njit(cache=True, nogil=True)
def predictor_run(
    a: FloatArray,
    b: FloatArray,
    c: FloatArray,
    d: FloatArray,
    offset: FloatArray,
    gain: FloatArray,
    u: FloatArray,
    y: FloatArray,
    x0: FloatArray,
) -> FloatArray:  # pragma: no cover - compiled; tested against the free run with gain 0
    """One-step predictor ``ŷ(t) = C x̂(t) + D u(t) + offset``, ``x̂(t+1) = A x̂ + B u + K (y − ŷ)``."""
    n_samples, n_in = u.shape
    n, p = a.shape[0], c.shape[0]
    predicted = np.empty((n_samples, p))
    x = x0.copy()
    following = np.empty(n)
    for t in range(n_samples):
        for o in range(p):
            total = offset[o]
            for k in range(n):
                total += c[o, k] * x[k]
            for j in range(n_in):
                total += d[o, j] * u[t, j]
            predicted[t, o] = total
        for r in range(n):
            total = 0.0
            for k in range(n):
                total += a[r, k] * x[k]
            for j in range(n_in):
                total += b[r, j] * u[t, j]
            for o in range(p):
                total += gain[r, o] * (y[t, o] - predicted[t, o])
            following[r] = total
        x[:] = following
    return predicted


def spectral_radius(a: FloatArray) -> float:
    """Largest eigenvalue magnitude of ``a`` (0 for an empty matrix)."""
    return float(np.max(np.abs(np.linalg.eigvals(a)))) if a.size else 0.0


# ============================================================================ steps 1-3
def _windows(signal: FloatArray, horizon: int) -> FloatArray:
    """``(n_windows, 2 * horizon * width)``: row ``t`` holds samples ``t .. t + 2i − 1``."""
    n, width = signal.shape
    view = np.lib.stride_tricks.sliding_window_view(signal, 2 * horizon, axis=0)
    return view.transpose(0, 2, 1).reshape(n - 2 * horizon + 1, 2 * horizon * width)


def past_future_factor(
    experiments: Sequence[tuple[FloatArray, FloatArray]], horizon: int, centre: bool
) -> FloatArray:
    """The lower-triangular factor ``L`` of ``[U_f; U_p; Y_p; Y_f]``, scaled by ``1/√columns``.

    Parameters
    ----------
    experiments : sequence of (u, y)
        Scaled inputs ``(n_samples, n_inputs)`` and outputs ``(n_samples, n_outputs)`` of each
        experiment; one with fewer than ``2 * horizon`` samples gives no window.
    horizon : int
        Block rows ``i`` of the past and of the future.
    centre : bool
        Project out a constant first (a row of ones ahead of the others, then dropped): the
        Hankel rows are centred, which an output offset requires.

    Returns
    -------
    ndarray, shape (2 i (n_inputs + n_outputs), same)
        Rows and columns in the order ``U_f, U_p, Y_p, Y_f``.
    """
    blocks = []
    for u, y in experiments:
        if u.shape[0] < 2 * horizon:
            continue
        m, p, i = u.shape[1], y.shape[1], horizon
        wu, wy = _windows(u, i), _windows(y, i)
        parts = [wu[:, i * m :], wu[:, : i * m], wy[:, : i * p], wy[:, i * p :]]
        if centre:
            parts.insert(0, np.ones((wu.shape[0], 1)))
        blocks.append(np.hstack(parts))
    if not blocks:
        raise ValueError(
            f"no experiment has the {2 * horizon} samples one window of horizon={horizon} block"
            " rows needs; use a smaller horizon or longer records"
        )
    stacked = np.vstack(blocks)
    if stacked.shape[0] < stacked.shape[1]:
        raise ValueError(
            f"{stacked.shape[0]} windows of {2 * horizon} samples are fewer than the"
            f" {stacked.shape[1]} rows of the block Hankel matrix; use a smaller horizon or"
            " longer records"
        )
    r = scipy.linalg.qr(stacked, mode="r", check_finite=False)[0]
    r = r[: stacked.shape[1]] / np.sqrt(stacked.shape[0])
    if centre:
        r = r[1:, 1:]
    return np.ascontiguousarray(r.T)


def observability_basis(
    factor: FloatArray, horizon: int, n_inputs: int, n_outputs: int
) -> tuple[FloatArray, FloatArray]:
    """A basis of the extended observability matrix and the canonical correlations (CVA).

    ``L_32`` holds the future outputs against the past inputs and outputs, the future inputs
    projected out; its column space is that of ``Γ_i`` (Verhaegen 1994, theorem 3). Weighted on
    the left by ``W = Σ^{-1/2}``, ``Σ = L_32 L_32ᵀ + L_33 L_33ᵀ`` the covariance of the future
    outputs with the future inputs projected out, its singular values are the canonical
    correlations between future outputs and past data (CVA, Larimore 1990; the weighting of Van
    Overschee & De Moor 1996, theorem 13): each in [0, 1], 1 for a noise-free state
    direction, near 0 for noise. ``Γ_i = Σ^{1/2} U_n S_n^{1/2}``.

    Returns
    -------
    (ndarray (i p, i p), ndarray (i p,))
        ``Σ^{1/2} U`` (its first ``n`` columns times ``S_n^{1/2}`` are ``Γ_i``) and the
        canonical correlations, largest first.
    """
    i, m, p = horizon, n_inputs, n_outputs
    future_in, past = i * m, i * (m + p)
    block = factor[future_in + past :, future_in : future_in + past]
    rest = factor[future_in + past :, future_in + past :]
    eigenvalues, vectors = np.linalg.eigh(block @ block.T + rest @ rest.T)
    eigenvalues = np.maximum(eigenvalues, max(float(eigenvalues.max()), 1e-300) * 1e-12)
    root = (vectors * np.sqrt(eigenvalues)) @ vectors.T
    inverse_root = (vectors / np.sqrt(eigenvalues)) @ vectors.T
    left, values, _ = np.linalg.svd(inverse_root @ block, full_matrices=False)
    return root @ left, np.minimum(values, 1.0)


def choose_order(values: FloatArray, largest: int) -> int:
    """The order at the largest gap of the singular values (on a log scale), 1 .. ``largest``.

    ``n = argmax_k log(σ_k / σ_{k+1})``; values below ``1e-13 σ_1`` count as ``1e-13 σ_1``
    (rounding), so a noise-free system of order ``n`` gives ``n``.
    """
    floor = max(float(values[0]) * _FLOOR, np.finfo(float).tiny)
    logs = np.log(np.maximum(values[: largest + 1], floor))
    if logs.size < 2:
        return 1
    return int(np.argmax(logs[:-1] - logs[1:])) + 1


def shift_invariance(
    left: FloatArray, values: FloatArray, order: int, n_outputs: int
) -> tuple[FloatArray, FloatArray, bool]:
    """``A`` and ``C`` from ``Γ_i = U_n Σ_n^{1/2}``; an unstable ``A`` is replaced (see module).

    Returns
    -------
    (A, C, stabilised)
        ``stabilised`` is True when the least-squares ``A`` had an eigenvalue on or outside
        the unit circle and Maciejowski's zero-padded estimate replaced it.
    """
    p = n_outputs
    gamma = left[:, :order] * np.sqrt(values[:order])
    c = gamma[:p].copy()
    a = np.asarray(np.linalg.lstsq(gamma[:-p], gamma[p:], rcond=None)[0], dtype=np.float64)
    if spectral_radius(a) < 1.0 - STABILITY_MARGIN:
        return a, c, False
    padded = np.vstack([gamma[p:], np.zeros((p, order))])
    a = np.asarray(np.linalg.lstsq(gamma, padded, rcond=None)[0], dtype=np.float64)
    if spectral_radius(a) >= 1.0 - STABILITY_MARGIN:  # pragma: no cover - excluded by theory
        raise ValueError(
            "the subspace estimate of A is unstable and Maciejowski's stabilised estimate is too"
            f" (spectral radius {spectral_radius(a):.6g}); choose a smaller order"
        )
    return a, c, True


# ============================================================================ step 4
def _responses(a: FloatArray, c: FloatArray, drive: FloatArray) -> FloatArray:
    """``(n_samples, n_outputs, n_states, n_drive)``: output of ``(A, e_k, C)`` driven by column j."""
    n, p = a.shape[0], c.shape[0]
    zeros_d, zeros_o = np.zeros((p, 1)), np.zeros(p)
    out = np.empty((drive.shape[0], p, n, drive.shape[1]))
    for j in range(drive.shape[1]):
        column = np.ascontiguousarray(drive[:, j : j + 1])
        for k in range(n):
            b = np.zeros((n, 1))
            b[k, 0] = 1.0
            out[:, :, k, j] = state_space_run(a, b, c, zeros_d, zeros_o, column, np.zeros(n))[0]
    return out


def _free_response(a: FloatArray, c: FloatArray, n_samples: int) -> FloatArray:
    """``(n_samples, n_outputs, n_states)``: ``C A^t e_k``."""
    n, p = a.shape[0], c.shape[0]
    out = np.empty((n_samples, p, n))
    none = np.zeros((n_samples, 0))
    for k in range(n):
        x0 = np.zeros(n)
        x0[k] = 1.0
        out[:, :, k] = state_space_run(
            a, np.zeros((n, 0)), c, np.zeros((p, 0)), np.zeros(p), none, x0
        )[0]
    return out


def _solve_scaled(x: FloatArray, y: FloatArray) -> FloatArray:
    """Least squares ``x θ ≈ y`` on columns scaled to unit norm (zero columns left at 0)."""
    norms = np.linalg.norm(x, axis=0)
    norms[norms == 0] = 1.0
    theta = np.linalg.lstsq(x / norms, y, rcond=None)[0]
    scale = norms if theta.ndim == 1 else norms[:, None]
    return np.asarray(theta / scale, dtype=np.float64)


def _columns(
    a: FloatArray,
    c: FloatArray,
    experiments: Sequence[tuple[FloatArray, FloatArray]],
    options: tuple[bool, bool],
    states: Sequence[FloatArray] | None = None,
) -> FloatArray:
    """Derivatives of the free run over ``[A?, B, C?, D?, c?, x0 per experiment]``, stacked.

    One row per sample and output (time first, as ``y.ravel()``), one column per parameter,
    in the order of :func:`_unpack`. ``A`` and ``C`` are there when the state trajectories
    ``states`` are given: ``∂y/∂A_jk`` is the response through state ``j`` to ``x_k(t)``,
    ``∂y/∂C_ok = x_k(t)`` on output ``o``. The others do not depend on the parameters.
    """
    feedthrough, intercept = options
    n, p = a.shape[0], c.shape[0]
    m = experiments[0][0].shape[1]
    sizes = [n * n if states else 0, n * m, p * n if states else 0]
    sizes += [p * m if feedthrough else 0, p if intercept else 0]
    n_shared = int(sum(sizes))
    total = n_shared + n * len(experiments)
    edges = np.concatenate([[0], np.cumsum(sizes)])
    rows = []
    for e, (u, _) in enumerate(experiments):
        columns = np.zeros((u.shape[0], p, total))
        if states:
            columns[:, :, : edges[1]] = _responses(a, c, states[e]).reshape(-1, p, n * n)
        columns[:, :, edges[1] : edges[2]] = _responses(a, c, u).reshape(-1, p, n * m)
        for o in range(p):
            if states:
                columns[:, o, edges[2] + o * n : edges[2] + (o + 1) * n] = states[e]
            if feedthrough:
                columns[:, o, edges[3] + o * m : edges[3] + (o + 1) * m] = u
        if intercept:
            columns[:, :, edges[4] : edges[5]] = np.eye(p)
        start = n_shared + n * e
        columns[:, :, start : start + n] = _free_response(a, c, u.shape[0])
        rows.append(columns.reshape(-1, total))
    return np.vstack(rows)


def output_error_regression(
    a: FloatArray,
    c: FloatArray,
    experiments: Sequence[tuple[FloatArray, FloatArray]],
    feedthrough: bool,
    intercept: bool,
) -> tuple[FloatArray, FloatArray, FloatArray, list[FloatArray]]:
    """``B``, ``D``, offset and one initial state per experiment, minimising the free-run error.

    With ``A`` and ``C`` fixed the free run
    ``y(t) = C A^t x_0 + Σ_{s<t} C A^{t−1−s} B u(s) + D u(t) + c`` is linear in
    ``(B, D, c, x_0)``: one regressor column per unknown, each the response of the model to one
    input channel through one state (:func:`state_space_run`), solved together over all
    experiments (each with its own ``x_0``).

    Returns
    -------
    (B (n, m), D (p, m), offset (p,), [x0 (n,) per experiment])
        ``D`` is zeros without ``feedthrough``, the offset zeros without ``intercept``.
    """
    n, p = a.shape[0], c.shape[0]
    m = experiments[0][0].shape[1]
    columns = _columns(a, c, experiments, (feedthrough, intercept))
    theta = _solve_scaled(columns, np.concatenate([y.reshape(-1) for _, y in experiments]))
    b = theta[: n * m].reshape(n, m)
    at = n * m
    d = theta[at : at + p * m].reshape(p, m) if feedthrough else np.zeros((p, m))
    at += p * m if feedthrough else 0
    offset = theta[at : at + p] if intercept else np.zeros(p)
    x0s = list(theta[-n * len(experiments) :].reshape(len(experiments), n))
    return b, d, np.asarray(offset, dtype=np.float64), x0s


# ============================================================================ step 5
def innovations(
    experiments: Sequence[tuple[FloatArray, FloatArray]],
    lags: int,
    feedthrough: bool,
    intercept: bool,
) -> list[FloatArray]:
    """Residuals of a long ARX model (``lags`` past outputs and inputs): the innovations' estimate.

    The first stage of Hannan & Rissanen (1982). The first ``lags`` rows of each experiment are
    zeros (no residual there).
    """
    rows, targets = [], []
    for u, y in experiments:
        n = u.shape[0]
        if n <= lags:
            continue
        past = [y[lags - k : n - k] for k in range(1, lags + 1)]
        past += [u[lags - k : n - k] for k in range(0 if feedthrough else 1, lags + 1)]
        if intercept:
            past.append(np.ones((n - lags, 1)))
        rows.append(np.hstack(past))
        targets.append(y[lags:])
    residuals = []
    theta = _solve_scaled(np.vstack(rows), np.vstack(targets)) if rows else None
    it = iter(zip(rows, targets, strict=True))
    for u, y in experiments:
        e = np.zeros_like(y)
        if theta is not None and u.shape[0] > lags:
            x, target = next(it)
            e[lags:] = target - x @ theta
        residuals.append(e)
    return residuals


def _stable_gain(a: FloatArray, c: FloatArray, gain: FloatArray) -> FloatArray:
    """``gain`` halved until ``A − K C`` is stable (zeros after 30 halvings)."""
    for _ in range(30):
        if spectral_radius(a - gain @ c) < 1.0 - STABILITY_MARGIN:
            return gain
        gain = 0.5 * gain
    return np.zeros_like(gain)


def kalman_gain(
    model: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    x0s: Sequence[FloatArray],
    experiments: Sequence[tuple[FloatArray, FloatArray]],
    residuals: Sequence[FloatArray],
) -> FloatArray:
    """``K`` of the innovation form by the second stage of Hannan & Rissanen (1982).

    With the innovations ``ê`` fixed, the output error of the free run is
    ``y(t) − y_sim(t) = Σ_{s<t} C A^{t−1−s} K ê(s) + e(t)``, linear in ``K``: least squares.
    The gain is halved until the predictor ``A − K C`` is stable, and dropped (zeros) unless it
    lowers the one-step error on the training data.
    """
    a, b, c, d, offset = model
    n, p = a.shape[0], c.shape[0]
    rows, targets = [], []
    for (u, y), x0, e in zip(experiments, x0s, residuals, strict=True):
        simulated = state_space_run(a, b, c, d, offset, u, x0)[0]
        rows.append(_responses(a, c, e).reshape(-1, n * p))
        targets.append((y - simulated - e).reshape(-1))
    gain = _solve_scaled(np.vstack(rows), np.concatenate(targets)).reshape(n, p)
    gain = _stable_gain(a, c, gain)

    def one_step_error(k: FloatArray) -> float:
        total = 0.0
        for (u, y), x0 in zip(experiments, x0s, strict=True):
            predicted = predictor_run(a, b, c, d, offset, k, u, y, x0)
            total += float(np.sum((y - predicted) ** 2))
        return total

    if one_step_error(gain) < one_step_error(np.zeros_like(gain)):
        return gain
    return np.zeros_like(gain)


# ============================================================================ refinement
def _unpack(
    theta: FloatArray, shape: tuple[int, int, int, int], feedthrough: bool, intercept: bool
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, list[FloatArray]]:
    n, m, p, n_exp = shape
    sizes = [n * n, n * m, p * n, p * m if feedthrough else 0, p if intercept else 0]
    parts = np.split(theta, np.cumsum(sizes))
    a, b, c = parts[0].reshape(n, n), parts[1].reshape(n, m), parts[2].reshape(p, n)
    d = parts[3].reshape(p, m) if feedthrough else np.zeros((p, m))
    offset = parts[4] if intercept else np.zeros(p)
    x0s = list(parts[5].reshape(n_exp, n))
    return a, b, c, d, offset, x0s


def refine_free_run(
    model: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    x0s: Sequence[FloatArray],
    experiments: Sequence[tuple[FloatArray, FloatArray]],
    feedthrough: bool,
    intercept: bool,
    max_iter: int,
) -> tuple[tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray], list[FloatArray]]:
    """All matrices, the offset and the initial states refined on the free-run error.

    ``scipy.optimize.least_squares`` (Levenberg–Marquardt, exact Jacobian by the forward
    sensitivities of :func:`_columns`) over the full parametrisation, from the subspace
    estimate. A step whose ``A`` is unstable gets a large
    residual; the result is kept only if it is stable and lowers the sum of squares, otherwise
    the estimate comes back unchanged.
    """
    a, b, c, d, offset = model
    n, m, p = a.shape[0], b.shape[1], c.shape[0]
    shape = (n, m, p, len(experiments))
    parts = [a.ravel(), b.ravel(), c.ravel()]
    parts += [d.ravel()] if feedthrough else []
    parts += [offset] if intercept else []
    theta0 = np.concatenate([*parts, *x0s])
    y_all = np.concatenate([y.ravel() for _, y in experiments])
    penalty = 1e3 * (1.0 + float(np.max(np.abs(y_all))))

    def residual(theta: FloatArray) -> FloatArray:
        a_, b_, c_, d_, o_, x0_ = _unpack(theta, shape, feedthrough, intercept)
        if spectral_radius(a_) >= 1.0:
            return np.full(y_all.size, penalty)
        with np.errstate(all="ignore"):
            runs = [
                state_space_run(a_, b_, c_, d_, o_, u, x)[0].ravel()
                for (u, _), x in zip(experiments, x0_, strict=True)
            ]
        error = np.concatenate(runs) - y_all
        return np.clip(np.nan_to_num(error, nan=penalty), -penalty, penalty)

    def jacobian(theta: FloatArray) -> FloatArray:
        a_, b_, c_, _, _, x0_ = _unpack(theta, shape, feedthrough, intercept)
        eye, none = np.eye(n), np.zeros((n, m))
        with np.errstate(all="ignore"):
            states = [
                state_space_run(a_, b_, eye, none, np.zeros(n), u, x)[0]
                for (u, _), x in zip(experiments, x0_, strict=True)
            ]
            columns = _columns(a_, c_, experiments, (feedthrough, intercept), states)
        return np.nan_to_num(columns, nan=0.0, posinf=penalty, neginf=-penalty)

    start = float(np.sum(residual(theta0) ** 2))
    fitted = least_squares(
        residual, theta0, jac=jacobian, method="lm", x_scale="jac", max_nfev=max_iter
    )
    a1, b1, c1, d1, o1, x1 = _unpack(fitted.x, shape, feedthrough, intercept)
    if spectral_radius(a1) < 1.0 - STABILITY_MARGIN and 2.0 * fitted.cost < start:
        return (a1, b1, c1, d1, o1), x1
    return model, list(x0s)


# ============================================================================ initial state
def estimate_state(
    model: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    y_rows: FloatArray,
    u_rows: FloatArray,
) -> FloatArray:
    """The state after ``len(y_rows)`` samples, from those outputs and inputs (least squares).

    ``x(0)`` solves ``y(k) − y_u(k) = C A^k x(0)``, ``k = 0 … m−1`` (``y_u`` the free run from
    ``x = 0``) in the least-squares sense (minimum norm where unobservable); the model then
    runs ``m`` samples from it: ``x(m) = A^m x(0) + x_u(m)``.
    """
    a, b, c, d, offset = model
    n, m = a.shape[0], y_rows.shape[0]
    forced, x_forced = state_space_run(a, b, c, d, offset, u_rows, np.zeros(n))
    free = _free_response(a, c, m).reshape(-1, n)
    solution = np.linalg.lstsq(free, (y_rows - forced).reshape(-1), rcond=None)[0]
    x0 = np.asarray(solution, dtype=np.float64)
    none = np.zeros((m, 0))
    p = c.shape[0]
    moved = state_space_run(a, np.zeros((n, 0)), c, np.zeros((p, 0)), np.zeros(p), none, x0)[1]
    return np.asarray(moved + x_forced, dtype=np.float64)
