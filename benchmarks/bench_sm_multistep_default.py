"""sm-multistep's default fit (settings chosen per horizon) on the payload split (issue 42).

Run:  .venv/bin/python benchmarks/bench_sm_multistep_default.py DATA/softneck [--horizon 40]
      [--save RUN.npz] [--compare RECORDED.npz]

``MultiStepSetMembership(Lags(outputs=[1, 2], inputs=[0, 1]), horizon=40)`` with every other
setting at its default, on the six training stair logs of the payload split (0 g and 600 g of
the ``ada``, ``fra`` and ``int`` controllers through ``softneck_protocol``, 18,426 rows). It
prints the wall time of the whole fit, of the cross-validation that chooses the settings
(``selection_.seconds``) and of the rest, the fit of every horizon with its chosen setting (what
a fit with those settings given does), with their ratio, and the load average; then the wall
time of ``predict_ahead`` at every horizon on the six test logs (200 g and 400 g).

``--profile K`` instead times the parts of one fold of horizon K (the first log held out) in
CPU seconds of the process, the second of two runs (compiled): the ε floor and weights, the
kd-tree, every point's steepest slope at the 7 ε factors, the bounds of the 14 priors and of the
7 global ones at the held-out rows, with the tree split in the principal frame as the
cross-validation splits it (``--no-frame``: in the raw components, as before).

``--save`` writes the chosen settings, ε, γ, the cross-validation table's coverage and width and
the guaranteed band of every horizon on the six test logs (200 g and 400 g); ``--compare``
checks them against a file written by ``--save`` (with the code of another commit: the issue's
"same choice and bands as today's"), equal bit for bit.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

import numpy as np

import neckid
from neckid import Lags
from neckid.experiments.benchmark import softneck_protocol
from neckid.models.set_membership.multistep import MultiStepSetMembership

LAGS = Lags(outputs=[1, 2], inputs=[0, 1])


def logs(folder: Path) -> tuple[list, list]:
    """The payload split's training and test stair logs."""
    found = neckid.datasets.load_softneck_directory(folder / "stair", pattern="[afi]*response.csv")
    by_run = {Path(k).name[:6]: softneck_protocol(v) for k, v in found.items()}
    train = [by_run[c + p] for c in ("ada", "fra", "int") for p in ("000", "600")]
    test = [by_run[c + p] for c in ("ada", "fra", "int") for p in ("200", "400")]
    return train, test


def results(model: MultiStepSetMembership, test: list) -> dict[str, np.ndarray]:
    """What must stay the same: settings, ε, γ, the fold table and the test bands."""
    out = {
        "settings": np.array(
            [[s.epsilon_factor, s.input_weight, s.lipschitz == "local"] for s in model.settings_],
            dtype=float,
        ),
        "epsilon": model.epsilon_,
        "gamma": model.gamma_,
    }
    assert model.selection_ is not None
    table = model.selection_.table()
    out["sel_cov"], out["sel_width"] = table.coverage.to_numpy(), table.width.to_numpy()
    for k in model.horizons_:
        for j, data in enumerate(test):
            ahead = model.predict_ahead(data, steps=int(k))
            out[f"lo_{k}_{j}"], out[f"up_{k}_{j}"] = ahead.lower, ahead.upper
    return out


