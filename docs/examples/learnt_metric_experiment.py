"""The learnt SM distance (``scaling="gradient"``) against the std one, on the training records only.

What it shows: whether learning the SM distance from the data beats the hand-made one, on the
benchmarks' selection splits (docs/benchmarks/silverbox.md, *The learnt distance*). Run from the repository,
with the data folder that holds ``benchmarks/`` (about 8 min on 2 cores; without a part, all)::

    .venv/bin/python docs/examples/learnt_metric_experiment.py DATA [silverbox-linear] [tanks-parallel] [silverbox-poly] [silverbox-projection]

Every figure is a selection score: fit on the first 75 % of the training record, free-run RMSE on
the last 25 % (the benchmark's rule); the cascaded-tanks lines also print the validation record's
RMSE of the same setting refitted on the whole training record.

- ``silverbox-linear``: SM with a linear part, ``Lags(outputs=[1, 2], inputs=[0, 1, 2, 3])``,
  ε ∈ {0.3, 0.45, 0.64, 1.0} mV; the std distance with the input terms weighted 0.03 (the
  benchmark's hand-made metric) against the learnt one, each with one γ or local constants.
- ``tanks-parallel``: SM on a parallel ARX ``Lags.arx(4, 4, 1)``, ε by the knee rule, the
  benchmark's four SM regressors.
- ``silverbox-poly``: SM on a parallel polynomial (``Lags.arx(3, 4, 0)``, degree 3, fitted for
  simulation), four SM regressors, ε ∈ {1, 3, 6} × the polynomial's training free-run RMS.
- ``silverbox-projection``: the setting the benchmark chooses for SM on the polynomial, fitted on
  the whole training record: how often and how far the projection moves the polynomial's output
  on the test records, the width of the bounds and the share of samples within ε of them.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from neckid import IOData, Lags, ParallelSetMembership, PolynomialNARX, SetMembership
from neckid.experiments.benchmark.datasets import load_benchmark
from neckid.selection.lags import free_run


def split(data: Path, name: str) -> tuple[IOData, IOData, Any]:
    """The benchmark's selection split of ``name``'s training record, and the benchmark."""
    bench = load_benchmark(name, data)
    if bench is None:
        raise SystemExit(f"{name} is not under {data}")
    cut = int(0.75 * bench.train.n_samples)
    return bench.train[:cut], bench.train[cut:], bench


def rmse(model: object, record: IOData) -> float:
    """Free-run RMSE of the first output, from the record's first ``max_lag_`` samples."""
    y, skip = free_run(model, record, None, diverged="keep")
    return float(np.sqrt(np.mean((y[skip:, 0] - record.y[skip:, 0]) ** 2)))


def silverbox_linear(data: Path) -> None:
    """SM + linear part on Silverbox: hand-made against learnt distance."""
    fit, check, _ = split(data, "silverbox")
    lags = Lags(outputs=[1, 2], inputs=[0, 1, 2, 3])
    for eps in (0.3e-3, 0.45e-3, 0.64e-3, 1e-3):
        for scaling, weight in (("std", 0.03), ("gradient", 1.0)):
            for lipschitz in ("global", "local"):
                model = SetMembership(
                    lags, epsilon=eps, linear_part=True, scaling=scaling, input_weight=weight,
                    lipschitz=lipschitz,
                ).fit(fit)  # fmt: skip
                relative = model.weights_ / model.weights_.max()
                print(
                    f"Silverbox SM + linear, eps {eps * 1e3:.2f} mV, {scaling} (input weight"
                    f" {weight:g}), {lipschitz}: {rmse(model, check) * 1e3:.4f} mV;"
                    f" relative weights {np.round(relative, 3).tolist()}",
                    flush=True,
                )


def tanks_parallel(data: Path) -> None:
    """SM on a parallel ARX on the cascaded tanks: std against learnt distance."""
    fit, check, bench = split(data, "cascaded_tanks")
    for linear_lags in ((0,), (0, 1), (0, 1, 2)):
        for input_lags in ((), (1,)):
            for scaling in ("std", "gradient"):
                for lipschitz in ("global", "local"):
                    params = {
                        "linear_lags": linear_lags, "input_lags": input_lags, "scaling": scaling,
                        "lipschitz": lipschitz, "progress": False,
                    }  # fmt: skip
                    model = ParallelSetMembership(Lags.arx(4, 4, 1), **params).fit(fit)
                    full = ParallelSetMembership(Lags.arx(4, 4, 1), **params).fit(bench.train)
                    print(
                        f"tanks SM parallel {list(linear_lags)} {list(input_lags)} {scaling}"
                        f" {lipschitz}: selection {rmse(model, check):.4f} V, validation"
                        f" {rmse(full, bench.tests['validation']):.4f} V",
                        flush=True,
                    )


