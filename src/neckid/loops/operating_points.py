"""The operating-point protocol: CFF-RLS first-order models of the neck at several inclinations.

Seed paper, section IV: for each target inclination the neck is driven there in closed loop, a
persistent excitation is added on top of the controller's velocity command, and CFF-RLS identifies
the first-order model from velocity command ``u`` [rad/s] to inclination rate ``r`` [deg/s]

``r(t) = P · r(t−1) + N · u(t−1)``,   i.e.  ``G(z) = N / (z − P)``,

with ``r(t) = (i(t) − i(t−1)) / ts``. The converged gain ``N`` and pole ``P`` are kept with the
inclination reached; :class:`~neckid.models.scheduled.model.GainScheduledModel` then fits lines through them.

:func:`identify_operating_points` runs the protocol on a plant (the simulated neck, or anything with
``reset()`` and ``step(u) -> y``); :func:`operating_points_from_logs` runs the identification part
on logs recorded elsewhere (a real rig).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from neckid.data.iodata import IOData, as_experiments
from neckid.models.linear.rls import RecursiveARX
from neckid.models.scheduled.model import GainScheduledModel, default_window, identify_point
from neckid.signals import random_binary
from neckid.utils.checks import check_number, check_ts
from neckid.utils.types import FloatArray

if TYPE_CHECKING:
    from neckid.systems import Controller, Plant

__all__ = [
    "DEFAULT_INCLINATIONS",
    "OperatingPointResult",
    "identify_operating_points",
    "operating_points_from_logs",
]


#: The seed paper's targets: 5° to 35° every 5°.
DEFAULT_INCLINATIONS = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0)

TABLE_COLUMNS = (
    "target",
    "inclination",
    "gain",
    "pole",
    "converged",
    "settled_at",
    "n_samples",
)


@dataclass(frozen=True)
class OperatingPointResult:
    """What the operating-point protocol found.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per operating point, columns:
        ``target`` (the reference [deg], NaN when unknown), ``inclination`` (the mean measured
        inclination over the last ``window`` samples [deg]), ``gain`` (``N`` [(deg/s)/(rad/s)]),
        ``pole`` (``P``), ``converged`` (bool, :meth:`RecursiveARX.converged`), ``settled_at``
        (sample of the RLS log from which the estimate stayed in the band, -1 when never),
        ``n_samples`` (length of the identification log).
    logs : tuple of IOData
        The identification logs, one per point: inputs ``"reference"`` and ``"velocity_command"``
        [rad/s], output ``"inclination"`` [deg] (from :func:`identify_operating_points`), or the
        logs given to :func:`operating_points_from_logs`.
    models : tuple of RecursiveARX
        The fitted CFF-RLS estimators (``theta_ = [a1, b1] = [−P, N]``, with ``theta_history_``).
    ts : float
        Sampling period in seconds.
    """

    table: pd.DataFrame
    logs: tuple[IOData, ...]
    models: tuple[RecursiveARX, ...]
    ts: float
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def inclinations(self) -> FloatArray:
        """Final inclination of every point [deg]."""
        return self.table["inclination"].to_numpy(dtype=np.float64)

    @property
    def gains(self) -> FloatArray:
        """``N`` of every point."""
        return self.table["gain"].to_numpy(dtype=np.float64)

    @property
    def poles(self) -> FloatArray:
        """``P`` of every point."""
        return self.table["pole"].to_numpy(dtype=np.float64)

    @property
    def converged(self) -> NDArray[np.bool_]:
        """Whether each point's estimate converged."""
        return self.table["converged"].to_numpy(dtype=bool)

    def fit_schedule(self, degree: int = 1, converged_only: bool = True) -> GainScheduledModel:
        """Fit :class:`GainScheduledModel` lines ``N(i)``, ``P(i)`` through the points.

        With ``converged_only`` the points whose estimate did not converge are left out. The
        model takes the form the points were identified in (``settings["form"]``, default
        ``"rate"``).
        """
        table = self.table[self.table["converged"]] if converged_only else self.table
        return GainScheduledModel.from_points(
            table["inclination"].to_numpy(dtype=np.float64),
            table["gain"].to_numpy(dtype=np.float64),
            table["pole"].to_numpy(dtype=np.float64),
            ts=self.ts,
            delay=int(self.settings.get("delay", 1)),
            degree=degree,
            input_name=str(self.settings.get("input", "velocity_command")),
            output_name=str(self.settings.get("output", "inclination")),
            form=self.settings.get("form", "rate"),
        )


