"""Guaranteed (Set Membership) and calibrated (conformal) bands on the real soft-neck stair logs.

What it shows: the measurements of ``docs/bounds.md`` (it prints its markdown tables): how wide
the guaranteed k-step bands of ``MultiStepSetMembership`` are and how many held-out samples they
hold, against split-conformal bands of any model.

Run from the repository, with the folder of the real soft-neck logs (it holds ``stair/``)::

    .venv/bin/python docs/examples/bounds_experiment.py DATA/softneck [--quick]

About 4 minutes on two cores (242 s); ``--quick`` skips the neural network, the SM centre's
conformal band and the k = 40 cross-validation.

Protocol (the issue "Guaranteed bounds that mean something"):

- channels: :func:`~neckid.experiments.benchmark.softneck_protocol` (motor displacement [rad] and
  measured motor velocity [rad/s] -> raw inclination [deg]), every stair log of the three
  controllers (``ada``, ``fra``, ``int``);
- training logs: the 0 g and 600 g runs (6 logs); test logs: the 200 g and 400 g runs (6 logs),
  used once, after every setting is fixed;
- one-step regressor ``Lags(outputs=[1, 2], inputs=[0, 1])``, the one the soft-neck benchmark's
  selection chose on a training log (``docs/examples/softneck_oracle.py``); the k-step regressors follow
  from it (:func:`~neckid.models.set_membership.multistep.horizon_lags`);
- Set Membership settings (``epsilon_factor``, ``input_weight``, ``lipschitz``) per horizon by leave-one-log-out
  cross-validation over the six training logs: the smallest mean width of the guaranteed band
  among the settings whose mean held-out coverage is at least 95 %;
- conformal bands: each model is fitted on three training logs and calibrated on the other three
  (both ways: split A = fit on ada000, fra600, int000; split B = the other three), then applied to
  the test logs.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

import neckid
from neckid import IOData, Lags, LinearARX, ModelResult
from neckid.experiments.benchmark import softneck_protocol
from neckid.metrics import coverage, mean_width, rmse
from neckid.models.conformal import calibrate
from neckid.models.linear.arx import least_squares
from neckid.models.set_membership._kernels.local import learn_constants, local_bounds
from neckid.models.set_membership._kernels.tree import SMTree
from neckid.models.set_membership.multistep import (
    MultiStepSetMembership,
    horizon_lags,
    robust_scale,
)
from neckid.models.set_membership.narx import DEFAULT_GAMMA_MARGIN
from neckid.models.set_membership.prior import _gamma_star
from neckid.models.set_membership.scaling import term_weights

LAGS = Lags(outputs=[1, 2], inputs=[0, 1])
HORIZONS = (10, 40)
CONTROLLERS = ("ada", "fra", "int")
TRAIN_PAYLOADS = ("000", "600")
TEST_PAYLOADS = ("200", "400")
EPSILON_FACTORS = (1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0)
INPUT_WEIGHTS = (1.0, 0.3)
LIPSCHITZ = ("global", "local")
NEIGHBOURS = 10  # the default of ``local_neighbours``, not cross-validated
TARGET = 0.95
SPLIT_A = ("ada000", "fra600", "int000")


def load(folder: Path) -> dict[str, IOData]:
    """The stair logs of the three controllers through the benchmark's protocol, by run name."""
    logs = neckid.datasets.load_softneck_directory(folder / "stair", pattern="[afi]*response.csv")
    return {Path(k).name[:6]: softneck_protocol(v) for k, v in logs.items()}