def silverbox_poly(data: Path) -> None:
    """SM on a parallel polynomial on Silverbox: std against learnt distance."""
    fit, check, _ = split(data, "silverbox")
    lags = Lags.arx(3, 4, 0)
    polynomial = PolynomialNARX(lags).fit(fit)
    scale = float(np.sqrt(np.mean(np.square(polynomial.fit_report_["rmse"]))))
    print(f"Silverbox polynomial alone: {rmse(polynomial, check) * 1e3:.4f} mV", flush=True)
    for linear_lags, input_lags in (((0, 1), ()), ((0, 1), (1,)), ((0, 1, 2), (0, 1, 2, 3))):
        for factor in (1.0, 3.0, 6.0):
            for scaling in ("std", "gradient"):
                for lipschitz in ("global", "local"):
                    model = ParallelSetMembership(
                        lags, linear_lags=linear_lags, input_lags=input_lags, parallel_degree=3,
                        parallel_fit="simulation", epsilon=factor * scale, scaling=scaling,
                        lipschitz=lipschitz, progress=False,
                    )  # fmt: skip
                    started = time.perf_counter()
                    model.fit(fit)  # the polynomial comes from PolynomialNARX's fit cache
                    print(
                        f"Silverbox SM on the polynomial {list(linear_lags)} {list(input_lags)},"
                        f" eps {factor:g} x, {scaling} {lipschitz}: {rmse(model, check) * 1e3:.4f}"
                        f" mV ({time.perf_counter() - started:.1f} s)",
                        flush=True,
                    )


def silverbox_projection(data: Path) -> None:
    """The benchmark's SM on the polynomial (projection) beside the polynomial alone, test records."""
    bench = load_benchmark("silverbox", data)
    assert bench is not None
    lags = Lags.arx(3, 4, 0)
    polynomial = PolynomialNARX(lags).fit(bench.train)
    scale = float(np.sqrt(np.mean(np.square(polynomial.fit_report_["rmse"]))))
    model = ParallelSetMembership(
        lags, linear_lags=[0, 1], input_lags=[1], parallel_degree=3, parallel_fit="simulation",
        epsilon=3 * scale, scaling="gradient", lipschitz="local", estimate="projection",
    ).fit(bench.train)  # fmt: skip
    for name in ("multisine", "arrow_no_extrapolation"):
        record = bench.tests[name]
        ours, skip = free_run(model, record, 50)
        alone, _ = free_run(polynomial, record, 50)
        moved = np.abs(ours[skip:, 0] - alone[skip:, 0])
        run = model.simulate(record[50 - model.max_lag_ :])
        low, high = run.lower[model.max_lag_ :, 0], run.upper[model.max_lag_ :, 0]
        eps = model.epsilon_[0]
        inside = (record.y[50:, 0] >= low - eps) & (record.y[50:, 0] <= high + eps)
        print(
            f"Silverbox {name}: RMSE {np.sqrt(np.mean((ours[skip:, 0] - record.y[skip:, 0]) ** 2)) * 1e3:.4f}"
            f" mV; projection moves {np.mean(moved > 0):.1%} of the samples, at most"
            f" {moved.max() * 1e3:.3f} mV; bounds {np.mean(high - low) * 1e3:.3f} mV apart;"
            f" {np.mean(inside):.1%} of the samples within eps = {eps * 1e3:.3f} mV of them",
            flush=True,
        )


PARTS = {
    "silverbox-linear": silverbox_linear,
    "tanks-parallel": tanks_parallel,
    "silverbox-poly": silverbox_poly,
    "silverbox-projection": silverbox_projection,
}


def main(argv: list[str] | None = None) -> None:
    """Run the parts asked for (all of them without one)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("data", type=Path, help="the data folder (it holds benchmarks/)")
    parser.add_argument("parts", nargs="*", help=f"among {list(PARTS)} (default: all)")
    args = parser.parse_args(argv)
    unknown = [p for p in args.parts if p not in PARTS]
    if unknown:
        parser.error(f"parts must be among {list(PARTS)}; got {unknown}")
    warnings.simplefilter("ignore")
    for part in args.parts or list(PARTS):
        PARTS[part](args.data)


if __name__ == "__main__":
    main()