def identify_operating_points(
    plant: Plant,
    controller: Controller | None = None,
    inclinations: Sequence[float] = DEFAULT_INCLINATIONS,
    *,
    ts: float = 0.02,
    excitation_amplitude: float = 1.0,
    excitation_clock: int = 5,
    settle_time: float = 5.0,
    hold_time: float = 20.0,
    motor: int = 0,
    input: str | None = None,
    delay: int = 1,
    forgetting_factor: float = 0.98,
    initial_covariance: float = 1e4,
    window: int | None = None,
    tolerance: float = 0.3,
    atol: float = 0.1,
    seed: int | np.random.Generator | None = 0,
) -> OperatingPointResult:
    """Run the seed paper's operating-point protocol on a plant in closed loop.

    The plant and controller are reset once; the targets are then visited in order, as on the real
    neck (a staircase). At each target the reference is held for ``settle_time`` seconds with no
    excitation, then for ``hold_time`` seconds with a random binary signal of
    ``±excitation_amplitude`` rad/s (:func:`~neckid.signals.random_binary`) added to the command of
    ``motor``; CFF-RLS runs on the excited part (see :func:`operating_points_from_logs`).

    Parameters
    ----------
    plant : Plant
        Anything with ``reset()`` and ``step(u) -> y`` (:class:`~neckid.plant.Plant`); ``u`` is the velocity command, shape ``(n_motors,)`` [rad/s]; ``y[0]`` is the inclination
        [deg]. For example ``neckid.plant.SoftNeck(configuration="planar", ts=ts)``.
    controller : Controller, optional
        The inclination controller, anything with ``reset()`` and
        ``step(reference, measurement) -> command`` (:class:`~neckid.plant.Controller`); by default
        ``neckid.plant.InclinationController(ts=ts)``.
    inclinations : sequence of float, default 5, 10, …, 35
        Targets [deg].
    ts : float, default 0.02
        Sampling period in seconds (must be the plant's).
    excitation_amplitude : float, default 1.0
        Level of the random binary excitation [rad/s], added on top of the controller's command.
    excitation_clock : int, default 5
        Samples each excitation level is held (5 samples at 50 Hz: most of the power below 5 Hz).
    settle_time, hold_time : float, default 5.0 and 20.0
        Seconds to reach the target, and seconds of excited identification there.
    motor : int, default 0
        Which motor gets the excitation (and, with three tendons, towards whose tendon the neck
        leans: orientation ``120° · motor``).
    input : str, optional
        Channel of the :func:`~neckid.plant.closed_loop` log used as the model input: by default
        that motor's velocity command (``"velocity_command"``, or ``"velocity_command_<motor+1>"``
        with three motors); ``"motor_velocity"`` uses the measured motor velocity instead.
    delay : int, default 1
        Input delay of the first-order model in samples (1: ``r(t) = P r(t−1) + N u(t−1)``, the
        seed paper's model; a plant with a slower sensor may be better served by more).
    forgetting_factor : float, default 0.98
        CFF-RLS ``λ`` (the seed paper's value).
    initial_covariance : float, default 1e4
        CFF-RLS ``F(0) = initial_covariance · I``.
    window : int, optional
        Convergence window in samples, and samples averaged for the final inclination; default
        ``5 / (1 − λ)`` (250 for λ = 0.98, 5 s at 50 Hz).
    tolerance, atol : float, default 0.3 and 0.1
        Convergence band around the settled estimate, ``atol + tolerance · |θ|`` per parameter.
    seed : int, Generator or None, default 0
        Seeds the random binary excitation.

    Returns
    -------
    OperatingPointResult
        The table of points, the logs and the estimators.

    Raises
    ------
    ValueError
        If a setting is out of range, an inclination is not finite, or the plant returns a
        non-finite inclination (the message names the target and the sample).

    Examples
    --------
    With the scheduled model itself as a stand-in plant and a proportional controller:

    >>> from neckid.models.scheduled.model import GainScheduledModel, default_window, identify_point
    >>> truth = GainScheduledModel.from_coefficients([-0.02, 1.5], [0.01, 0.3], ts=0.02)
    >>> class P:
    ...     def reset(self): pass
    ...     def step(self, reference, measurement): return [1.0 * (reference - measurement[0])]
    >>> result = identify_operating_points(truth.simulator(), P(), [10.0, 30.0], hold_time=10.0)
    >>> result.table[["target", "converged"]]
       target  converged
    0    10.0       True
    1    30.0       True
    >>> np.round(result.gains, 1), np.round(result.poles, 1)
    (array([1.3, 0.9]), array([0.4, 0.6]))
    """
    ts = check_ts(ts)
    settle = (
        round(check_number(settle_time, "settle_time", low=0, closed="neither") / ts)
        if settle_time
        else 0
    )
    hold = round(check_number(hold_time, "hold_time", low=0, closed="neither") / ts)
    amplitude = check_number(excitation_amplitude, "excitation_amplitude", low=0, closed="neither")
    targets = [float(v) for v in inclinations]
    if not targets:
        raise ValueError("inclinations is empty; give at least one target inclination in degrees")
    for value in targets:
        if not math.isfinite(value):
            raise ValueError(f"inclinations must be finite degrees; got {value!r}")
    from neckid.plant import InclinationController, closed_loop

    if controller is None:
        controller = InclinationController(ts=ts)
    n_motors = int(getattr(controller, "n_motors", getattr(plant, "n_motors", 1)))
    if isinstance(motor, bool) or not isinstance(motor, int | np.integer):
        raise TypeError(f"motor must be an int; got {motor!r}")
    if not 0 <= motor < n_motors:
        raise ValueError(f"motor must index one of the {n_motors} motor(s); got {motor!r}")
    rng = np.random.default_rng(seed)
    segment = settle + hold
    reference = np.repeat(np.asarray(targets), segment)
    excitation = np.zeros((reference.size, n_motors))
    for k in range(len(targets)):
        start = k * segment + settle
        excitation[start : start + hold, motor] = random_binary(
            hold, amplitude, excitation_clock, seed=rng
        )
    if getattr(controller, "n_references", 1) != 1:
        # Three tendons: lean towards the excited motor's tendon (orientation 120° per motor).
        reference = np.column_stack([reference, np.full(reference.size, 120.0 * motor)])
    record = closed_loop(plant, controller, reference, ts, excitation=excitation)
    command_name = "velocity_command" if n_motors == 1 else f"velocity_command_{motor + 1}"
    if input is None:
        input = command_name
    inclination_name = record.output_names[0]
    logs = [
        record[k * segment + settle : (k + 1) * segment].renamed(f"operating point {target:g} deg")
        for k, target in enumerate(targets)
    ]
    result = operating_points_from_logs(
        logs,
        input=input,
        output=inclination_name,
        targets=targets,
        delay=delay,
        forgetting_factor=forgetting_factor,
        initial_covariance=initial_covariance,
        window=window,
        tolerance=tolerance,
        atol=atol,
    )
    settings = {
        **result.settings,
        "excitation_amplitude": amplitude,
        "excitation_clock": int(excitation_clock),
        "settle_time": float(settle_time),
        "hold_time": float(hold_time),
        "motor": int(motor),
    }
    return OperatingPointResult(result.table, result.logs, result.models, result.ts, settings)


