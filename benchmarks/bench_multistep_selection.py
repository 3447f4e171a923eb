"""Choosing sm-multistep's settings (issues 29 and 33): independent fits per setting vs shared.

Run:  .venv/bin/python benchmarks/bench_multistep_selection.py [--data DATA/softneck] [--quick]

:class:`~neckid.models.set_membership.multistep.MultiStepSetMembership` with its default
settings chooses, per horizon, an ε factor (7), an input weight (2) and the Lipschitz form (2)
by cross-validation over the training runs (one log: three time blocks). Side by side in one
process, on one log:

- ``independent``: the old way, each of the 28 settings of each horizon fitted on each fold's
  training blocks on its own and scored on the held-out block (one regressor, kd-tree, γ*(ε)
  pass, local constants and bounds walk per setting: what fitting a fixed-setting model per
  fold and setting does, ``docs/examples/bounds_experiment.py`` by hand);
- ``shared``: :func:`~neckid.models.set_membership.multistep_selection.select_settings`, the
  regressor and least squares once per fold and horizon, one tree per input weight, the
  constants of every ε in one walk per point and the bounds of every setting in one walk per
  held-out sample.

Both must give the same coverage and width for every setting, bit for bit (checked). Then the
default fit (choice + final fit) against one fit with fixed settings (``epsilon_factor=3,
input_weight=1, lipschitz="global"``, the defaults before the choice): issue 33 asks for at most
5x on a stair log.

Logs: with ``--data``, the real ``stair/ada000response.csv`` (3,605 samples) and
``step/fra200stepresponse.csv`` (401) through ``softneck_protocol``, regressor
``Lags(outputs=[1, 2], inputs=[0, 1])``; without, synthetic logs of those lengths
(``_systems.held_input`` with two inputs). ``--quick``: horizons 1 and 10 only for the
independent way. On a shared 2-core machine the times move by tens of percent from run to run:
read the ratios, measured side by side.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

import numba
import numpy as np
from _systems import held_input

import neckid
from neckid import IOData, Lags
from neckid.models.set_membership.core import SMSettings
from neckid.models.set_membership.horizon_fit import fit_horizon, horizon_lags, horizon_rows
from neckid.models.set_membership.multistep import MultiStepSetMembership
from neckid.models.set_membership.multistep_selection import (
    SettingGrid,
    fold_experiments,
    select_settings,
)

LAGS = Lags(outputs=[1, 2], inputs=[0, 1])
HORIZONS = list(range(1, 11))
FIXED = {"epsilon_factor": 3.0, "input_weight": 1.0, "lipschitz": "global"}


def logs(folder: Path | None) -> dict[str, IOData]:
    """The stair and step logs (real with a folder, synthetic stand-ins without)."""
    if folder is not None:
        from neckid.experiments.benchmark import softneck_protocol

        load = neckid.datasets.load_softneck_log
        return {
            "stair": softneck_protocol(load(folder / "stair" / "ada000response.csv")),
            "step": softneck_protocol(load(folder / "step" / "fra200stepresponse.csv")),
        }
    out = {}
    for name, n in (("stair", 3605), ("step", 401)):
        one = held_input(n, seed=1)
        two = held_input(n, seed=2)
        out[name] = IOData(np.column_stack([one.u, two.u]), one.y + 0.5 * two.y, ts=0.025)
    return out


def independent(data: IOData, horizons: list[int]) -> dict[tuple[int, int, int], tuple]:
    """Coverage and width of every (horizon, fold, setting), each fitted on its own."""
    parts, _ = fold_experiments([data])
    options = SMSettings(linear_part=True, local_neighbours=10)
    settings = SettingGrid().settings()
    scores = {}
    for k in horizons:
        lags = horizon_lags(LAGS.resolve(parts), k)
        for f, held in enumerate(parts):
            train = parts[:f] + parts[f + 1 :]
            x, y = lags.resolve(parts).build_one(held)
            for s, setting in enumerate(settings):
                rows = horizon_rows(train, lags, options)
                try:
                    model, _, _ = fit_horizon(rows, setting, epsilon=None, options=options, steps=k)
                except ValueError:
                    scores[k, f, s] = (np.nan, np.nan)
                    continue
                bounds = model.core_.bounds(x)
                lower = bounds.lower - model.epsilon_
                upper = bounds.upper + model.epsilon_
                inside = (lower <= y) & (y <= upper)
                scores[k, f, s] = (inside.mean(axis=0)[0], (upper - lower).mean(axis=0)[0])
    return scores


def shared(data: IOData, horizons: list[int]) -> dict[tuple[int, int, int], tuple]:
    """The same scores from the selection's shared fold table."""
    options = SMSettings(linear_part=True, local_neighbours=10)
    selection = select_settings([data], LAGS, horizons, SettingGrid(), options, progress=False)
    n = len(SettingGrid().settings())
    scores = {}
    for i, row in enumerate(selection.rows):
        k, s = horizons[i // n], i % n
        for f, (cov, wid) in enumerate(zip(row.fold_coverage, row.fold_width, strict=True)):
            scores[k, f, s] = (cov[0], wid[0])
    return scores


def timed(function, *args):  # type: ignore[no-untyped-def]
    start = time.perf_counter()
    out = function(*args)
    return time.perf_counter() - start, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, help="the softneck folder (stair/, step/)")
    parser.add_argument("--quick", action="store_true", help="independent way on k = 1, 10 only")
    args = parser.parse_args()
    warnings.simplefilter("ignore")  # constant terms, ε raised to the duplicates' spread
    print(
        f"numba {numba.__version__}, {numba.get_num_threads()} threads, {os.cpu_count()} CPUs,"
        f" load average {os.getloadavg()[0]:.2f} (shared machine: timings are noisy)"
    )
    data = logs(args.data)
    source = "real" if args.data else "synthetic"
    for d in data.values():  # load the compiled kernels
        MultiStepSetMembership(LAGS, horizon=2).fit(d[:300])
    stair = data["stair"]
    horizons = [1, 10] if args.quick else HORIZONS
    t_old, old = timed(independent, stair, horizons)
    t_new, new = timed(shared, stair, horizons)
    # Coverage counts are exact; a mean width may differ in its last bits (summation order).
    same = old.keys() == new.keys() and all(
        np.allclose(old[key], new[key], rtol=1e-12, atol=0, equal_nan=True) for key in old
    )
    print(
        f"\n{source} stair log ({stair.n_samples} samples, 3 time blocks), horizons"
        f" {horizons[0]}..{horizons[-1]} ({len(horizons)}), 28 settings each:"
    )
    print(f"  independent fits per setting  {t_old:8.2f} s")
    print(f"  shared (select_settings)      {t_new:8.2f} s")
    print(f"  ratio independent / shared    {t_old / t_new:8.1f}x   same scores (1e-12): {same}")
    print(
        f"\n  {'log':<6} {'samples':>7} {'default fit [s]':>15} {'fixed fit [s]':>13} {'ratio':>6}"
    )
    for name, log in data.items():
        t_fixed, _ = timed(MultiStepSetMembership(LAGS, **FIXED).fit, log)
        t_default, _ = timed(MultiStepSetMembership(LAGS).fit, log)
        ratio = t_default / t_fixed
        print(f"  {name:<6} {log.n_samples:>7} {t_default:>15.2f} {t_fixed:>13.2f} {ratio:>5.1f}x")
    print("  (default: horizons 1..10 chosen by 3 time blocks, then fitted; issue 33: <= 5x)")


if __name__ == "__main__":
    main()
