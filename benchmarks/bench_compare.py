"""``compare`` with the model classes a user asks for: wall time and each method's seconds (issue 42).

Run:  .venv/bin/python benchmarks/bench_compare.py [DATA] [--methods arx,sm,sm-parallel,ss,nn]
      [--case payload|three-motor|both]

``payload``: :func:`neckid.compare` as ``neckid compare`` runs it (``Lags.arx(2, 2, 1)``
replaced by the command line's default ``1-2/1-2``, the stress check on) on the payload split
of DATA (train the 0 g and 600 g staircases of the three controllers, test 200 g and 400 g;
``load_softneck_cross_run``). ``three-motor``: two logs of the simulated three-tendon neck of
``neckid demo --3d`` (the tendon-space multisine of its identification record, 120 s for
training and 60 s, another seed, for the test; three motor positions in, the tilt vector out),
the regressor ``Lags(outputs=[1], inputs=[1, 2, 3])`` the demo chooses. Prints the wall time,
the load average, and per method the seconds of its selection (fits and free runs on the
training folds, the stress check) and of its test runs (``Comparison.seconds``). The floor of
issue 42: the payload case ≤ 60 s.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path
from typing import Any

from neckid import Lags, compare
from neckid.experiments.benchmark.datasets import load_softneck_cross_run

#: The command line's default regressor (``--lags 1-2/1-2``).
CLI_LAGS = Lags(outputs=[1, 2], inputs=[1, 2])


def three_motor_logs() -> tuple[Any, Any]:
    """The identification record of ``neckid demo --3d`` and a 60 s one of another seed."""
    from neckid.experiments.neck3d import Demo3DSettings, _open_loop_record
    from neckid.plant import SoftNeck

    settings = Demo3DSettings()
    neck = SoftNeck(configuration="three_tendon", ts=settings.ts, seed=1)
    train = _open_loop_record(neck, settings, settings.train_duration, 4.0, 11)[0]
    test = _open_loop_record(neck, settings, settings.validation_duration, 4.0, 12)[0]
    return train.renamed("three-motor train"), test.renamed("three-motor test")


def run(label: str, train: Any, tests: Any, methods: list[str], lags: Lags) -> None:
    """One comparison: its wall time, the load, and every method's seconds."""
    load = os.getloadavg()[0]
    start = time.perf_counter()
    result = compare(train, tests, methods=methods, lags=lags)
    wall = time.perf_counter() - start
    print(
        f"{label}: {wall:.1f} s wall for {','.join(methods)} (load average {load:.2f} ->"
        f" {os.getloadavg()[0]:.2f}); recommended {result.recommended}"
    )
    for method, spent in result.seconds.items():
        fit = result.summary().set_index("method")["fit_percent"].get(method, float("nan"))
        print(
            f"    {method:12s} selection {spent['selection']:7.1f} s, test {spent['test']:6.1f} s;"
            f" mean test fit {fit:.2f} %"
        )


def main() -> None:
    """Run the cases asked for."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="?", default="../shared/data", type=Path)
    parser.add_argument("--methods", default="arx,sm,sm-parallel,ss,nn")
    parser.add_argument("--case", choices=["payload", "three-motor", "both"], default="both")
    args = parser.parse_args()
    methods = args.methods.split(",")
    if args.case in ("payload", "both"):
        bench = load_softneck_cross_run(args.data / "softneck", "softneck-payload")
        run(
            "payload split (6 -> 6 logs)",
            bench.train,
            list(bench.tests.values()),
            methods,
            CLI_LAGS,
        )
    if args.case in ("three-motor", "both"):
        train, test = three_motor_logs()
        run("three-motor logs (1 -> 1)", train, test, methods, Lags(outputs=[1], inputs=[1, 2, 3]))


if __name__ == "__main__":
    main()