def operating_points_from_logs(
    logs: IOData | Sequence[IOData],
    *,
    input: str = "velocity_command",
    output: str = "inclination",
    targets: ArrayLike | None = None,
    skip: int = 0,
    delay: int = 1,
    forgetting_factor: float = 0.98,
    initial_covariance: float = 1e4,
    window: int | None = None,
    tolerance: float = 0.3,
    atol: float = 0.1,
    form: Literal["rate", "position"] = "rate",
) -> OperatingPointResult:
    """Identify ``N`` and ``P`` by CFF-RLS on recorded operating-point logs, one point per log.

    Parameters
    ----------
    logs : IOData or sequence of IOData
        Each log holds the neck at one operating point under persistent excitation.
    input : str, default "velocity_command"
        Channel of the command (input or output of the log): the velocity command [rad/s] in
        the rate form, a motor position [rad] in the position form.
    output : str, default "inclination"
        Channel of the inclination [deg].
    targets : array_like, optional
        Target inclination of each log [deg], for the table; by default the last value of a
        ``"reference"`` channel when the log has one, else NaN.
    skip : int, default 0
        Samples dropped at the start of every log (a transient before the excitation).
    delay : int, default 1
        Input delay ``d`` of the model ``r(t) = P r(t−1) + N u(t−d)``, in samples.
    forgetting_factor, initial_covariance : float, default 0.98 and 1e4
        CFF-RLS settings (``λ``, ``F(0) = initial_covariance · I``).
    window : int, optional
        Convergence window and samples averaged for the final inclination; default ``5 / (1 − λ)``.
    tolerance, atol : float, default 0.3 and 0.1
        Convergence band ``atol + tolerance · |θ|`` (see :meth:`RecursiveARX.converged`).
    form : {"rate", "position"}, default "rate"
        The seed paper's ``r(t) = P r(t−1) + N u(t−d)`` on the inclination rate, or
        ``i(t) = P i(t−1) + N u(t−d)`` on the inclination (see
        :class:`~neckid.models.scheduled.model.GainScheduledModel`); kept in ``settings["form"]``.

    Returns
    -------
    OperatingPointResult

    Raises
    ------
    KeyError
        If a log lacks the ``input`` or ``output`` channel.
    ValueError
        If a log is shorter than ``skip + window + 3`` samples, or the lengths of ``targets`` and
        ``logs`` differ.

    Notes
    -----
    With ``r(t) = (i(t) − i(t−1)) / ts`` [deg/s], :class:`RecursiveARX` ``(na=1, nb=1, delay=d)``
    estimates ``θ = [a1, b1]`` in ``r(t) = −a1 r(t−1) + b1 u(t−d)``, so ``P = −a1`` and ``N = b1``
    (in the position form the same with the inclination ``i`` in place of ``r``).
    The gain and pole kept are the means of the estimates over the last ``window`` samples: with
    ``λ = 0.98`` the estimates keep fluctuating with a memory of about ``1 / (1 − λ) = 50`` samples,
    and the mean of the settled part is less noisy than the last value (the final ``θ̂`` is in
    ``models[k].theta_``). The point is flagged converged when every estimate stayed in the band
    ``atol + tolerance · |θ̄|`` around that mean ``θ̄`` over those samples.
    """
    experiments = list(logs) if not isinstance(logs, IOData) else [logs]
    if not experiments:
        raise ValueError("logs is empty; give at least one IOData")
    as_experiments(experiments[:1])
    target_values = _log_targets(experiments, targets)
    if isinstance(skip, bool) or not isinstance(skip, int | np.integer) or skip < 0:
        raise ValueError(f"skip must be a whole number of samples >= 0; got {skip!r}")
    lam = float(forgetting_factor)
    if window is None:
        window = default_window(lam) if 0 < lam <= 1 else 1
    rows: list[dict[str, Any]] = []
    models: list[RecursiveARX] = []
    ts = experiments[0].ts
    for index, log in enumerate(experiments):
        label, u, incl = _log_signals(log, index, input, output, skip, window)
        point = identify_point(
            u,
            incl,
            log.ts,
            form=form,
            delay=delay,
            forgetting_factor=forgetting_factor,
            initial_covariance=initial_covariance,
            window=window,
            tolerance=tolerance,
            atol=atol,
            input_name=input,
            output_name=output,
            input_unit=log.unit(input),
            output_unit=log.unit(output),
            label=label,
        )
        models.append(point.model)
        rows.append(
            {
                "target": target_values[index],
                "inclination": point.inclination,
                "gain": point.gain,
                "pole": point.pole,
                "converged": point.converged,
                "settled_at": point.settled_at,
                "n_samples": point.n_samples,
            }
        )
    table = pd.DataFrame(rows, columns=list(TABLE_COLUMNS))
    settings = {
        "delay": int(delay),
        "forgetting_factor": lam,
        "initial_covariance": float(initial_covariance),
        "window": int(window),
        "tolerance": float(tolerance),
        "atol": float(atol),
        "skip": int(skip),
        "input": str(input),
        "output": str(output),
        "form": str(form),
    }
    return OperatingPointResult(table, tuple(experiments), tuple(models), ts, settings)


