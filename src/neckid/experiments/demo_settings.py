"""The settings, constants and result of the demo (:mod:`neckid.experiments.paper`)."""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from neckid.regressors import Lags

__all__ = [
    "DEMO_METHODS",
    "EXPERIMENTS",
    "NARX_INPUT",
    "OUTPUT",
    "PAPER_FITS",
    "PAPER_LAGS",
    "SCHEDULED_INPUT",
    "DemoResult",
    "DemoSettings",
    "quiet_smoke_run",
]

#: Columns of the results table: the validation record and the three closed-loop tests.
EXPERIMENTS = ("validation", "test 1: sine 2 rad/s", "test 2: 5° staircase", "test 3: 20° step")

#: The seed paper's NRMSE fits [%] on its own neck, same columns (NaN: not reported).
PAPER_FITS: dict[str, tuple[float, float, float, float]] = {
    "Set Membership (paper)": (88.75, 91.0, 84.65, 67.87),
    "Neural NARX 2x25 (paper)": (93.75, 92.0, 86.25, 75.16),
    "MATLAB nlarx default (paper)": (58.0, float("nan"), float("nan"), float("nan")),
}

#: The seed paper's regressor with one motor: [y(t-1..t-3), u(t-8..t-10)].
PAPER_LAGS = Lags(outputs=3, inputs=[8, 9, 10])
#: The NARX methods of the demo (registry names), in the order of its table; the scheduled
#: CFF-RLS model follows, identified by the operating-point protocol on the plant.
DEMO_METHODS = ("sm", "sm-linear", "nn", "arx")

NARX_INPUT = "motor_position"
SCHEDULED_INPUT = "velocity_command"
OUTPUT = "inclination"


@dataclass(frozen=True)
class DemoSettings:
    """Everything that shapes the demo's numbers (written into the report).

    Attributes
    ----------
    seed : int
        Seeds the neck's sensor noise, the multisine phases, the PRBS and the networks.
    quick : bool
        Shorter records and fewer lag candidates (for the test suite).
    paper_regressor : bool
        Use the paper's ``[y(t-1..3), u(t-8..10)]`` instead of selecting the lags.
    ts : float
        Sampling period [s] of the neck and of every record.
    train_duration, validation_duration, test_duration : float
        Record lengths [s].
    chirp_duration : float
        Length of the bandwidth chirp [s] (its frequency reaches ``0.2 * chirp_duration`` rad/s).
    position_center, position_amplitude : float
        Motor-position excitation: centre and peak deviation [rad].
    band_low : float
        Lowest excited frequency [rad/s]; the highest is the measured bandwidth.
    inclinations : tuple of float
        Operating points of the CFF-RLS protocol [deg].
    forgetting_factor : float
        CFF-RLS λ.
    """

    seed: int = 0
    quick: bool = False
    paper_regressor: bool = False
    ts: float = 0.02
    train_duration: float = 120.0
    validation_duration: float = 60.0
    test_duration: float = 20.0
    chirp_duration: float = 60.0
    position_center: float = 2.5
    position_amplitude: float = 2.5
    band_low: float = 0.05
    inclinations: tuple[float, ...] = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0)
    forgetting_factor: float = 0.98

    @classmethod
    def make(
        cls, *, quick: bool = False, seed: int = 0, paper_regressor: bool = False
    ) -> DemoSettings:
        """Default settings, or the shorter ``quick`` ones."""
        if quick:
            return cls(
                seed=seed,
                quick=True,
                paper_regressor=paper_regressor,
                train_duration=60.0,
                validation_duration=30.0,
                test_duration=12.0,
                chirp_duration=50.0,
                inclinations=(10.0, 20.0, 30.0),
            )
        return cls(seed=seed, paper_regressor=paper_regressor)


@dataclass
class DemoResult:
    """What :func:`run_demo` produced.

    Attributes
    ----------
    table : pandas.DataFrame
        Fit [%] per model (rows) and experiment (columns), the paper's rows below ours.
    mae : pandas.DataFrame
        Mean absolute error [deg], same layout (our models only).
    metrics : dict
        Everything machine-readable (also written to ``metrics.json``).
    bandwidth : float
        Measured bandwidth [rad/s].
    lags : Lags
        The regressor used by the NARX models.
    files : dict of str to Path
        Report, metrics, figures and model files written.
    wall_time : float
        Seconds for the whole run.
    """

    table: pd.DataFrame
    mae: pd.DataFrame
    metrics: dict[str, Any]
    bandwidth: float
    lags: Lags
    files: dict[str, Path] = field(default_factory=dict)
    wall_time: float = 0.0


@contextmanager
def quiet_smoke_run(settings: Any) -> Iterator[None]:
    """Inside a ``--quick`` run: no warning that the networks stopped at their iteration cap.

    The quick settings train small networks for a few iterations on purpose (a smoke run, the
    warm-up after installing); scikit-learn's ``ConvergenceWarning`` says just that, and is not
    the user's concern there. Full runs keep it.
    """
    with warnings.catch_warnings():
        if settings is not None and getattr(settings, "quick", False):
            from sklearn.exceptions import ConvergenceWarning

            warnings.filterwarnings("ignore", category=ConvergenceWarning)
        yield
