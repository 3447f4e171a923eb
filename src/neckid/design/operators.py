r"""Discrete realisations of the controllers' dynamic operator: an integrator or :math:`s^\alpha`.

A designed controller is :math:`c_k = k_p e_k + k_f v_k` with :math:`v = D(z)\,e`, where
:math:`D` is one of:

- ``"tustin"``: the integrator :math:`1/s` by the trapezoidal rule,
  :math:`D(z) = \tfrac{T}{2}\,\tfrac{z + 1}{z - 1}` (the lab's PI; :math:`k_f` is then
  :math:`k_i`);
- ``"gl"``: the lab's Grünwald–Letnikov realisation of :math:`s^\alpha`: the backward-Euler
  integral :math:`x_k = x_{k-1} + T e_k` through the short-memory sum of order
  :math:`a = 1 + \alpha`,

  .. math:: v_k = T^{-a} \sum_{i=0}^{N-1} w_i\, x_{k-i}, \qquad
            w_i = (-1)^i \binom{a}{i},

  truncated after the first :math:`|w_i| <` ``threshold`` (0.01, that tap included), as
  CONTROLLERS.md describes the lab's ``fra`` controller. The factor :math:`T^{-a}` makes
  :math:`k_f` the gain of :math:`s^\alpha` (the lab's sum has step 1, so the lab's gain
  :math:`k_d` realises :math:`k_d T^{a} s^\alpha`: :math:`k_d = k_f T^{-a}`). The FIR sum on
  the integral is an exact state-space system (a shift register of the last :math:`N - 1`
  integrals), so it converts to python-control without approximation;
- ``"oustaloup"``: Oustaloup's recursive approximation of :math:`s^\alpha` over a band
  :math:`[\omega_b, \omega_h]` by :math:`2n + 1` first-order sections,

  .. math:: s^\alpha \approx \omega_h^{\alpha} \prod_{k=-n}^{n}
            \frac{s + \omega'_k}{s + \omega_k}, \quad
            \omega'_k = \omega_b\,\nu^{(k + n + (1 - \alpha)/2)/(2n + 1)},\quad
            \omega_k = \omega_b\,\nu^{(k + n + (1 + \alpha)/2)/(2n + 1)},\quad
            \nu = \omega_h/\omega_b,

  each section discretised by Tustin's rule prewarped at the design crossover and realised as
  a cascade of first-order sections (robust where one high-order polynomial is not).

Why Oustaloup beside the lab's sum: the lab's truncation keeps 12 taps (0.3 s at
:math:`T = 0.025` s), so its sum is a fractional operator only above a few rad/s and an
integer integrator below (its taps do not sum to zero); Oustaloup's filter has the fractional
phase :math:`\alpha\pi/2` over the whole band, which is what the iso-damping design assumes.

References
----------
- A. Oustaloup, F. Levron, B. Mathieu, F. M. Nanot, "Frequency-band complex noninteger
  differentiator: characterization and synthesis", *IEEE Trans. Circuits and Systems I* 47 (1),
  2000 (and A. Oustaloup, *La commande CRONE*, Hermès, 1991).
- C. A. Monje, Y. Q. Chen, B. M. Vinagre, D. Xue, V. Feliu, *Fractional-order Systems and
  Controls*, Springer, 2010, ch. 12 (discretisation of fractional operators).
- I. Podlubny, *Fractional Differential Equations*, Academic Press, 1999, sec. 7.3 (the
  short-memory principle).
- ``shared/data/softneck/CONTROLLERS.md`` ("fra": the lab's sum, its truncation and its step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from neckid.loops.controllers.lab import GL_THRESHOLD, grunwald_letnikov_weights
from neckid.utils.checks import check_number, check_ts
from neckid.utils.types import FloatArray

__all__ = [
    "DISCRETISATIONS",
    "GL_THRESHOLD",
    "DiscreteOperator",
    "gl_taps",
    "grunwald_letnikov_operator",
    "oustaloup_operator",
    "tustin_integrator",
]

#: The discretisations of :math:`s^\alpha` a fractional controller may use.
DISCRETISATIONS = ("gl", "oustaloup")

Method = Literal["tustin", "gl", "oustaloup"]


@dataclass(frozen=True)
class DiscreteOperator:
    r"""A discrete SISO operator :math:`v = D(z)\,e` as a state-space system.

    :math:`s_{k+1} = A s_k + B e_k`, :math:`v_k = C s_k + D e_k` (``a``, ``b``, ``c``, ``d``).

    Attributes
    ----------
    a : ndarray, shape (n, n)
    b, c : ndarray, shape (n,)
    d : float
    ts : float
        Period, s.
    order : float
        The order it realises: −1 for the integrator, :math:`\alpha` for :math:`s^\alpha`.
    method : {"tustin", "gl", "oustaloup"}
    parameters : dict
        What rebuilds it (``threshold`` and ``taps`` for ``"gl"``; ``band``, ``sections`` and
        ``prewarp`` for ``"oustaloup"``), JSON-ready.
    """

    a: FloatArray
    b: FloatArray
    c: FloatArray
    d: float
    ts: float
    order: float
    method: Method
    parameters: dict[str, Any] = field(default_factory=dict)

    @property
    def n_states(self) -> int:
        """Number of states."""
        return int(self.a.shape[0])

    def response(self, omega: ArrayLike) -> np.ndarray:
        r"""Frequency response :math:`D(e^{j\omega T})`.

        Parameters
        ----------
        omega : array_like
            Frequencies, rad/s.

        Returns
        -------
        ndarray of complex, the shape of ``omega``
        """
        w = np.asarray(omega, dtype=np.float64)
        z = np.exp(1j * w.reshape(-1) * self.ts)
        n = self.n_states
        matrices = z[:, None, None] * np.eye(n)[None] - self.a[None]
        rhs = np.broadcast_to(self.b.astype(complex)[None, :, None], (z.shape[0], n, 1))
        x = np.linalg.solve(matrices, rhs)[:, :, 0]
        return np.asarray(x @ self.c + self.d).reshape(w.shape)

    def step(self, state: FloatArray, error: float) -> tuple[float, FloatArray]:
        """One period: ``(v_k, s_{k+1})`` from ``s_k`` and ``e_k``."""
        return float(self.c @ state + self.d * error), self.a @ state + self.b * error

    def to_control(self) -> Any:
        """The operator as a discrete ``control.StateSpace`` (input ``error``, output ``v``)."""
        import control

        return control.ss(
            self.a,
            self.b[:, None],
            self.c[None, :],
            [[self.d]],
            dt=self.ts,
            inputs=["error"],
            outputs=["v"],
        )


def tustin_integrator(ts: float) -> DiscreteOperator:
    r"""The trapezoidal integrator :math:`I_k = I_{k-1} + \tfrac{T}{2}(e_k + e_{k-1})` (the lab's PI).

    State :math:`[I_{k-1}, e_{k-1}]`, output :math:`I_k`.

    Parameters
    ----------
    ts : float
        Period, s.

    Returns
    -------
    DiscreteOperator

    Examples
    --------
    >>> op = tustin_integrator(0.5)
    >>> state = np.zeros(2)
    >>> for _ in range(3):
    ...     v, state = op.step(state, 1.0)
    >>> v
    1.25
    """
    t = check_ts(ts)
    return DiscreteOperator(
        a=np.array([[1.0, 0.5 * t], [0.0, 0.0]]),
        b=np.array([0.5 * t, 1.0]),
        c=np.array([1.0, 0.5 * t]),
        d=0.5 * t,
        ts=t,
        order=-1.0,
        method="tustin",
    )


def gl_taps(order: float, threshold: float = GL_THRESHOLD) -> FloatArray:
    r"""Grünwald–Letnikov taps :math:`w_i = (-1)^i\binom{a}{i}`, truncated as the lab does.

    :math:`w_0 = 1`, :math:`w_i = w_{i-1}(i - 1 - a)/i`; the list ends with the first tap of
    magnitude below ``threshold`` (kept). The lab's rule itself: this is
    :func:`neckid.loops.controllers.lab.grunwald_letnikov_weights` (one implementation, in the
    lower layer), under the name the design's operators use.

    Parameters
    ----------
    order : float
        :math:`a` (for :math:`s^\alpha` on the integral, :math:`a = 1 + \alpha`).
    threshold : float, default 0.01
        Truncation threshold, > 0.

    Returns
    -------
    ndarray, shape (N,), N >= 2

    Raises
    ------
    ValueError
        If the taps do not fall below ``threshold`` within 100000 taps.

    Examples
    --------
    >>> gl_taps(0.45).shape, gl_taps(0.45)[:2].tolist()
    ((12,), [1.0, -0.45])
    """
    return grunwald_letnikov_weights(order, threshold)


def _check_order(order: float) -> float:
    alpha = check_number(order, "order")
    if not (-1.0 < alpha < 1.0) or alpha == 0.0:
        raise ValueError(
            f"order must be in (-1, 0) (a fractional integral) or (0, 1) (a fractional"
            f" derivative); got {alpha}"
        )
    return alpha


def grunwald_letnikov_operator(
    order: float, ts: float, threshold: float = GL_THRESHOLD
) -> DiscreteOperator:
    r""":math:`s^\alpha` realised as the lab does: a truncated GL sum of order :math:`1 + \alpha` on the integral.

    Parameters
    ----------
    order : float
        :math:`\alpha`, in (−1, 0) or (0, 1) (the lab's ``fex``).
    ts : float
        Period :math:`T`, s.
    threshold : float, default 0.01
        The taps' truncation (the lab's).

    Returns
    -------
    DiscreteOperator
        State :math:`[x_{k-1}, \dots, x_{k-N+1}]` (the integrals of the error), as the lab's
        controller keeps it.

    Notes
    -----
    With :math:`s_k = [x_{k-1}, …, x_{k-N+1}]`: :math:`x_k = s_k[0] + T e_k`,
    :math:`v_k = T^{-a}(w_0 x_k + \sum_{i \ge 1} w_i s_k[i-1])`, and the register shifts.

    Examples
    --------
    >>> op = grunwald_letnikov_operator(-0.55, 0.025)
    >>> op.n_states, op.parameters["taps"][:2]
    (11, [1.0, -0.45])
    """
    alpha = _check_order(order)
    t = check_ts(ts)
    a = 1.0 + alpha
    taps = gl_taps(a, threshold)
    n = taps.shape[0] - 1
    scale = t ** (-a)
    shift = np.eye(n, k=-1)
    shift[0, 0] = 1.0
    b = np.zeros(n)
    b[0] = t
    c = scale * np.concatenate([[taps[0] + taps[1]], taps[2:]])
    return DiscreteOperator(
        a=shift,
        b=b,
        c=c,
        d=scale * taps[0] * t,
        ts=t,
        order=alpha,
        method="gl",
        parameters={"threshold": float(threshold), "taps": taps.tolist()},
    )


def default_band(crossover: float, ts: float) -> tuple[float, float]:
    r"""Oustaloup's band by default: :math:`[\omega_c/100,\ \min(100\,\omega_c, \pi/(2T))]`.

    Parameters
    ----------
    crossover : float
        :math:`\omega_c`, rad/s.
    ts : float
        Period, s.

    Returns
    -------
    (float, float)
        rad/s.
    """
    return crossover / 100.0, min(100.0 * crossover, 0.5 * math.pi / ts)


def oustaloup_operator(
    order: float,
    ts: float,
    band: tuple[float, float],
    sections: int = 5,
    prewarp: float | None = None,
) -> DiscreteOperator:
    r""":math:`s^\alpha` by Oustaloup's recursive filter, discretised section by section (Tustin).

    Parameters
    ----------
    order : float
        :math:`\alpha`, in (−1, 0) or (0, 1).
    ts : float
        Period, s.
    band : (float, float)
        :math:`(\omega_b, \omega_h)`, rad/s, :math:`0 < \omega_b < \omega_h`.
    sections : int, default 5
        :math:`n`: the filter has :math:`2n + 1` first-order sections.
    prewarp : float, optional
        Frequency [rad/s] where Tustin's map is exact (default the band's geometric centre).

    Returns
    -------
    DiscreteOperator
        A cascade of first-order sections, :math:`2n + 1` states.

    Examples
    --------
    >>> op = oustaloup_operator(-0.5, 0.02, band=(0.03, 78.0), prewarp=3.0)
    >>> bool(abs(np.degrees(np.angle(op.response(3.0))) + 45.0) < 2.0)   # -alpha * 90 deg
    True
    """
    alpha = _check_order(order)
    t = check_ts(ts)
    low = check_number(band[0], "band[0]", low=0, closed="neither")
    high = check_number(band[1], "band[1]", low=low, closed="neither")
    n = check_number(sections, "sections", low=1, integer=True)
    centre = math.sqrt(low * high) if prewarp is None else float(prewarp)
    centre = check_number(centre, "prewarp", low=0, high=math.pi / t, closed="neither")
    warp = centre / math.tan(0.5 * centre * t)
    ratio = high / low
    m = 2 * n + 1
    ks = np.arange(-n, n + 1)
    zeros = low * ratio ** ((ks + n + 0.5 * (1.0 - alpha)) / m)
    poles = low * ratio ** ((ks + n + 0.5 * (1.0 + alpha)) / m)
    # (s + q)/(s + p) with s = warp (z - 1)/(z + 1):  g (z - zz)/(z - pz)
    gains = (warp + zeros) / (warp + poles)
    zz = (warp - zeros) / (warp + zeros)
    pz = (warp - poles) / (warp + poles)
    a = np.zeros((m, m))
    b = np.zeros(m)
    c = np.zeros(m)
    d = high**alpha
    # Cascade: section j's input is the output so far, c s + d e (the gain times the error
    # before the first section); a section is s_{k+1} = p s_k + in_k, out_k = g ((p - zz) s_k + in_k).
    for j in range(m):
        a[j, :j] = c[:j]
        a[j, j] = pz[j]
        b[j] = d
        c = gains[j] * c
        c[j] = gains[j] * (pz[j] - zz[j])
        d = gains[j] * d
    return DiscreteOperator(
        a=a,
        b=b,
        c=c,
        d=float(d),
        ts=t,
        order=alpha,
        method="oustaloup",
        parameters={"band": [low, high], "sections": n, "prewarp": centre},
    )
