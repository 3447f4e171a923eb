"""The command that designs a controller from a saved model: design (a JSON controller file)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

import typer

from neckid.cli._app import FORCE_OPTION, app, console, handled
from neckid.cli.design_mpc import (
    HORIZON_OPTION,
    MOVE_WEIGHT_OPTION,
    MPC_OPTION,
    ON_LATE_OPTION,
    OUTPUT_MAX_OPTION,
    OUTPUT_MIN_OPTION,
    PREVIEW_OPTION,
    RATE_LIMIT_OPTION,
    TIGHTEN_LOG_OPTION,
    TIGHTEN_OPTION,
    design_mpc_controller,
    mpc_summary_lines,
    refuse_pi_options,
)

DISCRETISATION_HELP = (
    "How the fractional operator s^order is realised: gl (the lab's truncated Grünwald–Letnikov"
    " sum, 12 taps; the order from the continuous iso-damping condition, as the lab's tuner) or"
    " oustaloup (Oustaloup's filter over [wc/100, min(100 wc, pi/(2 ts))]; the order flattens"
    " the realised loop's phase)."
)


#: ``--delay`` when it is not given: neckid's simulated loop (closed_loop, model in the loop).
DEFAULT_DELAY = 1

#: The largest ``--delay`` [samples]: the closed loop's characteristic polynomial has a degree of
#: at least the delay, and its roots a companion matrix of that size squared (20 s at 0.02 s).
MAX_DELAY = 1000


def _check_delay(value: int | None) -> int | None:
    """``--delay``: a whole number of samples in [0, :data:`MAX_DELAY`] (refused by the option)."""
    if value is not None and not 0 <= value <= MAX_DELAY:
        raise typer.BadParameter(
            f"the computation delay must be 0 to {MAX_DELAY} samples (the loop's polynomials"
            f" grow with it); got {value}"
        )
    return value


def _delay_line(delay: int | None) -> str:
    """Which computation delay the design used, and where it came from."""
    if delay is not None:
        return f"computation delay: {delay} sample(s) (--delay)"
    return (
        f"computation delay: {DEFAULT_DELAY} sample (the default, neckid's simulated loop; on the"
        " lab's bench, where the command is computed in the period of its measurement, give"
        " --delay 0)"
    )


def _design(model: Any, options: dict[str, Any]) -> Any:
    """The design (fixed or scheduled) the options ask for."""
    from neckid.design import design_fractional, design_pi, design_scheduled, linear_form

    kind: Literal["pi", "fractional"] = "fractional" if options["fractional"] else "pi"
    if kind == "pi" and options["discretisation"] is not None:
        raise ValueError(
            f"--discretisation {options['discretisation']} applies to a fractional controller"
            " (a PI's integrator is always Tustin's): add --fractional, or leave it out"
        )
    fractional = {"discretisation": options["discretisation"] or "gl", "order": options["order"]}
    if options["scheduled"]:
        if options["inclination"] is not None:
            raise ValueError(
                "--scheduled designs over the model's inclinations: leave out --inclination"
            )
        return design_scheduled(
            model,
            options["pm"],
            options["wc"],
            kind=kind,
            computation_delay=options["delay"],
            drive_time_constant=options["drive_time_constant"],
            **(fractional if kind == "fractional" else {}),
        )
    form = linear_form(
        model,
        inclination=options["inclination"],
        computation_delay=options["delay"],
        drive_time_constant=options["drive_time_constant"],
    )
    if kind == "pi":
        if options["order"] is not None:
            raise ValueError("--order applies to a fractional controller: add --fractional")
        return design_pi(form, options["pm"], options["wc"])
    return design_fractional(form, options["pm"], options["wc"], **fractional)


def _summary_lines(document: dict[str, Any]) -> list[str]:
    gains = document["gains"]
    achieved = document["achieved"] or {}
    lines = [
        f"{document['kind']} controller, ts = {document['ts']:g} s,"
        f" discretisation {document['discretisation']['method']}",
        "gains: "
        + ", ".join(f"{k} = {v:.5g}" for k, v in gains.items())
        + ("" if document["order"] == -1.0 else f", order = {document['order']:.4f}"),
    ]
    if achieved:
        gm = achieved.get("gain_margin")
        lines.append(
            f"on the model: phase margin {achieved['phase_margin_deg']:.2f} deg at"
            f" {achieved['crossover_rad_s']:.4f} rad/s, gain margin"
            f" {'inf' if gm is None else f'{gm:.2f}'}, phase slope"
            f" {achieved['phase_slope_deg_per_rad_s']:.3f} deg/(rad/s), Ms"
            f" {achieved['sensitivity_peak']:.2f}, closed loop"
            f" {'stable' if achieved.get('closed_loop_stable') else 'UNSTABLE'}"
        )
    rule = document["design"].get("order_rule")
    if rule and document["order"] != -1.0:
        flat = document["design"].get("flat_phase_reached")
        lines.append(f"order: {rule}; flat phase on the model: {'yes' if flat else 'no'}")
    if document["schedule"] is not None:
        table = document["schedule"]
        lines.append(
            "schedule over the measured inclination: "
            + ", ".join(
                f"{i:g} deg: kp {p:.4g}, kf {f:.4g}"
                for i, p, f in zip(table["inclinations"], table["kp"], table["kf"], strict=True)
            )
        )
    return lines


def describe_controller_file(path: Path) -> dict[str, Any]:
    """``neckid info`` of a controller file: its kind, what it says, the model it was designed on."""
    from neckid.design.files import controller_document, load_controller

    controller = load_controller(path)
    if getattr(controller, "kind", None) == "mpc":
        from neckid.design.mpc import mpc_document

        document = mpc_document(controller)
        problem = document["problem"]
        return {
            "file": str(path),
            "kind": "mpc",
            "summary": mpc_summary_lines(controller),
            "model": document["model"],
            "robust": document["robust"],
            "solver": document["solver"],
            "prediction_matrices": {
                k: [len(problem[k]), len(problem[k][0])] for k in ("free", "forced")
            },
        }
    document = controller_document(controller)
    return {
        "file": str(path),
        "kind": document["kind"],
        "summary": _summary_lines(document),
        "model": document["model"],
    }


def _design_mpc(model_path: Path, options: dict[str, Any], out: Path) -> None:
    """``--mpc``: design, write and describe a predictive controller."""
    from neckid.design import model_description, save_controller
    from neckid.models.io import load_model

    refuse_pi_options(options)
    model = load_model(model_path)
    description = model_description(model_path, model, options["inclination"])
    controller = design_mpc_controller(model_path, model, options, description)
    save_controller(controller, out)
    for line in mpc_summary_lines(controller):
        console.print(line, markup=False)
    console.print(f"controller written to {out}", markup=False)


def _write_report(controller: Any, design: Any, staged: Any) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    from neckid.design import controller_document, simulated_neck_tests
    from neckid.design.plots import plot_loop
    from neckid.plant import InclinationController
    from neckid.report.html import Figure, Report

    document = controller_document(controller)
    designs = getattr(design, "designs", (design,))
    middle = designs[len(designs) // 2]
    inclination = float(design.inclinations[len(designs) // 2]) if len(designs) > 1 else None
    report = Report("neckid design")
    report.add_text("Controller", "\n\n".join(_summary_lines(document)))
    rows = [d.summary()["achieved"] for d in designs]
    margins = pd.DataFrame(rows)
    if len(designs) > 1:
        margins.insert(0, "inclination_deg", design.inclinations)
    report.add_table("Margins on the model", margins)
    fig = plot_loop(
        controller,
        middle.form,
        phase_margin=middle.spec.phase_margin,
        crossover=middle.spec.crossover,
        inclination=inclination,
    )
    fig.savefig(staged.path("loop.png"), dpi=110, bbox_inches="tight")
    plt.close(fig)
    report.add_figures("Loop on the model", [Figure(staged.path("loop.png"), "C G, Bode")])
    tests = simulated_neck_tests(
        {"designed": controller, "demo PI": InclinationController(ts=controller.ts)},
        ts=controller.ts,
    )
    report.add_table(
        "The simulated neck, the paper's tests 1-3",
        tests.table,
        note="Tracking error RMS [deg] on neckid's simulated neck (seed 7), beside the demo's"
        " PI (kp 0.35, ki 0.6, 4 rad/s limit). A check of the controller on a neck like the"
        " lab's; for a model of another rig it says little.",
    )
    report.write(staged.path("report.html"))
    console.print(f"report written to {staged.final('report.html')}", markup=False)


@app.command()
@handled
def design(
    model_path: Path = typer.Argument(
        ..., metavar="MODEL", help="A model file written by identify (or the demo).", exists=True
    ),
    pm: float = typer.Option(50.0, "--pm", help="Phase margin [deg]."),
    wc: float = typer.Option(3.0, "--wc", help="Crossover frequency [rad/s]."),
    fractional: bool = typer.Option(
        False,
        "--fractional",
        help="A fractional kp + kf s^order (order in (-1, 0): PI^lambda, or (0, 1): PD^mu) with a"
        " flat phase at the crossover (iso-damping); default a PI (Tustin integrator).",
    ),
    scheduled: bool = typer.Option(
        False,
        "--scheduled",
        help="Schedule the gains over the measured inclination (a scheduled CFF-RLS model: a"
        " design at each of its operating points, one order).",
    ),
    inclination: float = typer.Option(
        None,
        "--inclination",
        metavar="DEG",
        help="Operating point [deg]: freezes a scheduled model there, or linearises a nonlinear"
        " one (Set Membership, neural, polynomial) there.",
    ),
    discretisation: str = typer.Option(
        None, "--discretisation", help=DISCRETISATION_HELP + " Default gl.", show_default=False
    ),
    order: float = typer.Option(
        None, "--order", help="Fix the fractional order instead of choosing it for a flat phase."
    ),
    delay: int = typer.Option(
        None,
        "--delay",
        callback=_check_delay,
        help="Samples between a measurement and the command computed from it: 1 in neckid's"
        " closed_loop and model-in-the-loop; 0 on the lab's bench (sensor read and command in"
        " the same period). Default 1, said in the output (a bench model wants 0).",
        show_default=False,
    ),
    drive_time_constant: float = typer.Option(
        0.0,
        "--drive-time-constant",
        min=0.0,
        help="Time constant [s] of the drive's velocity loop, for a model of the motor position"
        " (0: the motor integrates the command; the simulated neck's is 0.015).",
    ),
    command_limit: float = typer.Option(
        None,
        "--command-limit",
        help="Saturate the command at this many rad/s, with conditional integration (the demo's"
        " PI: 4).",
    ),
    out: Path = typer.Option(..., "--out", help="The controller file to write (.json)."),
    report: Path = typer.Option(
        None, "--report", help="Write a short HTML report into this folder."
    ),
    mpc: bool = MPC_OPTION,
    horizon: int = HORIZON_OPTION,
    preview: bool = PREVIEW_OPTION,
    move_weight: float = MOVE_WEIGHT_OPTION,
    rate_limit: float = RATE_LIMIT_OPTION,
    output_min: float = OUTPUT_MIN_OPTION,
    output_max: float = OUTPUT_MAX_OPTION,
    tighten: Path = TIGHTEN_OPTION,
    tighten_logs: list[Path] = TIGHTEN_LOG_OPTION,
    on_late: str = ON_LATE_OPTION,
    force: bool = FORCE_OPTION,
) -> None:
    """Design a PI or a fractional controller for a phase margin at a crossover, from a saved model.

    The model's linear form (velocity command [rad/s] -> inclination [deg]; a model of the motor
    position through the drive) is read from linear models (arx, rls, ss), from the scheduled
    model at --inclination (or over its range with --scheduled), or from a nonlinear model
    linearised at --inclination. Example: neckid design model.npz --pm 50 --wc 3 --fractional
    --out controller.json

    With --mpc, a linear model predictive controller on the same linear form instead (OSQP
    each step; --horizon, --move-weight, --rate-limit, --command-limit, --output-min/--output-max,
    --preview, --tighten SM_MODEL with --tighten-log LOG: the documentation page "Predictive
    control"). Example: neckid design model.npz --mpc --output-max 31 --out mpc.json

    The file runs in neckid validate --in-loop --controller FILE, in neckid.plant.closed_loop
    (neckid.design.load_controller) and in python-control (its to_control()). Equations,
    discretisations and measurements: the documentation page "Controllers designed from models".
    """
    from contextlib import nullcontext

    from neckid.design import controller_document, model_description, save_controller
    from neckid.models.io import load_model
    from neckid.utils.files import check_output_file, output_folder

    check_output_file(out, force=force, inputs=[model_path], option="--out", suffixes=[".json"])
    if command_limit is not None and not (math.isfinite(command_limit) and command_limit > 0):
        raise ValueError(f"--command-limit must be a positive number of rad/s; got {command_limit}")
    if mpc:
        _design_mpc(
            model_path,
            {
                "--fractional": fractional,
                "--scheduled": scheduled,
                "--discretisation": discretisation,
                "--order": order,
                "--report": report,
                "inclination": inclination,
                "delay": DEFAULT_DELAY if delay is None else delay,
                "drive_time_constant": drive_time_constant,
                "command_limit": command_limit,
                "horizon": horizon,
                "preview": preview,
                "move_weight": move_weight,
                "rate_limit": rate_limit,
                "output_min": output_min,
                "output_max": output_max,
                "tighten": tighten,
                "tighten_logs": tighten_logs or [],
                "on_late": on_late,
            },
            out,
        )
        console.print(_delay_line(delay), markup=False)
        return
    options = {
        "pm": pm,
        "wc": wc,
        "fractional": fractional,
        "scheduled": scheduled,
        "inclination": inclination,
        "discretisation": discretisation,
        "order": order,
        "delay": DEFAULT_DELAY if delay is None else delay,
        "drive_time_constant": drive_time_constant,
    }
    # The report folder is claimed (and refused if it holds files) before anything is computed.
    with output_folder(report, force=force) if report is not None else nullcontext() as staged:
        model = load_model(model_path)
        result = _design(model, options)
        controller = result.controller(
            command_limit=command_limit,
            model=model_description(model_path, model, inclination),
        )
        save_controller(controller, out)
        for line in _summary_lines(controller_document(controller)):
            console.print(line, markup=False)
        console.print(_delay_line(delay), markup=False)
        console.print(f"controller written to {out}", markup=False)
        if staged is not None:
            _write_report(controller, result, staged)
