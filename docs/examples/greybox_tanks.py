"""The cascaded-tanks grey-box structure (``greybox-tanks``) on the cascaded-tanks benchmark.

Settings are chosen on the training record only, by the benchmark's hold-out rule: every
candidate (``fixed``: {none, the pump's dead zone, the lower outlet's height} x {free outflow
exponents, both held at Torricelli's 1/2}; x ``initial_state`` in {output, estimated}; the dead
zone and the outlet height both shift the level at which the lower tank's outflow starts, so
the data may not tell them apart) is fitted on
the first 75 % of the training record and run freely on the last 25 % (from that part's first
measured level, the structure's initial-state rule); the smallest RMSE there wins and is refitted
on the whole training record. The test record (the benchmark's validation record) is then run
once, from its first measured level. The script prints the hold-out table, the training free-run
RMSE and fit, the fit time, the fitted parameters and the test RMSE and fit.

Also printed, not used to choose anything: the test run from the training record's initial state
(the benchmark description says both records start from the same unknown state), the test RMSE
of the chosen settings refitted with other seeds (``--seeds``: how much the result depends on
the multi-start's random points) and, with ``--sensitivity``, the test RMSE of every candidate
refitted on the whole training record (how much the rule's choice matters).

With ``--substeps`` it prints how far the fitted model's training free run moves with 1, 2, 4,
8 and 16 Runge–Kutta steps per sample from a run with 64 (the integration error behind the
default of 4).

With ``--with-sm`` it also fits Set Membership on the grey box run in parallel
(``ParallelSetMembership(base=GreyBoxODE(...))``), its SM settings (``linear_lags`` x
``estimate``) chosen by the same hold-out rule, and prints its test RMSE and how much of the test
record its band holds.

Run: ``python docs/examples/greybox_tanks.py DATA [--seeds 1,2,3,4] [--sensitivity]
[--substeps] [--with-sm]`` (DATA holds ``benchmarks/cascaded_tanks/``).
"""

from __future__ import annotations

import argparse
import itertools
import time
import warnings
from pathlib import Path

import numpy as np

from neckid import Lags
from neckid.datasets import load_cascaded_tanks
from neckid.models.base import DivergenceError
from neckid.models.greybox import GreyBoxODE, simulate_structure
from neckid.models.set_membership.parallel import ParallelSetMembership


