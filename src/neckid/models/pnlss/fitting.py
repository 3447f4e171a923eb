r"""The free-run least-squares problem of a polynomial state-space model, and its start.

:class:`FreeRunProblem` holds the training experiments in the model's internal units (inputs
scaled to ``[-1, 1]`` of their training range, outputs to zero mean and unit standard
deviation), the initial state of each (fixed: estimated once from its first samples) and the
layout of the parameter vector ``θ = [A, B, E, C, D, c, F]``; it gives the residuals and their
exact Jacobian (:mod:`._kernels`) to :func:`neckid.models.levenberg.levenberg_marquardt`.

:func:`linear_start` turns a fitted :class:`~neckid.models.linear.SubspaceStateSpace` into the
start ``E = F = 0`` in those units, the states shifted to remove the input offset and scaled to
unit standard deviation over the training free run.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from neckid.models.linear.subspace import SubspaceStateSpace
from neckid.models.linear.subspace_steps import estimate_state
from neckid.models.pnlss._kernels import pnlss_run, pnlss_sensitivity
from neckid.models.polynomial.monomials import monomial_tables
from neckid.utils.types import BoolArray, FloatArray, IntArray

__all__ = ["FreeRunProblem", "Layout", "Matrices", "linear_start"]

logger = logging.getLogger(__name__)

#: ``(A, B, C, D, c, E, F)`` in internal units.
Matrices = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]


@dataclass(frozen=True)
class Layout:
    """Sizes of a PNLSS model and where each matrix sits in ``θ = [A, B, E, C, D, c, F]``.

    Attributes
    ----------
    n, m, p : int
        States, inputs, outputs.
    degree : int
        Largest total degree of ``ζ`` (its monomials are of degree 2 … ``degree`` in
        ``[x; u]``).
    feedthrough : bool
        ``D`` and the monomials of ``F`` that hold an input are free; otherwise they stay 0
        (the output then depends on the states alone).
    """

    n: int
    m: int
    p: int
    degree: int
    feedthrough: bool

    def tables(self) -> tuple[IntArray, IntArray, IntArray, IntArray]:
        """``powers, parent, var, lower`` of the monomials of ``[x; u]`` (graded)."""
        return monomial_tables(self.n + self.m, self.degree)

    @property
    def n_nonlinear(self) -> int:
        """Monomials of degree >= 2: the columns of ``E`` and ``F``."""
        return int(self.tables()[0].shape[0]) - 1 - self.n - self.m

    def shapes(self) -> list[tuple[int, int]]:
        """Shapes of ``A, B, E, C, D, c, F`` (``c`` as a column)."""
        n, m, p, k = self.n, self.m, self.p, self.n_nonlinear
        return [(n, n), (n, m), (n, k), (p, n), (p, m), (p, 1), (p, k)]

    def pack(self, matrices: Matrices) -> FloatArray:
        """``θ`` from ``(A, B, C, D, c, E, F)``."""
        a, b, c, d, offset, e, f = matrices
        parts = (a, b, e, c, d, offset.reshape(-1, 1), f)
        return np.concatenate([np.asarray(x, dtype=np.float64).ravel() for x in parts])

    def unpack(self, theta: FloatArray) -> Matrices:
        """``(A, B, C, D, c, E, F)`` from ``θ`` (contiguous copies)."""
        parts, start = [], 0
        for shape in self.shapes():
            size = shape[0] * shape[1]
            parts.append(np.ascontiguousarray(theta[start : start + size].reshape(shape)))
            start += size
        a, b, e, c, d, offset, f = parts
        return a, b, c, d, np.ascontiguousarray(offset[:, 0]), e, f

    def free(self) -> BoolArray:
        """Which entries of ``θ`` the fit moves (``D``, ``F``'s input monomials: feedthrough only)."""
        powers = self.tables()[0]
        k = self.n_nonlinear
        states_only = np.all(powers[-k:, self.n :] == 0, axis=1) if k else np.zeros(0, bool)
        blocks = []
        for name, shape in zip("ABECDcF", self.shapes(), strict=True):
            block = np.ones(shape, dtype=bool)
            if name == "D":
                block[:] = self.feedthrough
            if name == "F" and not self.feedthrough:
                block[:] = states_only[None, :]
            blocks.append(block.ravel())
        return np.concatenate(blocks)


def linear_start(
    ss: SubspaceStateSpace,
    u_center: FloatArray,
    u_scale: FloatArray,
    y_center: FloatArray,
    y_scale: FloatArray,
    experiments: Sequence[tuple[FloatArray, FloatArray]],
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """The ``ss`` model in internal units: ``(A, B, C, D, c)``, states of unit spread.

    ``experiments`` are ``(u, y)`` pairs already in internal units. The state is shifted by the
    steady state of the input offset (``x_0 = (I − A)^{-1} B u_center``, moved into ``c``) and
    scaled by ``T = diag(1 / std(x))`` of the free run over the experiments.
    """
    a, b, c, d, offset = ss.matrices_
    n = a.shape[0]
    b_int = b * u_scale[None, :]
    shift = np.linalg.solve(np.eye(n) - a, b @ u_center)
    c_int = c / y_scale[:, None]
    d_int = d * u_scale[None, :] / y_scale[:, None]
    off_int = (offset + c @ shift + d @ u_center - y_center) / y_scale
    base = (a, b_int, c_int, d_int, off_int)
    states = [free_run(base, u, y, ss.max_lag_)[1] for u, y in experiments]
    spread = np.vstack(states).std(axis=0)
    spread = np.where(spread > 0, spread, 1.0)
    t, t_inv = np.diag(1.0 / spread), np.diag(spread)
    return t @ a @ t_inv, t @ b_int, c_int @ t_inv, d_int, off_int


def free_run(
    linear: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    u: FloatArray,
    y: FloatArray,
    start: int,
) -> tuple[FloatArray, FloatArray]:
    """Outputs and states of the linear model from the state estimated on ``start`` samples."""
    a, b, c, d, offset = linear
    x = estimate_state(linear, y[:start], u[:start])
    states = np.empty((u.shape[0] - start, a.shape[0]))
    out = np.empty((u.shape[0] - start, c.shape[0]))
    for t in range(start, u.shape[0]):
        states[t - start] = x
        out[t - start] = c @ x + d @ u[t] + offset
        x = a @ x + b @ u[t]
    return out, states


class FreeRunProblem:
    """Weighted free-run errors of a PNLSS model over experiments, and their exact Jacobian.

    Parameters
    ----------
    layout : Layout
    experiments : sequence of (u, y, x0)
        Internal units; ``u`` and ``y`` from the first simulated sample on, ``x0`` the state
        there.
    box : tuple of arrays
        ``(center, scale, low, high)`` of ``z = ([x; u] − center) / scale``.
    limits : tuple of arrays
        ``(low, high)`` per output: a run that leaves them is stopped (the safeguard).
    """

    def __init__(
        self,
        layout: Layout,
        experiments: Sequence[tuple[FloatArray, FloatArray, FloatArray]],
        box: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
        limits: tuple[FloatArray, FloatArray],
    ) -> None:
        self.layout = layout
        self.experiments = list(experiments)
        self.box = box
        self.limits = limits
        self.free = np.flatnonzero(layout.free())
        self.n_rows = sum(u.shape[0] for u, _, _ in self.experiments)
        self.evaluations = 0
        self.diverged = 0

    def run(self, theta: FloatArray, jacobian: FloatArray | None = None) -> FloatArray:
        """Errors ``ŷ − y`` (rows × outputs, raveled); sensitivities into ``jacobian``."""
        a, b, c, d, offset, e, f = self.layout.unpack(theta)
        powers, parent, var, lower = self.layout.tables()
        errors, row, stopped = [], 0, False
        for u, y, x0 in self.experiments:
            ysim = np.empty_like(y)
            x = x0.copy()
            with np.errstate(all="ignore"):
                if jacobian is None:
                    where = pnlss_run(
                        a, b, c, d, offset, e, f, u, x, *self.box, parent, var, *self.limits, ysim
                    )
                else:
                    block = jacobian[row : row + u.shape[0]]
                    where = pnlss_sensitivity(
                        a, b, c, d, offset, e, f, u, x, *self.box, parent, var, powers, lower,
                        *self.limits, ysim, block,
                    )  # fmt: skip
            stopped = stopped or where >= 0
            errors.append(ysim - y)
            row += u.shape[0]
        if stopped:
            self.diverged += 1
        return np.concatenate(errors).ravel()

    def residuals(self, theta: FloatArray) -> FloatArray:
        """The free-run errors in the free parameters ``θ[free]`` (the others as in ``full``)."""
        errors = self.run(self.full(theta))
        self.evaluations += 1
        logger.info(
            "PNLSS fit: free run %d, RMS error %.4g (normalised outputs)",
            self.evaluations,
            float(np.sqrt(np.mean(errors**2))),
        )
        return errors

    def jacobian(self, theta: FloatArray) -> FloatArray:
        """``∂ residuals / ∂ θ[free]`` by the sensitivity recursion."""
        size = self._size
        jac = np.zeros((self.n_rows, self.layout.p, size))
        self.run(self.full(theta), jac)
        flat = jac.reshape(self.n_rows * self.layout.p, size)
        return flat if self.free.size == size else flat[:, self.free]

    @property
    def _size(self) -> int:
        """Entries of the whole ``θ``."""
        return int(sum(r * c for r, c in self.layout.shapes()))

    def full(self, theta: FloatArray) -> FloatArray:
        """``θ`` with the free entries from ``theta`` and the others 0."""
        full = np.zeros(self._size)
        full[self.free] = theta
        return full
