"""The default ε rule at scale (issue 33): the knee search vs the walk, and vs ε and γ given.

Run:  .venv/bin/python benchmarks/bench_default_epsilon.py [--quick] [--cases held,smooth-1e5]
      [--methods search,given,walk] [--kernel] [--margins] [--repeat 3]

``SetMembership().fit`` with ε and γ not given takes ε at the knee of the γ*(ε) curve (48
values) and γ = 1.1 γ*(ε). Fits per case, side by side in one process, with the cache of γ*(ε)
values turned off (``use_caches(gamma_curves=None)``: a fit must not reuse the curve of the one
before it):

- ``search``: the default fit (:func:`neckid.models.set_membership.prior.knee_search` from
  20,000 rows: the curve on a subsample locates the knee, γ*(ε) is exact only on the grid's
  first values, as far as the knee needs, each pass started at the subsample's values);
- ``given``: the same ε and γ passed by the user (the fit checks γ >= γ*(ε) by branch and
  bound started at γ);
- ``walk``: the rule before issue 33, γ*(ε) exact over all pairs at every ε of the grid: the
  fit with the default grid given as ``epsilons`` (its curve is then computed whole). It must
  choose the same ε and γ as the search, bit for bit (checked).

``--kernel`` also times the γ*(ε) pass of the search's exact part (the grid rows of its
``gamma_curve_``) on the fitted tree without and with the slope bound of
:mod:`neckid.models.set_membership._kernels.slope` (``slopes="never"`` vs ``"auto"``), same
result checked. ``--margins`` times γ*(ε) at the chosen ε against the checks that
γ <= (1 + δ) γ*(ε) for δ = 10 %, 1 %, 0.1 % (the price of bounds of that width on γ*(ε)).
Targets: search within 5x of given on the held-input log (200,000 rows,
``Lags(outputs=[1], inputs=[1])``) and at 1,000,000 rows with six regressors, within 3x at 100,000
rows. Cases (``--quick``: sizes / 10):

- ``held``: ``_systems.held_input`` (input held for 20 samples), 200,000 rows, 2 terms;
- ``smooth-1e5``, ``smooth-1e6``: ``_systems.neck_like`` with ``Lags(outputs=3, inputs=[8])``
  (three past outputs, three inputs at lag 8: six terms), 100,000 and 1,000,000 rows;
- ``held-6`` (only when asked for): the held-input plant with ``Lags(outputs=3, inputs=[1, 2,
  3])``, 200,000 rows, six terms;
- ``clean-1e5`` (only when asked for): ``smooth-1e5`` from sample 10 on (see docs/scaling.md:
  the first rows of ``neck_like`` are identical regressors with different targets, which set the
  knee of the smooth cases).

Each fit runs once (the walk at 1e6 rows takes minutes), the search and given fits ``--repeat``
times alternately (the median ratio is printed); wall and CPU time (all threads of the process,
which counts the threads' waiting too when other jobs hold the cores) are printed. On a shared 2-core machine the wall times move by tens of percent from
run to run: read the ratios, measured side by side, with the load average printed beside them.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable

import numba
import numpy as np
from _systems import HELD_INPUT_LAGS, held_input, neck_like

from neckid import IOData, Lags
from neckid.models.cache import use_caches
from neckid.models.set_membership._kernels.gamma import gamma_star
from neckid.models.set_membership.narx import SetMembership
from neckid.models.set_membership.prior import DEFAULT_GRID_POINTS, _default_epsilons

SIX_TERMS = Lags(outputs=3, inputs=[8])
CASES: dict[str, tuple[Lags, Callable[[int], IOData], int, float]] = {
    "held": (HELD_INPUT_LAGS, lambda n: held_input(n + 1), 200_000, 5.0),
    "smooth-1e5": (SIX_TERMS, lambda n: neck_like(n + 8, seed=1), 100_000, 3.0),
    "smooth-1e6": (SIX_TERMS, lambda n: neck_like(n + 8, seed=1), 1_000_000, 5.0),
    # not in the default run: the held-input plant with six terms, and the neck-like log from
    # sample 10 on (before it, its first rows are identical regressors with different targets)
    "held-6": (Lags(outputs=3, inputs=[1, 2, 3]), lambda n: held_input(n + 3), 200_000, 5.0),
    "clean-1e5": (SIX_TERMS, lambda n: neck_like(n + 18, seed=1)[10:], 100_000, 3.0),
}
DEFAULT_CASES = ("held", "smooth-1e5", "smooth-1e6")
METHODS = ("search", "given", "walk")


def timed(run: Callable[[], object]) -> tuple[float, float, object]:
    """Wall and CPU seconds of ``run()``, and its result."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = run()
    return time.perf_counter() - wall, time.process_time() - cpu, result


def fit(lags: Lags, data: IOData, **settings: object) -> Callable[[], SetMembership]:
    return lambda: SetMembership(lags, progress=False, **settings).fit(data)  # type: ignore[arg-type]


def load() -> str:
    return f"{os.getloadavg()[0]:.2f}"


def margin_checks(model: SetMembership) -> str:
    """γ*(ε) at the chosen ε, and the checks that γ*(ε) <= (1 + δ) γ*(ε), side by side.

    What a rule that certified γ instead of computing γ*(ε) (``floor`` at a lower bound times
    1 + δ) would pay for bounds of relative width δ on γ*(ε).
    """
    tree, epsilon = model._tree, model.epsilon_[None, :]
    wall, cpu, exact = timed(lambda: gamma_star(tree.points, tree.targets, epsilon, tree=tree))
    parts = [f"γ*(ε) at the chosen ε: wall {wall:.2f} s, cpu {cpu:.2f} s; γ <= (1 + δ) γ*(ε):"]
    for delta in (0.1, 0.01, 0.001):
        floor = (1.0 + delta) * np.asarray(exact)[0]
        w, c, checked = timed(
            lambda floor=floor: gamma_star(
                tree.points, tree.targets, epsilon, tree=tree, floor=floor
            )
        )
        assert np.array_equal(np.asarray(checked)[0], floor)  # the check holds
        parts.append(f"δ = {delta:g}: {w:.2f} s ({wall / w:.1f}x less), cpu {c:.2f} s")
    return "\n    ".join(parts)


