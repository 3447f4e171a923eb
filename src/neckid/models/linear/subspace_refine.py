r"""The free-run refinement of a subspace state-space model: compiled sensitivities and Levenberg–Marquardt.

With ``θ = [A, B, C, D?, c?]`` (row-major, the layout of :func:`.subspace_steps._unpack`) and
each run started, as in use, from the least-squares state of its first ``n_initial`` samples
(:func:`.subspace_steps.initial_states`), the free-run error of every run after those samples
is minimised over the full parametrisation.

**Jacobian.** With the initial state held, the output derivatives are those of the forward
sensitivities, computed on the *transposed* recursion, which costs ``p n (n + m)`` a sample
instead of ``n^2 (n^2 + n m)``: for output ``o`` with row ``c_o`` of ``C``,

.. math::

    V_o(t+1) = A^T V_o(t) + c_o^T [x(t); u(t)]^T, \quad V_o(0) = 0, \qquad
    \frac{\partial y_o(t)}{\partial A_{jk}} = V_o(t)_{j,k}, \quad
    \frac{\partial y_o(t)}{\partial B_{jl}} = V_o(t)_{j,n+l}

(``V_o(t)_{jk} = \sum_{s<t} c_o A^{t-1-s} e_j x_k(s)``), and ``∂y_o/∂C_{ok} = x_k(t)``,
``∂y_o/∂D_{ol} = u_l(t)``, ``∂y_o/∂c_o = 1``. The initial state
``x_0 = S (y_{0:i} − F_{0:i}(θ))`` moves with ``θ``; its share is
``∂x_0/∂θ ≈ −S\,∂ŷ_{0:i}/∂θ`` (the derivative of the solver ``S`` times the residual of the
first samples left out: Kaufman's 1975 approximation in variable projection), so every row
adds ``C A^t ∂x_0/∂θ`` (:func:`sensitivities`, :func:`run_jacobian`).

**Steps.** Levenberg–Marquardt (Moré 1978) on the QR factor of ``[J, r]``: one Householder QR
of the Jacobian and the residuals a Jacobian, then each trial step a small damped solve on
``R``; the damping scales are the largest column norms of ``J`` seen so far (MINPACK's
``mode=1``, scipy's ``x_scale="jac"``); a step is taken when it lowers the sum of squares,
and the fit stops when neither the actual nor the predicted relative reduction exceeds
``1e-8`` (scipy's ``ftol``), a step moves ``θ`` by less than ``1e-8`` relative, or after
``max_iter`` evaluations of the residuals. A trial whose ``A`` has a mode beyond the bound
counts as an increase. :func:`refine_free_run` keeps the result only if it is within the
bound and lowers the sum of squares.

References
----------
J. J. Moré, "The Levenberg–Marquardt algorithm: implementation and theory", *Numerical
Analysis*, Lecture Notes in Mathematics 630, Springer, 1978. L. Kaufman, "A variable projection
method for solving separable nonlinear least squares problems", *BIT* 15, 1975.
"""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np
import scipy.linalg

from neckid.models.linear.subspace_steps import (
    STABILITY_MARGIN,
    _unpack,
    initial_state_solver,
    initial_states,
    spectral_radius,
    state_space_run,
)
from neckid.utils.types import FloatArray

__all__ = ["refine_free_run", "run_jacobian", "sensitivities"]

Matrices = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]

#: Relative reduction of the sum of squares (actual and predicted) below which the fit stops.
FTOL = 1e-8

#: Relative step length below which the fit stops.
XTOL = 1e-8


