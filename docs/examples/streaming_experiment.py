"""Streaming 10-step-ahead prediction on the real soft-neck test logs (docs/benchmarks/softneck.md).

What it shows: ``neckid.loops.adaptive.streaming_ahead`` predicts the inclination 10 samples
(0.25 s) ahead while the model keeps learning from what it has seen, updated every 1 s, against
the same model never updated. The models and logs are those of ``adaptive_experiment.py`` (trained
on the 0 g and 600 g staircases with the payload condition, tested on the 200 g and 400 g ones).
Prints the 10-step-ahead fit [%] per test log and the mean time per run [s].

Run from the repository, with the folder of the real soft-neck logs (it holds ``stair/``)::

    .venv/bin/python docs/examples/streaming_experiment.py DATA/softneck
"""

from __future__ import annotations

import argparse
import importlib.util
import time
import warnings
from pathlib import Path
from types import ModuleType

import pandas as pd

from neckid.loops.adaptive import streaming_ahead


def sibling(name: str) -> ModuleType:
    """The example ``name`` of this folder, imported from its file (the folder is no package)."""
    spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name(f"{name}.py"))
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


adaptive = sibling("adaptive_experiment")


def main(argv: list[str] | None = None) -> None:
    """Fit the models, stream them over every test log and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("softneck", type=Path, help="folder of the real soft-neck logs (stair/)")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    train = [adaptive.load(args.softneck, n) for n in adaptive.TRAIN]
    test = {n: adaptive.load(args.softneck, n) for n in adaptive.TEST}
    rows = []
    for method, model in adaptive.models(train, True).items():
        model.fit(train)
        for name, data in test.items():
            for label, every in (("never", 10**9), ("every 1 s", None)):
                start = time.perf_counter()
                run = streaming_ahead(model, data, steps=10, update_every=every)
                rows.append(
                    {
                        "method": method,
                        "test": name,
                        "update": label,
                        "fit": float(run.fit[0]),
                        "seconds": time.perf_counter() - start,
                    }
                )
            print(rows[-2:], flush=True)
    frame = pd.DataFrame(rows)
    table = frame.pivot_table(index=["method", "update"], columns="test", values="fit", sort=False)
    table["mean"] = table.mean(axis=1)
    print("\n10-step-ahead fit [%] (payload condition), updated on what was seen")
    print(table.round(1).to_string())
    print("\nseconds per run (mean):")
    print(frame.groupby(["method", "update"], sort=False)["seconds"].mean().round(1).to_string())


if __name__ == "__main__":
    main()