def exact_pass(model: SetMembership) -> str:
    """The γ*(ε) pass over the model's exact grid rows, without and with the slope bound."""
    tree, grid = model._tree, model.gamma_curve_.epsilons
    runs = {
        slopes: timed(
            lambda slopes=slopes: gamma_star(  # type: ignore[misc]
                tree.points, tree.targets, grid, tree=tree, slopes=slopes
            )
        )
        for slopes in ("never", "auto")
    }
    assert np.array_equal(runs["never"][2], runs["auto"][2])  # type: ignore[arg-type]
    (wn, cn, _), (wa, ca, _) = runs["never"], runs["auto"]
    return (
        f"exact pass over {grid.shape[0]} ε, no slope bound / slope bound: wall {wn:.2f} /"
        f" {wa:.2f} s = {wn / wa:.1f}x, cpu {cn:.2f} / {ca:.2f} s = {cn / ca:.1f}x (same values)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="sizes / 10 (a smoke run)")
    parser.add_argument(
        "--cases",
        default=",".join(DEFAULT_CASES),
        help="comma-separated, of: " + ", ".join(CASES),
    )
    parser.add_argument(
        "--methods", default=",".join(METHODS), help="comma-separated, of: " + ", ".join(METHODS)
    )
    parser.add_argument(
        "--kernel", action="store_true", help="time the exact pass without/with slope bounds"
    )
    parser.add_argument(
        "--repeat", type=int, default=1, help="search and given fits, alternately, this often"
    )
    parser.add_argument(
        "--margins", action="store_true", help="time γ >= (1 + δ) γ*(ε) checks against γ*(ε)"
    )
    args = parser.parse_args()
    methods = args.methods.split(",")
    print(
        f"numba {numba.__version__}, {numba.get_num_threads()} threads, {os.cpu_count()} CPUs,"
        f" load average {load()} (shared machine: timings are noisy)"
    )
    for name in args.cases.split(","):
        lags, make, rows, target = CASES[name]
        rows = rows // 10 if args.quick else rows
        data = make(rows)
        warm = data[: min(rows, 25_000)]  # above the search's and the tree's thresholds
        with use_caches(gamma_curves=None):  # load the compiled kernels for this regressor
            model = fit(lags, warm)()
            fit(lags, warm, epsilon=model.epsilon_, gamma=model.gamma_)()
            tree = model._tree
            gamma_star(
                tree.points, tree.targets, model.gamma_curve_.epsilons, tree=tree, slopes="always"
            )
        times: dict[str, tuple[float, float]] = {}
        ratios: list[tuple[float, float]] = []
        with use_caches(gamma_curves=None):
            for _ in range(max(args.repeat, 1)):
                wall, cpu, new = timed(fit(lags, data))
                assert isinstance(new, SetMembership)
                times["search"] = (wall, cpu)
                load_search = load()
                if "given" in methods:
                    wall, cpu, _ = timed(fit(lags, data, epsilon=new.epsilon_, gamma=new.gamma_))
                    times["given"] = (wall, cpu)
                    (ws, cs), (wg, cg) = times["search"], times["given"]
                    ratios.append((ws / wg, cs / cg))
            same = "-"
            if "walk" in methods:
                grid = _default_epsilons(new._tree.targets)
                wall, cpu, old = timed(fit(lags, data, epsilons=grid))
                assert isinstance(old, SetMembership)
                times["walk"] = (wall, cpu)
                same = str(
                    np.array_equal(old.epsilon_, new.epsilon_)
                    and np.array_equal(old.gamma_, new.gamma_)
                )
                assert same == "True", (old.epsilon_, new.epsilon_, old.gamma_, new.gamma_)
        exact = new.gamma_curve_.epsilons.shape[0]
        print(
            f"\n{name}: {rows:,} rows, {lags.resolve([data]).n_terms} terms; ε = {new.epsilon_[0]:.4g},"
            f" γ = {new.gamma_[0]:.4g}; exact γ*(ε) on {exact} / {DEFAULT_GRID_POINTS} grid values;"
            f" walk chose the same: {same}; load average {load_search} after the search"
        )
        for method, (wall, cpu) in times.items():
            print(f"  {method:<7} wall {wall:8.2f} s   cpu {cpu:8.2f} s  (the last run)")
        if ratios:
            wall_ratio, cpu_ratio = np.median(np.array(ratios), axis=0)
            print(
                f"  search / given: wall {wall_ratio:5.1f}x   cpu {cpu_ratio:5.1f}x   (target"
                f" {target:.0f}x; the median of {len(ratios)}, wall"
                f" {min(r[0] for r in ratios):.1f}-{max(r[0] for r in ratios):.1f}x)"
            )
        if "walk" in times:
            (ws, cs), (ww, cw) = times["search"], times["walk"]
            print(f"  walk / search:  wall {ww / ws:5.1f}x   cpu {cw / cs:5.1f}x")
        if args.kernel:
            print("  " + exact_pass(new))
        if args.margins:
            print("  " + margin_checks(new))
    print(f"\nload average at the end {load()}")


if __name__ == "__main__":
    main()
