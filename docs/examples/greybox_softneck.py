"""The grey-box neck (slack + Prandtl–Ishlinskii hysteresis + 2nd-order dynamics) on the real logs.

What it shows (docs/greybox.md): the free-run fit of ``greybox-neck`` against the linear ARX
``Lags.arx(2, 2, 1)``, both identified on ``stair/ada000response.csv`` with the benchmark's
protocol (motor displacement [rad] -> raw inclination [deg]), on held-out stair and step logs,
and whether the simulated step responses overshoot as the measured ones do. Run from the
repository, with the folder of the real soft-neck logs::

    .venv/bin/python docs/examples/greybox_softneck.py DATA/softneck
"""

import argparse
import warnings
from pathlib import Path

import numpy as np

from neckid import Lags, LinearARX
from neckid.datasets import load_softneck_log
from neckid.experiments.benchmark.datasets import softneck_protocol
from neckid.models.greybox import GreyBoxNeck

TRAIN = "stair/ada000response.csv"
STAIRS = ("stair/ada200response.csv", "stair/fra000response.csv", "stair/int400response.csv")
STEPS = (
    "step/fra000stepresponse.csv",
    "step/fra200stepresponse.csv",
    "step/fra400stepresponse.csv",
    "step/int000stepresponse.csv",
    "step/int400stepresponse.csv",
)


def record(folder: Path, name: str):
    """The benchmark's channels of one log, motor displacement as the only input."""
    data = softneck_protocol(load_softneck_log(folder / name))
    return data.select(inputs=["motor_displacement"])


def overshoot(y: np.ndarray) -> float:
    """Step overshoot [%]: the peak beyond the final value (mean of the last fifth) over the rise."""
    start, final = float(np.mean(y[:5])), float(np.mean(y[-len(y) // 5 :]))
    rise = final - start
    peak = np.max(y) if rise >= 0 else np.min(y)
    return 100.0 * float((peak - final) / rise) if rise else float("nan")


def free_run(model, data) -> tuple[float, np.ndarray]:
    """Free-run fit [%] and the simulated output (-inf and NaN when the run diverges)."""
    try:
        result = model.simulate(data)
    except ValueError:
        return -np.inf, np.full(data.n_samples, np.nan)
    return float(result.fit_percent(data)[0]), result.y[:, 0]


def main(argv: list[str] | None = None) -> None:
    """Print the fit table and the overshoot table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", type=Path, help="the folder holding stair/ and step/")
    parser.add_argument("--max-iter", type=int, default=60)
    args = parser.parse_args(argv)
    train = record(args.data, TRAIN)
    arx = LinearARX(Lags.arx(2, 2, 1)).fit(train)
    grey = GreyBoxNeck(max_iter=args.max_iter).fit(train)
    print(f"grey box: slack {grey.slack_[0]:.4f} rad, poles {np.roots(grey.denominators_[0])}")
    print(
        f"{'log':34s} {'ARX %':>7s} {'grey %':>7s} {'OS meas':>8s} {'OS ARX':>7s} {'OS grey':>8s}"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in (TRAIN, *STAIRS, *STEPS):
            data = record(args.data, name)
            fit_arx, y_arx = free_run(arx, data)
            fit_grey, y_grey = free_run(grey, data)
            row = f"{name:34s} {fit_arx:7.1f} {fit_grey:7.1f}"
            if name.startswith("step/"):
                shots = (overshoot(data.y[:, 0]), overshoot(y_arx), overshoot(y_grey))
                row += " {:8.1f} {:7.1f} {:8.1f}".format(*shots)
            print(row)


if __name__ == "__main__":
    main()
