"""The Koopman model on the demo's records: free-run validation fit beside the demo's ARX.

The simulated neck's open-loop multisine records of ``neckid demo`` (seed 0: 6,000 training and
3,000 validation samples at 20 ms, motor position -> inclination) are rebuilt as the demo
builds them; ARX and ``koopman`` get the demo's regressor (``Lags(outputs=[1], inputs=[1, 2])``,
chosen by the demo's networks), ``koopman`` chooses its dictionary size and ridge on the
training record by the paired rule (thin-plate, Gaussian, monomials), then with the size forced.
Prints the validation free-run fit [%] and each fit's wall time, side by side in one run.

Run: ``python benchmarks/bench_koopman.py``.
"""

from __future__ import annotations

import os
import time
import warnings

import numpy as np

from neckid import Lags, LinearARX
from neckid.experiments import paper
from neckid.experiments.demo_settings import NARX_INPUT, OUTPUT, DemoSettings
from neckid.models.koopman import KoopmanEDMD


def main() -> None:
    """Print one line per model."""
    warnings.simplefilter("ignore")
    settings = DemoSettings.make()
    seeds = np.random.default_rng(settings.seed).integers(0, 2**31 - 1, size=8)
    records = paper._measure(settings, seeds, lambda step: None)
    train, validation = (
        r.select(inputs=[NARX_INPUT], outputs=[OUTPUT]) for r in (records.train, records.validation)
    )
    lags = Lags(outputs=[1], inputs=[1, 2])
    print(f"load average {os.getloadavg()[0]:.1f}; {train.n_samples} training samples")
    started = time.perf_counter()
    arx = LinearARX(lags).fit(train)
    print(f"arx: {arx.fit_percent(validation)[0]:.2f} % ({time.perf_counter() - started:.2f} s)")
    models = [KoopmanEDMD(lags, dictionary=d) for d in ("thin-plate", "gaussian", "monomials")]
    models += [KoopmanEDMD(lags, n_observables=n) for n in (10, 25, 50, 100)]
    for model in models:
        started = time.perf_counter()
        model.fit(train)
        spent = time.perf_counter() - started
        print(
            f"koopman {model.dictionary}, n_observables={model.n_observables_}, ridge="
            f"{model.ridge_:g}: {model.fit_percent(validation)[0]:.2f} % ({spent:.2f} s),"
            f" spectral radius {model.spectral_radius_:.4f}"
        )


if __name__ == "__main__":
    main()
