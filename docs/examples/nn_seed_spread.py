"""Issue 14: how much the neural NARX's free-run fit moves with its seed, one network against the ensemble.

What it shows: the spread of a neural NARX's free-run fit over seeds, and how much an ensemble
narrows it. Run from the repository, with the folder of the real soft-neck logs (it holds
``stair/``; about 200 s)::

    .venv/bin/python docs/examples/nn_seed_spread.py DATA/softneck

Protocol (the cross-run payload split of ``docs/benchmarks/softneck.md``): fit on the 0 g and 600 g
staircases of the three controllers at once, the payload [kg] as a constant input; free run on
each 200 g and 400 g staircase; NRMSE fit [%]. Regressor fixed in advance: the soft-neck grid's
quick-mode entry ``Lags.arx(2, 2, 1)`` with the payload (no selection, so the seed is the only
thing that changes). Networks (25, 25), 300 iterations, as the benchmark's. Two settings, five
seeds each: one network (``n_networks=1``) and the benchmark's ensemble (``n_networks=5``,
``simulation_tuning=5``: ten trained, the five with the best free run on the held-out ends of the
training runs averaged). Prints every fit, and per test log the spread (max − min over seeds).
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

import neckid
from neckid import Lags
from neckid.experiments.benchmark.datasets import load_softneck_cross_run

SEEDS = (0, 1, 2, 3, 4)
SETTINGS = {
    "one network": {"n_networks": 1},
    "ensemble of 5 (of 10)": {"n_networks": 5, "simulation_tuning": 5},
}


def main(argv: list[str] | None = None) -> None:
    """Fit five seeds of both settings and print the fits and their spread."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("softneck", type=Path, help="folder of the real soft-neck logs (stair/)")
    args = parser.parse_args(argv)
    data = load_softneck_cross_run(args.softneck, "softneck-payload")
    lags = Lags(outputs=[1, 2], inputs=[1, 2], conditions=["payload"])
    names = [k.split("/")[-1].replace("response.csv", "") for k in data.tests]
    print(f"test logs: {names}")
    for label, params in SETTINGS.items():
        fits = np.empty((len(SEEDS), len(names)))
        start = time.perf_counter()
        for i, seed in enumerate(SEEDS):
            model = neckid.methods()["nn"].make(
                lags, random_state=seed, hidden_layer_sizes=(25, 25), max_iter=300, **params
            )
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                model.fit(data.train)
                for j, test in enumerate(data.tests.values()):
                    try:
                        fits[i, j] = model.simulate(test).fit_percent(test)[0]
                    except neckid.DivergenceError:
                        fits[i, j] = np.nan
            print(f"  {label}, seed {seed}: " + " ".join(f"{v:6.1f}" for v in fits[i]), flush=True)
        spread = np.nanmax(fits, axis=0) - np.nanmin(fits, axis=0)
        print(
            f"{label}: spread over {len(SEEDS)} seeds [points] "
            + " ".join(f"{v:6.1f}" for v in spread)
        )
        print(
            f"{label}: mean fit per seed "
            + " ".join(f"{v:6.1f}" for v in np.nanmean(fits, axis=1))
            + f"; largest spread {np.nanmax(spread):.1f}; {time.perf_counter() - start:.0f} s"
        )


if __name__ == "__main__":
    main()
