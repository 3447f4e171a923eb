"""What a BLA says in words: the bandwidth read from it, and the model classes its levels call for."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from neckid.frequency.bla import BestLinearApproximation

__all__ = ["bandwidth_from_frf", "model_classes"]


def bandwidth_from_frf(omega: ArrayLike, frf: ArrayLike, threshold: float = 0.9) -> float:
    """The lowest frequency above which ``|frf|`` stays below ``threshold`` (the paper's 90 % rule).

    Parameters
    ----------
    omega : array_like, shape (F,)
        Increasing angular frequencies, rad/s.
    frf : array_like, shape (F,)
        A closed loop's response from reference to output (same unit), complex or magnitude.
    threshold : float, default 0.9
        Amplitude ratio.

    Returns
    -------
    float
        Interpolated linearly between the last line above and the first below for good, rad/s;
        NaN when the magnitude never falls below ``threshold`` for good or is below from the first
        line on.

    Examples
    --------
    >>> w = np.array([1.0, 2.0, 3.0, 4.0])
    >>> bandwidth_from_frf(w, [1.0, 0.95, 0.85, 0.5])
    2.5
    """
    w = np.asarray(omega, dtype=np.float64)
    magnitude = np.abs(np.asarray(frf))
    above = np.flatnonzero(magnitude >= threshold)
    if above.size == 0 or above[-1] == w.size - 1:
        return float("nan")
    k = int(above[-1])
    fraction = (magnitude[k] - threshold) / (magnitude[k] - magnitude[k + 1])
    return float(w[k] + fraction * (w[k + 1] - w[k]))


def model_classes(bla: BestLinearApproximation, pair: tuple[int, int] = (0, 0)) -> str:
    """The model classes the distortion levels call for, in one sentence (a rule of thumb).

    The rule: no distortion detected above the noise (99 % F test at <= 10 % of the lines) ->
    a linear model (``arx``, ``ss``); distortions more than 20 dB below the BLA (median over the
    lines of one block's distortion variance over ``|G_BLA|^2``) -> a linear model is right to
    within that share in amplitude (-20 dB: 10 %), a scheduled one (``scheduled``, ``lpv``) if the operating
    point moves; otherwise a nonlinear model (``poly``, ``pnlss``, ``sm``, ``greybox-neck``),
    with even terms when the even lines show power (an asymmetric nonlinearity: slack, gravity)
    and odd terms when the non-excited odd lines do (stiffening, saturation).
    """
    out, inp = pair
    detected = bla.nonlinear_detected()[:, out, inp].mean()
    if bla.n_blocks < 2 or bla.n_periods < 2:
        return "distortions not measured (needs M >= 2 n_u and P >= 2): no advice"
    if detected <= 0.1:
        return "no distortion above the noise: a linear model (arx, ss) suffices"
    with np.errstate(divide="ignore"):
        relative = float(
            np.median(
                10
                * np.log10(bla.distortion_variance[:, out, inp] / np.abs(bla.frf[:, out, inp]) ** 2)
            )
        )
    kinds = [
        word
        for parity, word in (("even", "even"), ("odd", "odd"))
        if bla.levels.kind_detected(parity)
    ]
    kind = f" ({' and '.join(kinds)} nonlinearity)" if kinds else ""
    if relative < -20:
        return (
            f"distortions {-relative:.0f} dB below the BLA{kind}: a linear model (arx, ss) is"
            f" right to within about {100 * 10 ** (relative / 20):.0f} % in amplitude at this"
            " operating point; scheduled or lpv when the operating point moves"
        )
    terms = " with even terms (asymmetric: slack, gravity)" if "even" in kinds else ""
    return (
        f"distortions only {-relative:.0f} dB below the BLA{kind}: a nonlinear model (poly,"
        f" pnlss, sm, greybox-neck){terms}"
    )
