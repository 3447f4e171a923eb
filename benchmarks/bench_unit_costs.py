"""Calibrate the selection's unit costs (issue 42): single fits side by side, seconds vs cost.

Run:  .venv/bin/python benchmarks/bench_unit_costs.py [DATA] [--logs 5] [--only nn,ss]
      .venv/bin/python benchmarks/bench_unit_costs.py [DATA] --compare arx,sm,sm-parallel,ss,nn

Each case fits one estimator (a registry method with the settings shown) on the first ``--logs``
training logs (5: a fold of ``compare``) of the payload split of DATA (``load_softneck_cross_run``, the softneck protocol)
and free-runs it on the next log, as one unit of a selection does; it prints the seconds, the
expected cost (:attr:`neckid.registry.Method.cost`, :mod:`neckid.selection.costs`) and the
seconds per cost unit relative to ``sm``'s: a column of ones is a calibrated table. The load
average before and after is printed; only the ratios in one run mean anything.

``--compare METHODS``: :func:`neckid.compare` on the payload split as ``neckid compare`` runs it
(the command line's default lags ``1-2/1-2``), every unit of its selection timed by the progress
(:class:`neckid.utils.progress.Plan`): per candidate its seconds, its cost and its seconds per
cost relative to ``sm``'s, and the first time left the progress would show after 5 s against
the real time left.

Measured (2-core machine, shared): single fits of 15,622 rows at load 2.2 → 2.9: sm 0.45 s, nn
12.5 s (1 network 1.7 s, quick 0.95 s), ss 0.42 s (order 2: 0.16 s, order 6: 0.49 s),
sm-multistep horizon 3: 15.1 s, 6: 72.8 s, pnlss quick 12.1 s, koopman 3.1 s (quick 0.04 s).
``--compare`` at load 3.4 → 3.8: per fold sm 0.39 s, ss 0.80 s, nn 22.9 s; at load 2.3: sm
0.37 s, ss 0.50 s, nn 11.2 s. After the compiled trainer of the networks and the faster SM
walks (load 1.2-1.6): single fits sm 0.09 s, nn 2.05 s (1 network 0.59 s), ss 0.32 s; ``--compare``
sm 0.51 s, ss 2.69 s, nn 10.84 s in all, which set ``_NEURAL`` and ``_SUBSPACE_*`` anew (per
cost against sm 0.52 and 3.37 before, 0.94 and 0.87 after; first time left 45.8 s shown
against 10.8 s real before, 12.2 s against 10.6 s after). The constants of
:mod:`neckid.selection.costs` sit between.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from typing import Any

from neckid import Lags, methods
from neckid.experiments.benchmark.datasets import load_softneck_cross_run
from neckid.selection.work import unit_cost

LAGS = Lags(outputs=[1, 2], inputs=[1, 2])

#: (label, method, settings): each method at its defaults and at settings that change its cost.
CASES: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("sm", "sm", {}),
    ("arx", "arx", {}),
    ("sm-parallel", "sm-parallel", {}),
    ("sm-multistep h=3", "sm-multistep", {"horizon": 3}),
    ("sm-multistep h=6", "sm-multistep", {"horizon": 6}),
    ("ss", "ss", {}),
    ("ss order 2", "ss", {"order": 2}),
    ("ss order 6", "ss", {"order": 6}),
    ("ss quick", "ss", {"max_iter": 20}),
    ("nn", "nn", {}),
    ("nn 1 network", "nn", {"n_networks": 1}),
    ("nn quick", "nn", {"hidden_layer_sizes": (8,), "max_iter": 50, "n_networks": 2}),
    ("poly quick", "poly", {"degree": 2, "max_iter": 10}),
    ("poly degree 2", "poly", {"degree": 2, "max_iter": 40}),
    ("pnlss quick", "pnlss", {"degree": 2, "max_iter": 10}),
    ("koopman", "koopman", {}),
    ("koopman quick", "koopman", {"n_observables": 10, "ridge": 1e-6}),
    ("sindy quick", "sindy", {"degree": 2, "max_iter": 20, "thresholds": (0.1, 0.01)}),
)


def _rows(record: Any, start: int, stop: int) -> Any:
    """Samples ``start:stop`` of a log (a small fit that compiles a method's kernels)."""
    t0 = record.t0 if hasattr(record, "t0") else 0.0
    return record.time_slice(t0 + start * record.ts, t0 + stop * record.ts)


def _unit(model: Any, train: list[Any], held: Any) -> tuple[float, str]:
    """Seconds of one selection unit: the fit, then a free run of the held-out log."""
    start = time.perf_counter()
    failed = ""
    try:
        model.fit(train)
        model.simulate(held)
    except Exception as error:  # a diverging free run still cost its time
        failed = f"  ({type(error).__name__})"
    return time.perf_counter() - start, failed


class _Keeper:
    """A reporter that keeps the plan of the selection's units (nothing is shown)."""

    def __init__(self) -> None:
        self.plans: list[Any] = []

    def start(self, label: str, total: float | None) -> _Keeper:
        return self

    def note(self, detail: str, estimate: Any) -> None:
        plan = getattr(estimate, "__self__", None)
        if plan is not None and (not self.plans or self.plans[-1] is not plan):
            self.plans.append(plan)

    def advance(self, steps: float = 1.0) -> None:
        pass

    def stop(self) -> None:
        pass


def run_compare(data: str, names: list[str]) -> None:
    """Every selection unit of a payload-split compare: seconds against cost, per candidate."""
    from neckid import compare
    from neckid.utils.progress import reporting

    bench = load_softneck_cross_run(data, "softneck-payload")
    keeper = _Keeper()
    print(f"load average before {os.getloadavg()[0]:.2f}")
    with reporting(keeper):
        compare(bench.train, list(bench.tests.values()), methods=names, lags=LAGS, progress=True)
    print(f"load average after {os.getloadavg()[0]:.2f}")
    plan = keeper.plans[0]
    times = [b - a for a, b in zip(plan.ends, plan.ends[1:], strict=False)]
    by_group: dict[str, list[float]] = {}
    for group, seconds, cost in zip(plan.groups, times, plan.costs, strict=False):
        by_group.setdefault(group, [0.0, 0.0])
        by_group[group][0] += seconds
        by_group[group][1] += cost
    reference = next((s / c for g, (s, c) in by_group.items() if g == "sm" and c), 1.0)
    for group, (seconds, cost) in by_group.items():
        ratio = seconds / cost / reference if cost else float("nan")
        print(
            f"  {group[:40]:40s} {seconds:7.2f} s  cost {cost:10.0f}  per cost vs sm {ratio:6.2f}"
        )
    start, end = plan.ends[0], plan.ends[-1]
    for at in (5.0, 15.0):
        done = sum(1 for t in plan.ends[1:] if t <= start + at)
        replay = type(plan)(plan.groups, plan.costs, start=start)
        for t in plan.ends[1 : done + 1]:
            replay.finish(t)
        left, _ = replay.left(start + at)
        print(f"  after {at:.0f} s: time left shown {left}, real {end - start - at:.1f} s")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("data", nargs="?", default="../shared/data/softneck")
    parser.add_argument("--logs", type=int, default=5)
    parser.add_argument("--only", default="")
    parser.add_argument("--compare", default="")
    args = parser.parse_args()
    if args.compare:
        run_compare(args.data, args.compare.split(","))
        return
    bench = load_softneck_cross_run(args.data, "softneck-payload")
    train, held = list(bench.train[: args.logs]), bench.train[args.logs]
    only = set(filter(None, args.only.split(",")))
    rows = []
    warnings.simplefilter("ignore")  # convergence warnings of the quick settings
    print(f"load average before {os.getloadavg()[0]:.2f}; {sum(r.n_samples for r in train)} rows")
    for label, name, settings in CASES:
        if only and name not in only and label not in only:
            continue
        method = methods()[name]
        lags = None if method.lag_free else LAGS
        _unit(method.make(lags, **settings), [_rows(held, 0, 800)], _rows(held, 800, 1600))
        model = method.make(lags, **settings)  # the small fit above compiled its kernels
        cost = unit_cost(model, train)
        seconds, failed = _unit(model, train, held)
        rows.append((label, seconds, cost))
        print(f"  {label:18s} {seconds:8.2f} s  cost {cost:12.0f}{failed}", flush=True)
    reference = next((s / c for label, s, c in rows if label == "sm"), None)
    print(f"load average after {os.getloadavg()[0]:.2f}")
    if reference:
        for label, seconds, cost in rows:
            print(
                f"  {label:18s} seconds per cost relative to sm: {seconds / cost / reference:6.2f}"
            )


if __name__ == "__main__":
    main()
