"""Silverbox: neckid's polynomial NARX beside SysIdentPy's FROLS polynomial NARX, same split, one run.

Run (SysIdentPy is not a dependency of neckid; install it beside it, in its own environment if it
asks for other NumPy versions):

    pip install -e ".[data]" sysidentpy
    python docs/examples/peer_frols.py DATA/benchmarks/silverbox

What it shows: what a Python user's usual polynomial NARX (SysIdentPy's FROLS) gets on Silverbox
beside neckid's polynomial NARX fitted for simulation, on the same regressor and split.

Both models use the same regressor: y(t-1), y(t-2) and u(t), ..., u(t-3), degree 3. FROLS (SysIdentPy)
selects its terms by forward orthogonal least squares with AIC and fits them by least squares on
the one-step error; neckid's ``PolynomialNARX`` keeps every monomial and fits them for free-run
simulation (Levenberg-Marquardt on the simulation error). Each is fitted on the official training
record and simulated in free run on the test records from their first 50 measured samples; RMSE
in mV after those 50. Prints the times of both fits.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from neckid import Lags, PolynomialNARX
from neckid.datasets.benchmarks import load_silverbox

TESTS = ("multisine", "arrow_no_extrapolation", "arrow_full")


def main(argv: list[str] | None = None) -> None:
    """Fit both models on the training record and print their free-run RMSE on the tests."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("silverbox", type=Path, help="the Silverbox folder (benchmarks/silverbox)")
    args = parser.parse_args(argv)
    folder = args.silverbox
    try:
        from sysidentpy.basis_function import Polynomial
        from sysidentpy.model_structure_selection import FROLS
        from sysidentpy.parameter_estimation import LeastSquares
    except ImportError:
        sys.exit(
            "SysIdentPy is not installed: pip install sysidentpy (the peer of this comparison)"
        )
    data = load_silverbox(folder)
    train = data.train if not isinstance(data.train, list) else data.train[0]
    rows = {}

    # SysIdentPy's lags start at 1: feed it the input one sample ahead, so its x(k-1..k-4) are
    # u(k..k-3), the regressor of the neckid model below.
    def ahead(u: np.ndarray) -> np.ndarray:
        return np.concatenate([u[1:], u[-1:]])[:, None]

    start = time.perf_counter()
    frols = FROLS(
        ylag=2, xlag=4, order_selection=True, info_criteria="aic", estimator=LeastSquares(),
        basis_function=Polynomial(degree=3), model_type="NARMAX", n_info_values=40,
    )  # fmt: skip
    frols.fit(X=ahead(train.u[:, 0]), y=train.y[:, :1])
    rows["SysIdentPy FROLS (AIC, least squares)"] = [time.perf_counter() - start]
    start = time.perf_counter()
    ours = PolynomialNARX(Lags(outputs=[1, 2], inputs=[0, 1, 2, 3]), degree=3).fit(train)
    rows["neckid PolynomialNARX (simulation fit)"] = [time.perf_counter() - start]
    for name in TESTS:
        record = data.tests[name]
        y = record.y[:, 0]
        peer = frols.predict(X=ahead(record.u[:, 0]), y=record.y[:50, :1])[:, 0]
        own = ours.simulate(record).y[:, 0]
        for label, sim in (("SysIdentPy", peer), ("neckid", own)):
            key = next(k for k in rows if k.startswith(label))
            error = sim[50 : y.size] - y[50:]
            rows[key].append(1000 * float(np.sqrt(np.mean(error**2))))
    print(
        f"Silverbox, free-run RMSE [mV] after 50 initial samples; FROLS kept {len(frols.final_model)} terms"
    )
    print(f"{'model':42s} {'fit [s]':>8s} " + " ".join(f"{t:>24s}" for t in TESTS))
    for key, (fit_s, *errors) in rows.items():
        print(f"{key:42s} {fit_s:8.1f} " + " ".join(f"{e:24.3f}" for e in errors))


if __name__ == "__main__":
    main()