@numba.njit(cache=True, nogil=True)
def sensitivities(
    a: FloatArray,
    b: FloatArray,
    c: FloatArray,
    d: FloatArray,
    offset: FloatArray,
    u: FloatArray,
    x0: FloatArray,
    feedthrough: bool,
    intercept: bool,
) -> tuple[FloatArray, FloatArray, FloatArray]:  # pragma: no cover - compiled; tested
    """Free run from ``x0``, its derivatives with ``x0`` held, and the free response ``C A^t``.

    Returns ``(y (T, p), jacobian (T p, n_params), free (T p, n))``, rows time first as
    ``y.ravel()``; columns in the order of :func:`.subspace_steps._unpack`.
    """
    n_samples, m = u.shape
    n, p = a.shape[0], c.shape[0]
    n_b = n * n
    n_c = n_b + n * m
    n_d = n_c + p * n
    n_o = n_d + (p * m if feedthrough else 0)
    size = n_o + (p if intercept else 0)
    y = np.empty((n_samples, p))
    jac = np.zeros((n_samples * p, size))
    free = np.empty((n_samples * p, n))
    v = np.zeros((p, n, n + m))  # V_o(t)
    g = np.empty((p, n))  # rows of C A^t
    for o in range(p):
        for k in range(n):
            g[o, k] = c[o, k]
    x = x0.copy()
    following = np.empty(n)
    scratch = np.empty((n, n + m))
    g_next = np.empty(n)
    for t in range(n_samples):
        for o in range(p):
            row = t * p + o
            total = offset[o]
            for k in range(n):
                total += c[o, k] * x[k]
            for j in range(m):
                total += d[o, j] * u[t, j]
            y[t, o] = total
            for j in range(n):
                for k in range(n):
                    jac[row, j * n + k] = v[o, j, k]
                for k in range(m):
                    jac[row, n_b + j * m + k] = v[o, j, n + k]
            for k in range(n):
                jac[row, n_c + o * n + k] = x[k]
                free[row, k] = g[o, k]
            if feedthrough:
                for k in range(m):
                    jac[row, n_d + o * m + k] = u[t, k]
            if intercept:
                jac[row, n_o + o] = 1.0
            # V_o(t+1) = A^T V_o(t) + c_o^T [x; u]^T and g_o <- g_o A
            for r in range(n):
                for q in range(n + m):
                    scratch[r, q] = 0.0
                for s in range(n):
                    weight = a[s, r]
                    if weight != 0.0:
                        for q in range(n + m):
                            scratch[r, q] += weight * v[o, s, q]
                for q in range(n):
                    scratch[r, q] += c[o, r] * x[q]
                for q in range(m):
                    scratch[r, n + q] += c[o, r] * u[t, q]
            for r in range(n):
                for q in range(n + m):
                    v[o, r, q] = scratch[r, q]
            for k in range(n):
                total = 0.0
                for s in range(n):
                    total += g[o, s] * a[s, k]
                g_next[k] = total
            for k in range(n):
                g[o, k] = g_next[k]
        for r in range(n):
            total = 0.0
            for k in range(n):
                total += a[r, k] * x[k]
            for j in range(m):
                total += b[r, j] * u[t, j]
            following[r] = total
        for r in range(n):
            x[r] = following[r]
    return y, jac, free


def run_jacobian(
    matrices: Matrices,
    u: FloatArray,
    x0: FloatArray,
    solver: FloatArray,
    n_initial: int,
    options: tuple[bool, bool],
) -> tuple[FloatArray, FloatArray]:
    """One run's free run and Jacobian from sample ``n_initial`` on, the initial state's share in.

    ``x0`` is the run's state from its first ``n_initial`` samples and ``solver`` the map
    :func:`.subspace_steps.initial_state_solver` gives it by (module docstring).
    """
    feedthrough, intercept = options
    y, jac, free = sensitivities(*matrices, u, x0, feedthrough, intercept)
    skip = n_initial * matrices[2].shape[0]
    moved = solver @ jac[:skip]  # −∂x0/∂θ
    tail = jac[skip:]
    tail -= free[skip:] @ moved
    return y[n_initial:], tail


def _pack(matrices: Matrices, feedthrough: bool, intercept: bool) -> FloatArray:
    a, b, c, d, offset = matrices
    parts = [a.ravel(), b.ravel(), c.ravel()]
    parts += [d.ravel()] if feedthrough else []
    parts += [offset] if intercept else []
    return np.concatenate(parts)


