"""How `neckid.compare` chooses on the public benchmarks, against linear ARX.

For the cascaded tanks, Silverbox, Bouc-Wen and the robot arm, runs :func:`neckid.compare` on the
official training record only (one record: three contiguous time blocks, each held out once;
runaways rejected; one standard error toward the simpler model; ARX always a candidate), with
every method tried on each regressor of the benchmark's lag grid
(:data:`neckid.experiments.benchmark.settings.LAG_GRIDS`), then one free run per official test
record. Prints, per data set: the selection table (mean fold fit, its standard error, fold fits,
status and the reason of each rejection), every method's test fit [%] and RMSE (in the unit of
the benchmark's literature) per test record, the recommended method and its margin over ARX, and
whether any free run diverged. When the candidate the rule chose is not the one ``compare`` ran
for its method (several lag sets: ``compare`` runs each method's best-scoring candidate), the
chosen candidate is also fitted on the training record and run on the tests, and printed.

Run: ``python docs/examples/compare_public.py DATA [--only cascaded_tanks,silverbox]
[--methods arx,sm,sm-linear,sm-parallel,ss,poly] [--lag-index 1] [--json out.json]``
(DATA holds ``benchmarks/<name>/``).
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np
from sklearn.base import clone

import neckid
from neckid.experiments.benchmark.datasets import load_benchmark
from neckid.experiments.benchmark.settings import LAG_GRIDS
from neckid.metrics import fit_percent, rmse
from neckid.models.base import DivergenceError

DATASETS = ("cascaded_tanks", "silverbox", "bouc_wen", "robot_arm")


def _chosen_on_tests(result, bench, tests) -> dict[str, tuple[float, float, str]]:
    """The chosen candidate fitted on the training record and run on every test record."""
    chosen = result.selection.chosen
    method = chosen.split(" ")[0]
    lags = next(lag for lag in LAG_GRIDS[bench.name] if chosen == f"{method} {lag!r}")
    model = neckid.methods()[method].make(lags)
    if "random_state" in model.get_params():
        model.set_params(random_state=0)
    model = clone(model).fit(bench.train)
    out = {}
    for key, record in tests.items():
        try:
            run = model.simulate(record)
        except DivergenceError as exc:
            out[key] = (-np.inf, np.inf, f"diverged: {exc}")
            continue
        skip = run.n_initial
        out[key] = (
            float(fit_percent(record.y, run.y, skip=skip)[0]),
            float(rmse(record.y, run.y, skip=skip)[0]) * bench.rmse_scale,
            "",
        )
    return out


def run_one(name: str, args: argparse.Namespace) -> dict:
    """Compare on one data set; print its block and return it as a JSON-ready dict."""
    bench = load_benchmark(name, args.data_dir)
    if bench is None:
        print(f"## {name}: not found under {args.data_dir}")
        return {"dataset": name, "found": False}
    grid = list(LAG_GRIDS[name])
    if args.lag_index is not None:
        grid = [grid[min(args.lag_index, len(grid) - 1)]]
    tests = dict(bench.tests)
    started = time.perf_counter()
    result = neckid.compare(bench.train, list(tests.values()), methods=args.methods, lags=grid)
    seconds = time.perf_counter() - started
    unit = bench.rmse_unit or "output units"
    print(f"## {name} ({seconds:.0f} s; scheme {result.selection.scheme}, lags {grid})")
    table = result.selection.table
    for _, row in table.iterrows():
        folds = ", ".join(f"{f:.1f}" for f in row["fold_fits"])
        reason = f" -- {row['reason'][:200]}" if row["reason"] else ""
        print(
            f"  {row['status']:8s} {row['name']}: mean fold fit {row['fit_mean']:.2f} %"
            f" (se {row['fit_se']:.2f}; folds {folds}){reason}"
        )
    print(f"  bar (paired rule): {result.selection.bar:.2f} %; chosen {result.selection.chosen}")
    rows = result.results.copy()
    rows["rmse_shown"] = rows["rmse"] * bench.rmse_scale
    arx = rows[rows["method"] == "arx"].set_index("log")["fit_percent"]
    for log, part in rows.groupby("log", sort=False):
        print(f"  test {log}:")
        for _, row in part.iterrows():
            note = f" [{row['error'][:120]}]" if row["error"] else ""
            print(
                f"    {row['method']:12s} fit {row['fit_percent']:9.2f} %"
                f"  RMSE {row['rmse_shown']:.4g} {unit}"
                f"  outside domain {row['outside_domain']:.1%}{note}"
            )
    summary = result.summary().set_index("method")
    recommended = result.recommended
    margins = {
        log: float(
            rows[(rows["method"] == recommended) & (rows["log"] == log)]["fit_percent"].iloc[0]
        )
        - float(arx[log])
        for log in arx.index
    }
    mean_margin = float(summary.loc[recommended, "fit_percent"] - summary.loc["arx", "fit_percent"])
    diverged = sorted(
        set(rows[rows["error"].str.startswith("diverged")]["method"]) if len(rows) else set()
    )
    print(
        f"  recommended {recommended} ({result.settings[recommended]['candidate']} run on the"
        f" tests); mean test fit {summary.loc[recommended, 'fit_percent']:.2f} %, "
        f"{mean_margin:+.2f} points from ARX; per test { ({k: round(v, 2) for k, v in margins.items()}) }"
    )
    print(f"  methods whose test free run diverged: {diverged or 'none'}")
    out = {
        "dataset": name,
        "found": True,
        "seconds": seconds,
        "lags": [repr(lag) for lag in grid],
        "unit": unit,
        "recommended": recommended,
        "chosen": result.selection.chosen,
        "settings": result.settings,
        "mean_margin_over_arx": mean_margin,
        "margins_over_arx": margins,
        "diverged_methods": diverged,
        "selection": json.loads(table.to_json(orient="records")),
        "tests": json.loads(rows.to_json(orient="records")),
    }
    if result.settings[recommended]["candidate"] != result.selection.chosen:
        chosen_runs = _chosen_on_tests(result, bench, tests)
        for key, (fit, err, note) in chosen_runs.items():
            print(
                f"  the chosen candidate itself on {key}: fit {fit:.2f} %, RMSE {err:.4g} {unit},"
                f" {fit - float(arx[tests[key].name]):+.2f} points from ARX {note[:120]}"
            )
        out["chosen_on_tests"] = chosen_runs
    return out


def main(argv: list[str] | None = None) -> None:
    """Print one block per data set."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data_dir", help="folder holding benchmarks/<name>/")
    parser.add_argument("--only", default=",".join(DATASETS), help="data sets, comma-separated")
    parser.add_argument("--methods", default="arx,sm,sm-linear,sm-parallel,ss,poly")
    parser.add_argument(
        "--lag-index", type=int, default=None, help="one regressor of the grid (default: all)"
    )
    parser.add_argument("--json", default=None, help="write the results here")
    args = parser.parse_args(argv)
    args.methods = args.methods.split(",")
    warnings.simplefilter("ignore")
    results = [run_one(name, args) for name in args.only.split(",")]
    if args.json:
        with open(args.json, "w", encoding="utf-8") as handle:
            json.dump(results, handle, indent=1, default=str)


if __name__ == "__main__":
    main()
