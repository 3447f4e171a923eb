r"""Levenberg–Marquardt for the free-run fits: Moré's MINPACK algorithm on LAPACK's QR.

The free-run fits of the polynomial NARX, the polynomial state space and the sparse NARX minimise
``½‖f(θ)‖²`` over a few hundred coefficients with a Jacobian of tens of thousands of rows.
``scipy.optimize.least_squares(method="lm")`` runs MINPACK's ``lmder`` for that (Moré 1978),
whose QR factorisation of the Jacobian is a Householder loop one column at a time: on Bouc–Wen's
41,000 × 364 Jacobian it is 3 s per iteration, two thirds of a 300-second fit.

:func:`levenberg_marquardt` is the same algorithm, step for step: the trust region in the
variables scaled by the Jacobian's column norms (MINPACK's ``mode=1``), the Levenberg–Marquardt
parameter by Moré's safeguarded Newton iteration (``lmpar``), the damped least-squares step by
Givens rotations on the triangular factor (``qrsolv``), the same step-bound updates, acceptance
ratio (10⁻⁴) and convergence tests (``ftol``, ``xtol``, ``gtol``), the same count of function
evaluations. Only the factorisation differs: ``J P = Q R`` is computed as one blocked QR of the
tall ``[J | f]`` (LAPACK ``dgeqrf``: ``R₁`` and ``Q₁ᵀ f`` together), then a column-pivoted QR of the
small ``R₁`` (``dgeqp3``): ``J P = Q₁ Q₂ R₂``, the factorisation MINPACK computes, by operations
that run at the speed of the machine's BLAS. The iterates agree with MINPACK's to rounding
(tested against scipy on problems where both converge; over a long run rounding differences
grow as in any two implementations).

References
----------
J. J. Moré, "The Levenberg-Marquardt algorithm: implementation and theory", Numerical Analysis,
Lecture Notes in Mathematics 630, 105-116, Springer, 1978.
J. J. Moré, B. S. Garbow, K. E. Hillstrom, *User Guide for MINPACK-1*, Argonne National
Laboratory report ANL-80-74, 1980 (``lmder``, ``lmpar``, ``qrsolv``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numba import njit

from neckid.utils.types import FloatArray, IntArray

__all__ = ["LeastSquaresResult", "fit_least_squares", "levenberg_marquardt"]

#: MINPACK's initial step bound: ``factor`` times the scaled norm of the start.
STEP_FACTOR = 100.0
#: What each ``status`` means (MINPACK's ``info``).
MESSAGES = {
    1: "Both actual and predicted relative reductions in the sum of squares are at most ftol.",
    2: "The relative error between two consecutive iterates is at most xtol.",
    3: "Both the sum-of-squares and the iterate tests (ftol and xtol) are satisfied.",
    4: "The cosine of the angle between the residuals and any Jacobian column is at most gtol.",
    5: "The maximum number of function evaluations is exceeded.",
    6: "ftol is too small: no further reduction in the sum of squares is possible.",
    7: "xtol is too small: no further improvement of the iterate is possible.",
    8: "gtol is too small: the residuals are orthogonal to the Jacobian's columns to machine precision.",
}
#: MINPACK's ``info`` for scipy's ``status`` (scipy's 1 is the gradient test, 2 ``ftol``, ...).
FROM_SCIPY_STATUS = {0: 5, 1: 4, 2: 1, 3: 2, 4: 3}
_EPS = float(np.finfo(np.float64).eps)
_DWARF = float(np.finfo(np.float64).tiny)


@dataclass(frozen=True)
class LeastSquaresResult:
    """Where :func:`levenberg_marquardt` stopped.

    Attributes
    ----------
    x : ndarray, shape (n,)
        The last accepted iterate.
    fun : ndarray, shape (m,)
        The residuals there.
    cost : float
        ``½ ‖fun‖²``.
    nfev, njev : int
        Evaluations of the residuals (the start's included) and of the Jacobian.
    status : int
        Why it stopped (1–8, see :data:`MESSAGES`); 5 is the evaluation budget.
    message : str
    """

    x: FloatArray
    fun: FloatArray
    cost: float
    nfev: int
    njev: int
    status: int
    message: str


def levenberg_marquardt(
    fun: Callable[[FloatArray], FloatArray],
    x0: FloatArray,
    jac: Callable[[FloatArray], FloatArray],
    *,
    max_nfev: int,
    f0: FloatArray | None = None,
    ftol: float = 1e-8,
    xtol: float = 1e-8,
    gtol: float = 1e-8,
) -> LeastSquaresResult:
    """Minimise ``½ ‖fun(x)‖²`` from ``x0`` (Moré's Levenberg–Marquardt, as MINPACK's ``lmder``).

    Parameters
    ----------
    fun : callable
        The residuals, ``(n,) -> (m,)`` with ``m >= n``.
    x0 : ndarray, shape (n,)
    jac : callable
        Their Jacobian, ``(n,) -> (m, n)``.
    max_nfev : int
        Largest number of residual evaluations (the start's counts as one).
    f0 : ndarray, shape (m,), optional
        ``fun(x0)`` when the caller has it (then not evaluated again; still counted).
    ftol, xtol, gtol : float
        MINPACK's tolerances (scipy's defaults): relative reduction of the sum of squares,
        relative size of the trust region, cosine of the residuals with the Jacobian's columns.

    Returns
    -------
    LeastSquaresResult

    Raises
    ------
    ValueError
        ``max_nfev < 1``, fewer residuals than variables, or a Jacobian of the wrong shape.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 1, 20)
    >>> y = 2.0 * np.exp(-3.0 * t)
    >>> r = lambda p: p[0] * np.exp(-p[1] * t) - y
    >>> J = lambda p: np.column_stack([np.exp(-p[1] * t), -p[0] * t * np.exp(-p[1] * t)])
    >>> result = levenberg_marquardt(r, np.array([1.0, 1.0]), J, max_nfev=100)
    >>> np.round(result.x, 6).tolist(), result.status
    ([2.0, 3.0], 2)
    """
    if max_nfev < 1:
        raise ValueError(f"max_nfev must be at least 1; got {max_nfev}")
    x = np.array(x0, dtype=np.float64).ravel()
    n = x.size
    f = np.asarray(fun(x) if f0 is None else f0, dtype=np.float64).ravel()
    m = f.size
    if m < n:
        raise ValueError(
            f"Levenberg-Marquardt needs at least as many residuals as variables; got {m} < {n}"
        )
    state = _State(x=x, f=f, fnorm=float(np.linalg.norm(f)))
    diag = np.zeros(n)
    nfev, njev, status, first = 1, 0, 0, True
    while status == 0:
        r, ipvt, qtf, acnorm = _factor(jac(state.x), state.f, m, n)
        njev += 1
        if first:
            diag[:] = np.where(acnorm == 0.0, 1.0, acnorm)
            state.xnorm = float(np.linalg.norm(diag * state.x))
            delta = STEP_FACTOR * state.xnorm if state.xnorm > 0 else STEP_FACTOR
        gnorm = _gradient_norm(r, ipvt, qtf, acnorm, state.fnorm)
        if gnorm <= gtol:
            status = 4
            break
        np.maximum(diag, acnorm, out=diag)
        while True:  # the inner loop: shrink the trust region until a step is accepted
            step, par = _lm_step(r, ipvt, diag, qtf, delta, state.par)
            state.par = par
            pnorm = float(np.linalg.norm(diag * step))
            if first:
                delta = min(delta, pnorm)
            trial = state.x + step
            f_trial = np.asarray(fun(trial), dtype=np.float64).ravel()
            nfev += 1
            fnorm1 = float(np.linalg.norm(f_trial))
            actred, prered, ratio, delta = _update_bound(state, r, ipvt, step, pnorm, fnorm1, delta)
            if ratio >= 1e-4:
                state.x, state.f, state.fnorm = trial, f_trial, fnorm1
                state.xnorm = float(np.linalg.norm(diag * trial))
                first = False
            status = _converged(actred, prered, ratio, delta, state.xnorm, ftol, xtol)
            if status == 0:
                status = _exhausted(
                    actred, prered, ratio, delta, state.xnorm, gnorm, nfev, max_nfev
                )
            if status != 0 or ratio >= 1e-4:
                break
    return LeastSquaresResult(
        x=state.x,
        fun=state.f,
        cost=0.5 * float(state.f @ state.f),
        nfev=nfev,
        njev=njev,
        status=status,
        message=MESSAGES[status],
    )


def fit_least_squares(
    fun: Callable[[FloatArray], FloatArray],
    x0: FloatArray,
    jac: Callable[[FloatArray], FloatArray],
    *,
    max_nfev: int,
    f0: FloatArray,
) -> LeastSquaresResult:
    """Minimise ``½ ‖fun(x)‖²`` from ``x0`` whose residuals ``f0`` the caller has.

    :func:`levenberg_marquardt` when there are at least as many residuals as variables; otherwise
    scipy's trust-region reflective method (``least_squares(method="trf", x_scale="jac")``),
    handed ``f0`` for the start instead of evaluating it again. Either way the start counts as one
    of the ``max_nfev`` evaluations, and ``status`` is MINPACK's (:data:`MESSAGES`).
    """
    if f0.size >= x0.size:
        return levenberg_marquardt(fun, x0, jac, max_nfev=max_nfev, f0=f0)
    from scipy.optimize import least_squares

    pending = [f0]

    def start_known(x: FloatArray) -> FloatArray:
        if pending and np.array_equal(x, x0):
            return pending.pop()
        pending.clear()
        return fun(x)

    solution = least_squares(
        start_known, x0, jac=jac, method="trf", x_scale="jac", max_nfev=max_nfev
    )
    status = FROM_SCIPY_STATUS[int(solution.status)]
    return LeastSquaresResult(
        x=solution.x,
        fun=solution.fun,
        cost=float(solution.cost),
        nfev=int(solution.nfev),
        njev=int(solution.njev or 0),
        status=status,
        message=str(solution.message),
    )


@dataclass
class _State:
    """The accepted iterate: ``x``, its residuals and their norm, ``D x``'s norm, the LM parameter."""

    x: FloatArray
    f: FloatArray
    fnorm: float
    xnorm: float = 0.0
    par: float = 0.0


