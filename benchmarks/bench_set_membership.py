"""Set Membership speed: compiled kd-tree branch and bound vs vectorised NumPy brute force.

Run:  .venv/bin/python benchmarks/bench_set_membership.py [--quick]

Targets (issue 4), all exact (results are checked against the brute force in the same run):
- N = 50,000 training regressors, n = 12: per-query >= 50x faster than vectorised NumPy;
- free-run simulation of 20,000 steps with 65,000 training points in < 2 s;
- gamma*(eps) over all pairs for a whole eps grid at N = 20,000 in < 10 s on 2 cores.

Regressors come from a simulated dynamic system shaped like the seed paper's neck regressor
(y(t-1..t-3), three inputs at lags 8..10: n = 12); a second table uses i.i.d. uniform points in
12-D, where kd-trees degrade, to be honest about the worst case. Timings on a shared machine
are noisy: take the ratios, measured side by side, rather than the absolute seconds.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numba
import numpy as np
from _systems import NECK_LIKE_LAGS, neck_like

# The plain NumPy references the kernels are tested against live with the tests.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from _sm_reference import bounds_reference, gamma_star_reference
from neckid import IOData
from neckid.models.set_membership._kernels.gamma import gamma_star
from neckid.models.set_membership._kernels.tree import (
    SMTree,
)
from neckid.models.set_membership.narx import SetMembership
from neckid.models.set_membership.prior import _default_epsilons

LAGS = NECK_LIKE_LAGS


def timed(function, repeat: int = 1):
    best = np.inf
    result = None
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


def bench_queries(points: np.ndarray, targets: np.ndarray, queries: np.ndarray, label: str) -> None:
    eps, gamma = 1e-3, 2.0
    n_ref = min(200, queries.shape[0])
    t_ref, (ref_lower, ref_upper) = timed(
        lambda: bounds_reference(points, targets[:, 0], queries[:n_ref], eps, gamma)
    )
    tree = SMTree(points, targets)
    threads = numba.get_num_threads()
    results = {}
    for n_threads in sorted({1, threads}):
        numba.set_num_threads(n_threads)
        t_tree, (lower, upper) = timed(
            lambda: tree.bounds(queries, np.array([eps]), np.array([gamma])), repeat=3
        )
        results[n_threads] = t_tree / queries.shape[0]
        np.testing.assert_allclose(lower[:n_ref, 0], ref_lower, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(upper[:n_ref, 0], ref_upper, rtol=1e-12, atol=1e-12)
    numba.set_num_threads(threads)
    per_ref = t_ref / n_ref
    print(f"  {label}: N = {points.shape[0]}, n = {points.shape[1]}")
    print(f"    NumPy brute force          {per_ref * 1e3:9.3f} ms/query  ({n_ref} queries)")
    for n_threads, per in results.items():
        print(
            f"    tree, {n_threads} thread{'s' if n_threads > 1 else ' '}             "
            f"{per * 1e3:9.3f} ms/query  ({queries.shape[0]} queries)  ratio {per_ref / per:7.1f}x"
        )
    print("    bounds equal brute force to 1e-12: yes")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller sizes (a smoke run)")
    args = parser.parse_args()
    scale = 10 if args.quick else 1
    n_query_train = 50_000 // scale
    n_sim_train = 65_000 // scale
    n_sim_steps = 20_000 // scale
    n_pairs = 20_000 // scale

    print(
        f"numba {numba.__version__}, {numba.get_num_threads()} threads,"
        f" {os.cpu_count()} CPUs visible (shared machine: timings are noisy)"
    )
    start = time.perf_counter()
    warm = neck_like(600, seed=9)
    SetMembership(LAGS, epsilon=1e-3).fit(warm).simulate(warm)  # also compiles gamma_star
    print(f"compile / cache load of the kernels: {time.perf_counter() - start:.1f} s\n")

    # ------------------------------------------------------------------ per-query bounds
    print("1. Bounds f_l, f_u at a query (exact branch and bound vs brute force)")
    train = neck_like(n_query_train + LAGS.max_lag, seed=1)
    test = neck_like(2_000 + LAGS.max_lag, seed=2)
    x, y = LAGS.build(train)
    xq, _ = LAGS.build(test)
    weights = 1.0 / x.std(axis=0)
    bench_queries(x * weights, y, xq * weights, "neck-like regressors")
    rng = np.random.default_rng(3)
    xu = rng.uniform(size=(x.shape[0], 12))
    yu = np.sin(xu.sum(axis=1, keepdims=True))
    bench_queries(xu, yu, rng.uniform(size=(500, 12)), "uniform i.i.d. in 12-D (worst case)")

    # ------------------------------------------------------------------ free run
    print("\n2. Free-run simulation (compiled loop)")
    train = neck_like(n_sim_train + LAGS.max_lag, seed=4)
    test = neck_like(n_sim_steps, seed=5)
    t_fit, model = timed(lambda: SetMembership(LAGS, epsilon=1e-3, gamma=5.0).fit(train))
    t_sim, sim = timed(lambda: model.simulate(test), repeat=2)
    steps = 300
    t_py, _ = timed(lambda: _python_free_run(model, test, steps))
    print(
        f"  {n_sim_steps} steps, {model.n_samples_} training points: {t_sim:.3f} s"
        f"  (target < 2 s; fit with given eps, gamma incl. tree and prior check: {t_fit:.2f} s)"
    )
    print(
        f"  per step: compiled {t_sim / n_sim_steps * 1e3:.3f} ms, Python loop over brute-force"
        f" bounds {t_py / steps * 1e3:.3f} ms ({steps} steps): ratio"
        f" {(t_py / steps) / (t_sim / n_sim_steps):.0f}x; fit {sim.fit_percent(test)[0]:.1f} %"
    )

    # ------------------------------------------------------------------ gamma*(eps)
    print("\n3. gamma*(eps) over all pairs, whole eps grid in one pass")
    train = neck_like(n_pairs + LAGS.max_lag, seed=6)
    x, y = LAGS.build(train)
    points = x / x.std(axis=0)
    grid = _default_epsilons(y)
    t_pairs, g = timed(lambda: gamma_star(points, y, grid))
    n_sub = 2_000 // scale
    t_ref, g_ref = timed(lambda: gamma_star_reference(points[:n_sub], y[:n_sub, 0], grid[:, 0]))
    g_sub = gamma_star(points[:n_sub], y[:n_sub], grid)
    np.testing.assert_allclose(g_sub[:, 0], g_ref, rtol=1e-12)
    pairs = n_pairs * (n_pairs - 1) / 2
    sub_pairs = n_sub * (n_sub - 1) / 2
    ref_full = t_ref * pairs / sub_pairs
    print(
        f"  N = {n_pairs} ({pairs:.3g} pairs), {grid.shape[0]} eps values:"
        f" {t_pairs:.2f} s on {numba.get_num_threads()} threads (target < 10 s)"
    )
    print(
        f"  NumPy reference on the first {n_sub} rows: {t_ref:.2f} s -> {ref_full:.0f} s"
        f" extrapolated by pair count; ratio {ref_full / t_pairs:.0f}x; equal to 1e-12: yes"
    )
    print(f"  gamma*(0) = {g[0, 0]:.4g}, gamma*(eps_max) = {g[-1, 0]:.4g}")


def _python_free_run(model: SetMembership, data: IOData, steps: int) -> None:
    x_train = model._x_train * model.weights_
    residual = model._y_train[:, 0]
    y = np.array(data.y[: steps + model.lags_.max_lag])
    for t in range(model.lags_.max_lag, y.shape[0]):
        w = model.lags_.regressor_from_history(y, data.u, t) * model.weights_
        low, high = bounds_reference(
            x_train, residual, w[None, :], model.epsilon_[0], model.gamma_[0]
        )
        y[t, 0] = 0.5 * (low[0] + high[0])


if __name__ == "__main__":
    main()