# ---------------------------------------------------------------------- cross-validation
def cross_validate(train: dict[str, IOData], steps: int) -> list[dict[str, Any]]:
    """Leave-one-training-log-out coverage and width of the guaranteed band, per setting.

    The same rule as :class:`MultiStepSetMembership` (ε = factor · 1.4826 · MAD of the k-step
    least-squares residual, γ = 1.1 γ*(ε)), with every ε of the grid in one γ*(ε) pass per fold;
    each setting with one global constant and with local constants (``local_neighbours`` = 10).
    """
    lags_k = horizon_lags(LAGS.resolve(list(train.values())), steps)
    resolved = lags_k.resolve(list(train.values()))
    built = {name: lags_k.build(d) for name, d in train.items()}
    factors = np.asarray(EPSILON_FACTORS)
    rows = []
    for weight in INPUT_WEIGHTS:
        per_fold: list[tuple[float, str, float, float]] = []
        for held in train:
            x = np.vstack([built[n][0] for n in train if n != held])
            y = np.vstack([built[n][1] for n in train if n != held])
            coef, intercept = least_squares(x, y)
            residual = np.ascontiguousarray(y - (x @ coef + intercept))
            scale = robust_scale(residual)
            grid = factors[:, None] * scale[None, :]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                weights = term_weights("std", weight, x, resolved)
            points = np.ascontiguousarray(x * weights)
            # One γ*(ε) pass for every ε and ε/2. The grid holds no value twice: the pass's
            # early exit assumes distinct ε (a repeated ε gives a too small γ* after it).
            multipliers = np.unique(np.concatenate([factors, 0.5 * factors]))
            star = _gamma_star(points, residual, multipliers[:, None] * scale[None, :], False)
            star_full = star[np.searchsorted(multipliers, factors)]
            star_half = star[np.searchsorted(multipliers, 0.5 * factors)]
            tree = SMTree(points, residual)
            x_held, y_held = built[held]
            linear = x_held @ coef + intercept
            query = np.ascontiguousarray(x_held * weights)
            for i, factor in enumerate(factors):
                gamma = DEFAULT_GAMMA_MARGIN * np.where(
                    star_full[i] > 0, star_full[i], star_half[i]
                )
                for lipschitz in LIPSCHITZ:
                    if lipschitz == "global":
                        f_l, f_u = tree.bounds(query, grid[i], gamma)
                    else:
                        constants = learn_constants(tree, grid[i], gamma, DEFAULT_GAMMA_MARGIN)
                        f_l, f_u, _ = local_bounds(
                            tree, constants, query, grid[i], gamma, NEIGHBOURS
                        )
                    lower, upper = linear + f_l - grid[i], linear + f_u + grid[i]
                    per_fold.append(
                        (
                            factor,
                            lipschitz,
                            coverage(y_held, lower, upper)[0],
                            mean_width(lower, upper)[0],
                        )
                    )
        for lipschitz in LIPSCHITZ:
            for factor in factors:
                values = np.array(
                    [(c, w) for f, g, c, w in per_fold if f == factor and g == lipschitz]
                )
                rows.append(
                    {
                        "epsilon_factor": float(factor),
                        "input_weight": weight,
                        "lipschitz": lipschitz,
                        "coverage": float(values[:, 0].mean()),
                        "worst_coverage": float(values[:, 0].min()),
                        "width": float(values[:, 1].mean()),
                    }
                )
    return rows