def _factor(
    jacobian: FloatArray, f: FloatArray, m: int, n: int
) -> tuple[FloatArray, IntArray, FloatArray, FloatArray]:
    """``J P = Q R``: ``R`` (n × n, zero below its diagonal), the permutation, ``(Qᵀ f)[:n]``, ``J``'s column norms.

    ``R`` stays as it is: :func:`_lm_step` hands ``lmpar`` a copy to write below the diagonal.
    """
    if jacobian.shape != (m, n):
        raise ValueError(f"the Jacobian has shape {jacobian.shape}; expected {(m, n)}")
    stacked = np.empty((m, n + 1), order="F")
    stacked[:, :n] = jacobian
    stacked[:, n] = f
    # the Householder vectors stay below the diagonal of ``stacked`` (LAPACK's raw form)
    (tall, _), _ = scipy.linalg.qr(stacked, mode="raw", overwrite_a=True, check_finite=False)
    r1 = np.triu(tall[:n, :n])
    q2, r, ipvt = scipy.linalg.qr(r1, pivoting=True, check_finite=False)
    qtf = q2.T @ tall[:n, n]
    acnorm = np.linalg.norm(r1, axis=0)
    return np.ascontiguousarray(r), ipvt.astype(np.int64), qtf, acnorm


def _gradient_norm(
    r: FloatArray, ipvt: IntArray, qtf: FloatArray, acnorm: FloatArray, fnorm: float
) -> float:
    """The largest cosine between the residuals and a column of ``J`` (MINPACK's ``gnorm``)."""
    if fnorm == 0.0:
        return 0.0
    sums = r.T @ (qtf / fnorm)
    norms = acnorm[ipvt]
    nonzero = norms != 0.0
    return float(np.max(np.abs(sums[nonzero] / norms[nonzero]), initial=0.0))


