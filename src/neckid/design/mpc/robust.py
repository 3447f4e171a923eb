r"""Output constraints tightened by a Set Membership model's k-step bands (tube MPC's tightening).

The nominal controller keeps its *prediction* inside the limits; the plant's output may leave
them by the prediction's error. Tube MPC (Mayne, Seron & Raković, *Automatica* 41, 2005;
Chisci, Rossiter & Zappa, *Automatica* 37, 2001) keeps the nominal prediction inside limits
shrunk by a bound of that error at each horizon step. Here the bound comes from a
:class:`~neckid.models.set_membership.multistep.MultiStepSetMembership` fitted beside the linear
model: under its prior of horizon :math:`K` (:math:`\varepsilon_K`, :math:`\gamma_K`), the
measurement :math:`y(t+K)` lies in its guaranteed band :math:`[\underline y_K(t),
\overline y_K(t)] = [f_{l,K} - \varepsilon_K, f_{u,K} + \varepsilon_K]` built from the measured
outputs up to :math:`t` and the inputs up to :math:`t + K`.

:func:`band_tightening` measures, on design logs run in closed loop, for each horizon step
:math:`j` (band horizon :math:`K = j + d`, :math:`d` the computation delay: the controller at
step :math:`k` has measured up to :math:`t = k - d`)

.. math:: w_j = \max_t \max\bigl(\overline y_K(t) - \hat y_K(t),\ \hat y_K(t) - \underline y_K(t)\bigr),

:math:`\hat y_K(t)` the controller's own prediction (its matrices, its disturbance estimate run
along the log, the log's commands as the plan). Then, **what is guaranteed**: at every step
whose QP is solved with zero slack, the sample the move first acts on,
:math:`y(k+1)` (horizon step 1, band horizon :math:`1 + d`), satisfies
:math:`y_{min} \le y(k+1) \le y_{max}` whenever

1. the SM prior of horizon :math:`1 + d` holds on the run (:math:`y(k+1)` is in the band: the
   SM model's invalidation test checks it afterwards), and
2. the band lies within :math:`w_1` of the controller's prediction, as it did at every anchor of
   the design logs (measured, not proven: outside the design logs' region it may not).

Steps :math:`j > 1` of each plan are kept inside their own tightened limits, so the plan stays
admissible as it is shifted; recursive feasibility is not proven (no terminal set): a step
where the tightened constraint cannot be met uses the slack and is counted
(:attr:`~neckid.design.mpc.controller.SolveStats.slack_steps`). Nothing is guaranteed under
a prior that does not hold (a neck outside the SM data, a disturbance beyond
:math:`\varepsilon`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from neckid.data.iodata import IOData
from neckid.design.linearise import COMMAND
from neckid.design.mpc.controller import MPCController
from neckid.design.mpc.problem import MPCProblem
from neckid.utils.types import FloatArray

__all__ = ["BandTightening", "band_tightening", "controller_predictions", "design_mpc"]


@dataclass(frozen=True)
class BandTightening:
    """The tightening and what it was measured on.

    Attributes
    ----------
    tightening : ndarray, shape (N,)
        :math:`w_j` [deg], for :func:`~neckid.design.mpc.problem.mpc_problem`.
    band_horizons : ndarray of int, shape (N,)
        :math:`K = j + d`.
    half_width : ndarray, shape (N,)
        Mean half-width of the SM band at each :math:`K` on the logs [deg].
    coverage : ndarray, shape (N,)
        Share of the logs' samples inside the band at each :math:`K`.
    anchors : int
        Anchors measured per horizon (all logs).
    """

    tightening: FloatArray
    band_horizons: FloatArray
    half_width: FloatArray
    coverage: FloatArray
    anchors: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "tightening_deg": self.tightening.tolist(),
            "band_horizons": [int(k) for k in self.band_horizons],
            "half_width_deg": self.half_width.tolist(),
            "coverage": self.coverage.tolist(),
            "anchors": self.anchors,
        }


def controller_predictions(
    problem: MPCProblem, log: IOData, output: str = "inclination"
) -> FloatArray:
    """The controller's predictions along a closed-loop log, with the log's commands as its plan.

    Parameters
    ----------
    problem : MPCProblem
    log : IOData
        A closed-loop log with the ``velocity_command`` input and the output.
    output : str, default "inclination"

    Returns
    -------
    ndarray, shape (n, N + d)
        Row ``t``: the predictions of ``y(t + 1) … y(t + N + d)`` from the measurements up to
        ``t`` (NaN where the log is too short or the history not yet full).
    """
    y = log.channel(output)
    u = log.channel(COMMAND)
    pr = problem
    n, na, p, nu, d = y.size, pr.a.size, pr.n_past_commands, pr.control_horizon, pr.delay
    rows = pr.horizon + d
    out = np.full((n, rows), np.nan)
    delta, predicted = 0.0, None
    start = max(na, p)
    for t in range(n):
        k = t + d  # the controller's step that measured y(t)
        if predicted is not None:
            delta += pr.disturbance_gain * (y[t] - predicted)
        if t < start or k + nu > n:
            predicted = None
            continue
        history = np.concatenate([y[t - np.arange(na)], u[k - 1 - np.arange(p)]])
        moves = u[k : k + nu]
        out[t] = pr.predict(history, moves, delta)
        predicted = float(out[t, 0])
    return out


def _band(model: Any, log: IOData, steps: int) -> tuple[FloatArray, FloatArray]:
    """The SM model's guaranteed band of ``y(s)`` made at ``s - steps`` (NaN where none)."""
    view = log.select(inputs=list(model.input_names_), outputs=list(model.output_names_))
    pipeline = getattr(model, "preprocessing_", None)  # the model's own (relative position, ...)
    if pipeline is not None:
        view = pipeline.apply(view)
    result = model.predict_ahead(view, steps=steps)
    return np.asarray(result.lower)[:, 0], np.asarray(result.upper)[:, 0]


