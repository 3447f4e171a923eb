"""Every registered method in the lab's loops on the real neck: free-run fit against in-loop figures.

What it shows: the ``softneck-in-loop`` protocol (``neckid.experiments.benchmark.in_loop``). Each
method is chosen and fitted as the benchmark does on the payload split's training runs (0 g and
600 g staircases of the int/fra/ada controllers), the drive is identified on the same runs
(``neckid.loops.lab_drive.identify_drive``), and each test run (200 g, 400 g) is simulated in free
run and in the loop of its own controller, reference and dither
(``neckid.loops.lab_loop.in_loop_on_log``; the adaptive runs replay their parameter logs from
``DATA/softneck_adaptive``). Prints Markdown tables: the drive's drift, one row per method and
test run (fits, tracking-error RMS, oscillation period and amplitude against the logged ones,
controller check), and the free-run and in-loop rankings side by side with the PI loop's
figures. Run from the repository, with the data folder that holds ``softneck/`` (about 10 min on
2 cores; ``--quick``: one candidate per method, about 2 min)::

    .venv/bin/python docs/examples/in_loop_softneck.py DATA [--methods arx,sm] [--quick] [--csv out.csv]
    .venv/bin/python docs/examples/in_loop_softneck.py DATA --integrator   # the plain integrator as drive
"""

from __future__ import annotations

import argparse
import logging
import time
import warnings
from pathlib import Path

import pandas as pd

from neckid.experiments.benchmark.in_loop import run_in_loop_benchmark
from neckid.loops.lab_drive import LabDrive

COLUMNS = {
    "method": "method",
    "test": "test",
    "free_run_fit_percent": "free-run fit [%]",
    "inclination_fit_percent": "in-loop fit [%]",
    "command_fit_percent": "command fit [%]",
    "tracking_rms_deg": "tracking RMS [deg]",
    "logged_tracking_rms_deg": "logged [deg]",
    "tracking_ratio": "ratio",
    "period_s": "period [s]",
    "logged_period_s": "logged [s]",
    "period_ratio": "ratio ",
    "amplitude_deg": "amplitude [deg]",
    "logged_amplitude_deg": "logged  [deg]",
}


def markdown(frame: pd.DataFrame, digits: int = 2) -> str:
    """A frame as a Markdown table (numbers rounded)."""
    lines = ["| " + " | ".join(str(c) for c in frame.columns) + " |"]
    lines.append("|" + "---|" * len(frame.columns))
    for row in frame.itertuples(index=False):
        cells = [f"{v:.{digits}f}" if isinstance(v, float) else str(v) for v in row]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    """Run the protocol and print its tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", type=Path, help="folder holding softneck/ (and softneck_adaptive/)")
    parser.add_argument("--methods", default=None, help="comma-separated registry names (all)")
    parser.add_argument("--quick", action="store_true", help="one candidate per method")
    parser.add_argument("--csv", type=Path, default=None, help="write the full table here")
    parser.add_argument(
        "--integrator",
        action="store_true",
        help="drive the loops with the plain integrator of the executed command instead",
    )
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    logging.getLogger("neckid.datasets").setLevel(logging.WARNING)
    warnings.simplefilter("ignore")
    start = time.perf_counter()
    names = args.methods.split(",") if args.methods else None
    drive = LabDrive() if args.integrator else None
    report = run_in_loop_benchmark(args.data, names, quick=args.quick, drive=drive)
    print(f"drive: {report.drive!r}\n")
    print(markdown(report.drift, 3), "\n")
    table = report.table.assign(test=report.table["test"].str.replace("stair/", ""))
    print(markdown(table[list(COLUMNS)].rename(columns=COLUMNS)), "\n")
    print(markdown(report.rankings()), "\n")
    checks = report.table.groupby("test")["controller_check_rad_s"].max()
    print(markdown(checks.reset_index(), 7), "\n")
    print(markdown(report.table[["method", "settings", "train_time_s"]].drop_duplicates("method")))
    if args.csv is not None:
        report.table.to_csv(args.csv, index=False)
    print(f"\n{time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
