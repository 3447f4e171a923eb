r"""The lab's adaptive fractional controller (the ``stair/ada*`` logs), replayed from its parameters.

The adaptive runs start with 801 rows (t = 0 … 20 s) of the fixed fractional controller
(:math:`k_p = 0.2547`, :math:`k_d = 0.7730`, :math:`f_{ex} = -0.6`). At the first stair row a new
fractional controller (zero state) starts from the tuner's current values; from then on every
row may replace :math:`k_p` and :math:`k_d` while the controller keeps its state. The parameter
logs ``adacon{000,200,400,600}.csv`` (:func:`load_adaptive_parameters`) hold the values after
each row's retuning, so for the stair rows after the first

.. math:: c_k = k_p[k-1]\, e_k + k_d[k-1]\, v_k,

with :math:`v_k` the truncated Grünwald–Letnikov sum of :class:`~.lab.LabFractionalController`.
The first stair row's command depends only on :math:`k_p + T k_d` of the starting values, which
the parameter log does not hold: :data:`ADAPTIVE_START_GAINS` gives CONTROLLERS.md's.

The replay follows the parameters as they were logged: it does not react to the plant it runs
with (see :mod:`.tuner` for a re-implementation of the identifier and tuner that does).

References
----------
- ``shared/data/softneck/CONTROLLERS.md`` (section "ada: adaptive fractional controller"), from
  github.com/munozyanez/phd_Archived @ a9198c8 (``main/ieeeaccess-adaptive.cpp``) and
  github.com/munozyanez/fcontrol @ 5e47a79 (``FractionalController1DOF``, ``FPDTuner``).
- ``shared/data/softneck_adaptive/SOURCE.md``: the parameter logs, from github.com/HUMASoft/results
  (``adaptive/data/final/``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neckid.loops.controllers.lab import LabController, fractional_period, grunwald_letnikov_weights
from neckid.loops.controllers.references import ADAPTIVE_WARMUP_ROWS, LAB_TS
from neckid.utils.checks import check_ts
from neckid.utils.types import FloatArray

__all__ = [
    "ADAPTIVE_START_GAINS",
    "ADAPTIVE_WARMUP_GAINS",
    "FEX_CHANGE",
    "AdaptiveFractionalReplay",
    "AdaptiveParameters",
    "load_adaptive_parameters",
]

#: The fixed fractional controller of the first 801 rows: (kp, kd, fex).
ADAPTIVE_WARMUP_GAINS = (0.2547, 0.7730, -0.6)
#: CONTROLLERS.md's starting (kp, kd) of the stair controller, by payload in grams.
ADAPTIVE_START_GAINS: dict[int, tuple[float, float]] = {
    0: (0.28919, 0.86459),
    200: (0.25765, 0.78200),
    400: (0.29609, 0.92476),
    600: (0.27103, 0.85330),
}
#: The controller takes a new fex only when the tuner's differs by more than this.
FEX_CHANGE = 0.05


@dataclass(frozen=True)
class AdaptiveParameters:
    """An adaptive run's parameters after each row's retuning (one row per log row).

    Attributes
    ----------
    t : ndarray, shape (n,)
        Time stamps as logged, s (they repeat; use row counts).
    kp : ndarray, shape (n,)
        Proportional gain, (rad/s)/deg.
    kd : ndarray, shape (n,)
        Fractional gain (on the step-1 sum).
    fex : ndarray, shape (n,)
        The lab's exponent (:math:`a = 1 + f_{ex}`).
    name : str
        The file name.
    """

    t: FloatArray
    kp: FloatArray
    kd: FloatArray
    fex: FloatArray
    name: str = ""

    def __len__(self) -> int:
        return int(self.kp.shape[0])


def load_adaptive_parameters(path: str | Path) -> AdaptiveParameters:
    """Read an ``adacon*.csv`` parameter log (no header; t [s], kp, kd, fex).

    Parameters
    ----------
    path : str or Path
        The file (``shared/data/softneck_adaptive/adacon{000,200,400,600}.csv``; not
        distributed with neckid).

    Returns
    -------
    AdaptiveParameters

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValueError
        If a row does not have 4 finite numbers.
    """
    file = Path(path)
    if not file.is_file():
        raise FileNotFoundError(f"adaptive parameter log {str(file)!r} does not exist")
    try:
        values = np.loadtxt(file, delimiter=",", ndmin=2)
    except ValueError as exc:
        raise ValueError(
            f"{file}: not an adaptive parameter log (4 numbers a row: t, kp, kd, fex): {exc}"
        ) from None
    if values.shape[1] != 4:
        raise ValueError(
            f"{file}: an adaptive parameter log has 4 columns (t, kp, kd, fex); got"
            f" {values.shape[1]}"
        )
    bad = np.argwhere(~np.isfinite(values))
    if bad.size:
        row, column = (int(v) for v in bad[0])
        raise ValueError(
            f"{file}: {('t', 'kp', 'kd', 'fex')[column]} of row {row + 1} is"
            f" {float(values[row, column])}; an adaptive parameter log holds finite numbers"
        )
    return AdaptiveParameters(
        values[:, 0].copy(),
        values[:, 1].copy(),
        values[:, 2].copy(),
        values[:, 3].copy(),
        name=file.name,
    )


def _fex_in_use(logged: FloatArray, first: int) -> FloatArray:
    """The controller's fex per row from ``first`` on: changed only by more than FEX_CHANGE."""
    used = np.empty(logged.shape[0] - first)
    current = float(logged[first])
    for j, value in enumerate(logged[first:]):
        if abs(float(value) - current) > FEX_CHANGE:
            current = float(value)
        used[j] = current
    return used


