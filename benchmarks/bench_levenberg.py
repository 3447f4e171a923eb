"""Levenberg–Marquardt on LAPACK's QR against scipy's MINPACK, side by side in one run (issue 42).

Run:  .venv/bin/python benchmarks/bench_levenberg.py [DATA] [--samples N] [--max-iter 100]

The free-run fit of ``PolynomialNARX(Lags.arx(5, 5, 0), degree=3)`` (364 monomials) on the first
``--samples`` samples of Bouc–Wen's training record (``DATA/benchmarks/bouc_wen``; without the
data, a simulated Duffing-like oscillator of the same length): the same residuals, Jacobian and
start (the least-squares polynomial) handed to

- **scipy**: ``scipy.optimize.least_squares(method="lm", x_scale="jac")`` (MINPACK's ``lmder``,
  what ``PolynomialNARX`` ran before);
- **neckid**: :func:`neckid.models.levenberg.levenberg_marquardt` (the same steps, the QR by
  LAPACK),

each with at most ``--max-iter`` free runs, taking turns. Prints the wall time of each, their
ratio, the load average, the evaluations and the final sums of squares (their relative
difference: rounding, grown over the iterations).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from neckid import IOData, Lags, PolynomialNARX
from neckid.data.iodata import as_experiments
from neckid.datasets import load_bouc_wen
from neckid.models.levenberg import levenberg_marquardt
from neckid.models.polynomial.narx import _FreeRunProblem


def _record(data: Path, samples: int) -> IOData:
    folder = data / "benchmarks" / "bouc_wen"
    if folder.is_dir():
        train = load_bouc_wen(folder).train
        return train.replace(u=train.u[:samples], y=train.y[:samples])
    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, samples)
    y = np.zeros(samples)
    for t in range(2, samples):
        y[t] = 1.6 * y[t - 1] - 0.7 * y[t - 2] - 0.05 * y[t - 1] ** 3 + 0.1 * u[t - 1]
    return IOData(u, y, ts=1 / 750)


def main() -> None:
    """Time both solvers on the same problem."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="?", default="../shared/data", type=Path)
    parser.add_argument("--samples", type=int, default=40_960)
    parser.add_argument("--max-iter", type=int, default=100)
    args = parser.parse_args()
    record = _record(args.data, args.samples)
    model = PolynomialNARX(Lags.arx(5, 5, 0), degree=3)
    x, y = model._prepare_fit(record)
    model._fit_regression(x, y)
    model._mark_fitted()
    problem = _FreeRunProblem(model, as_experiments(record), args.max_iter)
    start = model.coef_.ravel()[problem.free]
    print(
        f"{record.n_samples} samples, {start.size} coefficients, at most {args.max_iter} free runs,"
        f" load average {os.getloadavg()[0]:.2f}"
    )
    begin = time.perf_counter()
    reference = least_squares(
        problem.residuals,
        start,
        jac=problem.jacobian,
        method="lm",
        x_scale="jac",
        max_nfev=args.max_iter,
    )
    scipy_s = time.perf_counter() - begin
    begin = time.perf_counter()
    ours = levenberg_marquardt(problem.residuals, start, problem.jacobian, max_nfev=args.max_iter)
    neckid_s = time.perf_counter() - begin
    print(f"scipy (MINPACK lmder): {scipy_s:8.2f} s, {reference.nfev} evaluations")
    print(f"neckid (LAPACK QR):    {neckid_s:8.2f} s, {ours.nfev} evaluations")
    print(f"ratio scipy / neckid: {scipy_s / neckid_s:.2f}")
    print(
        f"sum of squares: scipy {2 * reference.cost:.10g}, neckid {2 * ours.cost:.10g}"
        f" (relative difference {abs(ours.cost - reference.cost) / reference.cost:.2g});"
        f" load average {os.getloadavg()[0]:.2f}"
    )


if __name__ == "__main__":
    main()
