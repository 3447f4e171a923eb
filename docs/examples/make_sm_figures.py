"""Figures of docs/set_membership.md: the γ*(ε) curve and a free run with its bounds.

What it shows: how the noise bound ε and the Lipschitz constant γ are chosen, and the guaranteed
bounds of a Set Membership free run. Run from the repository, with the folder to write the
figures to (``sm_gamma_curve.png``, ``sm_simulation.png``)::

    MPLBACKEND=Agg .venv/bin/python docs/examples/make_sm_figures.py docs/img

Data come from the simulated planar neck (``neckid.plant.SoftNeck``): the motor follows random
position targets; the model maps motor position to the tilt sensor's inclination (degrees).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from neckid import IOData, Lags
from neckid.models.set_membership.narx import SetMembership
from neckid.plant import SoftNeck
from neckid.report.sm_plots import plot_gamma_curve

LAGS = Lags(outputs=3, inputs=[1, 2, 3])


def experiment(n_samples: int, seed: int) -> IOData:
    """Random position targets (rad) held 1.2 s, tracked by a saturated proportional velocity law."""
    rng = np.random.default_rng(seed)
    hold = 60
    target = rng.uniform(0.0, 3.0, n_samples // hold + 1).repeat(hold)[:n_samples]
    commands = np.zeros(n_samples)
    position = 0.0
    for k in range(n_samples):
        commands[k] = np.clip(3.0 * (target[k] - position), -2.0, 2.0)
        position += commands[k] * 0.02
    log = SoftNeck(seed=seed).run(commands)
    return log.select(inputs=["motor_position"], outputs=["inclination"])


def main(argv: list[str] | None = None) -> None:
    """Fit the model, write the two figures and print the numbers quoted in the document."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", type=Path, help="folder to write the figures to")
    args = parser.parse_args(argv)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    train, test = experiment(8000, seed=1), experiment(3000, seed=2)
    model = SetMembership(LAGS, linear_part=True).fit(train)
    curve = model.gamma_curve_
    if curve is None:
        raise RuntimeError("the estimator computes the curve when gamma is not given")
    fig = plot_gamma_curve(curve, unit="deg")
    fig.axes[0].set_xscale("symlog", linthresh=1e-3)
    fig.axes[0].set_xlim(left=0.0)
    fig.axes[0].set_title("γ*(ε) of the simulated neck (residual of the linear part)")
    fig.tight_layout()
    fig.savefig(out / "sm_gamma_curve.png", dpi=120)
    plt.close(fig)

    sim = model.simulate(test)
    pred = model.predict(test)
    window = slice(600, 1500)
    t = test.time[window]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    top.plot(t, test.y[window, 0], "k", lw=1, label="measured")
    top.plot(t, sim.y[window, 0], "C0", lw=1, label="SM central (free run)")
    top.fill_between(
        t, sim.lower[window, 0], sim.upper[window, 0], color="C0", alpha=0.3, label="[f_l, f_u]"
    )
    top.set_ylabel("inclination [deg]")
    top.legend(loc="upper right")
    bottom.plot(t, sim.upper[window, 0] - sim.lower[window, 0], "C0", label="free run")
    bottom.plot(t, pred.upper[window, 0] - pred.lower[window, 0], "C1", label="one step")
    bottom.axhline(2 * model.epsilon_[0], color="k", ls="--", lw=0.8, label="2ε")
    bottom.set_ylabel("bound width [deg]")
    bottom.set_xlabel("time [s]")
    bottom.legend(loc="upper left", ncol=3)
    fig.tight_layout()
    fig.savefig(out / "sm_simulation.png", dpi=120)
    plt.close(fig)

    check = model.invalidation(test)
    print(f"training regressors: {model.n_samples_}, terms: {list(model.lags_.names)}")
    print(f"epsilon_ = {model.epsilon_[0]:.4g} deg, gamma*(eps) = {model.gamma_star_[0]:.4g},")
    print(f"gamma_ = {model.gamma_[0]:.4g} (margin {model.gamma_margin})")
    print(
        f"fit on the test run: free run {sim.fit_percent(test)[0]:.2f} %,"
        f" one step {pred.fit_percent(test)[0]:.2f} %"
    )
    width = sim.upper[LAGS.max_lag :, 0] - sim.lower[LAGS.max_lag :, 0]
    print(f"free-run bound width: median {np.median(width):.4g} deg, max {width.max():.4g} deg")
    print(f"test samples outside [f_l - eps, f_u + eps]: {check.fraction[0] * 100:.2f} %")


if __name__ == "__main__":
    main()