def _rmse(model, record, **options) -> float:
    """Free-run RMSE [V] on ``record`` after the first sample (inf when the run diverges)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a level outside the training range: said below
            run = model.simulate(record, **options)
    except DivergenceError:
        return float("inf")
    return float(run.rmse(record)[0])


def _choose(make, candidates, train):
    """The candidate of the smallest hold-out RMSE (fit on 75 %, free run on the last 25 %)."""
    split = int(0.75 * train.n_samples)
    first, held_out = train[:split], train[split:]
    rows = []
    for settings in candidates:
        start = time.perf_counter()
        model = make(**settings).fit(first)
        rows.append((_rmse(model, held_out), time.perf_counter() - start, settings))
        print(f"  {settings}: hold-out RMSE {rows[-1][0]:.4f} V ({rows[-1][1]:.1f} s)")
    return min(rows, key=lambda row: row[0])[2]


def _substeps_error(model, train) -> None:
    """RMS and largest change of the training free run against 64 Runge–Kutta steps per sample."""
    runs = {
        k: simulate_structure(
            model.structure_,
            train.u,
            model.parameters_,
            ts=train.ts,
            x0=model.initial_states_[0],
            substeps=k,
        )[1]
        for k in (1, 2, 4, 8, 16, 64)
    }
    for k in (1, 2, 4, 8, 16):
        change = runs[k] - runs[64]
        print(
            f"  substeps {k:2d}: training free run differs from 64 substeps by RMS"
            f" {1e3 * float(np.sqrt(np.mean(change**2))):.2f} mV, at most"
            f" {1e3 * float(np.abs(change).max()):.2f} mV"
        )


def main(argv: list[str] | None = None) -> None:
    """Choose the grey box's settings on the training record; print its test RMSE."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", type=Path, help="folder that holds benchmarks/cascaded_tanks/")
    parser.add_argument("--n-starts", type=int, default=8, help="starts of every fit")
    parser.add_argument("--seeds", default="1,2,3,4", help="other seeds to refit with")
    parser.add_argument("--with-sm", action="store_true", help="also SM on the grey box run")
    parser.add_argument(
        "--sensitivity", action="store_true", help="test RMSE of every candidate (not a choice)"
    )
    parser.add_argument("--substeps", action="store_true", help="integration error per substeps")
    args = parser.parse_args(argv)
    bench = load_cascaded_tanks(args.data / "benchmarks" / "cascaded_tanks")
    train, test = bench.train, bench.tests["validation"]

    print("hold-out rule on the training record:")
    torricelli = ("upper_exponent", "lower_exponent")
    grid = [
        {"fixed": held + law, "initial_state": mode, "n_starts": args.n_starts}
        for held, law, mode in itertools.product(
            ((), ("pump_threshold",), ("lower_outlet",)), ((), torricelli), ("output", "estimated")
        )
    ]
    chosen = _choose(lambda **s: GreyBoxODE(structure="cascaded-tanks", **s), grid, train)
    print(f"chosen: {chosen}")
    start = time.perf_counter()
    model = GreyBoxODE(structure="cascaded-tanks", **chosen).fit(train)
    seconds = time.perf_counter() - start
    train_run = model.simulate(train)
    print(
        f"training free run: RMSE {float(train_run.rmse(train)[0]):.4f} V, fit"
        f" {float(train_run.fit_percent(train)[0]):.2f} % (fit {seconds:.1f} s,"
        f" {model.n_evaluations_} free runs; the fit's own RMSE {model.train_rmse_[0]:.4f} V)"
    )
    for name, value in model.parameter_values().items():
        unit = next(p.unit for p in model.structure_.parameters if p.name == name)
        print(f"  {name} = {value:.5g} {unit}")
    run = model.simulate(test)
    print(
        f"test (validation record), from its first level: RMSE {float(run.rmse(test)[0]):.4f} V,"
        f" fit {float(run.fit_percent(test)[0]):.2f} %"
    )
    same = _rmse(model, test, state=model.initial_states_[0])
    print(f"test from the training record's initial state (not the protocol): RMSE {same:.4f} V")
    for seed in [int(s) for s in args.seeds.split(",") if s]:
        other = GreyBoxODE(structure="cascaded-tanks", random_state=seed, **chosen).fit(train)
        print(
            f"  seed {seed}: training RMSE {other.train_rmse_[0]:.4f} V, test RMSE"
            f" {_rmse(other, test):.4f} V"
        )

    if args.substeps:
        _substeps_error(model, train)

    if args.sensitivity:
        print("every candidate refitted on the whole training record (not used to choose):")
        for settings in grid:
            other = GreyBoxODE(structure="cascaded-tanks", **settings).fit(train)
            print(f"  {settings}: test RMSE {_rmse(other, test):.4f} V")

    if args.with_sm:
        print("SM on the grey box (ParallelSetMembership), hold-out rule:")
        base = GreyBoxODE(structure="cascaded-tanks", **chosen)
        sm_grid = [
            {"linear_lags": lags, "estimate": estimate}
            for lags, estimate in itertools.product(([0], [0, 1]), ("central", "projection"))
        ]

        def make(**settings):
            return ParallelSetMembership(Lags.arx(1, 1, 1), base=base, **settings)

        sm_chosen = _choose(make, sm_grid, train)
        sm = make(**sm_chosen).fit(train)
        run = sm.simulate(test)
        measured = test.y[run.n_initial :, 0]
        inside = (measured >= run.lower[run.n_initial :, 0] - sm.epsilon_[0]) & (
            measured <= run.upper[run.n_initial :, 0] + sm.epsilon_[0]
        )
        print(
            f"SM parallel {sm_chosen}: test RMSE {float(run.rmse(test)[0]):.4f} V, fit"
            f" {float(run.fit_percent(test)[0]):.2f} %, epsilon {sm.epsilon_[0]:.4f} V, band"
            f" [f_l - eps, f_u + eps] holds {np.mean(inside):.1%} of the test samples"
        )


if __name__ == "__main__":
    main()
