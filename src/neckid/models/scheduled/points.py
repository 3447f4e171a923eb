"""One operating point of the scheduled model: a CFF-RLS first-order model on a record held still.

:func:`identify_point` runs the recursive least squares of the seed paper (section IV) on one
record and keeps the settled gain ``N`` and pole ``P`` with the inclination reached, in one of the
two forms of :class:`~neckid.models.scheduled.model.GainScheduledModel`:

- ``form="rate"`` (the paper's): ``r(t) = P r(t−1) + N u(t−d)`` from the velocity command ``u``
  [rad/s] to the inclination rate ``r(t) = (i(t) − i(t−1)) / ts`` [deg/s];
- ``form="position"``: ``i(t) = P i(t−1) + N x(t−d)`` from a motor position ``x`` [rad] (e.g. the
  displacement since the start of the log) to the inclination ``i`` [deg] itself.
"""

from __future__ import annotations

from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData
from neckid.models.linear.rls import RecursiveARX
from neckid.regressors import Lags

__all__ = ["FORMS", "OperatingPoint", "default_window", "identify_point"]

#: The two model forms: ``"rate"`` (the seed paper's) and ``"position"``.
FORMS = ("rate", "position")


class OperatingPoint(NamedTuple):
    """One operating point identified by CFF-RLS (see :func:`identify_point`).

    ``inclination`` [deg] is the mean over the last ``window`` samples; ``gain`` (``N``,
    (deg/s)/(rad/s) in the rate form, deg/rad in the position form) and ``pole`` (``P``) are the
    means of the estimates over those samples; ``settled_at`` is -1 when the estimate never
    settled; ``model`` is the fitted estimator.
    """

    inclination: float
    gain: float
    pole: float
    converged: bool
    settled_at: int
    n_samples: int
    model: RecursiveARX


def default_window(forgetting_factor: float) -> int:
    """Five memories of the estimator, ``5 / (1 − λ)`` samples (500 when ``λ = 1``)."""
    if forgetting_factor >= 1.0:
        return 500
    return max(10, round(5.0 / (1.0 - forgetting_factor)))


def identify_point(
    command: ArrayLike,
    inclination: ArrayLike,
    ts: float,
    *,
    form: Literal["rate", "position"] = "rate",
    delay: int = 1,
    forgetting_factor: float = 0.98,
    initial_covariance: float = 1e4,
    window: int | None = None,
    tolerance: float = 0.3,
    atol: float = 0.1,
    input_name: str = "velocity_command",
    output_name: str = "inclination",
    input_unit: str = "rad/s",
    output_unit: str = "deg",
    label: str | None = None,
) -> OperatingPoint:
    """CFF-RLS estimate of a first-order model on one record held at one inclination.

    Parameters
    ----------
    command, inclination : array_like, shape (n_samples,)
        The model's input ``u`` (velocity command [rad/s] in the rate form, motor position [rad]
        in the position form) and the inclination ``i`` [deg].
    ts : float
        Sampling period [s].
    form : {"rate", "position"}, default "rate"
        ``"rate"``: ``r(t) = P r(t−1) + N u(t−d)`` with ``r(t) = (i(t) − i(t−1)) / ts``;
        ``"position"``: ``i(t) = P i(t−1) + N u(t−d)``.
    delay, forgetting_factor, initial_covariance
        Input delay ``d`` >= 1 [samples], ``λ`` in (0, 1], ``F(0) = initial_covariance · I``.
    window : int, optional
        Convergence window and samples averaged; default :func:`default_window`.
    tolerance, atol : float
        Convergence band ``atol + tolerance · |θ̄|`` (:meth:`RecursiveARX.converged`).

    Returns
    -------
    OperatingPoint

    Raises
    ------
    ValueError
        If the record is shorter than ``window + 3`` samples, or ``form`` is not one of
        :data:`FORMS`.

    Notes
    -----
    :class:`RecursiveARX` on ``Lags.arx(1, 1, d)`` estimates ``θ = [a1, b1]`` in
    ``y(t) = −a1 y(t−1) + b1 u(t−d)`` (``y`` the rate or the inclination), so ``P = −a1`` and
    ``N = b1`` (seed paper [1]_, section IV). The gain and pole kept are the means over the last
    ``window`` samples: with ``λ = 0.98`` the estimate keeps fluctuating with a memory of about
    50 samples, and the mean of the settled part is less noisy than the last value.

    References
    ----------
    .. [1] UC3M Robotics Lab, "Model Identification of a Soft Robotic Neck", section IV.
    """
    if form not in FORMS:
        raise ValueError(f"form must be one of {FORMS}; got {form!r}")
    u = np.asarray(command, dtype=np.float64).reshape(-1)
    incl = np.asarray(inclination, dtype=np.float64).reshape(-1)
    lam = float(forgetting_factor)
    if window is None:
        window = default_window(lam) if 0 < lam <= 1 else 1
    if incl.size < window + 3:
        raise ValueError(
            f"{label or 'the record'} has {incl.size} samples after the skipped ones; an operating"
            f" point needs at least window + 3 = {window + 3}"
        )
    if form == "rate":
        target, u = np.diff(incl) / ts, u[1:]
        target_name, target_unit = f"{output_name}_rate", f"{output_unit or 'deg'}/s"
    else:
        target, target_name, target_unit = incl, output_name, output_unit
    rls_data = IOData(
        u,
        target,
        ts=ts,
        input_names=[input_name],
        output_names=[target_name],
        input_units=[input_unit],
        output_units=[target_unit],
        name=label,
    )
    model = RecursiveARX(
        Lags.arx(1, 1, delay),
        forgetting_factor=forgetting_factor,
        initial_covariance=initial_covariance,
    ).fit(rls_data)
    ok, settled = model.converged(window=window, tolerance=tolerance, atol=atol)
    settled_part = model.theta_history_[-window:]
    return OperatingPoint(
        inclination=float(np.mean(incl[-window:])),
        gain=float(np.mean(settled_part[:, 1])),
        pole=float(-np.mean(settled_part[:, 0])),
        converged=bool(ok),
        settled_at=-1 if settled is None else int(settled),
        n_samples=int(rls_data.n_samples),
        model=model,
    )