def _lm_step(
    r: FloatArray, ipvt: IntArray, diag: FloatArray, qtf: FloatArray, delta: float, par: float
) -> tuple[FloatArray, float]:
    """The step ``−x`` of ``lmpar`` (so that ``x + step`` is the trial) and its LM parameter."""
    x = np.zeros(r.shape[0])
    par = _lmpar(r.copy(), ipvt, diag, qtf, delta, par, x)
    return -x, par


def _update_bound(
    state: _State,
    r: FloatArray,
    ipvt: IntArray,
    step: FloatArray,
    pnorm: float,
    fnorm1: float,
    delta: float,
) -> tuple[float, float, float, float]:
    """Actual and predicted reductions, their ratio, and the new step bound (``state.par`` too)."""
    fnorm = state.fnorm
    actred = 1.0 - (fnorm1 / fnorm) ** 2 if 0.1 * fnorm1 < fnorm else -1.0
    temp1 = float(np.linalg.norm(r @ step[ipvt])) / fnorm
    temp2 = np.sqrt(state.par) * pnorm / fnorm
    prered = temp1**2 + temp2**2 / 0.5
    dirder = -(temp1**2 + temp2**2)
    ratio = actred / prered if prered != 0.0 else 0.0
    if ratio <= 0.25:
        temp = 0.5 if actred >= 0.0 else 0.5 * dirder / (dirder + 0.5 * actred)
        if 0.1 * fnorm1 >= fnorm or temp < 0.1:
            temp = 0.1
        delta = temp * min(delta, pnorm / 0.1)
        state.par = state.par / temp
    elif state.par == 0.0 or ratio >= 0.75:
        delta = pnorm / 0.5
        state.par = 0.5 * state.par
    return actred, prered, ratio, delta


