r"""A re-implementation of the adaptive controller's online identifier and iso-damping tuner.

Approximate by nature: CONTROLLERS.md gives the structure, the initial estimates and the
averaging, not the least-squares details (forgetting factor, initial covariance, the
"random initialisation"), which are chosen here (:class:`OnlineIdentifier`'s defaults: no
forgetting and :math:`P_0 = I` came closest to the parameter logs among forgetting factors
0.95 … 1 and :math:`P_0` of 0.01 … 100 times the identity).
:func:`retune_log` runs both on a logged run (fed the logged command and raw inclination, as the
bench's identifier was) and :func:`compare_with_parameter_log` says how close the gains come to
the ``adacon*.csv`` parameter logs; docs/controllers.md reports it.

The identifier fits, on the command :math:`u` and the inclination :math:`y` through the
1 rad/s Tustin filter :math:`F(z) = b (z + 1)/(z - a)`, :math:`b = T/(2+T)`,
:math:`a = (2-T)/(2+T)`,

.. math:: y_f[k] = -a_1 y_f[k-1] - a_0 y_f[k-2] + b_0 u_f[k]

by recursive least squares with forgetting, and averages the estimates,
:math:`\bar\theta \leftarrow \tfrac{29}{30}\bar\theta + \tfrac{1}{30}\theta`. The tuner makes
:math:`G(z) = b_0/(z^2 + a_1 z + a_0)` meet a phase margin :math:`\varphi_m` (50 deg) at
:math:`\omega_c` (3 rad/s) with a flat phase there: it takes the phase to add
:math:`\varphi = -180° + \varphi_m - \arg G(\omega_c)`, the order :math:`\alpha` for which
:math:`C(s) = k(1 + \tau_a s^{\alpha})` cancels the phase slope of :math:`G` between
:math:`\omega_c` and :math:`\omega_c + 0.1`, then
:math:`\tau_x = (\sin(|\alpha|\pi/2) - \tan|\varphi| \cos(|\alpha|\pi/2))/\tan|\varphi|`,
:math:`\tau_a = 1/(\tau_x \omega_c^{\alpha})`,
:math:`k = 1/(|1 + \tau_a (j\omega_c)^{\alpha}|\,|G(j(\omega_c + 0.1))|)`,
:math:`k_p = k`, :math:`k_d = \tau_a k`. It retunes only when :math:`\arg G(\omega_c) < 0` and
:math:`|G(\omega_c)| > 0.1`.

References
----------
- ``shared/data/softneck/CONTROLLERS.md`` ("ada"), from github.com/munozyanez/fcontrol @ 5e47a79
  (``OnlineSystemIdentification``, ``FPDTuner``).
- C. A. Monje, B. M. Vinagre, V. Feliu and Y. Q. Chen, "Tuning and auto-tuning of fractional
  order controllers for industry applications", *Control Engineering Practice* 16 (7), 2008
  (the iso-damping condition).
- L. Ljung, *System Identification: Theory for the User*, 2nd ed., Prentice Hall, 1999,
  sec. 11.2 (recursive least squares with forgetting).
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

import numpy as np

from neckid.loops.controllers.adaptive import AdaptiveParameters
from neckid.loops.controllers.references import ADAPTIVE_WARMUP_ROWS, LAB_TS
from neckid.utils.types import BoolArray, FloatArray

__all__ = [
    "INITIAL_ESTIMATE",
    "IsoDampingTuning",
    "OnlineIdentifier",
    "TunerComparison",
    "compare_with_parameter_log",
    "iso_damping_tuning",
    "retune_log",
]

#: The identifier's initial (a1, a0, b0).
INITIAL_ESTIMATE = (-1.0246, 0.0248015, 0.133564)


class OnlineIdentifier:
    r"""Recursive least squares of the filtered second-order model, with averaged estimates.

    Parameters
    ----------
    forgetting : float, default 1.0
        Forgetting factor :math:`\lambda` of the least squares (1: none).
    covariance : float, default 1.0
        Initial covariance :math:`P_0 = c I`.
    window : int, default 30
        Averaging :math:`\bar\theta \leftarrow (1 - 1/n)\bar\theta + \theta/n`.
    ts : float, default 0.025
        Period, s (sets the 1 rad/s filter).
    theta0 : (float, float, float), default (-1.0246, 0.0248015, 0.133564)
        Initial :math:`(a_1, a_0, b_0)`.
    """

    def __init__(
        self,
        forgetting: float = 1.0,
        covariance: float = 1.0,
        window: int = 30,
        ts: float = LAB_TS,
        theta0: tuple[float, float, float] = INITIAL_ESTIMATE,
    ) -> None:
        self.forgetting = float(forgetting)
        self.covariance = float(covariance)
        self.window = int(window)
        self.ts = float(ts)
        self.theta0 = np.array(theta0, dtype=np.float64)
        self._b = self.ts / (2.0 + self.ts)
        self._a = (2.0 - self.ts) / (2.0 + self.ts)
        self.reset()

    def reset(self) -> None:
        """Back to the initial estimate, covariance and zero filters."""
        self.theta = self.theta0.copy()
        self.average = self.theta0.copy()
        self.p = self.covariance * np.eye(3)
        self._u = self._y = 0.0  # last raw inputs of the filters
        self._uf = 0.0
        self._yf = [0.0, 0.0]  # yf[k-1], yf[k-2]

    def update(self, command: float, inclination: float) -> FloatArray:
        """Filter one sample, update the estimate; return the averaged :math:`(a_1, a_0, b_0)`."""
        uf = self._b * (command + self._u) + self._a * self._uf
        yf = self._b * (inclination + self._y) + self._a * self._yf[0]
        phi = np.array([-self._yf[0], -self._yf[1], uf])
        gain = self.p @ phi / (self.forgetting + phi @ self.p @ phi)
        self.theta = self.theta + gain * (yf - phi @ self.theta)
        self.p = (self.p - np.outer(gain, phi @ self.p)) / self.forgetting
        self.average = (1.0 - 1.0 / self.window) * self.average + self.theta / self.window
        self._u, self._y, self._uf = command, inclination, uf
        self._yf = [yf, self._yf[0]]
        return self.average.copy()


@dataclass(frozen=True)
class IsoDampingTuning:
    r"""One tuning: the gains and what they came from.

    Attributes
    ----------
    kp, kd : float
        The controller's gains (``kd`` on the lab's step-1 Grünwald–Letnikov sum).
    alpha : float
        The fractional order (the lab's ``fex``).
    phase : float
        :math:`\arg G(j\omega_c)`, rad.
    magnitude : float
        :math:`|G(j\omega_c)|`.
    """

    kp: float
    kd: float
    alpha: float
    phase: float
    magnitude: float


def _frequency_response(theta: FloatArray, w: float, ts: float) -> complex:
    a1, a0, b0 = (float(v) for v in theta)
    z = cmath.exp(1j * w * ts)
    return b0 / (z * z + a1 * z + a0)


def _phase_slope_of_controller(alpha: float, phase: float, w: float) -> float:
    """The slope d arg C / dω at ω for C = 1 + τ s^α (α < 0) whose phase at ω is −|phase|."""
    beta = abs(alpha) * math.pi / 2.0
    t = math.tan(abs(phase))
    denominator = math.sin(beta) - t * math.cos(beta)
    if denominator <= 0.0:
        return math.nan  # this order cannot give that much phase
    x = t / denominator
    return math.sin(beta) / (1.0 + 2.0 * x * math.cos(beta) + x * x) * abs(alpha) * x / w


def _iso_damping_order(phase: float, slope: float, w: float) -> float:
    """The order α in (−1, 0) whose controller phase slope cancels ``slope`` (closest on a grid)."""
    orders = -np.linspace(0.01, 0.99, 981)
    mismatch = np.array([_phase_slope_of_controller(a, phase, w) + slope for a in orders])
    valid = np.isfinite(mismatch)
    if not valid.any():
        return math.nan
    sign_change = np.flatnonzero(valid[:-1] & valid[1:] & (np.diff(np.sign(mismatch)) != 0))
    if sign_change.size:
        i = int(sign_change[0])
        lo, hi = orders[i], orders[i + 1]
        return float(lo - mismatch[i] * (hi - lo) / (mismatch[i + 1] - mismatch[i]))
    return float(orders[valid][np.argmin(np.abs(mismatch[valid]))])


def iso_damping_tuning(
    theta: FloatArray,
    phase_margin: float = 50.0,
    crossover: float = 3.0,
    ts: float = LAB_TS,
) -> IsoDampingTuning | None:
    r"""The lab's iso-damping tuning of ``k (1 + τa s^α)`` for ``G(z) = b0/(z² + a1 z + a0)``.

    Parameters
    ----------
    theta : array_like, shape (3,)
        :math:`(a_1, a_0, b_0)`.
    phase_margin : float, default 50
        Degrees.
    crossover : float, default 3
        rad/s.
    ts : float, default 0.025
        Period, s.

    Returns
    -------
    IsoDampingTuning or None
        None when the lab would not retune (:math:`\arg G \ge 0` or :math:`|G| \le 0.1`) or
        no order gives the phase.
    """
    g = _frequency_response(theta, crossover, ts)
    g_next = _frequency_response(theta, crossover + 0.1, ts)
    phase, magnitude = cmath.phase(g), abs(g)
    if not (phase < 0.0 and magnitude > 0.1):
        return None
    slope = (cmath.phase(g_next) - phase) / 0.1
    needed = math.radians(-180.0 + phase_margin) - phase
    alpha = _iso_damping_order(needed, slope, crossover)
    if not math.isfinite(alpha):
        return None
    beta = abs(alpha) * math.pi / 2.0
    t = math.tan(abs(needed))
    tau_x = (math.sin(beta) - t * math.cos(beta)) / t
    tau_a = 1.0 / (tau_x * crossover**alpha)
    k = 1.0 / (abs(1.0 + tau_a * (1j * crossover) ** alpha) * abs(g_next))
    return IsoDampingTuning(k, tau_a * k, alpha, phase, magnitude)


@dataclass(frozen=True)
class TunerComparison:
    """The re-implemented tuner's gains beside a parameter log's.

    Attributes
    ----------
    kp, kd, fex : ndarray, shape (n,)
        The re-implementation's gains after each row (held between retunings).
    logged : AdaptiveParameters
        The parameter log.
    rows : ndarray of bool, shape (n,)
        The rows compared (the stair rows).
    """

    kp: FloatArray
    kd: FloatArray
    fex: FloatArray
    logged: AdaptiveParameters
    rows: BoolArray

    def median_relative_error(self, name: str) -> float:
        """Median of ``|re-implemented − logged| / |logged|`` over the compared rows."""
        mine = getattr(self, name)[self.rows]
        theirs = getattr(self.logged, name)[self.rows]
        return float(np.median(np.abs(mine - theirs) / np.abs(theirs)))


def retune_log(
    command: FloatArray,
    inclination: FloatArray,
    failed: BoolArray | None = None,
    identifier: OnlineIdentifier | None = None,
    start: tuple[float, float, float] = (0.23, 0.36, -0.6),
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Run the identifier and tuner over a logged run; the gains after each row.

    Parameters
    ----------
    command, inclination : ndarray, shape (n,)
        The logged velocity command [rad/s] and raw inclination [deg].
    failed : ndarray of bool, optional
        Failed reads (nothing is updated there).
    identifier : OnlineIdentifier, optional
        Default :class:`OnlineIdentifier` with its defaults.
    start : (float, float, float)
        The gains before the first retuning (the parameter logs' first row).

    Returns
    -------
    kp, kd, fex : ndarray, shape (n,)
    """
    model = identifier or OnlineIdentifier()
    model.reset()
    n = command.shape[0]
    out = np.empty((n, 3))
    current = list(start)
    skip = np.zeros(n, dtype=bool) if failed is None else np.asarray(failed, dtype=bool)
    for k in range(n):
        if not skip[k]:
            tuning = iso_damping_tuning(model.update(float(command[k]), float(inclination[k])))
            if tuning is not None:
                current[0], current[1] = tuning.kp, tuning.kd
                if abs(tuning.alpha - current[2]) > 0.05:
                    current[2] = tuning.alpha
        out[k] = current
    return out[:, 0], out[:, 1], out[:, 2]


def compare_with_parameter_log(
    command: FloatArray,
    inclination: FloatArray,
    logged: AdaptiveParameters,
    failed: BoolArray | None = None,
    identifier: OnlineIdentifier | None = None,
) -> TunerComparison:
    """:func:`retune_log` on an ``ada`` log beside its ``adacon*.csv``, over the stair rows.

    Parameters
    ----------
    command, inclination : ndarray, shape (n,)
        The ``ada`` log's velocity command [rad/s] and raw inclination [deg].
    logged : AdaptiveParameters
        Its parameter log.
    failed : ndarray of bool, optional
        Failed reads.
    identifier : OnlineIdentifier, optional
        The identifier's settings.

    Returns
    -------
    TunerComparison
    """
    kp, kd, fex = retune_log(command, inclination, failed, identifier)
    rows = np.zeros(kp.shape[0], dtype=bool)
    rows[ADAPTIVE_WARMUP_ROWS:] = True
    return TunerComparison(kp, kd, fex, logged, rows)
