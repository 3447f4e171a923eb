"""``neckid design MODEL --mpc``: a predictive controller file (neckid.design.mpc)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import typer

MPC_OPTION = typer.Option(
    False,
    "--mpc",
    help="A linear model predictive controller (OSQP each step) on the model's linear form,"
    " instead of a PI: horizon, weights, the motor's velocity and rate limits, optional"
    " inclination limits and reference preview (the documentation page 'Predictive control').",
)
HORIZON_OPTION = typer.Option(
    25, "--horizon", min=1, max=1000, help="With --mpc: prediction horizon [samples]."
)
PREVIEW_OPTION = typer.Option(
    True,
    "--preview/--no-preview",
    help="With --mpc: read the future reference when the loop gives it (a staircase known"
    " ahead); without, the current reference is held over the horizon.",
)
MOVE_WEIGHT_OPTION = typer.Option(
    5.0, "--move-weight", min=0.0, help="With --mpc: weight of the command moves [1/(rad/s)^2]."
)
RATE_LIMIT_OPTION = typer.Option(
    200.0,
    "--rate-limit",
    min=0.0,
    help="With --mpc: largest change of the command per second [rad/s^2] (the drive's 200).",
)
OUTPUT_MIN_OPTION = typer.Option(
    None, "--output-min", metavar="DEG", help="With --mpc: lowest inclination allowed [deg]."
)
OUTPUT_MAX_OPTION = typer.Option(
    None, "--output-max", metavar="DEG", help="With --mpc: highest inclination allowed [deg]."
)
TIGHTEN_OPTION = typer.Option(
    None,
    "--tighten",
    metavar="SM_MODEL",
    help="With --mpc and an inclination limit: a sm-multistep model file (fitted with"
    " --horizon plus --delay horizons); the limits are tightened by its k-step bands around"
    " the controller's prediction, measured on the --tighten-log logs.",
    exists=True,
)
ON_LATE_OPTION = typer.Option(
    "hold",
    "--on-late",
    help="With --mpc: a solve later than the period holds the previous command (hold, a"
    " real-time loop), or is counted and used (use, a simulation: results that do not depend"
    " on the machine's load).",
)
TIGHTEN_LOG_OPTION = typer.Option(
    None,
    "--tighten-log",
    help="With --tighten: a closed-loop CSV log (velocity_command, the SM model's channels);"
    " repeat for several.",
)

#: The PI / fractional options --mpc does not take (option -> what it was given as).
_NOT_WITH_MPC = ("--fractional", "--scheduled", "--discretisation", "--order", "--report")


def refuse_pi_options(given: dict[str, Any]) -> None:
    """Refuse the PI / fractional options with --mpc, naming the first one given."""
    for name in _NOT_WITH_MPC:
        value = given.get(name)
        if value not in (None, False):
            raise ValueError(
                f"{name} designs a PI or fractional controller; leave it out with --mpc"
            )


def _read_logs(paths: list[Path], sm: Any) -> list[Any]:
    """The closed-loop logs: the SM model's channels and the command, as CSV columns."""
    from neckid.cli.workflow import read_log

    inputs = list(dict.fromkeys([*sm.input_names_, "velocity_command"]))
    logs = []
    for path in paths:
        if not path.is_file():
            raise FileNotFoundError(f"--tighten-log {str(path)!r} does not exist")
        logs.append(read_log(path, inputs=inputs, outputs=list(sm.output_names_)))
    return logs


def design_mpc_controller(
    model_path: Path, model: Any, options: dict[str, Any], description: dict[str, Any]
) -> Any:
    """The MPC controller the command's options ask for."""
    from neckid.design.mpc import DEFAULT_COMMAND_LIMIT, design_mpc
    from neckid.models.io import load_model

    if options["on_late"] not in ("hold", "use"):
        raise ValueError(f"--on-late must be hold or use; got {options['on_late']!r}")
    limit = options["command_limit"]
    low, high = options["output_min"], options["output_max"]
    settings: dict[str, Any] = {
        "horizon": options["horizon"],
        "preview": options["preview"],
        "move_weight": options["move_weight"],
        "rate_limit": options["rate_limit"],
        "command_limit": DEFAULT_COMMAND_LIMIT if limit is None else limit,
        "output_min": -math.inf if low is None else low,
        "output_max": math.inf if high is None else high,
    }
    sm, logs = None, None
    if options["tighten"] is not None:
        if low is None and high is None:
            raise ValueError(
                "--tighten tightens an inclination limit: give --output-max or --output-min"
            )
        if not options["tighten_logs"]:
            raise ValueError("--tighten needs one or more --tighten-log (closed-loop logs)")
        sm = load_model(options["tighten"])
        logs = _read_logs(list(options["tighten_logs"]), sm)
    elif options["tighten_logs"]:
        raise ValueError("--tighten-log goes with --tighten SM_MODEL")
    return design_mpc(
        model,
        inclination=options["inclination"],
        computation_delay=options["delay"],
        drive_time_constant=options["drive_time_constant"],
        set_membership=sm,
        design_logs=logs,
        info={"model": description},
        on_late=options["on_late"],
        **settings,
    )


def mpc_summary_lines(controller: Any) -> list[str]:
    """What the command prints about an MPC controller (and ``neckid info`` about its file)."""
    pr = controller.problem
    lines = [
        f"mpc controller, ts = {pr.ts:g} s, horizon {pr.horizon} samples"
        f" ({pr.horizon * pr.ts:g} s), control horizon {pr.control_horizon},"
        f" preview {'on' if pr.preview else 'off'}, delay {pr.delay}",
        f"model: {pr.source}; difference equation with {pr.a.size} output and {pr.b.size}"
        " command coefficients, an integrating disturbance (Kalman gain"
        f" {pr.disturbance_gain:.4g})",
        f"weights: tracking {pr.tracking_weight:g} /deg^2, moves {pr.move_weight:g} /(rad/s)^2;"
        f" limits: |u| <= {pr.command_limit:g} rad/s, |du/dt| <= {pr.rate_limit:g} rad/s^2",
    ]
    if pr.constrained:
        lines.append(
            f"inclination in [{pr.output_min:g}, {pr.output_max:g}] deg, tightened by"
            f" {pr.tightening[0]:.3g} deg at step 1 to {pr.tightening[-1]:.3g} deg at step"
            f" {pr.horizon}"
            + (" (Set Membership k-step bands)" if "robust" in pr.info else " (nominal)")
        )
    return lines