def _converged(
    actred: float, prered: float, ratio: float, delta: float, xnorm: float, ftol: float, xtol: float
) -> int:
    """MINPACK's convergence tests: 1 (``ftol``), 2 (``xtol``), 3 (both) or 0."""
    reduction = abs(actred) <= ftol and prered <= ftol and 0.5 * ratio <= 1.0
    small = delta <= xtol * xnorm
    return 3 if reduction and small else 1 if reduction else 2 if small else 0


def _exhausted(
    actred: float,
    prered: float,
    ratio: float,
    delta: float,
    xnorm: float,
    gnorm: float,
    nfev: int,
    max_nfev: int,
) -> int:
    """MINPACK's termination tests: the budget (5) or tolerances below machine precision (6–8)."""
    status = 5 if nfev >= max_nfev else 0
    if abs(actred) <= _EPS and prered <= _EPS and 0.5 * ratio <= 1.0:
        status = 6
    if delta <= _EPS * xnorm:
        status = 7
    if gnorm <= _EPS:
        status = 8
    return status


@njit(cache=True)
def _lmpar(
    r: FloatArray,
    ipvt: IntArray,
    diag: FloatArray,
    qtb: FloatArray,
    delta: float,
    par: float,
    x: FloatArray,
) -> float:  # pragma: no cover - compiled
    """Moré's LM parameter: ``‖D x‖`` within 10 % of ``delta`` (``x`` solves the damped problem).

    ``r`` (upper triangle: ``R``) is overwritten below its diagonal, as in MINPACK.
    """
    n = r.shape[0]
    wa1 = np.empty(n)
    wa2 = np.empty(n)
    sdiag = np.empty(n)
    nsing = n
    for j in range(n):  # the Gauss-Newton direction (least squares if R is singular)
        wa1[j] = qtb[j]
        if r[j, j] == 0.0 and nsing == n:
            nsing = j
        if nsing < n:
            wa1[j] = 0.0
    for k in range(nsing):
        j = nsing - 1 - k
        wa1[j] /= r[j, j]
        temp = wa1[j]
        for i in range(j):
            wa1[i] -= r[i, j] * temp
    for j in range(n):
        x[ipvt[j]] = wa1[j]
    for j in range(n):
        wa2[j] = diag[j] * x[j]
    dxnorm = np.sqrt(np.sum(wa2 * wa2))
    fp = dxnorm - delta
    if fp <= 0.1 * delta:
        return 0.0
    parl = 0.0
    if nsing == n:  # the Newton step gives a lower bound
        for j in range(n):
            wa1[j] = diag[ipvt[j]] * (wa2[ipvt[j]] / dxnorm)
        for j in range(n):
            total = 0.0
            for i in range(j):
                total += r[i, j] * wa1[i]
            wa1[j] = (wa1[j] - total) / r[j, j]
        temp = np.sqrt(np.sum(wa1 * wa1))
        parl = ((fp / delta) / temp) / temp
    for j in range(n):  # an upper bound
        total = 0.0
        for i in range(j + 1):
            total += r[i, j] * qtb[i]
        wa1[j] = total / diag[ipvt[j]]
    gnorm = np.sqrt(np.sum(wa1 * wa1))
    paru = gnorm / delta
    if paru == 0.0:
        paru = _DWARF / min(delta, 0.1)
    par = min(max(par, parl), paru)
    if par == 0.0:
        par = gnorm / dxnorm
    iteration = 0
    while True:
        iteration += 1
        if par == 0.0:
            par = max(_DWARF, 0.001 * paru)
        temp = np.sqrt(par)
        for j in range(n):
            wa1[j] = temp * diag[j]
        _qrsolv(r, ipvt, wa1, qtb, x, sdiag)
        for j in range(n):
            wa2[j] = diag[j] * x[j]
        dxnorm = np.sqrt(np.sum(wa2 * wa2))
        temp = fp
        fp = dxnorm - delta
        if abs(fp) <= 0.1 * delta or (parl == 0.0 and fp <= temp and temp < 0.0) or iteration == 10:
            return par
        for j in range(n):  # the Newton correction
            wa1[j] = diag[ipvt[j]] * (wa2[ipvt[j]] / dxnorm)
        for j in range(n):
            wa1[j] /= sdiag[j]
            temp = wa1[j]
            for i in range(j + 1, n):
                wa1[i] -= r[i, j] * temp
        temp = np.sqrt(np.sum(wa1 * wa1))
        parc = ((fp / delta) / temp) / temp
        if fp > 0.0:
            parl = max(parl, par)
        if fp < 0.0:
            paru = min(paru, par)
        par = max(parl, par + parc)