class AdaptiveFractionalReplay(LabController):
    r"""The adaptive controller of an ``ada`` log, replaying its parameter log row by row.

    Rows :math:`k < 801`: the fixed fractional controller with :data:`ADAPTIVE_WARMUP_GAINS`.
    Row 801: a new controller (zero state) with ``start`` gains. Rows :math:`k > 801`:
    :math:`c_k = k_p[k-1] e_k + k_d[k-1] v_k` (``parameters``), the fractional order that of
    row 801's :math:`f_{ex}`, replaced only when the log's changes by more than 0.05. The row
    counter advances on failed reads too. After the last logged row the last parameters are
    kept.

    Parameters
    ----------
    parameters : AdaptiveParameters
        The run's parameter log (:func:`load_adaptive_parameters`).
    start : (float, float), optional
        :math:`(k_p, k_d)` of the stair controller's first row; default
        :data:`ADAPTIVE_START_GAINS` of the payload in the parameter file's name
        (``adacon200.csv`` → 200 g).
    warmup_rows : int, default 801
        Rows of the fixed warm-up controller.
    warmup : (float, float, float), default (0.2547, 0.7730, -0.6)
        Its :math:`(k_p, k_d, f_{ex})`.
    ts : float, default 0.025
        Period, s.

    References
    ----------
    CONTROLLERS.md ("ada: adaptive fractional controller"); fcontrol
    ``FractionalController1DOF``.
    """

    def __init__(
        self,
        parameters: AdaptiveParameters,
        start: tuple[float, float] | None = None,
        warmup_rows: int = ADAPTIVE_WARMUP_ROWS,
        warmup: tuple[float, float, float] = ADAPTIVE_WARMUP_GAINS,
        ts: float = LAB_TS,
    ) -> None:
        if not 0 <= warmup_rows < len(parameters):
            raise ValueError(
                f"warmup_rows must be in [0, {len(parameters)}) for a parameter log of"
                f" {len(parameters)} rows; got {warmup_rows}"
            )
        if start is None:
            digits = "".join(c for c in parameters.name if c.isdigit())
            if not digits or int(digits) not in ADAPTIVE_START_GAINS:
                raise ValueError(
                    f"no starting gains known for {parameters.name!r}: pass start=(kp, kd)"
                )
            start = ADAPTIVE_START_GAINS[int(digits)]
        self.parameters = parameters
        self.start = (float(start[0]), float(start[1]))
        self.warmup_rows = int(warmup_rows)
        self.warmup = tuple(float(v) for v in warmup)
        self.ts = check_ts(ts)
        self._warm_weights = grunwald_letnikov_weights(1.0 + self.warmup[2])
        self._fex = _fex_in_use(parameters.fex, self.warmup_rows)
        self._weights = {f: grunwald_letnikov_weights(1.0 + f) for f in np.unique(self._fex)}
        taps = max(w.shape[0] for w in [self._warm_weights, *self._weights.values()])
        self.law_states = ["row", *(f"x[t-{i}]" for i in range(1, taps))]
        self.reset()

    def initial_law_state(self) -> FloatArray:
        """``[row, x_{k-1}, …]``, zeros."""
        return np.zeros(len(self.law_states))

    def gains(self, row: int) -> tuple[float, float, FloatArray]:
        """``(kp, kd, taps)`` the controller uses at ``row``."""
        if row < self.warmup_rows:
            return self.warmup[0], self.warmup[1], self._warm_weights
        last = len(self.parameters) - 1
        fex = float(self._fex[min(row, last) - self.warmup_rows])
        if row == self.warmup_rows:
            return self.start[0], self.start[1], self._weights[fex]
        source = min(row - 1, last)
        return (
            float(self.parameters.kp[source]),
            float(self.parameters.kd[source]),
            self._weights[fex],
        )

    def law(self, state: FloatArray, error: float) -> tuple[float, FloatArray]:
        """One period: ``(c_k, [row + 1, x_k, …])``; the integral restarts at the first stair row."""
        row = round(float(state[0]))
        history = state[1:] if row != self.warmup_rows else np.zeros(state.shape[0] - 1)
        kp, kd, weights = self.gains(row)
        command, following = fractional_period(weights, history, error, self.ts, kp, kd)
        return command, np.concatenate([[row + 1.0], following])

    def hold(self, state: FloatArray) -> FloatArray:
        """A failed read: only the row counter advances (the stair controller still starts new)."""
        if round(float(state[0])) == self.warmup_rows:
            state[1:] = 0.0
        state[0] += 1.0
        return state
