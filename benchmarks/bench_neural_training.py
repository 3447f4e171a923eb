"""NeuralNARX's trainer against scikit-learn's ``MLPRegressor``, side by side in one run (issue 42).

Run:  .venv/bin/python benchmarks/bench_neural_training.py [DATA] [--repeat 3] [--lags 1-2/1-2]

On the six training logs of the payload split (``load_softneck_cross_run``, 18,426 rows), the
regressor ``--lags`` (the command line's default ``1-2/1-2``), standardised as ``NeuralNARX.fit``
standardises it, the model's default ensemble (five 2x25 tanh networks, seeds
``member_seeds(0, 5)``) is trained twice per repeat, taking turns:

- **scikit-learn**: one ``MLPRegressor(solver="adam")`` per seed, one after another (what
  ``NeuralNARX.fit`` ran before);
- **neckid**: :func:`neckid.models.neural._training.train_ensemble` (one compiled call per
  epoch, the networks in parallel).

Prints the wall time of each (best of the repeats), their ratio, the load average, and checks
that both ran the same epochs per network and reached the same weights (largest difference).
The compilation is warmed up first.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn.neural_network import MLPRegressor

from neckid import Lags
from neckid.data.iodata import as_experiments
from neckid.experiments.benchmark.datasets import load_softneck_cross_run
from neckid.models.neural._training import train_ensemble
from neckid.models.neural.narx import NeuralNARX, member_seeds


def _lags(text: str) -> Lags:
    outputs, inputs = text.split("/")

    def span(part: str) -> list[int]:
        low, _, high = part.partition("-")
        return list(range(int(low), int(high or low) + 1))

    return Lags(outputs=span(outputs), inputs=span(inputs))


def main() -> None:
    """Time both trainers on the same rows."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="?", default="../shared/data", type=Path)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--lags", default="1-2/1-2")
    args = parser.parse_args()
    bench = load_softneck_cross_run(args.data / "softneck", "softneck-payload")
    model = NeuralNARX(_lags(args.lags), random_state=0)
    x, y = model._prepare_fit(as_experiments(model._with_conditions(bench.train, fitting=True)))
    xs = (x - x.mean(axis=0)) / x.std(axis=0)
    ys = (y - y.mean(axis=0)) / y.std(axis=0)
    seeds = member_seeds(0, 5)
    settings = model._settings()
    layers = tuple(model.hidden_layer_sizes)
    train_ensemble(xs[:500], ys[:500], layers, seeds[:1], settings)  # compile
    print(f"{x.shape[0]:,} rows x {x.shape[1]} terms, {len(seeds)} networks of {list(layers)}")

    def sklearn() -> list[MLPRegressor]:
        return [
            MLPRegressor(
                hidden_layer_sizes=layers, activation=settings.activation, alpha=settings.alpha,
                learning_rate_init=settings.learning_rate_init, max_iter=settings.max_iter,
                tol=settings.tol, n_iter_no_change=settings.n_iter_no_change,
                early_stopping=settings.early_stopping,
                validation_fraction=settings.validation_fraction, random_state=seed,
            ).fit(xs, ys[:, 0])
            for seed in seeds
        ]  # fmt: skip

    times: dict[str, list[float]] = {"scikit-learn": [], "neckid": []}
    load = os.getloadavg()[0]
    for _ in range(args.repeat):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            start = time.perf_counter()
            theirs = sklearn()
            times["scikit-learn"].append(time.perf_counter() - start)
            start = time.perf_counter()
            ours = train_ensemble(xs, ys, layers, seeds, settings)
            times["neckid"].append(time.perf_counter() - start)
    best = {name: min(spent) for name, spent in times.items()}
    print(f"load average {load:.2f} -> {os.getloadavg()[0]:.2f}")
    for name, spent in times.items():
        print(f"  {name:13s} best {best[name]:6.2f} s of {', '.join(f'{s:.2f}' for s in spent)}")
    print(f"  ratio scikit-learn / neckid: {best['scikit-learn'] / best['neckid']:.2f}x")
    epochs = [int(n.n_iter_) for n in theirs]
    gap = max(
        float(np.abs(ours.coefs[k][m] - net.coefs_[k]).max())
        for m, net in enumerate(theirs)
        for k in range(len(net.coefs_))
    )
    print(f"  epochs per network: scikit-learn {epochs}, neckid {ours.n_iter.tolist()}")
    print(f"  largest weight difference: {gap:.2e}")


if __name__ == "__main__":
    main()
