"""Calibration figures and numbers of the simulated neck (docs/simulator.md).

What it shows: the simulated neck's static map, chirp bandwidth, operating-point models and
open-loop pull and release, beside the paper's figures. Run from the repository, with the folder
to write the figures to::

    MPLBACKEND=Agg .venv/bin/python docs/examples/make_simulator_figures.py docs/img [--real DATA/softneck]

It writes ``simulator_*.png`` there and prints the figures quoted in the document. With
``--real`` (the folder of the real soft-neck logs, it holds ``stair/``) it also draws the real
``int000`` staircase in the static-map figure.
"""

import argparse
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from neckid.plant import InclinationController, SoftNeck, SoftNeckParameters, closed_loop
from neckid.plant.calibration import (
    PAPER_GAIN,
    PAPER_POLE,
    chirp_bandwidth,
    operating_point_models,
    static_map,
)


def main(argv: list[str] | None = None) -> None:
    """Write the figures and print the numbers."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", type=Path, help="folder to write the simulator_*.png figures to")
    parser.add_argument("--real", type=Path, default=None, help="folder of the real softneck logs")
    args = parser.parse_args(argv)
    img = args.out
    img.mkdir(parents=True, exist_ok=True)
    neck = SoftNeck()

    # 1. static map (closed-loop staircase as in the real stair logs)
    result = static_map(neck)
    print(f"static map 15-30 deg: {result.slope:.2f} deg/rad (real bench about 7)")
    print("up/down motor difference [rad]:", {k: round(v, 4) for k, v in result.up_down.items()})
    fig, ax = plt.subplots(figsize=(6, 4))
    ref = np.repeat(result.levels, round(10.0 / neck.ts))
    data = closed_loop(SoftNeck(), InclinationController(), ref, neck.ts)
    ax.plot(data.channel("motor_position"), data.channel("inclination"), lw=0.7, label="simulated")
    if args.real is not None:
        real = np.loadtxt(args.real / "stair" / "int000response.csv", delimiter=",")
        ax.plot(
            real[:, 3] - real[0, 3], real[:, 4], lw=0.5, alpha=0.6, label="real int000 (shifted)"
        )
    ax.set_xlabel("motor position [rad]")
    ax.set_ylabel("inclination [deg]")
    ax.set_title(f"closed-loop staircase: {result.slope:.2f} deg/rad (15-30 deg)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(img / "simulator_static_map.png", dpi=110)

    # 2. chirp bandwidth
    bw, time, reference, response = chirp_bandwidth(neck)
    print(f"chirp bandwidth: {bw.bandwidth:.2f} rad/s ({bw.status}); paper 4.2 rad/s")
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 5))
    ax1.plot(time, reference, lw=0.7, label="reference 5 + 4 sin(0.1 t^2)")
    ax1.plot(time, response, lw=0.7, label="inclination")
    ax1.set_xlabel("t [s]")
    ax1.set_ylabel("deg")
    ax1.legend(loc="upper left")
    ax2.plot(bw.frequency, bw.ratio, ".-")
    ax2.axhline(0.9, color="k", lw=0.5)
    ax2.axvline(bw.bandwidth, color="r", lw=0.7, label=f"{bw.bandwidth:.2f} rad/s")
    ax2.set_xlabel("frequency [rad/s]")
    ax2.set_ylabel("amplitude ratio")
    ax2.legend()
    fig.tight_layout()
    fig.savefig(img / "simulator_chirp.png", dpi=110)

    # 3. operating-point first-order models
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.6))
    for delay, style in ((None, "o-"), (0, "s--")):
        models = operating_point_models(neck, input_delay=delay)
        g, p = models.trend()
        print(
            f"input_delay={models.input_delay}: N={np.round(models.gain, 3)}, P={np.round(models.pole, 3)}"
            f"; slopes dN/di={g:.4f}, dP/di={p:.4f} per deg"
        )
        label = f"simulated, u(t-{models.input_delay})"
        ax1.plot(models.inclination, models.gain, style, label=label)
        ax2.plot(models.inclination, models.pole, style, label=label)
    i = np.linspace(5, 35, 7)
    ax1.plot(i, PAPER_GAIN[0] * i + PAPER_GAIN[1], "k:", label="paper")
    ax2.plot(i, PAPER_POLE[0] * i + PAPER_POLE[1], "k:", label="paper")
    ax1.set_xlabel("inclination [deg]")
    ax1.set_ylabel("gain N [(deg/s)/(rad/s)]")
    ax2.set_xlabel("inclination [deg]")
    ax2.set_ylabel("pole P")
    ax1.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(img / "simulator_operating_points.png", dpi=110)

    # 4. open-loop pull and release, payloads
    fig, ax = plt.subplots(figsize=(6, 3.6))
    commands = np.r_[np.full(25, 4.0), np.zeros(75), np.full(25, -4.0), np.zeros(125)]
    for payload in (0.0, 0.6, 1.0):
        run = SoftNeck(SoftNeckParameters(payload=payload)).run(commands)
        ax.plot(run.time, run.channel("inclination"), lw=0.8, label=f"payload {payload} kg")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("inclination [deg]")
    ax.set_title("wind 0.5 s at 4 rad/s, hold, unwind 0.5 s")
    ax.legend()
    fig.tight_layout()
    fig.savefig(img / "simulator_pull_release.png", dpi=110)


if __name__ == "__main__":
    main()