def band_tightening(
    problem: MPCProblem, model: Any, logs: IOData | Sequence[IOData]
) -> BandTightening:
    r""":math:`w_j` of the module docstring, measured on closed-loop logs.

    Parameters
    ----------
    problem : MPCProblem
        The nominal controller (its tightening is not read).
    model : MultiStepSetMembership
        Fitted with every horizon :math:`1 + d \dots N + d` (``horizon=N + d``), on the
        inclination (its first output) and channels the logs hold.
    logs : IOData or sequence of IOData
        Closed-loop logs with ``velocity_command``, the model's channels and the inclination.

    Returns
    -------
    BandTightening

    Raises
    ------
    ValueError
        If the model lacks a horizon the controller needs.
    """
    if not callable(getattr(model, "predict_ahead", None)) or not hasattr(model, "horizons_"):
        raise TypeError(
            "the tightening needs a fitted MultiStepSetMembership (its guaranteed k-step bands);"
            f" got {type(model).__name__}"
        )
    runs = [logs] if isinstance(logs, IOData) else list(logs)
    d, n = problem.delay, problem.horizon
    wanted = np.arange(1, n + 1) + d
    missing = sorted(set(wanted.tolist()) - {int(k) for k in model.horizons_})
    if missing:
        raise ValueError(
            f"the Set Membership model has no band at horizons {missing}: fit it with"
            f" horizon={int(wanted[-1])} (the controller's horizon plus its delay)"
        )
    output = model.output_names_[0]
    gaps: list[list[FloatArray]] = [[] for _ in range(n)]
    widths: list[list[FloatArray]] = [[] for _ in range(n)]
    inside: list[list[FloatArray]] = [[] for _ in range(n)]
    for log in runs:
        predictions = controller_predictions(problem, log, output)
        y = log.channel(output)
        for j, steps in enumerate(wanted):
            lower, upper = _band(model, log, int(steps))
            yhat = np.full(y.size, np.nan)
            yhat[steps:] = predictions[: y.size - steps, d + j]
            ok = np.isfinite(yhat) & np.isfinite(lower) & np.isfinite(upper)
            gaps[j].append(np.maximum(upper[ok] - yhat[ok], yhat[ok] - lower[ok]))
            widths[j].append((upper[ok] - lower[ok]) / 2.0)
            inside[j].append((y[ok] >= lower[ok]) & (y[ok] <= upper[ok]))
    tightening = np.array([float(np.max(np.concatenate(g))) for g in gaps])
    return BandTightening(
        tightening=tightening,
        band_horizons=wanted.astype(np.float64),
        half_width=np.array([float(np.mean(np.concatenate(w))) for w in widths]),
        coverage=np.array([float(np.mean(np.concatenate(c))) for c in inside]),
        anchors=int(sum(g.size for g in gaps[0])),
    )


def design_mpc(
    model: Any,
    *,
    inclination: float | None = None,
    computation_delay: int = 1,
    drive_time_constant: float = 0.0,
    set_membership: Any = None,
    design_logs: IOData | Sequence[IOData] | None = None,
    info: dict[str, Any] | None = None,
    on_late: Literal["hold", "use"] = "hold",
    **settings: Any,
) -> MPCController:
    """An MPC controller on a model's linear form, nominal or tightened by SM bands.

    Parameters
    ----------
    model : fitted model or python-control system
        Anything :func:`~neckid.design.linear_form.linear_form` takes.
    inclination, computation_delay, drive_time_constant
        As for :func:`~neckid.design.linear_form.linear_form`.
    set_membership : MultiStepSetMembership, optional
        Tighten the output limits by its k-step bands (:func:`band_tightening`), measured on
        ``design_logs`` (required then).
    design_logs : IOData or sequence of IOData, optional
        Closed-loop logs (``velocity_command``, the SM model's channels).
    info : dict, optional
        Kept in the controller file (``model``: the model's description).
    on_late : {"hold", "use"}, default "hold"
        :class:`~neckid.design.mpc.controller.MPCController`'s.
    **settings
        :func:`~neckid.design.mpc.problem.mpc_problem`'s keywords (``horizon``,
        ``output_max``, ...).

    Returns
    -------
    MPCController
        ``problem.info["robust"]`` holds the tightening's measurements when tightened.
    """
    from neckid.design.linear_form import linear_form
    from neckid.design.mpc.problem import mpc_problem

    form = linear_form(
        model,
        inclination=inclination,
        computation_delay=computation_delay,
        drive_time_constant=drive_time_constant,
    )
    record = dict(info or {})
    record["plant"] = form.to_dict()
    nominal = mpc_problem(form, info=record, **settings)
    if set_membership is None:
        return MPCController(nominal, on_late=on_late)
    if design_logs is None:
        raise ValueError("a tightening by Set Membership bands needs design_logs (closed-loop)")
    if "tightening" in settings:
        raise ValueError("give set_membership or tightening, not both")
    measured = band_tightening(nominal, set_membership, design_logs)
    record["robust"] = {
        "set_membership": type(set_membership).__name__,
        "design_logs": len([design_logs] if isinstance(design_logs, IOData) else design_logs),
        **measured.to_dict(),
        **(record.get("robust") or {}),
    }
    tightened = mpc_problem(form, tightening=measured.tightening, info=record, **settings)
    return MPCController(tightened, on_late=on_late)
