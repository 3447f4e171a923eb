"""SM parallel across runs of the real neck: the benchmark's grid with other SM distances and estimates.

What it shows: whether the learnt SM distance or the projection estimate changes what the
cross-run benchmark protocols (docs/benchmarks/softneck.md, *A learnt distance for SM parallel across
runs*) choose and score. Run from the repository, with the data folder that holds ``softneck/``
(about 2-3 min per protocol and variant on 2 cores)::

    .venv/bin/python docs/examples/cross_run_variants.py DATA softneck-payload central-std central-grad proj-std proj-grad
    .venv/bin/python docs/examples/cross_run_variants.py DATA softneck-controller central-grad
    .venv/bin/python docs/examples/cross_run_variants.py DATA adaptive

``adaptive`` runs ``neckid.loops.adaptive.adaptive_free_run`` (5 s warm-up, the four
adaptation modes) on the payload split for the ARX the benchmark chooses there and SM parallel on
it with the learnt distance and local constants (``linear_lags=[0, 1]``, ε by the knee), the
setting the ``central-grad`` variant chooses.

For each variant, the candidates of the benchmark's ``sm-parallel`` grid (lags × SM regressor ×
ε) with the variant's options are ranked by leave-one-run-out free-run RMSE on the training runs
(the benchmark's rule), the best is refitted on all of them, and the test runs are simulated once.
Variants: ``central``/``proj`` is the estimate (SM's central one, or the linear model's output
projected into the SM bounds); ``std``/``grad`` the distance (unit standard deviation per term
and one γ, or the learnt distance ``scaling="gradient"`` with one constant per training point).
Prints the chosen candidate, its leave-one-run-out RMSE [deg] and the free-run fit [%] per test
log.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn.base import clone

from neckid import Lags, LinearARX, ParallelSetMembership
from neckid.experiments.benchmark import settings
from neckid.experiments.benchmark.datasets import load_benchmark
from neckid.experiments.benchmark.runner import _select
from neckid.loops.adaptive import ADAPT_MODES, adaptive_free_run
from neckid.metrics import fit_percent
from neckid.registry import methods
from neckid.selection.lags import free_run

VARIANTS = {
    "central-std": {},
    "proj-std": {"estimate": "projection"},
    "central-grad": {"scaling": "gradient", "lipschitz": "local"},
    "proj-grad": {"estimate": "projection", "scaling": "gradient", "lipschitz": "local"},
}


def run(data: Path, protocol: str, variant: str) -> None:
    """Select, fit and test one variant on one cross-run protocol; print the result."""
    bench = load_benchmark(protocol, data)
    if bench is None:
        raise SystemExit(f"{protocol}: the soft-neck staircases are not under {data}")
    make = methods()["sm-parallel"].make
    started = time.perf_counter()
    candidates = []
    for lags in settings.lag_grid(protocol):
        try:
            scale = settings.arx_error_scale(lags, bench.train, free_run=True)
        except ValueError:
            continue
        candidates += settings._parallel_candidates(
            make, lags, False, settings.SM_PARALLEL_REGRESSORS,
            settings.SM_PARALLEL_EPSILON_FACTORS, scale, "", VARIANTS[variant],
        )  # fmt: skip
    (label, estimator), scores = _select(candidates, bench.train, bench.n_initial)
    model = clone(estimator).fit(bench.train)
    fits = {}
    for test, record in bench.tests.items():
        y, skip = free_run(model, record, bench.n_initial, diverged="keep")
        fits[Path(test).stem.removesuffix("response")] = float(
            fit_percent(record.y, y, skip=skip)[0]
        )
    best = min(s["holdout_rmse"] for s in scores)
    print(
        f"{protocol} {variant}: {len(candidates)} candidates, {time.perf_counter() - started:.0f} s"
    )
    print(f"  chosen {label} (leave-one-run-out RMSE {best:.4f} deg)")
    shown = ", ".join(f"{k} {v:.1f}" for k, v in fits.items())
    print(f"  fit [%]: {shown}; mean {np.mean(list(fits.values())):.2f}", flush=True)


def adaptive(data: Path) -> None:
    """Adaptive free run of the payload split's ARX and learnt-distance SM parallel; print fits."""
    bench = load_benchmark("softneck-payload", data)
    if bench is None:
        raise SystemExit(f"the soft-neck staircases are not under {data}")
    lags = Lags(outputs=[1], inputs=[0], conditions=["payload"])
    models = {
        "arx": LinearARX(lags),
        "sm-parallel, learnt distance": ParallelSetMembership(
            lags, linear_lags=[0, 1], scaling="gradient", lipschitz="local", progress=False
        ),
    }
    for name, model in models.items():
        model.fit(bench.train)
        for adapt in ADAPT_MODES:
            fits = [
                float(adaptive_free_run(model, record, 5.0, adapt=adapt).fit[0])
                for record in bench.tests.values()
            ]
            shown = " ".join(f"{f:5.1f}" for f in fits)
            print(f"{name:30s} {adapt:7s} {shown}  mean {np.mean(fits):.2f}", flush=True)


def main(argv: list[str] | None = None) -> None:
    """Run the variants asked for."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("data", type=Path, help="the data folder (it holds softneck/)")
    parser.add_argument("protocol", choices=[*sorted(settings.CROSS_RUN_BENCHMARKS), "adaptive"])
    parser.add_argument("variants", nargs="*", help=f"among {sorted(VARIANTS)}")
    args = parser.parse_args(argv)
    unknown = [v for v in args.variants if v not in VARIANTS]
    if unknown:
        parser.error(f"variants must be among {sorted(VARIANTS)}; got {unknown}")
    warnings.simplefilter("ignore")
    if args.protocol == "adaptive":
        adaptive(args.data)
    for variant in args.variants:
        run(args.data, args.protocol, variant)


if __name__ == "__main__":
    main()