def choose(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The narrowest setting whose mean held-out coverage reaches the target (else the widest cover)."""
    good = [r for r in rows if r["coverage"] >= TARGET]
    if good:
        return min(good, key=lambda r: r["width"])
    return max(rows, key=lambda r: r["coverage"])


# ---------------------------------------------------------------------- measurements
def pooled(results: list[tuple[IOData, ModelResult]]) -> tuple[float, float, float]:
    """Coverage, mean width and RMSE of the centre over every non-initial sample of several logs."""
    inside, widths, errors = [], [], []
    for data, result in results:
        s = result.n_initial
        assert result.lower is not None and result.upper is not None
        low, high = result.lower[s:], result.upper[s:]
        inside.append((low <= data.y[s:]) & (data.y[s:] <= high))
        widths.append(high - low)
        errors.append(data.y[s:] - result.y[s:])
    error = np.vstack(errors)
    return (
        float(np.mean(np.vstack(inside))),
        float(np.mean(np.vstack(widths))),
        float(np.sqrt(np.mean(error**2))),
    )


def function_band(result: ModelResult) -> ModelResult:
    """The result with the band of the noise-free ``f_k`` (``f_l``, ``f_u``) as its band."""
    extras = result.extras
    return dataclasses.replace(
        result, lower=extras["function_lower"], upper=extras["function_upper"]
    )


def table(header: list[str], rows: list[list[str]]) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def guaranteed_bands(
    train: dict[str, IOData], test: dict[str, IOData], quick: bool
) -> dict[int, dict[str, Any]]:
    """Choose the SM settings per horizon on the training logs, fit, and measure on the tests."""
    models = {}
    settings = {}
    for steps in HORIZONS:
        started = time.perf_counter()
        if quick and steps > 10:
            setting = {"epsilon_factor": 3.0, "input_weight": 0.3, "lipschitz": "global"}
            print(f"\nk = {steps}: cross-validation skipped (--quick); settings {setting}")
        else:
            rows = cross_validate(train, steps)
            setting = choose(rows)
            print(f"\nk = {steps}: leave-one-training-log-out (guaranteed band, 6 folds)\n")
            print(
                table(
                    [
                        "lipschitz",
                        "epsilon_factor",
                        "input_weight",
                        "coverage",
                        "worst log",
                        "width [deg]",
                    ],
                    [
                        [
                            r["lipschitz"],
                            f"{r['epsilon_factor']:g}",
                            f"{r['input_weight']:g}",
                            f"{r['coverage']:.3f}",
                            f"{r['worst_coverage']:.3f}",
                            f"{r['width']:.2f}",
                        ]
                        for r in rows
                    ],
                )
            )
        model = MultiStepSetMembership(
            LAGS,
            horizon=1,
            horizons=[steps],
            epsilon_factor=setting["epsilon_factor"],
            input_weight=setting["input_weight"],
            lipschitz=setting["lipschitz"],
        ).fit(list(train.values()))
        models[steps] = model
        settings[steps] = setting
        print(
            f"\nchosen: lipschitz={setting['lipschitz']}, epsilon_factor={setting['epsilon_factor']:g},"
            f" input_weight={setting['input_weight']:g}; fitted on the 6 training logs:"
            f" epsilon_{steps} = {model.epsilon_[-1, 0]:.3f} deg, gamma_{steps} ="
            f" {model.gamma_[-1, 0]:.3f} ({time.perf_counter() - started:.0f} s)"
        )
    print("\nTest logs (200 g and 400 g), used once:\n")
    table_rows = []
    for steps, model in models.items():
        arx = LinearARX(horizon_lags(model.lags_, steps)).fit(list(train.values()))
        results, directs = [], []
        for name, data in test.items():
            result = model.predict_ahead(data, steps=steps)
            direct = arx.predict(data)
            results.append((data, result))
            directs.append((data, dataclasses.replace(direct, lower=direct.y, upper=direct.y)))
            s = result.n_initial
            table_rows.append(
                [
                    str(steps),
                    name,
                    f"{coverage(data.y, result.lower, result.upper, s)[0]:.3f}",
                    f"{mean_width(result.lower, result.upper, s)[0]:.2f}",
                    f"{rmse(data.y, result.y, s)[0]:.3f}",
                    f"{rmse(data.y, direct.y, s)[0]:.3f}",
                ]
            )
        cov, width, error = pooled(results)
        f_cov, f_width, _ = pooled([(d, function_band(r)) for d, r in results])
        direct_error = pooled(directs)[2]
        table_rows.append(
            [
                f"**{steps}**",
                "**all 6**",
                f"**{cov:.3f}**",
                f"**{width:.2f}**",
                f"**{error:.3f}**",
                f"**{direct_error:.3f}**",
            ]
        )
        table_rows.append(
            [str(steps), "all 6, band of f_k only", f"{f_cov:.3f}", f"{f_width:.2f}", "", ""]
        )
    print(
        table(
            ["k", "log", "coverage", "width [deg]", "RMSE SM centre", "RMSE direct ARX"],
            table_rows,
        )
    )
    return settings


def width_vs_horizon(
    train: dict[str, IOData], test: dict[str, IOData], setting: dict[str, Any]
) -> None:
    """Guaranteed band and centre against the horizon, pooled over the test logs."""
    started = time.perf_counter()
    horizons = (5, 10, 20, 40)
    model = MultiStepSetMembership(
        LAGS,
        horizon=1,
        horizons=list(horizons),
        epsilon_factor=setting["epsilon_factor"],
        input_weight=setting["input_weight"],
        lipschitz=setting["lipschitz"],
    ).fit(list(train.values()))
    rows = []
    for i, steps in enumerate(model.horizons_):
        arx = LinearARX(horizon_lags(model.lags_, int(steps))).fit(list(train.values()))
        results = [(d, model.predict_ahead(d, steps=int(steps))) for d in test.values()]
        directs = []
        for d in test.values():
            direct = arx.predict(d)
            directs.append((d, dataclasses.replace(direct, lower=direct.y, upper=direct.y)))
        cov, width, error = pooled(results)
        f_cov, f_width, _ = pooled([(d, function_band(r)) for d, r in results])
        rows.append(
            [
                str(int(steps)),
                f"{model.epsilon_[i, 0]:.3f}",
                f"{model.gamma_[i, 0]:.3f}",
                f"{cov:.3f}",
                f"{width:.2f}",
                f"{f_cov:.3f}",
                f"{f_width:.2f}",
                f"{error:.3f}",
                f"{pooled(directs)[2]:.3f}",
            ]
        )
    print(
        f"\nWidth against the horizon (lipschitz={setting['lipschitz']},"
        f" epsilon_factor={setting['epsilon_factor']:g},"
        f" input_weight={setting['input_weight']:g}; 6 test logs pooled;"
        f" {time.perf_counter() - started:.0f} s):\n"
    )
    print(
        table(
            [
                "k",
                "eps_k [deg]",
                "gamma_k",
                "coverage",
                "width [deg]",
                "f_k band coverage",
                "f_k band width",
                "RMSE centre",
                "RMSE direct ARX",
            ],
            rows,
        )
    )


def calibrated_bands(train: dict[str, IOData], test: dict[str, IOData], quick: bool) -> None:
    """Split-conformal bands at 95 % (fit on 3 training logs, calibrate on the other 3)."""
    split_b = tuple(n for n in train if n not in SPLIT_A)
    methods = ["arx"] if quick else ["arx", "nn", "sm-multistep"]
    # The centre with the settings of the registry before sm-multistep chose its own (issue 29).
    fixed = {"epsilon_factor": 3.0, "input_weight": 1.0, "lipschitz": "global"}
    settings = {"sm-multistep": {"horizon": 1, "horizons": list(HORIZONS), **fixed}}
    kinds: list[str | int] = ["simulation", *HORIZONS]
    rows = []
    for method in methods:
        for fit_names, calibration_names, label in (
            (SPLIT_A, split_b, "A"),
            (split_b, SPLIT_A, "B"),
        ):
            started = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                make = neckid.methods()[method].make
                model = make(LAGS, **settings.get(method, {})).fit([train[n] for n in fit_names])
                for kind in kinds:
                    bands = calibrate(
                        model, [train[n] for n in calibration_names], coverage=TARGET, kind=kind
                    )
                    results = []
                    for data in test.values():
                        if kind == "simulation":
                            results.append((data, bands.simulate(data)))
                        else:
                            results.append((data, bands.predict_ahead(data)))
                    cov, width, error = pooled(results)
                    per_log = [coverage(d.y, r.lower, r.upper, r.n_initial)[0] for d, r in results]
                    rows.append(
                        [
                            method,
                            label,
                            "free run" if kind == "simulation" else f"k = {kind}",
                            f"{cov:.3f}",
                            f"{min(per_log):.3f} - {max(per_log):.3f}",
                            f"{width:.2f}",
                            f"{error:.3f}",
                        ]
                    )
            print(f"{method} split {label}: {time.perf_counter() - started:.0f} s", flush=True)
    print("\nConformal bands at 95 % on the test logs (pooled; range over the 6 logs):\n")
    print(
        table(
            ["model", "split", "result", "coverage", "per log", "width [deg]", "RMSE [deg]"],
            rows,
        )
    )


def main(argv: list[str] | None = None) -> None:
    """Run the whole measurement and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folder", type=Path, help="the softneck folder (stair/, step/, id/)")
    parser.add_argument("--quick", action="store_true", help="no NN, no k = 40 cross-validation")
    args = parser.parse_args(argv)
    logs = load(args.folder)
    train = {c + p: logs[c + p] for c in CONTROLLERS for p in TRAIN_PAYLOADS}
    test = {c + p: logs[c + p] for c in CONTROLLERS for p in TEST_PAYLOADS}
    started = time.perf_counter()
    settings = guaranteed_bands(train, test, args.quick)
    width_vs_horizon(train, test, settings[10])
    calibrated_bands(train, test, args.quick)
    print(f"\ntotal {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
