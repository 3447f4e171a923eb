"""Predictive control on the identified models (issue 44): the figures of docs/benchmarks/mpc.md.

Run:  .venv/bin/python benchmarks/bench_mpc.py [--demo DIR] [--softneck ../shared/data/softneck]
          [--plot docs/img/mpc_staircase.png]

1. **Simulated neck, tests 1-3** (``neckid.design.simulated_neck_tests``, seed 7): the MPC
   designed on the demo's identified ARX (``neckid demo``'s ``model_linear_arx.npz``; the
   drive's 0.015 s time constant; one sample of delay), with and without reference preview,
   beside the demo's PI and the fractional GL designs of docs/benchmarks/design.md; the largest
   command [rad/s] against the 4 rad/s limit; the velocity-limited floor (the tracking RMS of
   an inclination that follows the reference as fast as the limit lets it, through the ARX's
   gain: causal without preview, centred on each change with preview).
2. **Robust**: a ``MultiStepSetMembership`` (horizons 1-26, fixed settings) fitted on two
   closed-loop runs of the neck with the demo's PI over random levels (5-34 deg, 2 s each;
   seeds 11 and 12); the tightening measured on the same runs; test 2 (staircase to 30 deg)
   with an inclination limit of 30.3 deg and a staircase to 35 deg with one of 35.3 deg, the
   nominal MPC beside the SM-tightened one: samples of the measured inclination above the limit.
3. **Real logs**: an ARX of the payload split (the six 0 g / 600 g staircases; motor
   displacement and measured velocity -> raw inclination; lags y 1-2, u 0-1), the MPC on it
   (delay 0, as on the bench) in the lab's loop (``in_loop_on_log``, the identified drive) on
   the six 200 g / 400 g staircases, beside the lab's PI on the same model.
4. Test 2 with preview, the MPC on the other kinds of model with a linear form (the demo's
   scheduled and SM models at 20 deg, an ``ss`` and an ``lpv`` fitted on one PI run).

Every run's OSQP solve time per step (median, max; wall and CPU time of the thread) is printed,
with the solves that failed and those later than the period. The runs use ``on_late="use"``: a
late solve is counted but its move used, so that the figures do not depend on the shared
machine's load (printed); the wall-time max is the scheduler's as much as the solver's.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from neckid import Lags, LinearARX, load_model
from neckid.design import (
    PAPER_TESTS,
    design_fractional,
    linear_form,
    paper_test_references,
    tracking_rms,
)
from neckid.design.mpc import MPCController, band_tightening, mpc_problem
from neckid.plant import InclinationController, SoftNeck, SoftNeckParameters, closed_loop
from neckid.signals import staircase

TS = 0.02
REAL_LAGS = Lags(outputs=[1, 2], inputs=[0, 1])


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


def run(controller, reference: np.ndarray, seed: int = 7):
    """One closed loop on the simulated neck (the preview set when it is an MPC)."""
    if isinstance(controller, MPCController):
        controller.set_reference(reference)
    return closed_loop(SoftNeck(None, ts=TS, seed=seed), controller, reference, TS)


def velocity_floor(reference: np.ndarray, slope: float, preview: bool) -> float:
    """RMS [deg] of the best velocity-limited follower of ``reference`` (slope in deg/s)."""
    step = slope * TS
    follower = np.empty_like(reference)
    y = 0.0
    if not preview:
        for k, r in enumerate(reference):  # one sample of delay, then the fastest ramp
            follower[k] = y
            y += float(np.clip(r - y, -step, step))
        return float(np.sqrt(np.mean((reference - follower) ** 2)))
    # with preview: the same ramps, shifted back by half their length (centred on the change)
    forward = np.empty_like(reference)
    for k, r in enumerate(reference):
        y += float(np.clip(r - y, -step, step))
        forward[k] = y
    backward = np.empty_like(reference)
    y = float(reference[-1])
    for k in range(reference.size - 1, -1, -1):
        y += float(np.clip(reference[k] - y, -step, step))
        backward[k] = y
    follower = (forward + backward) / 2.0
    return float(np.sqrt(np.mean((reference - follower) ** 2)))


def stats_row(controller: MPCController) -> dict[str, float]:
    s = controller.stats
    return {
        "steps": s.steps,
        "median_ms": s.median_ms,
        "max_ms": s.max_ms,
        "median_cpu_ms": s.median_cpu_ms,
        "max_cpu_ms": s.max_cpu_ms,
        "failed": s.failed,
        "late (used)": s.late,
        "slack_step1": s.slack_steps,
    }


def simulated(models: dict) -> tuple[object, list]:
    """Part 1: tests 1-3."""
    tau = SoftNeckParameters().motor_time_constant
    form = linear_form(models["linear_arx"], drive_time_constant=tau)
    scheduled = linear_form(models["scheduled_cff_rls"], inclination=20.0, drive_time_constant=tau)
    controllers = {
        "demo PI (kp 0.35, ki 0.6)": InclinationController(ts=TS),
        "fractional GL on scheduled@20": design_fractional(
            scheduled, discretisation="gl"
        ).controller(command_limit=4.0),
        "fractional GL on ARX": design_fractional(form, discretisation="gl").controller(
            command_limit=4.0
        ),
        "MPC on ARX, preview": MPCController(mpc_problem(form, preview=True), on_late="use"),
        "MPC on ARX, no preview": MPCController(mpc_problem(form, preview=False), on_late="use"),
    }
    references = paper_test_references(TS)
    rms, peak, moves, solves = {}, {}, {}, []
    for name, controller in controllers.items():
        for test, reference in references.items():
            log = run(controller, reference)
            rms[(name, test)] = tracking_rms(log, reference)
            command = log.channel("velocity_command")
            peak[(name, test)] = float(np.max(np.abs(command)))
            moves[(name, test)] = float(np.sqrt(np.mean(np.diff(command) ** 2)))
            if isinstance(controller, MPCController):
                solves.append({"run": f"{name}, {test}", **stats_row(controller)})
    table = pd.Series(rms).unstack()[list(PAPER_TESTS)].loc[list(controllers)]
    pi = table.loc["demo PI (kp 0.35, ki 0.6)"]
    table.loc["MPC preview / demo PI"] = table.loc["MPC on ARX, preview"] / pi
    q, _ = np.polydiv(form.den, [1.0, -1.0])  # G = num / ((z - 1) q): ramp slope per rad/s
    gain = float(np.polyval(form.num, 1.0) / np.polyval(q, 1.0) / TS)
    slope = gain * 4.0
    for preview in (False, True):
        label = f"velocity-limited floor ({'preview' if preview else 'causal'})"
        table.loc[label] = [velocity_floor(references[t], slope, preview) for t in PAPER_TESTS]
    print(f"ARX ramp gain {gain:.4g} deg/s per rad/s: at 4 rad/s {slope:.4g} deg/s")
    print("\nTracking error RMS [deg] on the simulated neck (seed 7):\n")
    print(markdown(table))
    print("\nLargest |command| [rad/s] (limit 4):\n")
    print(markdown(pd.Series(peak).unstack()[list(PAPER_TESTS)].loc[list(controllers)]))
    print("\nRMS command move per period [rad/s] (chatter):\n")
    print(markdown(pd.Series(moves).unstack()[list(PAPER_TESTS)].loc[list(controllers)]))
    return form, solves


def plot_staircase(form, tightening: np.ndarray, path: Path) -> None:
    """Test 2: the demo PI and the MPC with and without preview; the limit at 30.3 deg."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    reference = paper_test_references(TS)[PAPER_TESTS[1]]
    runs = {
        "demo PI": InclinationController(ts=TS),
        "MPC, preview": MPCController(mpc_problem(form), on_late="use"),
        "MPC, no preview": MPCController(mpc_problem(form, preview=False), on_late="use"),
        "MPC, limit 30.3, nominal": MPCController(
            mpc_problem(form, output_max=30.3), on_late="use"
        ),
        "MPC, limit 30.3, SM-tightened": MPCController(
            mpc_problem(form, output_max=30.3, tightening=tightening), on_late="use"
        ),
    }
    logs = {name: run(controller, reference) for name, controller in runs.items()}
    fig, axes = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    t = logs["demo PI"].time
    for ax, names in ((axes[0], list(runs)[:3]), (axes[1], list(runs)[3:])):
        ax.plot(t, reference, "k--", lw=1, label="reference")
        for name in names:
            ax.plot(t, logs[name].y[:, 0], lw=1, label=name)
        ax.set_ylabel("inclination [deg]")
        ax.legend(loc="lower right", fontsize=8)
    axes[1].axhline(30.3, color="r", lw=0.8, label="limit")
    axes[1].set_ylim(24.0, 32.0)
    axes[1].set_xlim(0.0, 20.0)
    for name in list(runs)[:3]:
        axes[2].plot(t, logs[name].channel("velocity_command"), lw=1, label=name)
    axes[2].set_ylabel("velocity command [rad/s]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(loc="upper right", fontsize=8)
    axes[0].set_title("Test 2 on the simulated neck (seed 7): MPC on the demo's ARX")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print(f"figure written to {path}")


def other_models(models: dict) -> None:
    """Test 2 with preview, the MPC on each kind of model with a linear form."""
    from neckid import methods
    from neckid.design.mpc import design_mpc

    reference = paper_test_references(TS)[PAPER_TESTS[1]]
    log = run(
        InclinationController(ts=TS), np.repeat(np.random.default_rng(2).uniform(5, 30, 20), 100), 3
    )
    view = log.select(inputs=["motor_position"], outputs=["inclination"])
    lags = Lags(outputs=[1], inputs=[1, 2])
    cases = {
        "arx (the demo's)": (models["linear_arx"], None),
        "scheduled CFF-RLS at 20 deg (the demo's)": (models["scheduled_cff_rls"], 20.0),
        "sm linearised at 20 deg (the demo's)": (models["set_membership"], 20.0),
        "ss (order chosen, one PI run)": (methods()["ss"].make(lags).fit(view), None),
        "lpv at 20 deg (one PI run)": (methods()["lpv"].make(lags).fit(view), 20.0),
    }
    rows = {}
    for name, (model, inclination) in cases.items():
        mpc = design_mpc(model, inclination=inclination, drive_time_constant=0.015, on_late="use")
        rows[name] = {
            "tracking_rms_deg": tracking_rms(run(mpc, reference), reference),
            "n_a": mpc.problem.a.size,
            "n_b": mpc.problem.b.size,
        }
    print("\nTest 2 with preview, the MPC on other models' linear forms:\n")
    print(markdown(pd.DataFrame.from_dict(rows, orient="index")))


def closed_loop_logs() -> list:
    """Two closed-loop runs of the neck with the demo's PI over random levels."""
    rng = np.random.default_rng(1)
    logs = []
    for seed in (11, 12):
        levels = np.repeat(rng.uniform(5.0, 34.0, 40), round(2.0 / TS))
        logs.append(run(InclinationController(ts=TS), levels, seed=seed))
    return logs


def robust(form, plot: Path | None = None) -> list:
    """Part 2: the inclination limit near the staircase's top."""
    from neckid.models.set_membership.multistep import MultiStepSetMembership

    logs = closed_loop_logs()
    nominal = mpc_problem(form)
    views = [log.select(inputs=["motor_position"], outputs=["inclination"]) for log in logs]
    sm = MultiStepSetMembership(
        Lags(outputs=[1], inputs=[1, 2]),
        horizon=nominal.horizon + nominal.delay,
        epsilon_factor=2.0,
        input_weight=1.0,
        lipschitz="global",
    ).fit(views)
    tight = band_tightening(nominal, sm, logs)
    print(
        "\nTightening w_j [deg] at j = 1, 5, 10, 25:", np.round(tight.tightening[[0, 4, 9, 24]], 3)
    )
    print("SM band half-width [deg] at the same:", np.round(tight.half_width[[0, 4, 9, 24]], 3))
    print(f"coverage on the design runs: min {tight.coverage.min():.4f}")
    if plot is not None:
        plot_staircase(form, tight.tightening, plot)
    t = np.arange(round(20.0 / TS)) * TS
    cases = {
        "test 2 (to 30 deg)": (paper_test_references(TS)[PAPER_TESTS[1]], 30.3),
        "staircase to 35 deg": (
            staircase(t, step=5.0, step_duration=3.0, start_time=1.0, maximum=35.0),
            35.3,
        ),
    }
    rows, solves = {}, []
    for case, (reference, limit) in cases.items():
        for label, tightening in (("nominal", None), ("SM-tightened", tight.tightening)):
            for preview in (True, False):
                mpc = MPCController(
                    mpc_problem(form, output_max=limit, tightening=tightening, preview=preview),
                    on_late="use",
                )
                y = run(mpc, reference).y[:, 0]
                name = f"{case}, limit {limit}, {label}, {'preview' if preview else 'no preview'}"
                rows[name] = {
                    "violations": int(np.sum(y > limit)),
                    "max_inclination_deg": float(y.max()),
                    "tracking_rms_deg": float(np.sqrt(np.mean((reference - y) ** 2))),
                    "slack_step1": mpc.stats.slack_steps,
                }
                solves.append({"run": name, **stats_row(mpc)})
    print(
        "\nStaircases with an inclination limit (samples of the measured inclination above it):\n"
    )
    print(markdown(pd.DataFrame.from_dict(rows, orient="index")))
    return solves


def real(softneck: Path) -> list:
    """Part 3: the lab's loop on the test staircases."""
    from neckid.data.preprocess import Pipeline, Relative
    from neckid.datasets import load_softneck_log
    from neckid.design.mpc import design_mpc
    from neckid.loops.controllers.reconstruct import controller_for_log
    from neckid.loops.controllers.references import reference_for_log
    from neckid.loops.lab_loop import in_loop_on_log

    stair = softneck / "stair"
    train = [f"{c}{p}response.csv" for p in ("000", "600") for c in ("int", "fra", "ada")]
    test = [f"{c}{p}response.csv" for p in ("200", "400") for c in ("int", "fra", "ada")]
    pipeline = Pipeline([Relative("motor_position")])
    logs = [
        load_softneck_log(stair / n).select(
            inputs=["motor_position", "motor_velocity"], outputs=["inclination"]
        )
        for n in train
    ]
    model = LinearARX(REAL_LAGS).fit(pipeline.apply(logs))
    model.preprocessing_ = pipeline  # as neckid identify --relative motor_position records it
    rows, solves = {}, []
    keys = ("tracking_rms_deg", "amplitude_deg", "oscillation_share", "period_s")
    for name in test:
        nominal = reference_for_log(name).nominal
        for label in ("lab PI (int)", "MPC, no preview", "MPC, preview"):
            if label.startswith("lab"):
                controller = controller_for_log("int" + name[3:])
            else:
                designed = design_mpc(model, computation_delay=0, preview="no" not in label)
                controller = MPCController(designed.problem, on_late="use")
                controller.set_reference(nominal)
            result = in_loop_on_log(
                model, stair / name, controller=controller, check_tolerance=None
            )
            summary = result.summary()
            rows[(name, label)] = {k: summary[k] for k in keys}
            rows[(name, label)]["logged_tracking_rms_deg"] = summary["logged_tracking_rms_deg"]
            if isinstance(controller, MPCController):
                solves.append({"run": f"{name}, {label}", **stats_row(controller)})
    frame = pd.DataFrame.from_dict(rows, orient="index")
    print("\nThe lab's loop, the payload-split ARX in the neck's place (test staircases):\n")
    print(markdown(frame))
    print("\nMean over the six test logs:\n")
    print(markdown(frame.groupby(level=1).mean()))
    return solves


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--demo", type=Path, help="a folder neckid demo wrote")
    parser.add_argument("--softneck", type=Path, help="../shared/data/softneck")
    parser.add_argument("--plot", type=Path, help="write the staircase figure (PNG) there")
    parser.add_argument(
        "--models-only", action="store_true", help="only the MPC on other models' linear forms"
    )
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    folder = args.demo
    if folder is None:
        from neckid.experiments.paper import run_demo

        folder = Path(tempfile.mkdtemp(prefix="neckid-mpc-demo-"))
        run_demo(folder, force=True)
    models = {
        p.stem.removeprefix("model_"): load_model(p) for p in sorted(folder.glob("model_*.npz"))
    }
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    other_models(models)
    if args.models_only:
        return
    form, solves = simulated(models)
    solves += robust(form, args.plot)
    if args.softneck is not None and (args.softneck / "stair").is_dir():
        solves += real(args.softneck)
    table = pd.DataFrame(solves).set_index("run")
    print("\nOSQP solve time per step [ms] and fallbacks, per run:\n")
    print(markdown(table))
    print(
        f"\nover all runs: median of the medians {table['median_ms'].median():.3f} ms wall,"
        f" {table['median_cpu_ms'].median():.3f} ms CPU; largest {table['max_ms'].max():.2f} ms"
        f" wall, {table['max_cpu_ms'].max():.2f} ms CPU; failed {int(table['failed'].sum())},"
        f" late {int(table['late (used)'].sum())} of {int(table['steps'].sum())} steps; load"
        f" average {os.getloadavg()[0]:.1f}"
    )


if __name__ == "__main__":
    main()
