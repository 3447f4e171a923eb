"""How far a model identified on another log can get on each soft-neck validation log (docs/benchmarks/softneck.md).

What it shows: whether any model identified on another log can beat the linear ARX by 5 points
per log on the real neck. Run from the repository, with the folder of the real soft-neck logs::

    .venv/bin/python docs/examples/softneck_oracle.py DATA/softneck

For every validation log of the benchmark's soft-neck protocol it prints the free-run fit of

- the benchmark's ARX identified on ``stair/ada000response.csv`` (the cross-log baseline);
- an ARX and two ``ParallelSetMembership`` models identified on *that log itself* (oracles that
  have seen the test data);

and counts the logs where the better oracle is at least 5 points above the cross-log ARX: where it
is not, a model identified on another log is not expected to be either.
"""

import argparse
import warnings
from pathlib import Path

import numpy as np

from neckid import Lags, LinearARX, ParallelSetMembership
from neckid.experiments.benchmark import load_softneck_benchmark
from neckid.metrics import fit_percent
from neckid.selection.lags import free_run

#: The regressor the benchmark's selection chose for the ARX on the training log.
ARX_LAGS = Lags(outputs=[1, 2], inputs=[0, 1])


def free_run_fit(model, record) -> float:
    """Free-run fit [%] as in the benchmark (the model's own initial samples skipped)."""
    y, skip = free_run(model, record, diverged="keep")
    return float(fit_percent(record.y, y, skip=skip)[0]) if np.isfinite(y).all() else -np.inf


def main(argv: list[str] | None = None) -> None:
    """Print the per-log table and the count."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("softneck", type=Path, help="folder of the real soft-neck logs")
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore")
    bench = load_softneck_benchmark(args.softneck)
    cross = LinearARX(ARX_LAGS).fit(bench.train)
    rows = []
    for name, record in bench.tests.items():
        oracles = [
            LinearARX(ARX_LAGS),
            ParallelSetMembership(Lags(outputs=[1], inputs=[0]), linear_lags=[0]),
            ParallelSetMembership(ARX_LAGS, linear_lags=[0, 1], input_lags=[0, 1]),
        ]
        fits = [free_run_fit(cross, record)]
        fits += [free_run_fit(model.fit(record), record) for model in oracles]
        rows.append(fits)
        print(
            f"{name:32s} cross-log ARX {fits[0]:6.1f} | own-log ARX {fits[1]:6.1f}"
            f" | own-log SM parallel {fits[2]:6.1f} / {fits[3]:6.1f}"
        )
    table = np.array(rows)
    reach = np.maximum(table[:, 2], table[:, 3]) >= table[:, 0] + 5
    print("mean fit [%]:", np.round(table.mean(axis=0), 1).tolist())
    print(
        f"logs where the better own-log SM is >= cross-log ARX + 5: {int(reach.sum())} / {len(table)}"
    )


if __name__ == "__main__":
    main()
