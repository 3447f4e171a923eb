r"""The references of the lab's soft-neck runs, with their ``rand()`` dither, row by row.

Every run of the UC3M soft-neck bench (period :math:`T = 0.025` s) computes the error
:math:`e_k = r_k + d_k - i_k` from a nominal reference :math:`r_k`, a dither :math:`d_k` drawn from
glibc's ``rand()`` (seed 1, the first 24 outputs consumed before the loop) and the **raw**
inclination :math:`i_k`. The references here are built from row counts (the logs' time stamps
repeat), in degrees:

==============  ======  =====================================================================
run             rows    reference (deg), :math:`t = kT`, :math:`\rho_k` = ``rand()`` output
==============  ======  =====================================================================
staircase       2804    15, 20, 25, 30, 25, 20, 15 held 401, 401, 401, 401, 400, 400, 400 rows;
                        dither :math:`0.2\,((\rho \bmod 10) - 5)`
step            401     :math:`10 + 0.1\,((\rho \bmod 10) - 5)`
identification  6000    :math:`5 + 5\,(1 + (\sin 0.3t + \sin 3t + \sin 30t)/3
                        + 0.1\,((\rho \bmod 10) - 5))`
adaptive        801 +   :math:`10 + 2.5\,(\sin 3t + \sin 30t) + 0.5\,((\rho \bmod 10) - 5)`,
                2804    then the staircase, whose dither continues the sequence
==============  ======  =====================================================================

References
----------
- ``shared/data/softneck/CONTROLLERS.md`` ("What every run shares", "The references"), from the
  lab's C++ sources: github.com/munozyanez/phd_Archived @ a9198c8 (``main/ieeeaccess-adaptive.cpp``,
  ``main/neck-id.cpp``, ``main/stepresponse.cpp``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neckid.loops.controllers.glibc import glibc_rand
from neckid.utils.types import FloatArray, IntArray

__all__ = [
    "ADAPTIVE_WARMUP_ROWS",
    "FIRST_LOOP_DRAW",
    "LAB_TS",
    "STAIR_LEVELS",
    "STAIR_ROWS",
    "LabReference",
    "adaptive_reference",
    "identification_reference",
    "lab_dither",
    "reference_for_log",
    "staircase_reference",
    "step_reference",
]

#: The bench's control period, s.
LAB_TS = 0.025
#: ``rand()`` outputs consumed before the control loop (the identifier's random initialisation).
FIRST_LOOP_DRAW = 24
#: Levels of the staircase, deg, and the rows each is held.
STAIR_LEVELS = (15.0, 20.0, 25.0, 30.0, 25.0, 20.0, 15.0)
STAIR_ROWS = (401, 401, 401, 401, 400, 400, 400)
#: Rows of the adaptive runs before the staircase (t = 0 … 20 s).
ADAPTIVE_WARMUP_ROWS = 801
#: Rows of a step log and of the identification run.
STEP_ROWS = 401
IDENTIFICATION_ROWS = 6000


@dataclass(frozen=True)
class LabReference:
    """A run's reference, row by row: the nominal part and the dither, in degrees.

    Attributes
    ----------
    name : str
        ``"staircase"``, ``"step"``, ``"identification"`` or ``"adaptive"``.
    nominal : ndarray, shape (n,)
        The reference without dither [deg].
    dither : ndarray, shape (n,)
        The ``rand()`` dither [deg].
    draws : ndarray of int64, shape (n,)
        The ``rand()`` output each row drew.
    ts : float
        Period, s.
    """

    name: str
    nominal: FloatArray
    dither: FloatArray
    draws: IntArray
    ts: float = LAB_TS

    @property
    def values(self) -> FloatArray:
        """What the controller subtracts the inclination from: nominal + dither [deg]."""
        return self.nominal + self.dither

    def __len__(self) -> int:
        return int(self.nominal.shape[0])


def lab_dither(draws: IntArray, scale: float) -> FloatArray:
    r"""The bench's dither :math:`s\,((\rho \bmod 10) - 5)` of ``rand()`` outputs :math:`\rho`, deg.

    Parameters
    ----------
    draws : ndarray of int
        ``rand()`` outputs.
    scale : float
        0.2 (staircase), 0.1 (step), 0.5 (adaptive warm-up), 0.5 (identification: 5 × 0.1).

    Returns
    -------
    ndarray of float
        In :math:`s \cdot \{-5, \ldots, 4\}`.

    Examples
    --------
    >>> from neckid.loops.controllers.glibc import glibc_rand
    >>> lab_dither(glibc_rand(3), 0.2).round(6).tolist()
    [-0.4, 0.2, 0.4]
    """
    return float(scale) * (np.asarray(draws, dtype=np.int64) % 10 - 5).astype(np.float64)


def _staircase(start: int) -> LabReference:
    nominal = np.repeat(np.array(STAIR_LEVELS), STAIR_ROWS)
    draws = glibc_rand(nominal.shape[0], start=start)
    return LabReference("staircase", nominal, lab_dither(draws, 0.2), draws)


def staircase_reference(start: int = FIRST_LOOP_DRAW) -> LabReference:
    """The staircase of the ``stair/{fra,int}*`` logs: 2804 rows, dither ±1 deg.

    Parameters
    ----------
    start : int, default 24
        Index of the ``rand()`` output of the first row (24 for the fra/int runs; the adaptive
        runs' staircase starts at 24 + 801, see :func:`adaptive_reference`).

    Returns
    -------
    LabReference

    Examples
    --------
    >>> ref = staircase_reference()
    >>> len(ref), ref.nominal[[0, 401, 1604, -1]].tolist()
    (2804, [15.0, 20.0, 25.0, 15.0])
    """
    return _staircase(start)


def step_reference(start: int = FIRST_LOOP_DRAW) -> LabReference:
    """The 10 deg step of the ``step/{fra,int}*`` logs: 401 rows, dither −0.5 … +0.4 deg.

    Parameters
    ----------
    start : int, default 24
        Index of the ``rand()`` output of the first row.

    Returns
    -------
    LabReference
    """
    draws = glibc_rand(STEP_ROWS, start=start)
    return LabReference("step", np.full(STEP_ROWS, 10.0), lab_dither(draws, 0.1), draws)


def identification_reference(start: int = FIRST_LOOP_DRAW) -> LabReference:
    r"""The multisine of ``id/id000response.csv``: 6000 rows, 0 … 15 deg.

    :math:`5 + 5\,(1 + (\sin 0.3t + \sin 3t + \sin 30t)/3 + 0.1\,((\rho \bmod 10) - 5))`,
    :math:`t = kT`.

    Parameters
    ----------
    start : int, default 24
        Index of the ``rand()`` output of the first row.

    Returns
    -------
    LabReference
    """
    t = np.arange(IDENTIFICATION_ROWS) * LAB_TS
    nominal = 5.0 + 5.0 * (1.0 + (np.sin(0.3 * t) + np.sin(3.0 * t) + np.sin(30.0 * t)) / 3.0)
    draws = glibc_rand(IDENTIFICATION_ROWS, start=start)
    return LabReference("identification", nominal, lab_dither(draws, 0.5), draws)


def adaptive_reference(start: int = FIRST_LOOP_DRAW) -> LabReference:
    r"""The ``stair/ada*`` runs: 801 rows of warm-up, then the staircase (3605 rows).

    Warm-up :math:`10 + 2.5\,(\sin 3t + \sin 30t) + 0.5\,((\rho \bmod 10) - 5)`, :math:`t = kT`,
    then :func:`staircase_reference` continuing the ``rand()`` sequence.

    Parameters
    ----------
    start : int, default 24
        Index of the ``rand()`` output of the first row.

    Returns
    -------
    LabReference
    """
    t = np.arange(ADAPTIVE_WARMUP_ROWS) * LAB_TS
    draws = glibc_rand(ADAPTIVE_WARMUP_ROWS, start=start)
    warm = 10.0 + 2.5 * (np.sin(3.0 * t) + np.sin(30.0 * t))
    stair = _staircase(start + ADAPTIVE_WARMUP_ROWS)
    return LabReference(
        "adaptive",
        np.concatenate([warm, stair.nominal]),
        np.concatenate([lab_dither(draws, 0.5), stair.dither]),
        np.concatenate([draws, stair.draws]),
    )


def reference_for_log(name: str) -> LabReference:
    """The reference of a shared closed-loop log, from its file name.

    Parameters
    ----------
    name : str
        ``ada*response.csv``, ``{fra,int}*response.csv`` (staircase),
        ``{fra,int}*stepresponse.csv`` or ``id000response.csv`` (a path's last part is used).

    Returns
    -------
    LabReference

    Raises
    ------
    ValueError
        For another name (the open-loop logs have no reference).

    Examples
    --------
    >>> reference_for_log("stair/fra200response.csv").name
    'staircase'
    """
    base = name.replace("\\", "/").rsplit("/", 1)[-1]
    if base.startswith(("fra", "int")) and base.endswith("stepresponse.csv"):
        return step_reference()
    if base.startswith(("fra", "int")) and base.endswith("response.csv"):
        return staircase_reference()
    if base.startswith("ada") and base.endswith("response.csv"):
        return adaptive_reference()
    if base == "id000response.csv" and "ol1" not in name:
        return identification_reference()
    raise ValueError(
        f"{name!r} is not a closed-loop log of the shared set (ada*/fra*/int*response.csv,"
        " {fra,int}*stepresponse.csv, id/id000response.csv)"
    )