def profile_fold(train: list, steps: int, frame: bool = True) -> None:
    """CPU seconds of the parts of one fold of one horizon (see the module docstring)."""
    from neckid.models.set_membership import multistep_selection as ms
    from neckid.models.set_membership._kernels.priors import prior_bounds
    from neckid.models.set_membership.horizon_fit import (
        epsilon_floor,
        local_constants,
        prior_grid,
        rule_epsilon,
        stack_rows,
    )
    from neckid.models.set_membership.scaling import term_weights
    from neckid.models.set_membership.training import training_tree

    folds = ms._horizon_folds(train, LAGS.resolve(train), steps)
    rows = [folds.lags.build_one(p) for p in train]
    x, y = stack_rows(rows[1:])
    linear = folds.linear[0]
    assert not isinstance(linear, str)
    held = rows[0][0]
    grid = ms.SettingGrid()
    for run in range(2):
        for weight in grid.input_weights:
            clock, times = time.process_time(), {}
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                weights = term_weights("std", weight, x, folds.lags)
            floor = epsilon_floor(np.ascontiguousarray(x * weights), linear.residual)
            eps = np.vstack([rule_epsilon(f, linear.scale, floor) for f in grid.epsilon_factors])
            times["floor"], clock = time.process_time() - clock, time.process_time()
            tree, _ = training_tree(
                x.copy(),
                y,
                weights,
                linear.coef,
                linear.intercept,
                True,
                frame=frame,
                leaf_size=ms.SELECTION_LEAF_SIZE if frame else 16,
            )
            times["tree"], clock = time.process_time() - clock, time.process_time()
            priors = prior_grid(tree, eps, 1.1)
            times["slopes"], clock = time.process_time() - clock, time.process_time()
            gamma = np.nan_to_num(priors.gamma)
            local = np.stack([local_constants(priors.steepest[e], gamma[e], 1.1) for e in range(7)])
            index = np.array([-1] * 7 + list(range(7)))
            both, twice = np.vstack([eps, eps]), np.vstack([priors.gamma, priors.gamma])
            prior_bounds(tree, held * weights, both, twice, local, index, 10)
            times["bounds 14"], clock = time.process_time() - clock, time.process_time()
            prior_bounds(tree, held * weights, eps, priors.gamma, local[:0], index[:7], 10)
            times["bounds 7 global"] = time.process_time() - clock
            if run:
                parts = ", ".join(f"{k} {v:.2f}" for k, v in times.items())
                print(f"horizon {steps}, {x.shape} rows, input weight {weight}: {parts} CPU s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="the softneck folder (holds stair/)")
    parser.add_argument("--horizon", type=int, default=40)
    parser.add_argument("--profile", type=int, metavar="K", help="time one fold of horizon K")
    parser.add_argument(
        "--no-frame", action="store_true", help="with --profile: the tree split in raw components"
    )
    parser.add_argument("--save", type=Path, help="write the results to this .npz")
    parser.add_argument("--compare", type=Path, help="check the results against this .npz")
    args = parser.parse_args()
    train, test = logs(args.folder)
    if args.profile:
        print(f"load average {os.getloadavg()[0]:.1f}")
        profile_fold(train, args.profile, frame=not args.no_frame)
        return
    load = os.getloadavg()[0]
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = MultiStepSetMembership(LAGS, horizon=args.horizon).fit(train)
    total = time.perf_counter() - start
    assert model.selection_ is not None
    choice = model.selection_.seconds
    print(
        f"sm-multistep default fit, horizon {args.horizon}, {sum(d.n_samples for d in train)}"
        f" rows: {total:.1f} s (choice {choice:.1f} s, fit with the chosen settings"
        f" {total - choice:.1f} s, ratio {total / (total - choice):.1f}x); load average"
        f" {load:.1f} -> {os.getloadavg()[0]:.1f}"
    )
    start = time.perf_counter()
    found = results(model, test)
    print(
        f"predict_ahead at the {len(model.horizons_)} horizons on the {len(test)} test logs:"
        f" {time.perf_counter() - start:.1f} s"
    )
    if args.save:
        np.savez(args.save, **found)
    if args.compare:
        recorded = np.load(args.compare)
        differ = [
            key
            for key in recorded.files
            if key in found and not np.array_equal(recorded[key], found[key], equal_nan=True)
        ]
        missing = [key for key in found if key not in recorded.files]
        print(
            f"against {args.compare}: {len(found) - len(missing)} arrays compared,"
            f" {'all equal bit for bit' if not (differ or missing) else 'DIFFERENT'}"
            + (f"; differ: {differ[:5]}" if differ else "")
            + (f"; not recorded: {missing[:5]}" if missing else "")
        )


if __name__ == "__main__":
    main()
