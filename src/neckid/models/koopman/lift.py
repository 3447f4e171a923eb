r"""The lifted linear system of the Koopman model: its state layout, least squares and free run.

The lifted state at time ``t`` is

.. math::

    z(t) = [\,p(t);\; \varphi(r(t));\; 1\,], \qquad
    p(t) = [y_o(t-1), …, y_o(t-L_o), \;u_i(t-1), …, u_i(t-K_i)]_{o, i},

``p`` the output and input delays up to each channel's largest lag (in standardised units),
``r`` the model's lag terms of lag ``>= 1`` (a subset of ``p``), ``φ`` the observables
(:mod:`neckid.models.koopman.dictionary`) and a constant. The model is linear in ``z``:

.. math::

    z(t+1) = A z(t) + B u(t), \qquad y(t) = C z(t) + D u(t),

``D`` non-zero only on the inputs of lag 0 (conditions included). The rows of ``A`` and ``B``
that move the delays are exact: a delay shifts, ``u(t)`` enters ``p(t+1)``, and the newest output
delay is the output equation ``C z(t) + D u(t)`` itself, so a free run's delays are its own past
outputs. The output equation (one ridge least squares of ``y(t)`` on ``[r(t), φ(t), 1, u_0(t)]``)
and the observables' rows (one ridge least squares of ``φ(t+1)`` on ``[z(t), u(t)]``, pairs
within an experiment) are fitted: extended DMD with control (Korda & Mezić 2018). The ridge
solves reuse one eigen-decomposition of each Gram matrix for every penalty.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from neckid.models.koopman.dictionary import Observables
from neckid.regressors import ResolvedLags
from neckid.utils.types import FloatArray, IntArray

__all__ = [
    "Gram",
    "Layout",
    "LiftedSystem",
    "clip_spectrum",
    "free_run",
    "free_run_reference",
    "gram",
    "solve",
]


@dataclass(frozen=True)
class Layout:
    """Where each delay sits in the lifted state, from the model's resolved lags.

    Attributes
    ----------
    source, channel, lag : ndarray of int, shape (n_delays,)
        Output (0) or input (1), the channel, the lag of each delay of ``p``.
    terms : ndarray of int, shape (n_terms,)
        Position in ``p`` of each lag term of lag ``>= 1`` (the regressor ``r``).
    direct : ndarray of int
        The inputs with a term of lag 0 (``D``'s columns).
    max_lag : int
        Samples a lift reads before ``t``.
    names : tuple of str
        The delays' names (``"incl(t-1)"``).
    """

    source: IntArray
    channel: IntArray
    lag: IntArray
    terms: IntArray
    direct: IntArray
    max_lag: int
    names: tuple[str, ...]

    @classmethod
    def of(cls, resolved: ResolvedLags) -> Layout:
        """The layout of ``resolved`` (every channel's delays from 1 to its largest lag)."""
        rows: list[tuple[int, int, int]] = []
        names: list[str] = []
        for source, channels in ((0, resolved.output_names), (1, resolved.input_names)):
            for c, name in enumerate(channels):
                mine = (resolved.source == source) & (resolved.channel == c)
                deepest = int(resolved.lag[mine].max()) if mine.any() else 0
                for k in range(1, deepest + 1):
                    rows.append((source, c, k))
                    names.append(f"{name}(t-{k})")
        if not rows:
            raise ValueError(
                f"the Koopman model needs at least one output or input lag >= 1 (its state);"
                f" got {resolved.to_lags()!r}"
            )
        position = {row: i for i, row in enumerate(rows)}
        terms = [
            position[(int(s), int(c), int(k))]
            for s, c, k in zip(resolved.source, resolved.channel, resolved.lag, strict=True)
            if k >= 1
        ]
        direct = sorted(
            {
                int(c)
                for s, c, k in zip(resolved.source, resolved.channel, resolved.lag, strict=True)
                if s and not k
            }
        )
        table = np.array(rows, dtype=np.int64)
        return cls(
            table[:, 0].copy(),
            table[:, 1].copy(),
            table[:, 2].copy(),
            np.array(terms, dtype=np.int64),
            np.array(direct, dtype=np.int64),
            int(resolved.max_lag),
            tuple(names),
        )

    @property
    def n_delays(self) -> int:
        """Entries of ``p``."""
        return int(self.lag.shape[0])

    def delays(self, y: FloatArray, u: FloatArray, start: int) -> FloatArray:
        """``p(t)`` for ``t = start … n − 1`` of standardised histories ``y``, ``u`` (rows: time)."""
        n = y.shape[0]
        out = np.empty((n - start, self.n_delays))
        for j in range(self.n_delays):
            signal = y if self.source[j] == 0 else u
            k = int(self.lag[j])
            out[:, j] = signal[start - k : n - k, self.channel[j]]
        return out


@dataclass(frozen=True)
class LiftedSystem:
    """``z⁺ = A z + B u``, ``y = C z + D u`` in the units of the logs (``z`` standardised).

    ``lift(y_rows, u_rows)`` gives ``z`` from the ``max_lag`` samples before a time.
    """

    A: FloatArray
    B: FloatArray
    C: FloatArray
    D: FloatArray

    @property
    def order(self) -> int:
        """Dimension of ``z``."""
        return int(self.A.shape[0])


def lift_rows(layout: Layout, observables: Observables, p: FloatArray) -> FloatArray:
    """``z`` of delay rows ``p``: ``[p, φ(r), 1]``."""
    return np.hstack([p, observables(p[:, layout.terms]), np.ones((p.shape[0], 1))])


@dataclass(frozen=True)
class Gram:
    """Sums of products of one training set: the normal equations of both least squares.

    ``x = [r, φ, 1, u_0]`` (the output equation's regressors) and ``w = [z(t), u(t)]`` (the
    observables' rows), over every sample of every experiment. Sums add: the Gram of two
    training sets is the sum of theirs (:meth:`plus`), which is what ``partial_fit`` uses.
    """

    xx: FloatArray
    xy: FloatArray
    ww: FloatArray
    wz: FloatArray  # wᵀ z(t+1)
    rows: FloatArray  # [rows of x, rows of w]

    def plus(self, other: Gram) -> Gram:
        """The Gram of both training sets."""
        return Gram(
            self.xx + other.xx,
            self.xy + other.xy,
            self.ww + other.ww,
            self.wz + other.wz,
            self.rows + other.rows,
        )


def gram(
    layout: Layout,
    observables: Observables,
    blocks: Sequence[tuple[FloatArray, FloatArray]],
    values: FloatArray | None = None,
) -> Gram:
    """The sums of products of ``blocks`` (per experiment, the standardised ``(y, u)``).

    ``values``, when given, are the observables of every block's delay rows, stacked in block
    order (what :func:`~.dictionary.fit_observables_with_values` returns for those rows).
    """
    m = layout.max_lag
    n_z = layout.n_delays + observables.size + 1
    n_in, n_out = blocks[0][1].shape[1], blocks[0][0].shape[1]
    n_x = layout.terms.size + observables.size + 1 + layout.direct.size
    xx, xy = np.zeros((n_x, n_x)), np.zeros((n_x, n_out))
    ww, wz = np.zeros((n_z + n_in, n_z + n_in)), np.zeros((n_z + n_in, n_z))
    rows = np.zeros(2)
    first = 0
    for y, u in blocks:
        p = layout.delays(y, u, m)
        if values is None:
            z = lift_rows(layout, observables, p)
        else:
            phi = values[first : first + p.shape[0]]
            z = np.hstack([p, phi, np.ones((p.shape[0], 1))])
        first += p.shape[0]
        x = np.hstack([z[:, layout.terms], z[:, layout.n_delays :], u[m:, layout.direct]])
        xx += x.T @ x
        xy += x.T @ y[m:]
        w = np.hstack([z[:-1], u[m:-1]])
        ww += w.T @ w
        wz += w.T @ z[1:]
        rows += (x.shape[0], w.shape[0])
    return Gram(xx, xy, ww, wz, rows)


def _ridge(matrix: FloatArray, target: FloatArray, penalty: float) -> FloatArray:
    """``(G + penalty I)⁻¹ b`` by the eigen-decomposition of ``G`` (negative rounding clipped)."""
    values, vectors = np.linalg.eigh(matrix)
    shrink = 1.0 / (np.maximum(values, 0.0) + penalty)
    return np.asarray(vectors @ (shrink[:, None] * (vectors.T @ target)))


def solve(
    layout: Layout,
    observables: Observables,
    normal: Gram,
    ridge: float,
    n_inputs: int,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``(A, B, C, D)`` in standardised units, for penalty ``ridge`` per training row.

    The penalty is ``ridge × rows`` on every coefficient (the regressors are standardised).
    """
    d, k = layout.n_delays, observables.size
    n_z = d + k + 1
    penalty_x = ridge * float(normal.rows[0]) + 1e-12
    readout = _ridge(normal.xx, normal.xy, penalty_x).T  # (n_outputs, n_x)
    n_out = readout.shape[0]
    c = np.zeros((n_out, n_z))
    c[:, layout.terms] = readout[:, : layout.terms.size]
    c[:, d:] = readout[:, layout.terms.size : layout.terms.size + k + 1]
    dd = np.zeros((n_out, n_inputs))
    dd[:, layout.direct] = readout[:, layout.terms.size + k + 1 :]
    a = np.zeros((n_z, n_z))
    b = np.zeros((n_z, n_inputs))
    for j in range(d):
        ch, lag = int(layout.channel[j]), int(layout.lag[j])
        if lag > 1:  # a shift: the delay one sample younger
            younger = np.flatnonzero(
                (layout.source == layout.source[j])
                & (layout.channel == ch)
                & (layout.lag == lag - 1)
            )
            a[j, int(younger[0])] = 1.0
        elif layout.source[j] == 0:  # the newest output delay: the output equation
            a[j], b[j] = c[ch], dd[ch]
        else:  # the newest input delay: u(t)
            b[j, ch] = 1.0
    if k and normal.rows[1] > 0:
        penalty_w = ridge * float(normal.rows[1]) + 1e-12
        step = _ridge(normal.ww, normal.wz[:, d : d + k], penalty_w).T  # (k, n_z + n_inputs)
        a[d : d + k] = step[:, :n_z]
        b[d : d + k] = step[:, n_z:]
    a[-1, -1] = 1.0
    return a, b, c, dd


def clip_spectrum(
    a: FloatArray, b: FloatArray, radius: float, normal: Gram
) -> tuple[FloatArray, FloatArray]:
    """``A`` with its eigenvalues pulled inside ``radius``, and ``B`` refitted for it.

    The eigenvalues of ``A`` without its constant state (the last) whose modulus exceeds
    ``radius`` are scaled onto the circle of that radius (their directions kept, conjugate
    pairs kept conjugate); ``B`` is then the least squares of ``z(t+1) − A z(t)`` on ``u(t)``
    over the training pairs, ``B = (Σ z⁺uᵀ − A Σ z uᵀ)(Σ u uᵀ)⁻¹`` from the Gram sums. The
    constant state keeps its eigenvalue 1.
    """
    core = a[:-1, :-1]
    values, vectors = np.linalg.eig(core)
    big = np.abs(values) > radius
    if not big.any():
        return a, b
    values = values * np.where(big, radius / np.maximum(np.abs(values), radius), 1.0)
    a = a.copy()
    a[:-1, :-1] = np.real(vectors @ np.diag(values) @ np.linalg.inv(vectors))
    n_z = a.shape[0]
    uu = normal.ww[n_z:, n_z:]
    zu_next = normal.wz[n_z:, :].T  # Σ z(t+1) u(t)ᵀ
    zu = normal.ww[:n_z, n_z:]  # Σ z(t) u(t)ᵀ
    rhs = zu_next - a @ zu
    refitted = np.linalg.lstsq(uu.T, rhs.T, rcond=None)[0].T
    return a, np.asarray(refitted, dtype=np.float64)


def free_run(system: LiftedSystem, z: FloatArray, u: FloatArray) -> FloatArray:
    """Outputs ``y(t)`` of inputs ``u`` (rows: time) from state ``z`` (updated in place).

    One sample at a time in a compiled loop (:func:`_free_run_kernel`), with the same products
    whatever the length of ``u``: a simulator stepping one input row gives the floats of a whole
    run. Each product sums its terms in one fixed order, so the floats do not depend on the CPU.
    """
    u = np.ascontiguousarray(u, dtype=np.float64)
    out = np.empty((u.shape[0], system.C.shape[0]))
    state = np.array(z, dtype=np.float64)
    _free_run_kernel(
        np.ascontiguousarray(system.A.T),
        np.ascontiguousarray(system.B.T),
        np.ascontiguousarray(system.C.T),
        np.ascontiguousarray(system.D.T),
        state,
        u,
        out,
    )
    z[:] = state
    return out


def free_run_reference(system: LiftedSystem, z: FloatArray, u: FloatArray) -> FloatArray:
    """:func:`free_run` in plain NumPy (matrix products by BLAS; the tests compare the two)."""
    a, b, c, d = system.A, system.B, system.C, system.D
    out = np.empty((u.shape[0], c.shape[0]))
    state = np.array(z, dtype=np.float64)
    with np.errstate(all="ignore"):
        for t in range(u.shape[0]):
            out[t] = c @ state + d @ u[t]
            state = a @ state + b @ u[t]
    z[:] = state
    return out


@njit(cache=True)
def _free_run_kernel(
    a_t: FloatArray,
    b_t: FloatArray,
    c_t: FloatArray,
    d_t: FloatArray,
    state: FloatArray,
    u: FloatArray,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled
    """``out[t] = C z + D u[t]``, ``z ← A z + B u[t]``; the matrices transposed (columns as rows).

    Every product adds one column at a time (``Σ_j A[:, j] z_j``): the rows are independent, so
    the loop over them vectorises while each sum keeps its order.
    """
    n_z, n_out, n_in = state.shape[0], c_t.shape[1], u.shape[1]
    following = np.empty(n_z)
    for t in range(u.shape[0]):
        for i in range(n_out):
            out[t, i] = 0.0
        for i in range(n_z):
            following[i] = 0.0
        for j in range(n_z):
            zj = state[j]
            for i in range(n_out):
                out[t, i] += c_t[j, i] * zj
            for i in range(n_z):
                following[i] += a_t[j, i] * zj
        for j in range(n_in):
            uj = u[t, j]
            for i in range(n_out):
                out[t, i] += d_t[j, i] * uj
            for i in range(n_z):
                following[i] += b_t[j, i] * uj
        for i in range(n_z):
            state[i] = following[i]
