"""The default ε rule at scale (issue 33): the knee search vs the walk, and vs ε and γ given.

Run:  .venv/bin/python benchmarks/bench_default_epsilon.py [--quick] [--cases held,smooth-1e5,smooth-1e6]

``SetMembership().fit`` with ε and γ not given takes ε at the knee of the γ*(ε) curve (48
values) and γ = 1.1 γ*(ε). Three fits per case, side by side in one process:

- ``walk``: the rule before issue 33, γ*(ε) exact over all pairs at every ε of the grid
  (``prior.KNEE_METHOD = "walk"``);
- ``search``: the default now (:func:`neckid.models.set_membership.prior.knee_search`): the
  curve on a subsample locates the knee, γ*(ε) is exact only on the grid's first values, as far
  as the knee needs;
- ``given``: the same ε and γ passed by the user (the fit checks γ >= γ*(ε) by branch and
  bound).

The walk and the search must choose the same ε and γ, bit for bit (checked). Targets: default
within 5x of given on the held-input log (200,000 rows, ``Lags(outputs=[1], inputs=[1])``) and
at 1,000,000 rows with six regressors, within 3x at 100,000 rows. Cases (``--quick``: sizes / 10):

- ``held``: ``_systems.held_input`` (input held for 20 samples), 200,000 rows, 2 terms;
- ``smooth-1e5``, ``smooth-1e6``: ``_systems.neck_like`` with ``Lags(outputs=3, inputs=[8])``
  (three past outputs, three inputs at lag 8: six terms), 100,000 and 1,000,000 rows.

Each fit runs once (a fit at 1e6 rows takes minutes with the walk); on a shared 2-core machine
the times move by tens of percent from run to run: read the ratios, measured side by side.
"""

from __future__ import annotations

import argparse
import os
import time

import numba
import numpy as np
from _systems import HELD_INPUT_LAGS, held_input, neck_like

import neckid.models.set_membership.prior as prior
from neckid import IOData, Lags
from neckid.models.set_membership.narx import SetMembership

SIX_TERMS = Lags(outputs=3, inputs=[8])
CASES = {
    "held": (HELD_INPUT_LAGS, lambda n: held_input(n + 1), 200_000, 5.0),
    "smooth-1e5": (SIX_TERMS, lambda n: neck_like(n + 8, seed=1), 100_000, 3.0),
    "smooth-1e6": (SIX_TERMS, lambda n: neck_like(n + 8, seed=1), 1_000_000, 5.0),
}


def fit(
    lags: Lags, data: IOData, method: str = "search", **given: object
) -> tuple[float, SetMembership]:
    prior.KNEE_METHOD = method  # type: ignore[assignment]
    start = time.perf_counter()
    model = SetMembership(lags, progress=False, **given).fit(data)  # type: ignore[arg-type]
    return time.perf_counter() - start, model


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="sizes / 10 (a smoke run)")
    parser.add_argument(
        "--cases", default=",".join(CASES), help="comma-separated, of: " + ", ".join(CASES)
    )
    args = parser.parse_args()
    print(
        f"numba {numba.__version__}, {numba.get_num_threads()} threads, {os.cpu_count()} CPUs,"
        f" load average {os.getloadavg()[0]:.2f} (shared machine: timings are noisy)"
    )
    print(
        f"\n  {'case':<12} {'rows':>9} {'walk [s]':>9} {'search [s]':>10} {'given [s]':>9}"
        f" {'walk/search':>11} {'walk/given':>10} {'search/given':>12} {'target':>6}"
        f"  {'exact eps':>9}  same"
    )
    for name in args.cases.split(","):
        lags, make, rows, target = CASES[name]
        rows = rows // 10 if args.quick else rows
        data = make(rows)
        for method in ("walk", "search"):  # load the compiled kernels for this regressor
            fit(lags, data[:3_000], method)
        t_new, new = fit(lags, data, "search")
        t_old, old = fit(lags, data, "walk")
        t_given, _ = fit(lags, data, epsilon=new.epsilon_, gamma=new.gamma_)
        same = np.array_equal(old.epsilon_, new.epsilon_) and np.array_equal(old.gamma_, new.gamma_)
        print(
            f"  {name:<12} {rows:>9,} {t_old:9.2f} {t_new:10.2f} {t_given:9.2f}"
            f" {t_old / t_new:10.1f}x {t_old / t_given:9.1f}x {t_new / t_given:11.1f}x"
            f" {target:5.0f}x  {new.gamma_curve_.epsilons.shape[0]:>4} / {prior.DEFAULT_GRID_POINTS}"
            f"  {same}"
        )
        assert same, (old.epsilon_, new.epsilon_, old.gamma_, new.gamma_)
    print(f"\nload average at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
