"""Adaptive free run on the real soft-neck staircase logs (docs/benchmarks/softneck.md, *Adaptive*).

What it shows: how much a model identified on other runs gains when it adapts on the first 5 s of
a test run. Train on ``stair/{ada,fra,int}{000,600}response.csv``, test on
``stair/{ada,fra,int}{200,400}response.csv``; free-run fit [%] after a 5 s warm-up with
adapt = none / offset / update / both, for arx, sm-linear and sm-parallel, with and without the
payload condition. About 2 minutes on two cores.

Run from the repository, with the folder of the real soft-neck logs (it holds ``stair/``)::

    .venv/bin/python docs/examples/adaptive_experiment.py DATA/softneck [--prior adapt|keep]
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

import neckid
from neckid import IOData, Lags
from neckid.datasets import load_softneck_log
from neckid.experiments.benchmark.datasets import softneck_protocol
from neckid.experiments.benchmark.settings import arx_error_scale
from neckid.loops.adaptive import ADAPT_MODES, adaptive_free_run
from neckid.models.online import simulate_with_offset

TRAIN = [f"{c}{p}" for c in ("ada", "fra", "int") for p in ("000", "600")]
TEST = [f"{c}{p}" for c in ("ada", "fra", "int") for p in ("200", "400")]
WARMUP_S = 5.0


def load(folder: Path, name: str) -> IOData:
    """The stair log ``name`` (e.g. ``ada200``) of ``folder`` through the benchmark's protocol."""
    return softneck_protocol(load_softneck_log(Path(folder) / "stair" / f"{name}response.csv"))


def models(train: list[IOData], payload: bool) -> dict[str, Any]:
    """The three models compared, unfitted (ε from the ARX's errors on ``train``)."""
    base = Lags.arx(2, 2)
    lags = Lags(base.outputs, base.inputs, conditions=["payload"]) if payload else base
    one_step = arx_error_scale(lags, train)
    free_run = arx_error_scale(lags, train, free_run=True)
    make = neckid.methods()
    return {
        "arx": make["arx"].make(lags),
        # benchmark candidates: epsilon = 1 x ARX one-step RMS; 0.25 x ARX free-run RMS
        "sm-linear": make["sm-linear"].make(lags, epsilon=one_step, progress=False),
        "sm-parallel": make["sm-parallel"].make(lags, epsilon=0.25 * free_run, progress=False),
    }


#: Perturbations [deg] of the initial outputs of the scored free run (the sensor's step is 0.01).
JITTER = (-2e-3, -1e-3, 1e-3, 2e-3)


def perturbed_fit(run: Any, delta: float) -> float:
    """Fit of the same adapted run from initial outputs moved by ``delta`` degrees."""
    scored = run.scored
    m = run.result.n_initial
    y = np.array(scored.y)
    y[:m] += delta
    moved = IOData(
        scored.u,
        y,
        ts=scored.ts,
        input_names=scored.input_names,
        output_names=scored.output_names,
        conditions=scored.conditions,
    )
    result = simulate_with_offset(run.model, moved, run.offset)
    return float(result.fit_percent(scored)[0])


def main(argv: list[str] | None = None) -> None:
    """Fit, adapt on every test log and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("softneck", type=Path, help="folder of the real soft-neck logs (stair/)")
    parser.add_argument("--prior", default="adapt", choices=["adapt", "keep"])
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    train = [load(args.softneck, n) for n in TRAIN]
    test = {n: load(args.softneck, n) for n in TEST}
    rows = []
    for payload in (False, True):
        for method, model in models(train, payload).items():
            start = time.perf_counter()
            model.fit(train)
            fit_time = time.perf_counter() - start
            options = {} if method == "arx" else {"prior": args.prior}
            for name, data in test.items():
                for adapt in ADAPT_MODES:
                    start = time.perf_counter()
                    outside = jitter = np.nan
                    try:
                        run = adaptive_free_run(
                            model, data, WARMUP_S, adapt=adapt, update_options=options
                        )
                        fit = float(run.fit[0])
                        seconds = time.perf_counter() - start
                        sm = getattr(run.model, "sm_", run.model)
                        if adapt in ("update", "both") and hasattr(sm, "last_invalidation_"):
                            outside = 100 * float(sm.last_invalidation_[0].fraction[0])
                        jitter = np.mean([perturbed_fit(run, d) for d in JITTER])
                    except (ValueError, ArithmeticError) as exc:
                        print(f"{method} {name} {adapt}: {type(exc).__name__}: {exc}")
                        fit = seconds = np.nan
                    rows.append(
                        {
                            "payload": "yes" if payload else "no",
                            "method": method,
                            "test": name,
                            "adapt": adapt,
                            "fit": fit,
                            "jittered": jitter,
                            "outside": outside,
                            "seconds": seconds,
                        }
                    )
            print(f"{method} payload={payload}: fit {fit_time:.1f} s", flush=True)
    frame = pd.DataFrame(rows)
    table = frame.pivot_table(
        index=["payload", "method", "adapt"], columns="test", values="fit", sort=False
    )
    table["mean"] = table.mean(axis=1)
    pd.set_option("display.width", 200)
    print(f"\nFree-run fit [%] after a {WARMUP_S:g} s warm-up (prior={args.prior})")
    print(table.round(1).to_string())
    for value, title in (
        ("jittered", f"mean fit [%] over initial outputs moved by {list(JITTER)} deg"),
        ("outside", "share [%] of warm-up samples outside the SM band before the update"),
    ):
        other = frame.pivot_table(
            index=["payload", "method", "adapt"], columns="test", values=value, sort=False
        )
        other["mean"] = other.mean(axis=1)
        print(f"\n{title}")
        print(other.round(1).to_string())
    print("\nseconds per adaptive run (mean):")
    print(frame.groupby(["method", "adapt"], sort=False)["seconds"].mean().round(2).to_string())


if __name__ == "__main__":
    main()
