"""A Set Membership selection with and without the γ*(ε) cache, side by side.

Run:  .venv/bin/python benchmarks/bench_selection_cache.py [--quick]

What a selection does (issue 18: "cache the curve per (data, ε grid) so a selection never
recomputes it"): several candidates on the same regressor and data that differ only in ε. Each
``SetMembership(lags, epsilon=e)`` fit computes the default 48-value γ*(ε) curve plus its own
``e``; without the cache every candidate walks the pairs for all 49 values, with it the second
and later candidates compute only their own ε. Both ways are timed in one run on the neck-like
system of ``bench_set_membership.py`` (n = 12), the cache cleared before every fit for the old
way; the fitted models are checked identical. Read the ratio: the machine is shared.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _systems import NECK_LIKE_LAGS, NECK_LIKE_NOISE, neck_like

from neckid.models.cache import GAMMA_CURVES
from neckid.models.set_membership.narx import SetMembership

FACTORS = (1.0, 2.0, 4.0)


def select(data: object, clear: bool) -> tuple[float, list[np.ndarray]]:
    """Fit one candidate per ε factor; return the wall time and each model's γ."""
    GAMMA_CURVES.clear()
    gammas = []
    started = time.perf_counter()
    for factor in FACTORS:
        if clear:
            GAMMA_CURVES.clear()
        model = SetMembership(NECK_LIKE_LAGS, epsilon=factor * NECK_LIKE_NOISE).fit(data)
        gammas.append(model.gamma_.copy())
    return time.perf_counter() - started, gammas


def main() -> None:
    """Time the selection both ways and print the ratio."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="8,000 samples instead of 40,000")
    args = parser.parse_args()
    n = 8_000 if args.quick else 40_000
    data = neck_like(n, seed=6)
    SetMembership(NECK_LIKE_LAGS, epsilon=NECK_LIKE_NOISE).fit(data[:3000])  # compile first
    old, old_gammas = select(data, clear=True)
    new, new_gammas = select(data, clear=False)
    for a, b in zip(old_gammas, new_gammas, strict=True):
        np.testing.assert_array_equal(a, b)
    print(f"{len(FACTORS)} candidates (epsilon = {FACTORS} x the noise bound), N = {n:,}, n = 12")
    print(f"  without the cache: {old:.2f} s")
    print(f"  with the cache:    {new:.2f} s")
    print(f"  ratio: {old / new:.2f}x (the same gamma for every candidate)")


if __name__ == "__main__":
    main()