@njit(cache=True)
def _qrsolv(
    r: FloatArray,
    ipvt: IntArray,
    diag: FloatArray,
    qtb: FloatArray,
    x: FloatArray,
    sdiag: FloatArray,
) -> None:  # pragma: no cover - compiled
    """Solve ``min ‖(R; D P) z − (Qᵀb; 0)‖`` by Givens rotations (MINPACK's ``qrsolv``).

    The triangular factor ``S`` of the damped problem goes below ``r``'s diagonal (transposed)
    and into ``sdiag``; ``r``'s upper triangle and diagonal are kept.
    """
    n = r.shape[0]
    wa = np.empty(n)
    for j in range(n):
        for i in range(j, n):
            r[i, j] = r[j, i]
        x[j] = r[j, j]
        wa[j] = qtb[j]
    for j in range(n):
        lj = ipvt[j]
        if diag[lj] != 0.0:
            for k in range(j, n):
                sdiag[k] = 0.0
            sdiag[j] = diag[lj]
            qtbpj = 0.0
            for k in range(j, n):
                if sdiag[k] == 0.0:
                    continue
                if abs(r[k, k]) < abs(sdiag[k]):
                    cotan = r[k, k] / sdiag[k]
                    sin = 0.5 / np.sqrt(0.25 + 0.25 * cotan * cotan)
                    cos = sin * cotan
                else:
                    tan = sdiag[k] / r[k, k]
                    cos = 0.5 / np.sqrt(0.25 + 0.25 * tan * tan)
                    sin = cos * tan
                r[k, k] = cos * r[k, k] + sin * sdiag[k]
                temp = cos * wa[k] + sin * qtbpj
                qtbpj = -sin * wa[k] + cos * qtbpj
                wa[k] = temp
                for i in range(k + 1, n):
                    temp = cos * r[i, k] + sin * sdiag[i]
                    sdiag[i] = -sin * r[i, k] + cos * sdiag[i]
                    r[i, k] = temp
        sdiag[j] = r[j, j]
        r[j, j] = x[j]
    nsing = n
    for j in range(n):
        if sdiag[j] == 0.0 and nsing == n:
            nsing = j
        if nsing < n:
            wa[j] = 0.0
    for k in range(nsing):
        j = nsing - 1 - k
        total = 0.0
        for i in range(j + 1, nsing):
            total += r[i, j] * wa[i]
        wa[j] = (wa[j] - total) / sdiag[j]
    for j in range(n):
        x[ipvt[j]] = wa[j]
