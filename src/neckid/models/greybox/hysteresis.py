r"""The operators of the grey-box neck: play (backlash), Prandtl–Ishlinskii, stable linear dynamics.

The **play operator** of radius :math:`r \ge 0` (Krasnosel'skii & Pokrovskii 1989; Brokate &
Sprekels 1996, ch. 2) maps an input sequence :math:`x` to

.. math::

    z(t) = \max\bigl(x(t) - r,\ \min(x(t) + r,\ z(t-1))\bigr), \qquad z(-1) = x(0),

a backlash of width :math:`2r`: the output follows the input once the input has crossed the gap,
and holds while the input reverses inside it. Plays compose as a semigroup,
:math:`P_{r_2}[P_{r_1}[x]] = P_{r_1 + r_2}[x]` from the relaxed start :math:`z(-1) = x(0)`,
so a tendon slack of width :math:`s` in series with a **Prandtl–Ishlinskii operator**
:math:`H[x] = \sum_k w_k P_{r_k}[x]` is itself a Prandtl–Ishlinskii operator of radii
:math:`s/2 + r_k`: :func:`play` computes them all in one pass.

The **linear dynamics** are an all-pole filter of order ``n`` with unit static gain and a delay
``d``, :math:`y(t) = -\sum_{i=1}^n a_i\,y(t-i) + g\,v(t-d)` with :math:`g = 1 + \sum_i a_i`,
parametrised by reflection coefficients :math:`k_i \in (-1, 1)` (the Levinson step-up
recursion), which is stable for every value in the box, every pole within a radius
:math:`\rho \le 1` when the coefficients are scaled by :math:`\rho^i`: :func:`denominator`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.signal import lfilter, lfiltic

from neckid.utils.checks import check_finite
from neckid.utils.types import FloatArray

__all__ = [
    "denominator",
    "dynamics_run",
    "play",
    "play_step",
    "reflection",
]


def play(x: ArrayLike, radii: ArrayLike, initial: ArrayLike | None = None) -> FloatArray:
    """Play (backlash) operators of several radii on one input sequence.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        The input, e.g. the motor displacement [rad].
    radii : array_like, shape (n_radii,)
        Half-widths of the plays, in the input's units; each ``>= 0`` (0 is the identity).
    initial : array_like, shape (n_radii,), optional
        The plays' outputs before the first sample, ``z(-1)``; default ``x(0)`` (relaxed).

    Returns
    -------
    ndarray, shape (n_samples, n_radii)
        ``z(t) = max(x(t) - r, min(x(t) + r, z(t-1)))`` per radius.

    Raises
    ------
    ValueError
        For a negative or non-finite radius, or a non-finite input.

    Examples
    --------
    >>> import numpy as np
    >>> play([0.0, 1.0, 2.0, 1.5, 0.0], [0.0, 0.5]).T
    array([[0. , 1. , 2. , 1.5, 0. ],
           [0. , 0.5, 1.5, 1.5, 0.5]])
    """
    values = np.ascontiguousarray(x, dtype=np.float64).reshape(-1)
    widths = np.ascontiguousarray(radii, dtype=np.float64).reshape(-1)
    check_finite(values[:, None], "x")
    if not np.all(np.isfinite(widths) & (widths >= 0)):
        raise ValueError(f"radii must be finite and >= 0; got {widths.tolist()}")
    if values.size == 0:
        return np.zeros((0, widths.size))
    start = (
        np.full(widths.size, values[0])
        if initial is None
        else np.array(initial, dtype=np.float64).reshape(widths.size)
    )
    return _play_kernel(values, widths, start)


def _play_kernel(x: FloatArray, radii: FloatArray, start: FloatArray) -> FloatArray:
    """The loop of :func:`play` (no checks)."""
    out = np.empty((x.size, radii.size))
    z = start.copy()
    for t in range(x.size):
        z = np.minimum(np.maximum(z, x[t] - radii), x[t] + radii)
        out[t] = z
    return out


def play_step(state: FloatArray, x: float, radii: FloatArray) -> FloatArray:
    """One sample of :func:`play`: the new outputs from the previous ones ``state``."""
    return np.minimum(np.maximum(state, x - radii), x + radii)


def denominator(coefficients: ArrayLike, radius: float = 1.0) -> FloatArray:
    r"""``[1, a_1, …, a_n]`` from reflection coefficients ``k_1 … k_n`` (Levinson step-up).

    :math:`a^{(i)}(z) = a^{(i-1)}(z) + k_i\,z^{-i} a^{(i-1)}(1/z)`; every root lies inside the
    unit circle when every :math:`|k_i| < 1`. With ``radius`` :math:`\rho \in (0, 1]` the
    coefficients become :math:`a_i \rho^i`, the roots :math:`\rho` times those: every pole lies
    within :math:`|z| < \rho`.

    Examples
    --------
    >>> denominator([-0.9])
    array([ 1. , -0.9])
    >>> bool(np.all(np.abs(np.roots(denominator([-0.99, 0.95]))) < 1))
    True
    >>> bool(np.all(np.abs(np.roots(denominator([-0.99, 0.95], radius=0.9))) < 0.9))
    True
    """
    a = np.ones(1)
    for k in np.asarray(coefficients, dtype=np.float64).reshape(-1):
        padded = np.append(a, 0.0)
        a = padded + k * padded[::-1]
    return np.asarray(a * float(radius) ** np.arange(a.size), dtype=np.float64)


def reflection(polynomial: ArrayLike, bound: float = 0.9995) -> FloatArray:
    """Reflection coefficients of ``[1, a_1, …, a_n]`` (step-down), each clipped to ``±bound``.

    An unstable polynomial has a coefficient of magnitude ``>= 1``: clipped, it becomes the
    nearest stable one of this parametrisation (used as a starting point only).
    """
    a = np.asarray(polynomial, dtype=np.float64).reshape(-1)
    a = a / a[0]
    ks = []
    for m in range(a.size - 1, 0, -1):
        k = float(np.clip(a[m], -bound, bound))
        ks.append(k)
        a = (a[:m] - k * a[m:0:-1]) / (1.0 - k * k)
    return np.asarray(ks[::-1], dtype=np.float64)


def dynamics_run(
    polynomial: FloatArray, v: FloatArray, y: FloatArray, start: int, delay: int
) -> FloatArray:
    r"""Free run of :math:`y(t) = -\sum_i a_i y(t-i) + g\,v(t-d)` from sample ``start`` on.

    Parameters
    ----------
    polynomial : ndarray, shape (n + 1,)
        ``[1, a_1, …, a_n]``; the gain is ``g = sum(polynomial)`` (unit static gain).
    v : ndarray, shape (n_samples, k)
        The filter's input, column by column.
    y : ndarray, shape (start, k)
        The outputs before ``start`` (``start >= n`` and ``start >= delay``); the last ``n``
        are the initial conditions.
    start, delay : int

    Returns
    -------
    ndarray, shape (n_samples - start, k)
        ``y(start) … y(n_samples - 1)``.
    """
    n = polynomial.size - 1
    gain = float(np.sum(polynomial))
    drive = gain * v[start - delay : v.shape[0] - delay]
    if n == 0:
        return np.asarray(drive, dtype=np.float64)
    zi = np.column_stack(
        [lfiltic([1.0], polynomial, y[start - n : start, j][::-1]) for j in range(y.shape[1])]
    )
    out, _ = lfilter([1.0], polynomial, drive, axis=0, zi=zi)
    return np.asarray(out, dtype=np.float64)
