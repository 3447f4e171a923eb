"""The guaranteed k-step bands that ``sm-multistep`` gives with its own choice of settings.

What it shows: the floor of ``docs/bounds.md`` for :class:`MultiStepSetMembership` as a user gets
it (no setting given: the ε factor, the input weight and the Lipschitz form of every horizon are
chosen by the model's leave-one-run-out on the training logs), measured once on held-out logs.

Run from the repository, with the folder of the real soft-neck logs (it holds ``stair/``)::

    .venv/bin/python docs/examples/multistep_defaults.py DATA/softneck [--horizon 10] [--horizons 40]

Protocol (the one of ``docs/examples/bounds_experiment.py``):

- channels: :func:`~neckid.experiments.benchmark.softneck_protocol` (motor displacement [rad] and
  measured motor velocity [rad/s] -> raw inclination [deg]), the stair logs of the three
  controllers (``ada``, ``fra``, ``int``);
- training logs: the 0 g and 600 g runs (6 logs, 6 folds); test logs: the 200 g and 400 g runs
  (6 logs), used once, after the fit;
- one-step regressor ``Lags(outputs=[1, 2], inputs=[0, 1])``; the model
  ``MultiStepSetMembership(LAGS, horizon=10, horizons=[40])``, every other setting at its
  default (what ``neckid identify --method sm-multistep --set horizons=[40]`` fits).

It prints the settings chosen per horizon, the cross-validation table of the horizons asked
for, the test table (coverage and mean width of the guaranteed band per log and pooled) and the
floors of issue 29 (k = 10: width <= 4.5 deg at coverage >= 95 %; k = 40: <= 9 deg at >= 95 %).
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

import neckid
from neckid import IOData, Lags
from neckid.experiments.benchmark import softneck_protocol
from neckid.models.set_membership.multistep import MultiStepSetMembership

LAGS = Lags(outputs=[1, 2], inputs=[0, 1])
CONTROLLERS = ("ada", "fra", "int")
TRAIN_PAYLOADS = ("000", "600")
TEST_PAYLOADS = ("200", "400")
#: Issue 29's floors: horizon -> (largest mean width [deg], smallest coverage).
FLOORS = {10: (4.5, 0.95), 40: (9.0, 0.95)}


def load(folder: Path) -> dict[str, IOData]:
    """The stair logs of the three controllers through the benchmark's protocol, by run name."""
    logs = neckid.datasets.load_softneck_directory(folder / "stair", pattern="[afi]*response.csv")
    return {Path(k).name[:6]: softneck_protocol(v) for k, v in logs.items()}


def table(header: list[str], rows: list[list[str]]) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def print_selection(model: MultiStepSetMembership, shown: list[int]) -> None:
    """The chosen setting of every horizon and the fold table of the ``shown`` horizons."""
    selection = model.selection_
    assert selection is not None
    print(
        f"\nCross-validation: {selection.folds}, {len(selection.fold_names)} folds,"
        f" target {selection.target_coverage:g}, {selection.seconds:.0f} s\n"
    )
    rows = [
        [str(int(k)), f"{s.epsilon_factor:g}", f"{s.input_weight:g}", s.lipschitz]
        for k, s in zip(model.horizons_, model.settings_, strict=True)
    ]
    print(table(["k", "epsilon_factor", "input_weight", "lipschitz"], rows))
    frame = selection.table()
    for k in shown:
        part = frame[frame.horizon == k]
        print(f"\nk = {k}: mean held-out coverage / worst fold / mean width [deg]\n")
        print(
            table(
                [
                    "lipschitz",
                    "input_weight",
                    "epsilon_factor",
                    "coverage",
                    "worst",
                    "width",
                    "status",
                ],
                [
                    [
                        r.lipschitz,
                        f"{r.input_weight:g}",
                        f"{r.epsilon_factor:g}",
                        f"{r.coverage:.3f}",
                        f"{r.worst_coverage:.3f}",
                        f"{r.width:.2f}",
                        r.status,
                    ]
                    for r in part.itertuples()
                ],
            )
        )


def measure(model: MultiStepSetMembership, test: dict[str, IOData], shown: list[int]) -> None:
    """Coverage and width of the guaranteed band on every test log and pooled; the floors."""
    rows, verdicts = [], []
    for k in shown:
        inside, widths = [], []
        for name, data in test.items():
            ahead = model.predict_ahead(data, steps=k)
            s = ahead.n_initial
            assert ahead.lower is not None and ahead.upper is not None
            held = (ahead.lower[s:] <= data.y[s:]) & (data.y[s:] <= ahead.upper[s:])
            width = ahead.upper[s:] - ahead.lower[s:]
            inside.append(held)
            widths.append(width)
            rows.append([str(k), name, f"{held.mean():.3f}", f"{width.mean():.2f}"])
        cov, wid = float(np.mean(np.vstack(inside))), float(np.mean(np.vstack(widths)))
        rows.append([f"**{k}**", "**all 6**", f"**{cov:.3f}**", f"**{wid:.2f}**"])
        if k in FLOORS:
            most, least = FLOORS[k]
            met = "yes" if wid <= most and cov >= least else "**no**"
            verdicts.append(
                [str(k), f"<= {most:g} deg at >= {least:.0%}", f"{wid:.2f} deg, {cov:.1%}", met]
            )
    print("\nTest logs (200 g and 400 g), used once; guaranteed band [f_l - eps, f_u + eps]:\n")
    print(table(["k", "log", "coverage", "width [deg]"], rows))
    print("\n" + table(["k", "floor", "measured", "met?"], verdicts))


def main(argv: list[str] | None = None) -> None:
    """Fit with the default settings on the training logs, then measure on the test logs."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folder", type=Path, help="the softneck folder (stair/, step/, id/)")
    parser.add_argument("--horizon", type=int, default=10, help="horizons 1..HORIZON (default 10)")
    parser.add_argument(
        "--horizons", default="40", help="further horizons, comma-separated (default 40)"
    )
    args = parser.parse_args(argv)
    extra = [int(k) for k in args.horizons.split(",") if k]
    logs = load(args.folder)
    train = [logs[c + p] for c in CONTROLLERS for p in TRAIN_PAYLOADS]
    test = {c + p: logs[c + p] for c in CONTROLLERS for p in TEST_PAYLOADS}
    started = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = MultiStepSetMembership(LAGS, horizon=args.horizon, horizons=extra).fit(train)
    print(f"fit on the 6 training logs (choice included): {time.perf_counter() - started:.0f} s")
    for warning in caught:
        print(f"warning: {warning.message}")
    shown = sorted({min(args.horizon, 10), args.horizon, *extra})
    print_selection(model, shown)
    measure(model, test, shown)


if __name__ == "__main__":
    main()