class _Problem:
    """The free-run errors of every run after its first samples, and their Jacobian."""

    def __init__(
        self,
        model: Matrices,
        experiments: Sequence[tuple[FloatArray, FloatArray]],
        options: tuple[bool, bool],
        n_initial: int,
        limit: float,
        output_scale: FloatArray | None,
    ) -> None:
        a, b, c = model[:3]
        self.shape = (a.shape[0], b.shape[1], c.shape[0])
        self.options, self.n_initial, self.limit = options, n_initial, limit
        self.experiments = [(np.ascontiguousarray(u), y) for u, y in experiments]
        self.output_scale = output_scale
        self.target = np.concatenate([y[n_initial:].ravel() for _, y in experiments])
        self.penalty = 1e3 * (1.0 + float(np.max(np.abs(self.target))))
        self.evaluations = 0

    def matrices(self, theta: FloatArray) -> Matrices:
        return _unpack(theta, self.shape, *self.options)

    def residuals(self, theta: FloatArray) -> FloatArray | None:
        """The errors, or ``None`` for a ``θ`` whose ``A`` has a mode beyond the bound."""
        self.evaluations += 1
        matrices = self.matrices(theta)
        if spectral_radius(matrices[0]) > self.limit:
            return None
        with np.errstate(all="ignore"):
            starts = initial_states(matrices, self.experiments, self.n_initial, self.output_scale)
            runs = [
                state_space_run(*matrices, u, x)[0][self.n_initial :].ravel()
                for (u, _), x in zip(self.experiments, starts, strict=True)
            ]
        error = np.concatenate(runs) - self.target
        if not np.all(np.isfinite(error)):
            return None
        return error

    def normal_equations(
        self, theta: FloatArray, error: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """``(JᵀJ, Jᵀr)`` of the Jacobian at ``θ`` (module docstring) and the errors ``r``."""
        matrices = self.matrices(theta)
        a, c = matrices[0], matrices[2]
        size = theta.size
        hessian, gradient, row = np.zeros((size, size)), np.zeros(size), 0
        with np.errstate(all="ignore"):
            solver = initial_state_solver(a, c, self.n_initial, self.output_scale)
            starts = initial_states(matrices, self.experiments, self.n_initial, self.output_scale)
            for (u, _), x in zip(self.experiments, starts, strict=True):
                jac = run_jacobian(matrices, u, x, solver, self.n_initial, self.options)[1]
                if not np.all(np.isfinite(jac)):
                    jac = np.nan_to_num(jac, nan=0.0, posinf=self.penalty, neginf=-self.penalty)
                hessian += jac.T @ jac
                gradient += jac.T @ error[row : row + jac.shape[0]]
                row += jac.shape[0]
        return hessian, gradient


def _damped_step(
    hessian: FloatArray, gradient: FloatArray, scale: FloatArray, damping: float
) -> FloatArray | None:
    """``δ`` solving ``(JᵀJ + damping diag(scale)²) δ = −Jᵀr`` (``None``: not positive definite)."""
    try:
        factor = scipy.linalg.cho_factor(hessian + np.diag(damping * scale**2), check_finite=False)
    except np.linalg.LinAlgError:
        return None
    step = scipy.linalg.cho_solve(factor, -gradient, check_finite=False)
    return np.asarray(step) if np.all(np.isfinite(step)) else None


#: Damping rule: (factor after a step that lowers the sum of squares, factor after one that does not).
DAMPING = (1.0 / 3.0, 2.0)


def _next_damping(damping: float, ratio: float) -> float:
    """The damping after a trial whose actual over predicted reduction is ``ratio``."""
    return damping * (DAMPING[0] if ratio > 0.0 else DAMPING[1])


def _levenberg_marquardt(
    problem: _Problem, theta: FloatArray, error: FloatArray, max_iter: int
) -> tuple[FloatArray, float]:
    """Minimise ``‖residuals‖²`` from ``theta``, its errors ``error`` (module docstring).

    Returns ``(θ, sum of squares)``.
    """
    cost = float(error @ error)
    scale = np.zeros(theta.size)
    damping = 1e-3
    while problem.evaluations < max_iter:
        hessian, gradient = problem.normal_equations(theta, error)
        scale = np.maximum(scale, np.sqrt(np.maximum(np.diag(hessian), 0.0)))
        scale[scale == 0.0] = 1.0
        while problem.evaluations < max_iter:
            step = _damped_step(hessian, gradient, scale, damping)
            if step is None:
                damping *= 4.0
                continue
            predicted = -float(2.0 * gradient @ step + step @ hessian @ step)
            trial = theta + step
            trial_error = problem.residuals(trial)
            trial_cost = np.inf if trial_error is None else float(trial_error @ trial_error)
            actual = cost - trial_cost
            ratio = actual / predicted if predicted > 0 else -1.0
            damping = _next_damping(damping, ratio)
            if trial_error is not None and trial_cost < cost:
                small_step = np.linalg.norm(scale * step) <= XTOL * np.linalg.norm(scale * trial)
                settled = actual <= FTOL * cost and predicted <= FTOL * cost
                theta, error, cost = trial, trial_error, trial_cost
                if small_step or settled:
                    return theta, cost
                break
            if 0.0 <= predicted <= FTOL * cost:
                return theta, cost
    return theta, cost


def refine_free_run(
    model: Matrices,
    experiments: Sequence[tuple[FloatArray, FloatArray]],
    feedthrough: bool,
    intercept: bool,
    max_iter: int,
    n_initial: int,
    radius: float = 1.0 - STABILITY_MARGIN,
    output_scale: FloatArray | None = None,
) -> Matrices:
    """All matrices and the offset refined on the free-run error, runs from their first samples.

    Levenberg–Marquardt over the full parametrisation from the subspace estimate, with the
    compiled Jacobian of the module docstring and at most ``max_iter`` evaluations of the
    free-run errors. A trial whose ``A`` has an eigenvalue beyond ``radius`` (unstable, or slower
    than the records show settling, :func:`.subspace_steps.slowest_mode_radius`) is refused;
    the result is kept only if it stays within ``radius`` and lowers the sum of squares,
    otherwise the estimate comes back unchanged. ``output_scale``: see
    :func:`.subspace_steps.initial_state_solver`.

    Raises
    ------
    ValueError
        If the order has more parameters than the logs give output values after their first
        ``n_initial`` samples.
    """
    # Trials stay within the bound the result must meet; the start may sit just beyond it, on
    # the circle bound_modes moved it to.
    limit = min(radius, 1.0 - STABILITY_MARGIN)
    options = (bool(feedthrough), bool(intercept))
    problem = _Problem(model, experiments, options, n_initial, limit, output_scale)
    theta0 = _pack(model, *options)
    n, m, p = problem.shape
    if theta0.size > problem.target.size:

        def unknowns(k: int) -> int:
            return k * k + k * m + p * k + (p * m if feedthrough else 0) + (p if intercept else 0)

        fits = [k for k in range(1, n + 1) if unknowns(k) <= problem.target.size]
        raise ValueError(
            f"order {n} has {theta0.size} parameters to refine on the free-run error, more than"
            f" the {problem.target.size} output values the logs give after their first"
            f" {n_initial} samples: give an order of at most {max(fits, default=0)}, or longer"
            " logs"
        )
    problem.limit = radius * (1.0 + 1e-9)
    start = problem.residuals(theta0)
    problem.limit, problem.evaluations = limit, 0
    if start is None:
        return model
    theta, cost = _levenberg_marquardt(problem, theta0, start, max_iter)
    refined = problem.matrices(theta)
    if cost < float(start @ start) and spectral_radius(refined[0]) <= limit:
        return refined
    return model
