"""Controllers designed from identified models, verified (docs/design.md; issue 31's floors).

What it shows: PI and fractional controllers designed for the lab's specification (50 deg of
phase margin at 3 rad/s with a flat phase) on the models the demo identifies on the simulated
neck, and how each one does: its margins on the model it was designed on and on the others; the
paper's tests 1-3 on the simulated neck against the demo's PI; every identified model in the
loop; the Set Membership model's bounding functions in the loop. With the real logs, the same
design procedure on ARX models of each staircase log, beside the lab's adaptive tuner's ranges
and the lab's own identified model. Run from the repository::

    .venv/bin/python docs/examples/design_controllers.py [--demo DIR] [--softneck DATA/softneck]

Without ``--demo`` it runs ``neckid demo`` into a temporary folder first (about 35 s) and uses
its models; with ``--demo`` it loads the models of a folder ``neckid demo`` wrote. Without
``--softneck`` the real-log part is skipped. It prints Markdown tables (the ones of
docs/design.md).
"""

import argparse
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from neckid import Lags, LinearARX, load_model
from neckid.design import (
    PAPER_TESTS,
    design_fractional,
    design_pi,
    design_scheduled,
    ideal_iso_damping,
    linear_form,
    margins_on_models,
    models_in_the_loop,
    paper_test_references,
    set_membership_check,
    simulated_neck_tests,
)
from neckid.design.linear_form import LinearForm
from neckid.design.loop_shaping import phase_slope
from neckid.plant import InclinationController, SoftNeckParameters

#: The demo's PI limit, given to the designed controllers too (the neck's motors stop at 4 rad/s).
COMMAND_LIMIT = 4.0
#: The lab's adaptive tuner's ranges (CONTROLLERS.md, "ada").
LAB_RANGES = {"kp": (0.19, 0.43), "kd": (0.36, 1.22), "order": (-0.60, -0.56)}
#: The regressor the benchmark's selection chose for the ARX on the real logs.
REAL_ARX_LAGS = Lags(outputs=[1, 2], inputs=[0, 1])
#: The operating point the fixed designs on the scheduled model are made at [deg].
INCLINATION = 20.0


def markdown(frame: pd.DataFrame, digits: int = 3) -> str:
    """A DataFrame as a Markdown table (index first)."""
    frame = frame.reset_index()
    head = "| " + " | ".join(str(c) for c in frame.columns) + " |"
    rule = "|" + "|".join("---" for _ in frame.columns) + "|"
    rows = [
        "| " + " | ".join(f"{v:.{digits}f}" if isinstance(v, float) else str(v) for v in row) + " |"
        for row in frame.itertuples(index=False)
    ]
    return "\n".join([head, rule, *rows])


def demo_models(folder: Path | None) -> dict:
    """The demo's models by name (running the demo first when no folder is given)."""
    if folder is None:
        from neckid.experiments.paper import run_demo

        folder = Path(tempfile.mkdtemp(prefix="neckid-design-demo-"))
        run_demo(folder, force=True)
    models = {
        p.stem.removeprefix("model_"): load_model(p) for p in sorted(folder.glob("model_*.npz"))
    }
    if "scheduled_cff_rls" not in models or "linear_arx" not in models:
        raise SystemExit(f"{folder} holds no model_linear_arx.npz / model_scheduled_cff_rls.npz")
    return models


def simulated_designs(models: dict) -> tuple[dict, dict]:
    """The designs on the simulated neck's models, and every model's linear form."""
    drive = SoftNeckParameters().motor_time_constant
    forms = {}
    for name, model in models.items():
        inclination = None if name == "linear_arx" else INCLINATION
        forms[name] = linear_form(model, inclination=inclination, drive_time_constant=drive)
    scheduled, arx = forms["scheduled_cff_rls"], forms["linear_arx"]
    designs = {
        "PI on scheduled@20": design_pi(scheduled),
        "fractional GL on scheduled@20": design_fractional(scheduled, discretisation="gl"),
        "fractional Oustaloup on scheduled@20": design_fractional(
            scheduled, discretisation="oustaloup"
        ),
        "PI on ARX": design_pi(arx),
        "fractional GL on ARX": design_fractional(arx, discretisation="gl"),
        "fractional Oustaloup on ARX": design_fractional(arx, discretisation="oustaloup"),
        "scheduled fractional GL": design_scheduled(models["scheduled_cff_rls"]),
    }
    return designs, forms


