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

from collections.abc import Sequence
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData
from neckid.models.linear.rls import RecursiveARX
from neckid.models.scheduled.segments import OperatingSegment
from neckid.regressors import Lags
from neckid.utils.types import FloatArray

__all__ = ["FORMS", "OperatingPoint", "default_window", "identify_point", "identify_segments"]

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
    u = np.asarray(command, dtype=np.float64).reshape(-1)
    incl = np.asarray(inclination, dtype=np.float64).reshape(-1)
    return _identify_runs(
        [(u, incl)],
        ts,
        form=form,
        delay=delay,
        forgetting_factor=forgetting_factor,
        initial_covariance=initial_covariance,
        window=window,
        tolerance=tolerance,
        atol=atol,
        names=(input_name, output_name, input_unit, output_unit),
        label=label,
    )


def _identify_runs(
    runs: Sequence[tuple[FloatArray, FloatArray]],
    ts: float,
    *,
    form: str,
    delay: int,
    forgetting_factor: float,
    initial_covariance: float = 1e4,
    window: int | None,
    tolerance: float = 0.3,
    atol: float = 0.1,
    names: tuple[str, str, str, str],
    label: str | None,
) -> OperatingPoint:
    """:func:`identify_point` over stretches ``(command, inclination)`` run one after the other.

    CFF-RLS carries its estimate and ``F`` from one stretch to the next, no regressor straddles
    two; the inclination and the estimates kept are the means over the last ``window`` samples.
    """
    if form not in FORMS:
        raise ValueError(f"form must be one of {FORMS}; got {form!r}")
    input_name, output_name, input_unit, output_unit = names
    lam = float(forgetting_factor)
    if window is None:
        window = default_window(lam) if 0 < lam <= 1 else 1
    n_samples = sum(incl.size for _, incl in runs)
    if n_samples < window + 3:
        raise ValueError(
            f"{label or 'the record'} has {n_samples} samples after the skipped ones; an operating"
            f" point needs at least window + 3 = {window + 3}"
        )
    if form == "rate":
        target_name, target_unit = f"{output_name}_rate", f"{output_unit or 'deg'}/s"
    else:
        target_name, target_unit = output_name, output_unit
    records = []
    for u, incl in runs:
        if incl.size < delay + 3:  # too short for one regressor row on the rate
            continue
        target, command = (np.diff(incl) / ts, u[1:]) if form == "rate" else (incl, u)
        records.append(
            IOData(
                command,
                target,
                ts=ts,
                input_names=[input_name],
                output_names=[target_name],
                input_units=[input_unit],
                output_units=[target_unit],
                name=label,
            )
        )
    model = RecursiveARX(
        Lags.arx(1, 1, delay),
        forgetting_factor=forgetting_factor,
        initial_covariance=initial_covariance,
    ).fit(records)
    ok, settled = model.converged(window=window, tolerance=tolerance, atol=atol)
    settled_part = model.theta_history_[-window:]
    inclination = np.concatenate([incl for _, incl in runs])
    return OperatingPoint(
        inclination=float(np.mean(inclination[-window:])),
        gain=float(np.mean(settled_part[:, 1])),
        pole=float(-np.mean(settled_part[:, 0])),
        converged=bool(ok),
        settled_at=-1 if settled is None else int(settled),
        n_samples=int(sum(r.n_samples for r in records)),
        model=model,
    )


def identify_segments(
    segments: Sequence[OperatingSegment],
    channel: int,
    delay: int,
    template: IOData,
    *,
    form: str = "rate",
    forgetting_factor: float = 0.98,
    skip: int = 0,
    window: int | None = None,
    label: str = "operating point",
) -> list[OperatingPoint]:
    """One operating point per segment (:func:`identify_point` over each segment's stretches).

    Parameters
    ----------
    segments : sequence of OperatingSegment
        From :func:`~neckid.models.scheduled.segments.operating_segments`.
    channel, delay : int
        Index of the command among the inputs; its delay ``d`` [samples].
    template : IOData
        A record on the same channels (sampling period, names and units).
    form, forgetting_factor
        As :func:`identify_point`.
    skip : int, default 0
        Samples left out at the start of every stretch.
    window : int, optional
        Default: five memories of the estimator (:func:`default_window`), at most half the
        segment's samples after ``skip`` (at least 10).
    label : str
        How errors name a segment (``"<label> <k> (<record name>)"``).

    Returns
    -------
    list of OperatingPoint
    """
    names = (
        template.input_names[channel],
        template.output_names[0],
        template.input_units[channel],
        template.output_units[0],
    )
    points = []
    for k, segment in enumerate(segments):
        runs = [(run.u[skip:, channel], run.y[skip:, 0]) for run in segment.runs]
        size = window
        if size is None:
            usable = sum(incl.size for _, incl in runs)
            size = min(default_window(forgetting_factor), max(10, usable // 2))
        name = segment.runs[0].name or f"{segment.kind} {k}"
        points.append(
            _identify_runs(
                runs,
                template.ts,
                form=form,
                delay=delay,
                forgetting_factor=forgetting_factor,
                window=size,
                names=names,
                label=f"{label} {k} ({name})",
            )
        )
    return points
