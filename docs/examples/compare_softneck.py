"""How the comparison's rule chooses on the soft-neck cross-run splits: state models against ARX.

For the payload split (train the 0 g and 600 g staircases of the three controllers, test 200 g
and 400 g) and the controller split (train adaptive and fixed fractional, test the integer PI),
every method gets the benchmark's regressor (motor displacement and velocity -> raw
inclination, ``Lags(outputs=[1, 2], inputs=[0, 1])``; the state models use only its
conditions, none here) and is chosen as :func:`neckid.compare` chooses: on the training logs
only with :func:`neckid.select_safely` (leave one log out, runaways rejected, the stress check
reaching as far as the test inputs go beyond the training range, one standard error toward the
simpler model by :data:`neckid.selection.comparison.COMPLEXITY`), then one free run per test log. A
method is a registry name (:func:`neckid.methods`), with settings after colons
(``pnlss:order=2``), or ``sm-parallel[BASE]``: Set Membership on the registry model ``BASE`` run
in parallel (``ParallelSetMembership(base=BASE)``, ranked as ``sm-parallel``); ``compare``
names neither. Prints, per split, every method's mean test
fit [%], the recommended method and its margin over ARX, the rejected candidates with their
reasons, and the fold fits of the chosen one.

Run: ``python docs/examples/compare_softneck.py DATA [--methods arx,ss,sm-parallel[ss]]``
(DATA holds ``softneck/``; the default methods take about an hour on two busy cores).
"""

from __future__ import annotations

import argparse
import ast
import os
import re
import time
import warnings
from typing import Any

import numpy as np
from sklearn.base import clone

import neckid
from neckid import Lags, ParallelSetMembership
from neckid.data.training import TrainingSet
from neckid.experiments.benchmark.datasets import load_softneck_cross_run
from neckid.metrics import fit_percent
from neckid.selection.comparison import COMPLEXITY

#: Every method measured in ``docs/compare.md`` ("Measured on the real neck").
DEFAULT_METHODS = (
    "arx,sm,sm-linear,sm-parallel,ss,sm-parallel[ss],greybox-neck,pnlss:order=1,pnlss:order=2"
)

#: The benchmark's regressor.
LAGS = Lags(outputs=[1, 2], inputs=[0, 1])


def candidate(name: str, seed: int = 0) -> tuple[Any, int]:
    """The unfitted estimator of ``name`` and its complexity rank."""
    parallel = re.fullmatch(r"sm-parallel\[(.+)\]", name)
    if parallel:
        base = parallel.group(1)
        neckid.registry.get_method(base)  # an unknown base fails here, naming the registry
        return ParallelSetMembership(LAGS, base=base), COMPLEXITY["sm-parallel"]
    method, *settings = name.split(":")
    params = {k: ast.literal_eval(v) for k, v in (item.split("=", 1) for item in settings)}
    estimator = neckid.registry.get_method(method).make(LAGS, **params)
    if "random_state" in estimator.get_params():
        estimator.set_params(random_state=seed)
    return estimator, COMPLEXITY.get(method, 99)


def test_fits(estimator: Any, train: list[Any], tests: list[Any]) -> list[float]:
    """Free-run fit [%] of ``estimator`` fitted on ``train``, on each test log (-inf: ran away)."""
    model = clone(estimator).fit(train)
    fits = []
    for record in tests:
        try:
            result = model.simulate(record)
        except neckid.DivergenceError:
            fits.append(-np.inf)
            continue
        fits.append(float(fit_percent(record.y, result.y, skip=result.n_initial)[0]))
    return fits


def main(argv: list[str] | None = None) -> None:
    """Print one block per split."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data_dir", help="folder holding softneck/ (the lab's bench logs)")
    parser.add_argument("--methods", default=DEFAULT_METHODS)
    parser.add_argument(
        "--split", choices=["payload", "controller"], action="append", help="default: both"
    )
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    names = list(dict.fromkeys(["arx", *args.methods.split(",")]))  # ARX, the reference
    options = {name: candidate(name) for name in names}
    for split in args.split or ["payload", "controller"]:
        bench = load_softneck_cross_run(f"{args.data_dir}/softneck", f"softneck-{split}")
        tests = list(bench.tests.values())
        started = time.perf_counter()
        reach = max(0.1, TrainingSet.of(bench.train).input_reach(tests))
        selection = neckid.select_safely(
            [(name, estimator) for name, (estimator, _) in options.items()],
            bench.train,
            stress=reach,
            complexity={name: rank for name, (_, rank) in options.items()},
        )
        table = selection.table.set_index("name")
        means = {
            name: float(np.mean(test_fits(estimator, bench.train, tests)))
            for name, (estimator, _) in options.items()
            if table.loc[name, "status"] != "rejected"
        }
        load = os.getloadavg()[0]
        print(f"## {split} ({time.perf_counter() - started:.0f} s, load average {load:.1f})")
        for name in names:
            row = table.loc[name]
            shown = f"{means[name]:.1f} %" if name in means else "rejected"
            print(
                f"{name}: mean test fit {shown} (free run); folds {row['fit_mean']:.1f}"
                f" ± {row['fit_se']:.1f} %"
            )
        for name, reason in selection.rejected.items():
            print(f"rejected on the training logs: {name}: {reason[:160]}")
        chosen, best, arx = selection.chosen, selection.best, means["arx"]
        print(
            f"best on the folds {best} ({table.loc[best, 'fit_mean']:.1f} %), test"
            f" {means.get(best, float('nan')):.1f} %"
        )
        print(
            f"recommended {chosen}: {means[chosen]:.1f} %, {means[chosen] - arx:+.1f} points"
            f" from ARX ({arx:.1f} %); stress reach {reach:.0%}"
        )
        for line in [*selection.explain(), *selection.warnings]:
            print(line)
        print(f"baselines on the folds: {selection.baselines}")
        print(f"fold fits of the chosen: {np.round(table.loc[chosen, 'fold_fits'], 1)}")


if __name__ == "__main__":
    main()
