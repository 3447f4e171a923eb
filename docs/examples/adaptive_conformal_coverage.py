"""Running coverage of adaptive conformal bands on the soft-neck cross-run splits.

Trains linear ARX and Set Membership on the training logs of the payload split (0 g and 600 g
staircases) and of the controller split (adaptive and fixed fractional), then reads each test
log in time order with :func:`neckid.models.adaptive_conformal.adaptive_band` at 95 % nominal,
10 steps ahead and in free run, and prints the running coverage at the end of each log and the
mean band width [deg]. Settings are fixed in advance (the benchmark's ARX regressor; ACI step
0.005, window 500); the test logs are read once.

Run: ``python docs/examples/adaptive_conformal_coverage.py DATA`` (DATA holds ``softneck/``)
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from neckid import Lags, LinearARX, SetMembership
from neckid.experiments.benchmark.datasets import load_softneck_cross_run
from neckid.models.adaptive_conformal import adaptive_band


def main(argv: list[str] | None = None) -> None:
    """Print one row per split, model, horizon and test log."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data_dir", help="folder holding softneck/ (the lab's bench logs)")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    lags = Lags(outputs=[1, 2], inputs=[0, 1])
    print("split | model | horizon | test log | running coverage [%] | mean width [deg]")
    for split in ("softneck-payload", "softneck-controller"):
        bench = load_softneck_cross_run(f"{args.data_dir}/softneck", split)
        for name, model in (("ARX", LinearARX(lags)), ("SM", SetMembership(lags))):
            started = time.perf_counter()
            model.fit(bench.train)
            for steps in (10, None):
                for log, data in bench.tests.items():
                    band = adaptive_band(model, data, steps=steps)
                    running = band.extras["running_coverage"][-1, 0]
                    width = np.nanmean(
                        np.where(np.isfinite(band.upper), band.upper - band.lower, np.nan)
                    )
                    horizon = "free run" if steps is None else f"k = {steps}"
                    print(
                        f"{split} | {name} | {horizon} | {log} | {100 * running:.1f} | {width:.2f}"
                    )
            print(f"# {split} {name}: {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
