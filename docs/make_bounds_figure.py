"""Figure of docs/bounds.md: guaranteed k-step bands on a held-out real staircase.

Run: ``.venv/bin/python docs/make_bounds_figure.py /work/shared/data/softneck`` (about 30 s). It
writes ``docs/img/bounds_k_step.png``.

The models are the ones ``docs/bounds_experiment.py`` chose by leave-one-log-out on the six
training staircases (0 g and 600 g of the three controllers), refitted on all six: horizon 10
(0.25 s) with local constants, ``epsilon_factor=1.5``, ``input_weight=1``; horizon 40 (1 s) with
local constants, ``epsilon_factor=2.5``, ``input_weight=0.3``. The log drawn, ``ada200`` (200 g,
adaptive controller), is a test log none of them saw. The band drawn at time ``s`` is the one
predicted at ``s − k`` from the measurements up to then.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from bounds_experiment import CONTROLLERS, LAGS, TRAIN_PAYLOADS, load  # noqa: E402

from neckid.metrics import coverage, mean_width  # noqa: E402
from neckid.models.set_membership.multistep import MultiStepSetMembership  # noqa: E402

CHOSEN = {10: (1.5, 1.0), 40: (2.5, 0.3)}  # horizon: (epsilon_factor, input_weight), bounds.md
WINDOW_S = (20.0, 60.0)
OUT = Path(__file__).parent / "img" / "bounds_k_step.png"


def main() -> None:
    """Fit the two chosen predictors and draw their bands on a window of ada200."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folder", type=Path, help="the softneck folder (stair/, ...)")
    args = parser.parse_args()
    logs = load(args.folder)
    train = [logs[c + p] for c in CONTROLLERS for p in TRAIN_PAYLOADS]
    test = logs["ada200"]
    t = np.arange(test.n_samples) * test.ts
    shown = (t >= WINDOW_S[0]) & (t <= WINDOW_S[1])
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True, layout="constrained")
    for ax, (steps, (factor, weight)) in zip(axes, CHOSEN.items(), strict=True):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            model = MultiStepSetMembership(
                LAGS, horizon=1, horizons=[steps], epsilon_factor=factor, input_weight=weight,
                lipschitz="local",
            ).fit(train)  # fmt: skip
        ahead = model.predict_ahead(test, steps=steps)
        skip = ahead.n_initial
        held = coverage(test.y, ahead.lower, ahead.upper, skip)[0]
        width = mean_width(ahead.lower, ahead.upper, skip)[0]
        assert ahead.lower is not None and ahead.upper is not None
        ax.fill_between(
            t[shown], ahead.lower[shown, 0], ahead.upper[shown, 0], color="tab:blue", alpha=0.25,
            linewidth=0, label=f"guaranteed band (mean width {width:.2f}°, holds {held:.1%})",
        )  # fmt: skip
        ax.plot(t[shown], test.y[shown, 0], color="black", lw=1.0, label="measured")
        ax.plot(
            t[shown], ahead.y[shown, 0], color="tab:blue", lw=1.0,
            label=f"central estimate, {steps} samples ({steps * test.ts:g} s) ahead",
        )  # fmt: skip
        ax.set_ylabel("inclination [deg]")
        ax.set_title(
            f"k = {steps} ({steps * test.ts:g} s): local Lipschitz constants,"
            f" ε_k = {model.epsilon_[-1, 0]:.2f}°",
            fontsize=10,
        )
        ax.legend(loc="upper left", fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("Held-out staircase ada200 (200 g): k-step predictions with guaranteed bands")
    fig.savefig(OUT, dpi=110)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
