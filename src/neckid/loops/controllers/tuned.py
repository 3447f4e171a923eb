r"""The adaptive fractional controller re-implemented: it retunes itself on the loop it runs in.

:class:`~.adaptive.AdaptiveFractionalReplay` replays an ``ada`` run's logged gains, so it does not
react to a simulated plant. :class:`AdaptiveFractionalTuner` does: every row it feeds its command
and the inclination to the re-implemented online identifier (:class:`~.tuner.OnlineIdentifier`)
and retunes :math:`k_p`, :math:`k_d` (and the order, when it moves by more than 0.05) with the
iso-damping tuner (:func:`~.tuner.iso_damping_tuning`), as :func:`~.tuner.retune_log` does on a
log. The run's structure is the lab's: 801 rows of the fixed warm-up controller, then a new
fractional controller (zero state) with the tuner's current gains, whose gains every later row
may replace, :math:`c_k = k_p[k-1] e_k + k_d[k-1] v_k`.

Approximate by nature (docs/controllers.md: the re-implemented gains move less than the logged
ones, kd 12–31 % low), so an in-loop run with it says how a model behaves under an adaptive
controller of that kind, not under the logged one; pass the parameter log for that.

References
----------
- ``shared/data/softneck/CONTROLLERS.md`` ("ada: adaptive fractional controller").
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from neckid.loops.controllers.adaptive import ADAPTIVE_WARMUP_GAINS, FEX_CHANGE
from neckid.loops.controllers.lab import fractional_period, grunwald_letnikov_weights
from neckid.loops.controllers.references import ADAPTIVE_WARMUP_ROWS, LAB_TS
from neckid.loops.controllers.tuner import OnlineIdentifier, iso_damping_tuning
from neckid.utils.types import FloatArray

__all__ = ["TUNER_START_GAINS", "AdaptiveFractionalTuner"]

#: The tuner's gains before its first retuning (the parameter logs' first rows): (kp, kd, fex).
TUNER_START_GAINS = (0.23, 0.36, -0.6)

#: Length of the integral's history kept (more than any order's taps in (−1, 0)).
_HISTORY = 256


class AdaptiveFractionalTuner:
    """The adaptive fractional controller, retuned online by the re-implemented identifier and tuner.

    Parameters
    ----------
    warmup_rows : int, default 801
        Rows of the fixed warm-up controller (0: start with the tuned one).
    warmup : (float, float, float), default (0.2547, 0.7730, -0.6)
        Its :math:`(k_p, k_d, f_{ex})`.
    start : (float, float, float), default (0.23, 0.36, -0.6)
        The tuner's gains before its first retuning.
    phase_margin : float, default 50
        Degrees.
    crossover : float, default 3
        rad/s.
    forgetting, covariance : float, default 1.0
        The identifier's settings (:class:`~.tuner.OnlineIdentifier`).
    ts : float, default 0.025
        Period, s.

    Attributes
    ----------
    gains : list of (float, float, float)
        After :meth:`step`: :math:`(k_p, k_d, f_{ex})` after each row's retuning.

    Examples
    --------
    >>> ctrl = AdaptiveFractionalTuner(warmup_rows=2)
    >>> ctrl.reset()
    >>> [round(float(ctrl.step(10.0, 0.0)[0]), 4) for _ in range(2)]   # the warm-up controller
    [2.7402, 2.8562]
    """

    n_references = 1
    n_motors = 1

    def __init__(
        self,
        warmup_rows: int = ADAPTIVE_WARMUP_ROWS,
        warmup: tuple[float, float, float] = ADAPTIVE_WARMUP_GAINS,
        start: tuple[float, float, float] = TUNER_START_GAINS,
        phase_margin: float = 50.0,
        crossover: float = 3.0,
        forgetting: float = 1.0,
        covariance: float = 1.0,
        ts: float = LAB_TS,
    ) -> None:
        self.warmup_rows = warmup_rows
        self.warmup = warmup
        self.start = start
        self.phase_margin = phase_margin
        self.crossover = crossover
        self.forgetting = forgetting
        self.covariance = covariance
        self.ts = ts

    def reset(self) -> None:
        """Back to the start: zero integral, the identifier's initial estimate, no command yet."""
        if int(self.warmup_rows) < 0:
            raise ValueError(f"warmup_rows must be >= 0; got {self.warmup_rows}")
        self._identifier = OnlineIdentifier(self.forgetting, self.covariance, ts=self.ts)
        self._row = 0
        self._history = np.zeros(_HISTORY)
        self._last = 0.0
        self._tuned = [float(v) for v in self.start]
        self._order = float(self.start[2])  # the stair controller's fex
        self._weights = grunwald_letnikov_weights(1.0 + float(self.warmup[2]))
        self.gains: list[tuple[float, float, float]] = []

    def _law(self) -> tuple[float, float, FloatArray]:
        """``(kp, kd, taps)`` of this row; the stair controller starts new at ``warmup_rows``."""
        if self._row < int(self.warmup_rows):
            return float(self.warmup[0]), float(self.warmup[1]), self._weights
        if self._row == int(self.warmup_rows):
            self._history = np.zeros(_HISTORY)
            self._order = self._tuned[2]
            self._weights = grunwald_letnikov_weights(1.0 + self._order)
        elif abs(self._tuned[2] - self._order) > FEX_CHANGE:
            self._order = self._tuned[2]
            self._weights = grunwald_letnikov_weights(1.0 + self._order)
        return self._tuned[0], self._tuned[1], self._weights

    def step(self, reference: ArrayLike, measurement: ArrayLike) -> FloatArray:
        """One row: command from the current gains, then the identifier's update and a retuning.

        Parameters
        ----------
        reference : float
            Reference plus dither [deg].
        measurement : float
            Raw inclination [deg]; NaN for a failed read (the command is held, nothing updated
            but the row counter).

        Returns
        -------
        ndarray, shape (1,)
            Velocity command [rad/s].
        """
        if not hasattr(self, "_identifier"):
            self.reset()
        y = float(np.asarray(measurement, dtype=np.float64).reshape(-1)[0])
        r = float(np.asarray(reference, dtype=np.float64).reshape(-1)[0])
        if math.isnan(y):
            if self._row == int(self.warmup_rows):
                self._history = np.zeros(_HISTORY)
            self._row += 1
            self.gains.append((self._tuned[0], self._tuned[1], self._tuned[2]))
            return np.array([self._last])
        kp, kd, weights = self._law()
        command, self._history = fractional_period(
            weights, self._history, r - y, float(self.ts), kp, kd
        )
        tuning = iso_damping_tuning(
            self._identifier.update(command, y), self.phase_margin, self.crossover, self.ts
        )
        if tuning is not None:
            self._tuned[0], self._tuned[1] = tuning.kp, tuning.kd
            if abs(tuning.alpha - self._tuned[2]) > FEX_CHANGE:
                self._tuned[2] = tuning.alpha
        self.gains.append((self._tuned[0], self._tuned[1], self._tuned[2]))
        self._row += 1
        self._last = command
        return np.array([command])
