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
4. :func:`output_error_regression`: :math:`B`, :math:`D` and the output offset :math:`c` by
   linear least squares on the free-run (output) error, in which they enter linearly once
   :math:`A` and :math:`C` are fixed, each experiment starting from the state its first
   ``n_initial`` samples give (:func:`initial_state_solver`), as every free run of the model
   starts: the fit minimises the error of the runs the model will make.
5. :func:`kalman_gain`: :math:`K` by the two-stage regression of Hannan & Rissanen (1982):
   innovations from a long ARX model, then the output error of step 4 regressed on their
   filtered values.

The refinement of the free-run error over all matrices, the initial states again from the first
samples, is :func:`.subspace_refine.refine_free_run`. All of it works on signals scaled to unit
standard deviation per channel; :mod:`.subspace` maps the matrices back.
"""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np
import scipy.linalg

from neckid.utils.types import FloatArray

__all__ = [
    "SETTLING_SHARE",
    "STABILITY_MARGIN",
    "bound_modes",
    "choose_order",
    "estimate_state",
    "initial_state_solver",
    "initial_states",
    "innovations",
    "kalman_gain",
    "observability_basis",
    "output_error_regression",
    "past_future_factor",
    "predictor_run",
    "shift_invariance",
    "slowest_mode_radius",
    "spectral_radius",
    "state_space_run",
]

#: Largest spectral radius of ``A`` (and of ``A − K C``) accepted: 1 − 1e-9.
STABILITY_MARGIN = 1e-9

#: A mode must decay to ``exp(−SETTLING_SHARE)`` within the shortest training record
#: (:func:`slowest_mode_radius`): its time constant is at most a fifth of that record.
SETTLING_SHARE = 5.0

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


def slowest_mode_radius(n_samples: int, share: float = SETTLING_SHARE) -> float:
    """The largest eigenvalue magnitude a record of ``n_samples`` can show settling.

    ``exp(−share / n_samples)``: a mode of that magnitude has the time constant
    ``n_samples / share`` samples and decays to ``e^{−share}`` (0.7 % for 5) within the record.
    A slower mode is not identifiable from it as a decaying one: over the record it is an
    integrator, and a model that keeps it drifts on any input bias of a new run.
    """
    return float(min(np.exp(-share / n_samples), 1.0 - STABILITY_MARGIN))


def bound_modes(a: FloatArray, radius: float) -> tuple[FloatArray, bool]:
    """``a`` with every eigenvalue of magnitude above ``radius`` moved onto that circle.

    On the real Schur form ``A = Z T Zᵀ``: a real eigenvalue ``λ`` on the diagonal of ``T``
    becomes ``sign(λ) radius``, a 2×2 block of a complex pair (``|λ|² = det``) is scaled by
    ``radius / |λ|``; the other blocks, the coupling above the diagonal and ``Z`` are kept, so
    the faster modes do not move. Returns ``(A, moved)``.

    Examples
    --------
    >>> a, moved = bound_modes(np.diag([0.999, 0.5]), 0.99)
    >>> np.round(np.diag(a), 6).tolist(), moved
    ([0.99, 0.5], True)
    """
    if spectral_radius(a) <= radius:
        return a, False
    t, z = scipy.linalg.schur(a, output="real")
    k, n = 0, t.shape[0]
    while k < n:
        if k + 1 < n and t[k + 1, k] != 0.0:
            magnitude = float(np.sqrt(abs(np.linalg.det(t[k : k + 2, k : k + 2]))))
            if magnitude > radius:
                t[k : k + 2, k : k + 2] *= radius / magnitude
            k += 2
            continue
        if abs(t[k, k]) > radius:
            t[k, k] = np.copysign(radius, t[k, k])
        k += 1
    return np.asarray(z @ t @ z.T, dtype=np.float64), True


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


def _columns(a: FloatArray, c: FloatArray, u: FloatArray, options: tuple[bool, bool]) -> FloatArray:
    """Derivatives of one experiment's free run over ``[B, D?, c?]``, its state fixed.

    One row per sample and output (time first, as ``y.ravel()``), one column per parameter,
    in the order of :func:`_unpack` without ``A`` and ``C``; none depends on the parameters.
    """
    feedthrough, intercept = options
    n, p = a.shape[0], c.shape[0]
    m = u.shape[1]
    sizes = [n * m, p * m if feedthrough else 0, p if intercept else 0]
    edges = np.concatenate([[0], np.cumsum(sizes)])
    columns = np.zeros((u.shape[0], p, int(edges[-1])))
    columns[:, :, : edges[1]] = _responses(a, c, u).reshape(-1, p, n * m)
    for o in range(p):
        if feedthrough:
            columns[:, o, edges[1] + o * m : edges[1] + (o + 1) * m] = u
    if intercept:
        columns[:, :, edges[2] : edges[3]] = np.eye(p)
    return columns.reshape(u.shape[0] * p, -1)


def initial_state_solver(
    a: FloatArray, c: FloatArray, n_initial: int, output_scale: FloatArray | None = None
) -> FloatArray:
    """The map from the first ``n_initial`` samples' free-response error to ``x(0)``.

    ``pinv(W O) W``, ``O`` the ``(n_initial · n_outputs, n)`` free response ``C A^k``, ``k = 0 …
    n_initial − 1`` (rows time first), ``W`` each output's row multiplied by
    ``output_scale`` (default 1): ``x(0)`` is the least-squares state (minimum norm where
    unobservable) of those samples. On signals divided by ``output_scale`` it gives the state
    :func:`estimate_state` finds on the unscaled ones, so the fit starts every training run
    where the fitted model will start it.
    """
    free = _free_response(a, c, n_initial).reshape(-1, a.shape[0])
    if output_scale is None:
        return np.asarray(np.linalg.pinv(free), dtype=np.float64)
    weights = np.tile(np.asarray(output_scale, dtype=np.float64), n_initial)
    solver = np.linalg.pinv(weights[:, None] * free) * weights[None, :]
    return np.asarray(solver, dtype=np.float64)


def _after_initial(
    values: FloatArray, free: FloatArray, solver: FloatArray, skip: int
) -> FloatArray:
    """``values − O pinv(O_m) values[:m]`` from row ``skip`` on: the state's share taken out.

    For a free run ``y = F θ + O x(0)`` whose ``x(0) = pinv(O_m) (y_m − F_m θ)`` comes from the
    first ``skip`` rows, ``y − ŷ = (y − O pinv(O_m) y_m) − (F − O pinv(O_m) F_m) θ``: the
    target and the columns both go through this map.
    """
    return (values - free @ (solver @ values[:skip]))[skip:]


def output_error_regression(
    a: FloatArray,
    c: FloatArray,
    experiments: Sequence[tuple[FloatArray, FloatArray]],
    feedthrough: bool,
    intercept: bool,
    n_initial: int,
    output_scale: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, list[FloatArray]]:
    """``B``, ``D`` and offset minimising the free-run error, each run from its first samples.

    With ``A`` and ``C`` fixed the free run
    ``y(t) = C A^t x_0 + Σ_{s<t} C A^{t−1−s} B u(s) + D u(t) + c`` is linear in ``(B, D, c)``,
    and so is ``x_0`` when it is the least-squares state of the first ``n_initial`` samples
    (:func:`initial_state_solver`, as :func:`estimate_state` gives it to every free run): one
    regressor column per unknown, each the response of the model to one input channel through
    one state (:func:`state_space_run`) with the part the initial state absorbs taken out,
    solved over the samples after the first ``n_initial`` of every experiment (Verhaegen &
    Verdult 2007, §9.2.4, with the initial state of the protocol instead of a free one).

    ``output_scale``: see :func:`initial_state_solver`.

    Returns
    -------
    (B (n, m), D (p, m), offset (p,), [x0 (n,) per experiment])
        ``D`` is zeros without ``feedthrough``, the offset zeros without ``intercept``; ``x0``
        each experiment's state at sample 0, from its first ``n_initial`` samples.
    """
    n, p = a.shape[0], c.shape[0]
    m = experiments[0][0].shape[1]
    solver, skip = initial_state_solver(a, c, n_initial, output_scale), n_initial * p
    rows, targets = [], []
    for u, y in experiments:
        free = _free_response(a, c, u.shape[0]).reshape(-1, n)
        rows.append(_after_initial(_columns(a, c, u, (feedthrough, intercept)), free, solver, skip))
        targets.append(_after_initial(y.reshape(-1), free, solver, skip))
    theta = _solve_scaled(np.vstack(rows), np.concatenate(targets))
    b = theta[: n * m].reshape(n, m)
    at = n * m
    d = theta[at : at + p * m].reshape(p, m) if feedthrough else np.zeros((p, m))
    at += p * m if feedthrough else 0
    offset = np.asarray(theta[at : at + p] if intercept else np.zeros(p), dtype=np.float64)
    x0s = initial_states((a, b, c, d, offset), experiments, n_initial, output_scale)
    return b, d, offset, x0s


def initial_states(
    model: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    experiments: Sequence[tuple[FloatArray, FloatArray]],
    n_initial: int,
    output_scale: FloatArray | None = None,
) -> list[FloatArray]:
    """``x(0)`` of every experiment from its first ``n_initial`` samples.

    ``output_scale``: see :func:`initial_state_solver`.
    """
    a, b, c, d, offset = model
    solver = initial_state_solver(a, c, n_initial, output_scale)
    states = []
    for u, y in experiments:
        forced = state_space_run(a, b, c, d, offset, u[:n_initial], np.zeros(a.shape[0]))[0]
        states.append(np.asarray(solver @ (y[:n_initial] - forced).reshape(-1)))
    return states


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
    theta: FloatArray, shape: tuple[int, int, int], feedthrough: bool, intercept: bool
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """``(A, B, C, D, offset)`` from the refinement's parameter vector (:mod:`.subspace_refine`)."""
    n, m, p = shape
    sizes = [n * n, n * m, p * n, p * m if feedthrough else 0]
    parts = np.split(theta, np.cumsum(sizes))
    a, b, c = parts[0].reshape(n, n), parts[1].reshape(n, m), parts[2].reshape(p, n)
    d = parts[3].reshape(p, m) if feedthrough else np.zeros((p, m))
    offset = parts[4] if intercept else np.zeros(p)
    return a, b, c, d, offset


# ============================================================================ initial state
def estimate_state(
    model: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    y_rows: FloatArray,
    u_rows: FloatArray,
) -> FloatArray:
    """The state after ``len(y_rows)`` samples, from those outputs and inputs (least squares).

    ``x(0)`` solves ``y(k) − y_u(k) = C A^k x(0)``, ``k = 0 … m−1`` (``y_u`` the free run from
    ``x = 0``) in the least-squares sense (minimum norm where unobservable,
    :func:`initial_state_solver`: the state the fit gave each training run); the model then
    runs ``m`` samples from it: ``x(m) = A^m x(0) + x_u(m)``.
    """
    a, b, c, d, offset = model
    n, m = a.shape[0], y_rows.shape[0]
    forced, x_forced = state_space_run(a, b, c, d, offset, u_rows, np.zeros(n))
    x0 = np.asarray(initial_state_solver(a, c, m) @ (y_rows - forced).reshape(-1))
    none = np.zeros((m, 0))
    p = c.shape[0]
    moved = state_space_run(a, np.zeros((n, 0)), c, np.zeros((p, 0)), np.zeros(p), none, x0)[1]
    return np.asarray(moved + x_forced, dtype=np.float64)
