"""Periodic multisine plans for the best linear approximation: odd and random-odd, M x P periods.

A plan is what to run on the rig to measure a best linear approximation (BLA) and its distortion
levels with the robust method (:func:`neckid.frequency.robust_bla`): ``M`` realisations of a
random-phase multisine with the same amplitude spectrum, each played for ``transient_periods``
periods (thrown away: the transient) and then ``P`` measured periods.

Contents
--------
- :func:`multisine_plan`: the plan (a :class:`MultisinePlan`: the signal, which realisation and
  period each sample belongs to, and the table of its frequency lines).

References
----------
R. Pintelon and J. Schoukens, *System Identification: A Frequency Domain Approach*, 2nd ed.,
Wiley-IEEE Press, 2012, ch. 3-4 (odd and random-odd multisines, the robust BLA); J. Schoukens,
M. Vaes and R. Pintelon, "Linear system identification in a nonlinear setting", IEEE Control
Systems Magazine 36(3), 38-69, 2016.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from neckid.signals.excitation import multisine_frequencies
from neckid.utils.checks import check_number, check_ts
from neckid.utils.types import FloatArray

__all__ = ["MultisineKind", "MultisinePlan", "multisine_plan"]

#: Which lines a multisine excites: every line of the band, its odd lines, or its odd lines but
#: one left out at random in each group of ``group`` consecutive odd lines.
MultisineKind = Literal["full", "odd", "random-odd"]

#: The roles of a line in the band, as the lines' table writes them.
ROLES = ("excited", "odd detection", "even detection")


@dataclass(frozen=True)
class MultisinePlan:
    """A multisine experiment: ``M`` realisations x (transient + ``P``) periods, and its lines.

    Attributes
    ----------
    signal : ndarray, shape (n_samples, n_inputs)
        The commands, realisation after realisation, each ``transient_periods + n_periods``
        periods long; ``n_samples = M (T + P) N``.
    ts : float
        Sampling period, s.
    period : int
        Samples per period, ``N``.
    n_periods, n_realisations, transient_periods : int
        ``P``, ``M`` and ``T``.
    kind : {"full", "odd", "random-odd"}
        Which lines are excited.
    lines : ndarray of int
        Every DFT line ``k`` of the band (``omega_k = 2 pi k / (N ts)``).
    roles : ndarray of str
        Per line: ``"excited"``, ``"odd detection"`` (an odd line left out: only odd
        nonlinearities put power there) or ``"even detection"`` (an even line of an odd
        multisine: only even nonlinearities put power there).
    realisation, period_index : ndarray of int, shape (n_samples,)
        Per sample: its realisation ``0 .. M-1`` and its period, ``-T .. -1`` for the transient
        periods and ``0 .. P-1`` for the measured ones.
    rms : float
        Root-mean-square value of every input in every realisation (its unit: the command's).

    Examples
    --------
    >>> plan = multisine_plan(64, 0.05, (0.5, 20.0), kind="odd", n_realisations=2, seed=1)
    >>> plan.n_realisations, plan.period, plan.excited_lines[:3].tolist()
    (2, 64, [1, 3, 5])
    >>> plan.lines_table()[0]["role"], round(float(plan.omegas[0]), 4)
    ('excited', 1.9635)
    """

    signal: FloatArray
    ts: float
    period: int
    n_periods: int
    n_realisations: int
    transient_periods: int
    kind: str
    lines: NDArray[np.int64]
    roles: NDArray[np.str_]
    realisation: NDArray[np.int64]
    period_index: NDArray[np.int64]
    rms: float

    @property
    def omegas(self) -> FloatArray:
        """Angular frequency of every line of the band, rad/s."""
        return np.asarray(2.0 * math.pi * self.lines / (self.period * self.ts), dtype=np.float64)

    @property
    def excited_lines(self) -> NDArray[np.int64]:
        """The excited DFT lines."""
        return self.lines[self.roles == "excited"]

    def lines_table(self) -> list[dict[str, float | int | str]]:
        """One row per line of the band: ``line``, ``omega_rad_s``, ``frequency_hz``, ``role``."""
        return [
            {
                "line": int(k),
                "omega_rad_s": float(w),
                "frequency_hz": float(w / (2.0 * math.pi)),
                "role": str(role),
            }
            for k, w, role in zip(self.lines, self.omegas, self.roles, strict=True)
        ]


def _roles(
    lines: NDArray[np.int64], kind: str, group: int, rng: np.random.Generator
) -> NDArray[np.str_]:
    if kind == "full":
        return np.full(lines.size, "excited", dtype="<U14")
    if kind not in ("odd", "random-odd"):
        raise ValueError(f"kind must be 'full', 'odd' or 'random-odd'; got {kind!r}")
    roles = np.where(lines % 2 == 1, "excited", "even detection").astype("<U14")
    if kind == "random-odd":
        odd = np.flatnonzero(lines % 2 == 1)
        for start in range(0, odd.size - group + 1, group):
            roles[odd[start + rng.integers(group)]] = "odd detection"
    if not (roles == "excited").any():
        raise ValueError("the band holds no odd line to excite; widen the band")
    return roles


def _realisation(
    period: int,
    excited: NDArray[np.int64],
    phases: FloatArray,
    amplitude: float,
) -> FloatArray:
    """One period of each input: ``phases`` of shape (n_inputs, n_excited)."""
    spectrum = np.zeros((phases.shape[0], period // 2 + 1), dtype=np.complex128)
    spectrum[:, excited] = np.exp(1j * phases)
    return np.fft.irfft(spectrum, n=period, axis=1).T * amplitude


def multisine_plan(
    period: int,
    ts: float,
    band: tuple[float, float],
    *,
    kind: MultisineKind = "random-odd",
    n_realisations: int = 8,
    n_periods: int = 4,
    transient_periods: int = 1,
    rms: float = 1.0,
    offset: float = 0.0,
    group: int = 3,
    n_inputs: int = 1,
    seed: int | np.random.Generator | None = None,
) -> MultisinePlan:
    r"""A random-phase multisine experiment for the robust BLA: M realisations x P periods.

    Parameters
    ----------
    period : int
        Samples per period ``N`` (even, >= 8); the frequency resolution is
        ``2 pi / (N ts)`` rad/s.
    ts : float
        Sampling period, s.
    band : (float, float)
        ``(omega_low, omega_high)`` rad/s, the band whose lines are excited (DC and Nyquist never).
    kind : {"full", "odd", "random-odd"}, default "random-odd"
        ``"full"``: every line of the band. ``"odd"``: its odd lines (``k`` odd); the even lines
        then show even nonlinearities. ``"random-odd"``: its odd lines but one chosen at random
        in each group of ``group`` consecutive odd lines, left out to show odd nonlinearities.
        The left-out lines are the same in every realisation.
    n_realisations : int, default 8
        ``M``, realisations with independent random phases (uniform on ``[0, 2 pi)``), >= 1.
        With several inputs, a multiple of ``n_inputs``.
    n_periods : int, default 4
        ``P``, measured periods per realisation, >= 1 (>= 2 for a noise level).
    transient_periods : int, default 1
        ``T``, periods played before the measured ones in every realisation, >= 0.
    rms : float, default 1.0
        Root-mean-square value of every input (about a third of its peak for many lines), > 0.
    offset : float, default 0.0
        Added to the signal: the operating point the multisine is played around.
    group : int, default 3
        Odd lines per group of a random-odd multisine (one left out per group), >= 2.
    n_inputs : int, default 1
        Inputs excited at once. Realisations come in blocks of ``n_inputs``: in experiment ``j``
        of a block, input ``i``'s phases are turned by ``2 pi i j / n_inputs`` (an orthogonal
        DFT matrix), so the block's input spectra are well conditioned at every line.
    seed : int or numpy.random.Generator, optional
        Source of the phases and of the left-out lines (:func:`numpy.random.default_rng`).

    Returns
    -------
    MultisinePlan

    Raises
    ------
    ValueError
        For a value out of range, a band without lines, or realisations not in whole blocks.

    Notes
    -----
    A realisation is :math:`u(t) = A \sum_{k \in \mathcal{E}} \cos(\omega_k t + \varphi_k)`
    with the same :math:`A` for every excited line :math:`k \in \mathcal{E}` and every
    realisation: the realisations share their power spectrum, which is what the BLA depends on
    (Pintelon & Schoukens 2012, §3.4). An odd nonlinearity maps odd lines onto odd lines, an
    even one onto even lines: the non-excited lines tell them apart (§3.6).

    Examples
    --------
    >>> plan = multisine_plan(64, 0.05, (0.5, 20.0), n_realisations=2, n_periods=3, seed=1)
    >>> plan.signal.shape  # 2 realisations x (1 transient + 3 periods) x 64 samples
    (512, 1)
    >>> sorted(set(plan.roles.tolist()))
    ['even detection', 'excited', 'odd detection']
    >>> bool(np.allclose(plan.signal[64:128], plan.signal[128:192]))  # periodic
    True
    """
    length = check_number(period, "period", low=8, integer=True)
    if length % 2:
        raise ValueError(f"period must be even (samples per period); got {length}")
    sample_time = check_ts(ts)
    m = check_number(n_realisations, "n_realisations", low=1, integer=True)
    p = check_number(n_periods, "n_periods", low=1, integer=True)
    t = check_number(transient_periods, "transient_periods", low=0, integer=True)
    value = check_number(rms, "rms", low=0, closed="neither")
    level = check_number(offset, "offset")
    size = check_number(group, "group", low=2, integer=True)
    n_u = check_number(n_inputs, "n_inputs", low=1, integer=True)
    if m % n_u:
        raise ValueError(
            f"n_realisations={m} must be a multiple of n_inputs={n_u} (blocks of one experiment"
            " per input)"
        )
    rng = np.random.default_rng(seed)
    lines, _ = multisine_frequencies(length, sample_time, band)
    roles = _roles(lines, kind, size, rng)
    excited = lines[roles == "excited"]
    # rms of sum_k cos(.) over excited lines with unit spectrum entries: irfft scales by 2/N.
    amplitude = value / (math.sqrt(excited.size / 2.0) * 2.0 / length)
    rotation = 2.0 * math.pi * np.outer(np.arange(n_u), np.arange(n_u)) / n_u
    blocks = []
    for _block in range(m // n_u):
        phases = rng.uniform(0.0, 2.0 * math.pi, size=(n_u, excited.size))
        for j in range(n_u):
            one = _realisation(length, excited, phases + rotation[:, j : j + 1], amplitude)
            blocks.append(np.tile(one, (t + p, 1)))
    signal = np.ascontiguousarray(np.vstack(blocks) + level, dtype=np.float64)
    per_period = np.repeat(np.arange(-t, p, dtype=np.int64), length)
    return MultisinePlan(
        signal=signal,
        ts=sample_time,
        period=length,
        n_periods=p,
        n_realisations=m,
        transient_periods=t,
        kind=kind,
        lines=lines,
        roles=roles,
        realisation=np.repeat(np.arange(m, dtype=np.int64), (t + p) * length),
        period_index=np.tile(per_period, m),
        rms=value,
    )