def design_table(designs: dict) -> pd.DataFrame:
    """Gains, order and what each design achieves on its own model."""
    rows = {}
    for name, design in designs.items():
        one = design.designs[len(design.designs) // 2] if hasattr(design, "designs") else design
        rows[name] = {
            "kp": one.kp,
            "kf": one.kf,
            "order": one.order,
            "pm [deg]": one.margins.phase_margin,
            "wc [rad/s]": one.margins.crossover,
            "slope [deg/(rad/s)]": one.margins.phase_slope,
            "Ms": one.margins.sensitivity_peak,
            "order rule": one.order_rule,
        }
    return pd.DataFrame.from_dict(rows, orient="index")


def simulated_part(models: dict) -> None:
    """Print the simulated neck's tables."""
    designs, forms = simulated_designs(models)
    print("\n## Designs and their margins on the model designed on\n")
    print(markdown(design_table(designs)))
    controllers = {name: d.controller(command_limit=COMMAND_LIMIT) for name, d in designs.items()}
    print(
        "\n## Smallest phase margin [deg] / its crossover [rad/s] over every model's linear form\n"
    )
    rows = {}
    for name, controller in controllers.items():
        table = margins_on_models(controller, forms, inclination=INCLINATION)
        worst = table["phase_margin_deg"].idxmin()
        rows[name] = {
            "worst model": worst,
            "pm [deg]": table.loc[worst, "phase_margin_deg"],
            "wc [rad/s]": table.loc[worst, "crossover_rad_s"],
            "all stable": bool(table["closed_loop_stable"].all()),
        }
    print(markdown(pd.DataFrame.from_dict(rows, orient="index")))
    tests = simulated_neck_tests(
        {"demo PI (kp 0.35, ki 0.6)": InclinationController(ts=0.02), **controllers}
    )
    print("\n## Tracking error RMS [deg] on the simulated neck, the paper's tests 1-3\n")
    print(markdown(tests.table))
    chosen = "fractional GL on scheduled@20"
    print(f"\n## Every model in the loop with '{chosen}'\n")
    print(markdown(models_in_the_loop(controllers[chosen], models, tests.logs[chosen])))
    references = paper_test_references()
    for name in ("set_membership", "set_membership_linear"):
        if name not in models:
            continue
        print(f"\n## '{chosen}' with {name}: central estimate, bounding functions, adversary\n")
        parts = []
        for test in PAPER_TESTS:
            table = set_membership_check(controllers[chosen], models[name], references[test])
            parts.append(table.assign(test=test).set_index("test", append=True))
        print(markdown(pd.concat(parts)))


def lab_model_form(log) -> tuple[LinearForm, np.ndarray]:
    """The lab's own model of a run: its identifier's averaged estimate at the run's end."""
    from neckid.loops.controllers.tuner import OnlineIdentifier

    identifier = OnlineIdentifier()
    identifier.reset()
    command, inclination = log.channel("velocity_command"), log.channel("inclination")
    theta = identifier.theta0
    for c, i in zip(command, inclination, strict=True):
        theta = identifier.update(float(c), float(i))
    form = LinearForm(np.array([theta[2]]), np.array([1.0, theta[0], theta[1]]), 0.025, 0)
    return form, theta


def real_part(folder: Path) -> None:
    """Print the real logs' table: the same procedure on ARX models of each staircase log."""
    from neckid.datasets import load_softneck_log
    from neckid.experiments.benchmark import softneck_protocol
    from neckid.loops.controllers.tuner import iso_damping_tuning

    rows = {}
    for path in sorted((folder / "stair").glob("*response.csv")):
        log = load_softneck_log(path)
        if "velocity_command" not in log.input_names:
            continue
        data = softneck_protocol(log).select(inputs=["motor_displacement"], outputs=["inclination"])
        arx = LinearARX(REAL_ARX_LAGS).fit(data)
        form = linear_form(arx, computation_delay=0)  # the lab reads and commands in one period
        kp, kf, order, flat = ideal_iso_damping(form)
        gl = design_fractional(form, discretisation="gl")
        lab_form, theta = lab_model_form(log)
        lab = iso_damping_tuning(theta)
        mine = ideal_iso_damping(lab_form)
        rows[path.stem.removesuffix("response")] = {
            "ARX: arg G(3j) [deg]": float(np.degrees(np.angle(form.response(3.0)))),
            "slope [deg/(rad/s)]": phase_slope(form.response, 3.0),
            "ARX: kp": kp,
            "kf (=kd)": kf,
            "order": order,
            "flat": flat,
            "GL kd_lab": gl.kf * 0.025 ** (-(1.0 + gl.order)),
            "lab model: arg G(3j)": float(np.degrees(np.angle(lab_form.response(3.0)))),
            "slope": phase_slope(lab_form.response, 3.0),
            "lab model: kp": mine[0],
            "kf": mine[1],
            "order ": mine[2],
            "lab tuner: kp": np.nan if lab is None else lab.kp,
            "kd": np.nan if lab is None else lab.kd,
            "order  ": np.nan if lab is None else lab.alpha,
        }
    table = pd.DataFrame.from_dict(rows, orient="index")
    print("\n## Real staircase logs: the same design (50 deg at 3 rad/s, flat phase, delay 0)\n")
    print(markdown(table))
    inside = table.apply(
        lambda r: (
            LAB_RANGES["kp"][0] <= r["ARX: kp"] <= LAB_RANGES["kp"][1]
            and LAB_RANGES["kd"][0] <= r["kf (=kd)"] <= LAB_RANGES["kd"][1]
        ),
        axis=1,
    )
    print(
        f"\nARX designs with kp and kf inside the lab tuner's ranges: {int(inside.sum())} of"
        f" {len(table)}; orders {table['order'].min():.3f} ... {table['order'].max():.3f}"
        f" (the lab's {LAB_RANGES['order'][0]} ... {LAB_RANGES['order'][1]})"
    )


def main(argv: list[str] | None = None) -> None:
    """Run the simulated part, then the real-log part when the logs are given."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--demo", type=Path, help="a folder written by `neckid demo`")
    parser.add_argument("--softneck", type=Path, help="folder of the real soft-neck logs")
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore")
    simulated_part(demo_models(args.demo))
    if args.softneck is not None:
        real_part(args.softneck)


if __name__ == "__main__":
    main()
