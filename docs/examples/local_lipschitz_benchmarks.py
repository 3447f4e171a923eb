"""Local against global Lipschitz constants on the public benchmarks (issue 19).

What it shows: whether one Lipschitz constant per training point (``lipschitz="local"``) helps
Set Membership on the public benchmarks. Run from the repository, with the data folder that holds
``benchmarks/`` (about 3 minutes on two cores)::

    .venv/bin/python docs/examples/local_lipschitz_benchmarks.py DATA

It prints the figures of ``docs/benchmarks/silverbox.md`` (*Local Lipschitz constants*).

Protocol (each benchmark's official split; every setting chosen on the training record only,
the benchmark's rule: fit on its first 75 %, free-run RMSE on the last 25 %; then refit on the
whole training record and simulate the test records once):

- Silverbox, SM + linear part on the benchmark's chosen regressor
  ``Lags(outputs=[1, 2], inputs=[0, 1, 2, 3])``, ``input_weight=0.03``; ε from the grid
  {0.1, 0.15, 0.2, 0.3, 0.45, 0.64, 1.0} mV, separately for the global and the local constants;
- cascaded tanks, SM parallel on the benchmark's chosen ``Lags.arx(4, 4, 1)``,
  ``linear_lags=[0, 1, 2]``, ε by the knee; global or local constants, the better on the
  training record's last quarter;
- cascaded tanks, SM parallel on a linear model fitted by least squares or for simulation
  (output error), ARX orders 2–4, the three SM regressors, both kinds of constants: the best of
  each on the training record's last quarter;
- Silverbox, a polynomial NARX fitted for simulation (``Lags.arx(3, 4, 0)``, degree 3) with a
  Set Membership map of its one-step residual on the same regressor (standardised, input terms
  weighted 1 or 0.1, ε = 1, 2 or 3 × the residual's RMS), free run on the training record's last
  quarter only: does SM on top of the best parametric model help?
"""

from __future__ import annotations

import argparse
import itertools
import time
import warnings
from pathlib import Path

import numpy as np

from neckid import IOData, Lags
from neckid.experiments.benchmark.datasets import load_benchmark
from neckid.models.polynomial.narx import PolynomialNARX
from neckid.models.set_membership._kernels.local import learn_constants, local_bounds
from neckid.models.set_membership._kernels.tree import SMTree
from neckid.models.set_membership.narx import SetMembership
from neckid.models.set_membership.parallel import ParallelSetMembership
from neckid.models.set_membership.prior import _gamma_star

SILVERBOX_EPSILONS_MV = (0.1, 0.15, 0.2, 0.3, 0.45, 0.64, 1.0)


def split(train: IOData) -> tuple[IOData, IOData]:
    """The benchmark's selection split: first 75 % to fit, last 25 % to score."""
    cut = int(0.75 * train.n_samples)
    return train[:cut], train[cut:]


def rmse(model: object, data: IOData) -> float:
    """Free-run RMSE of the first output."""
    return float(model.simulate(data).rmse(data)[0])  # type: ignore[attr-defined]


def silverbox_sm_linear(folder: Path) -> None:
    """SM + linear part, ε chosen on the training record, global against local constants."""
    bench = load_benchmark("silverbox", folder)
    assert bench is not None
    fit_part, score_part = split(bench.train)
    lags = Lags(outputs=[1, 2], inputs=[0, 1, 2, 3])
    for lipschitz in ("global", "local"):
        scores = {}
        for eps_mv in SILVERBOX_EPSILONS_MV:
            model = SetMembership(
                lags, epsilon=eps_mv / 1000, linear_part=True, input_weight=0.03,
                lipschitz=lipschitz,
            ).fit(fit_part)  # fmt: skip
            scores[eps_mv] = rmse(model, score_part) * 1000
        best = min(scores, key=lambda e: scores[e])
        started = time.perf_counter()
        model = SetMembership(
            lags, epsilon=best / 1000, linear_part=True, input_weight=0.03, lipschitz=lipschitz
        ).fit(bench.train)
        tests = {name: rmse(model, d) * 1000 for name, d in bench.tests.items()}
        print(
            f"Silverbox SM + linear, {lipschitz}: selection RMSE [mV] "
            + ", ".join(f"{e:g}: {v:.3f}" for e, v in scores.items())
            + f"; chosen eps = {best:g} mV; test [mV] "
            + ", ".join(f"{k} {v:.3f}" for k, v in tests.items())
            + f" (fit and tests {time.perf_counter() - started:.1f} s)",
            flush=True,
        )


