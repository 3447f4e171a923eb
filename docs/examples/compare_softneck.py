"""How `neckid.compare` chooses on the soft-neck cross-run splits, against linear ARX.

For the payload split (train the 0 g and 600 g staircases of the three controllers, test 200 g
and 400 g) and the controller split (train adaptive and fixed fractional, test the integer PI),
runs :func:`neckid.compare` with the benchmark's regressor (motor displacement and velocity ->
raw inclination, ``Lags(outputs=[1, 2], inputs=[0, 1])``): selection on the training logs only
(leave one log out, runaways rejected, one standard error toward the simpler model), then one
free run per test log. Prints, per split, every method's mean test fit [%], the recommended
method and its margin over ARX, and whether any run diverged.

Run: ``python docs/examples/compare_softneck.py DATA [--methods arx,sm,sm-linear,sm-parallel,ss]``
(DATA holds ``softneck/``).
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import neckid
from neckid import Lags
from neckid.experiments.benchmark.datasets import load_softneck_cross_run


def main(argv: list[str] | None = None) -> None:
    """Print one block per split."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data_dir", help="folder holding softneck/ (the lab's bench logs)")
    parser.add_argument("--methods", default="arx,sm,sm-linear,sm-parallel,ss")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    methods = args.methods.split(",")
    for split in ("softneck-payload", "softneck-controller"):
        bench = load_softneck_cross_run(f"{args.data_dir}/softneck", split)
        started = time.perf_counter()
        result = neckid.compare(
            bench.train,
            list(bench.tests.values()),
            methods=methods,
            lags=Lags(outputs=[1, 2], inputs=[0, 1]),
        )
        summary = result.summary().set_index("method")
        arx = float(summary.loc["arx", "fit_percent"])
        best = float(summary.loc[result.recommended, "fit_percent"])
        diverged = result.results["error"].str.startswith("diverged").any()
        print(f"## {split} ({time.perf_counter() - started:.0f} s)")
        for method, row in summary.iterrows():
            print(f"{method}: mean test fit {row['fit_percent']:.1f} % (free run)")
        for name, reason in result.selection.rejected.items():
            print(f"rejected on the training logs: {name}: {reason[:160]}")
        print(
            f"recommended {result.recommended}: {best:.1f} %, {best - arx:+.1f} points from ARX;"
            f" any test run diverged: {bool(diverged)}"
        )
        table = result.selection.table
        chosen = table[table["name"] == result.selection.chosen].iloc[0]
        print(f"fold fits of the chosen: {np.round(chosen['fold_fits'], 1)}")


if __name__ == "__main__":
    main()