def _log_targets(experiments: list[Any], targets: ArrayLike | None) -> list[float]:
    """The target inclination of each log: ``targets``, else the last reference value, else NaN."""
    if targets is None:
        return [
            float(log.channel("reference")[-1])
            if "reference" in (*log.input_names, *log.output_names)
            else math.nan
            for log in experiments
        ]
    target_values = [float(v) for v in np.asarray(targets, dtype=np.float64).reshape(-1)]
    if len(target_values) != len(experiments):
        raise ValueError(f"targets has {len(target_values)} values for {len(experiments)} logs")
    return target_values


def _log_signals(
    log: Any, index: int, input: str, output: str, skip: int, window: int
) -> tuple[str, FloatArray, FloatArray]:
    """A log's label and its command and inclination after ``skip``, checked long enough."""
    if not isinstance(log, IOData):
        raise TypeError(f"logs[{index}] must be an IOData; got {type(log).__name__}")
    label = log.name or f"logs[{index}]"
    try:
        u = np.asarray(log.channel(input))[skip:]
        incl = np.asarray(log.channel(output))[skip:]
    except KeyError as exc:
        raise KeyError(f"{label}: {exc.args[0]}; set input=... and output=...") from None
    if incl.size < window + 3:
        raise ValueError(
            f"{label} has {log.n_samples} samples; the protocol needs at least"
            f" skip + window + 3 = {skip + window + 3}"
        )
    return label, u, incl
