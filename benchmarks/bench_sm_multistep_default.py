"""sm-multistep's default fit (settings chosen per horizon) on the payload split (issue 42).

Run:  .venv/bin/python benchmarks/bench_sm_multistep_default.py DATA/softneck [--horizon 40]
      [--save RUN.npz] [--compare RECORDED.npz]

``MultiStepSetMembership(Lags(outputs=[1, 2], inputs=[0, 1]), horizon=40)`` with every other
setting at its default, on the six training stair logs of the payload split (0 g and 600 g of
the ``ada``, ``fra`` and ``int`` controllers through ``softneck_protocol``, 18,426 rows). It
prints the wall time of the whole fit, of the cross-validation that chooses the settings
(``selection_.seconds``) and of the rest, the fit of every horizon with its chosen setting (what
a fit with those settings given does), with their ratio, and the load average.

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="the softneck folder (holds stair/)")
    parser.add_argument("--horizon", type=int, default=40)
    parser.add_argument("--save", type=Path, help="write the results to this .npz")
    parser.add_argument("--compare", type=Path, help="check the results against this .npz")
    args = parser.parse_args()
    train, test = logs(args.folder)
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
    found = results(model, test)
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
