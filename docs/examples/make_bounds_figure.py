"""Figure of docs/bounds.md: guaranteed k-step bands on a held-out real staircase.

What it shows: the measured inclination of a held-out staircase inside the guaranteed bands
0.25 s and 1 s ahead. Run from the repository, with the folder of the real soft-neck logs (it
holds ``stair/``) and the folder to write the figure to (about 30 s)::

    .venv/bin/python docs/examples/make_bounds_figure.py DATA/softneck docs/img

It writes ``bounds_k_step.png`` there (``docs/img/bounds_k_step.png`` is the one in the docs).

The models are the ones ``bounds_experiment.py`` chose by leave-one-log-out on the six
training staircases (0 g and 600 g of the three controllers), refitted on all six: horizon 10
(0.25 s) with local constants, ``epsilon_factor=1.5``, ``input_weight=1``; horizon 40 (1 s) with
local constants, ``epsilon_factor=2.5``, ``input_weight=0.3``. The log drawn, ``ada200`` (200 g,
adaptive controller), is a test log none of them saw. The band drawn at time ``s`` is the one
predicted at ``s − k`` from the measurements up to then.
"""

from __future__ import annotations

import argparse
import importlib.util
import warnings
from pathlib import Path
from types import ModuleType

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from neckid.metrics import coverage, mean_width
from neckid.models.set_membership.multistep import MultiStepSetMembership


def sibling(name: str) -> ModuleType:
    """The example ``name`` of this folder, imported from its file (the folder is no package)."""
    spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name(f"{name}.py"))
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


experiment = sibling("bounds_experiment")
CHOSEN = {10: (1.5, 1.0), 40: (2.5, 0.3)}  # horizon: (epsilon_factor, input_weight), bounds.md
WINDOW_S = (20.0, 60.0)


def main(argv: list[str] | None = None) -> None:
    """Fit the two chosen predictors and draw their bands on a window of ada200."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folder", type=Path, help="the softneck folder (stair/, ...)")
    parser.add_argument("out", type=Path, help="folder to write bounds_k_step.png to")
    args = parser.parse_args(argv)
    logs = experiment.load(args.folder)
    train = [logs[c + p] for c in experiment.CONTROLLERS for p in experiment.TRAIN_PAYLOADS]
    test = logs["ada200"]
    t = np.arange(test.n_samples) * test.ts
    shown = (t >= WINDOW_S[0]) & (t <= WINDOW_S[1])
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True, layout="constrained")
    for ax, (steps, (factor, weight)) in zip(axes, CHOSEN.items(), strict=True):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            model = MultiStepSetMembership(
                experiment.LAGS, horizon=1, horizons=[steps], epsilon_factor=factor, input_weight=weight,
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
    args.out.mkdir(parents=True, exist_ok=True)
    out = args.out / "bounds_k_step.png"
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