def tanks_sm_parallel(folder: Path) -> None:
    """SM parallel with the knee ε, global against local constants."""
    bench = load_benchmark("cascaded_tanks", folder)
    assert bench is not None
    fit_part, score_part = split(bench.train)
    for lipschitz in ("global", "local"):
        settings = {"linear_lags": [0, 1, 2], "lipschitz": lipschitz}
        score = rmse(ParallelSetMembership(Lags.arx(4, 4, 1), **settings).fit(fit_part), score_part)
        model = ParallelSetMembership(Lags.arx(4, 4, 1), **settings).fit(bench.train)
        tests = {name: rmse(model, d) for name, d in bench.tests.items()}
        print(
            f"cascaded tanks SM parallel, {lipschitz}: selection RMSE {score:.4f} V; test [V] "
            + ", ".join(f"{k} {v:.4f}" for k, v in tests.items()),
            flush=True,
        )


def tanks_output_error_base(folder: Path) -> None:
    """SM parallel on a one-step (least squares) or an output-error linear model, tanks."""
    bench = load_benchmark("cascaded_tanks", folder)
    assert bench is not None
    fit_part, score_part = split(bench.train)
    best: dict[str, tuple[float, str]] = {}
    for order, fit_for, linear_lags, lipschitz in itertools.product(
        (2, 3, 4), ("prediction", "simulation"), ([0], [0, 1], [0, 1, 2]), ("global", "local")
    ):
        model = ParallelSetMembership(
            Lags.arx(order, order, 1), parallel_fit=fit_for, linear_lags=linear_lags,
            lipschitz=lipschitz,
        )  # fmt: skip
        score = rmse(model.fit(fit_part), score_part)
        label = f"order {order}, linear_lags {linear_lags}, {lipschitz}"
        if fit_for not in best or score < best[fit_for][0]:
            best[fit_for] = (score, label)
    for fit_for, (score, label) in best.items():
        print(
            f"cascaded tanks SM parallel, linear part fitted for {fit_for}: best selection RMSE"
            f" {score:.4f} V ({label})",
            flush=True,
        )


def silverbox_sm_on_polynomial(folder: Path) -> None:
    """A polynomial fitted for simulation plus an SM map of its one-step residual (free run)."""
    bench = load_benchmark("silverbox", folder)
    assert bench is not None
    fit_part, score_part = split(bench.train)
    poly = PolynomialNARX(Lags.arx(3, 4, 0), fit_for="simulation").fit(fit_part)
    print(f"Silverbox polynomial alone: selection RMSE {rmse(poly, score_part) * 1000:.4f} mV")
    lags = poly.lags_
    x, y = lags.build_one(fit_part)
    residual = np.ascontiguousarray(y - poly._predict_rows(x))
    scale = float(np.sqrt(np.mean(residual**2)))
    for input_weight in (1.0, 0.1):
        weights = 1.0 / x.std(axis=0)
        weights[lags.source == 1] *= input_weight
        tree = SMTree(np.ascontiguousarray(x * weights), residual)
        for factor in (1.0, 2.0, 3.0):
            eps = np.array([factor * scale])
            gamma = 1.1 * _gamma_star(tree.points, tree.targets, eps[None, :], False, tree)[0]
            for lipschitz in ("global", "local"):
                if lipschitz == "local":
                    constants = learn_constants(tree, eps, gamma, 1.1)
                else:
                    constants = np.full((tree.points.shape[0], 1), gamma[0])
                y_sim = np.array(score_part.y, dtype=np.float64)
                u = score_part.u
                w = np.empty(lags.n_terms)
                for t in range(lags.max_lag, y_sim.shape[0]):
                    for k in range(lags.n_terms):
                        source = y_sim if lags.source[k] == 0 else u
                        w[k] = source[t - lags.lag[k], lags.channel[k]]
                    low, high, _ = local_bounds(
                        tree, constants, (w * weights)[None, :], eps, gamma, 10
                    )
                    y_sim[t] = poly._predict_rows(w[None, :])[0] + 0.5 * (low[0] + high[0])
                m = lags.max_lag
                error = np.sqrt(np.mean((y_sim[m:] - score_part.y[m:]) ** 2)) * 1000
                print(
                    f"Silverbox polynomial + SM map, input weight {input_weight:g}, eps ="
                    f" {factor:g} x {scale * 1000:.3f} mV, {lipschitz}: selection RMSE"
                    f" {error:.4f} mV",
                    flush=True,
                )


def main(argv: list[str] | None = None) -> None:
    """Run the four measurements."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folder", type=Path, help="the shared data folder (benchmarks/...)")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    started = time.perf_counter()
    silverbox_sm_linear(args.folder)
    tanks_sm_parallel(args.folder)
    tanks_output_error_base(args.folder)
    silverbox_sm_on_polynomial(args.folder)
    print(f"total {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
