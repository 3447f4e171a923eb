"""The ``softneck-in-loop`` protocol: every method in the lab's loops, beside its free run.

The payload split of :data:`~neckid.experiments.benchmark.datasets.SOFTNECK_CROSS_RUN` (train on
the 0 g and 600 g staircases of the three controllers, test on the 200 g and 400 g ones). Each
method is chosen and fitted exactly as the benchmark does (:mod:`.runner`: its candidate grid
ranked by leave-one-run-out free-run RMSE on the training runs, the best refitted on all of them);
methods without a grid on the soft-neck logs get one fixed setting, said in the table
(:data:`FIXED_SETTINGS`). The drive is identified on the same training runs
(:func:`neckid.loops.lab_drive.identify_drive`). Every test log is then run twice: in free run
(the benchmark's figure) and in the loop of its own controller, reference and dither
(:func:`neckid.loops.lab_loop.in_loop_on_log`; the adaptive runs replay their parameter logs from
``softneck_adaptive/`` when it is there, else the re-implemented tuner runs).

:func:`run_in_loop_benchmark` returns an :class:`InLoopReport`: one row per (method, test log),
and :meth:`InLoopReport.rankings`, the free-run and in-loop rankings side by side with the PI
loop's oscillation figures.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from sklearn.base import clone

from neckid.datasets.softneck import load_softneck_log
from neckid.experiments.benchmark.datasets import SOFTNECK_CROSS_RUN, load_softneck_cross_run
from neckid.experiments.benchmark.runner import _select
from neckid.experiments.benchmark.settings import (
    CANDIDATE_GRIDS,
    SCHEDULED_LAGS,
    SCHEDULED_PARAMS,
    candidates,
    lag_grid,
    runs_on,
)
from neckid.loops.lab_drive import LabDrive, identify_drive
from neckid.loops.lab_loop import in_loop_on_log
from neckid.registry import methods

__all__ = ["FIXED_SETTINGS", "IN_LOOP_PROTOCOL", "InLoopReport", "run_in_loop_benchmark"]

logger = logging.getLogger(__name__)

#: The cross-run protocol whose split this protocol uses.
IN_LOOP_PROTOCOL = "softneck-payload"

#: Settings of the methods without a candidate grid on the soft-neck logs (the registry's
#: defaults otherwise): the scheduled position form as the benchmark's ``scheduled``.
FIXED_SETTINGS: dict[str, dict[str, Any]] = {"scheduled-position": dict(SCHEDULED_PARAMS)}

#: Within these the in-loop figure "predicts" the logged one (issue 31).
PERIOD_TOLERANCE = 0.10
TRACKING_TOLERANCE = 0.20


@dataclass(frozen=True)
class InLoopReport:
    """What :func:`run_in_loop_benchmark` measured.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per (method, test log): ``method``, ``test``, ``settings``, ``train_time_s``,
        ``loop_time_s`` and the columns of :meth:`neckid.loops.lab_loop_result.LabLoopResult.summary`.
    drive : LabDrive
        The drive in the loops (by default the one identified on the training runs).
    drift : pandas.DataFrame
        Its drift on the training and test runs (:meth:`~neckid.loops.lab_drive.DriveFit.drift`),
        with a ``split`` column.
    """

    table: pd.DataFrame
    drive: LabDrive
    drift: pd.DataFrame

    def rankings(self) -> pd.DataFrame:
        """Per method: mean free-run and in-loop fits [%] and their ranks, and the PI loop's figures.

        Columns ``free_run_fit``, ``free_run_rank``, ``inclination_fit``, ``in_loop_rank``,
        ``command_fit`` (means over the test logs; a diverged run counts as −inf), then over the
        ``int`` logs: ``int_period_ratio`` and ``int_tracking_ratio`` (means), and
        ``period_within_10``, ``tracking_within_20`` (on every ``int`` log).
        """
        rows = []
        for method, group in self.table.groupby("method", sort=False):
            pi = group[group["controller"] == "int"]
            period = pi["period_ratio"].to_numpy(dtype=np.float64)
            tracking = pi["tracking_ratio"].to_numpy(dtype=np.float64)
            rows.append(
                {
                    "method": method,
                    "free_run_fit": float(group["free_run_fit_percent"].mean()),
                    "inclination_fit": float(group["inclination_fit_percent"].mean()),
                    "command_fit": float(group["command_fit_percent"].mean()),
                    "int_period_ratio": float(np.mean(period)) if len(period) else math.nan,
                    "int_tracking_ratio": float(np.mean(tracking)) if len(tracking) else math.nan,
                    "period_within_10": bool(
                        len(period) and np.all(np.abs(period - 1.0) <= PERIOD_TOLERANCE)
                    ),
                    "tracking_within_20": bool(
                        len(tracking) and np.all(np.abs(tracking - 1.0) <= TRACKING_TOLERANCE)
                    ),
                }
            )
        frame = pd.DataFrame(rows)
        frame.insert(2, "free_run_rank", frame["free_run_fit"].rank(ascending=False, method="min"))
        frame.insert(
            4, "in_loop_rank", frame["inclination_fit"].rank(ascending=False, method="min")
        )
        return frame


def _fixed(name: str, quick: bool) -> tuple[str, Any]:
    """One setting of a method without a grid: the grid's quick regressor, or the scheduled one."""
    method = methods()[name]
    params = FIXED_SETTINGS.get(name, {})
    lags = SCHEDULED_LAGS if name.startswith("scheduled") else lag_grid(IN_LOOP_PROTOCOL, True)[0]
    text = f"lags={lags!r} (fixed)" + "".join(f", {k}={v}" for k, v in params.items())
    return text, method.make(lags, quick=quick, **params)


def _fit_method(name: str, train: list[Any], quick: bool, seed: int) -> tuple[str, Any, float]:
    start = time.perf_counter()
    if name in CANDIDATE_GRIDS and runs_on(name, IN_LOOP_PROTOCOL):
        options = candidates(name, IN_LOOP_PROTOCOL, train, quick=quick, seed=seed)
        (settings, estimator), _ = _select(options, train, None)
    else:
        settings, estimator = _fixed(name, quick)
    model = clone(estimator).fit(train)
    return settings, model, time.perf_counter() - start


def run_in_loop_benchmark(
    data_dir: str | Path,
    method_names: Sequence[str] | None = None,
    *,
    quick: bool = False,
    seed: int = 0,
    drive: LabDrive | None = None,
) -> InLoopReport:
    """Identify every method on the payload split's training runs; run each test run in its loop.

    Parameters
    ----------
    data_dir : str or Path
        The folder holding ``softneck/`` (and ``softneck_adaptive/`` for the adaptive replay).
    method_names : sequence of str, optional
        Registry names; default every registered method.
    quick : bool, default False
        One candidate per method and the registry's smoke settings.
    seed : int, default 0
        ``random_state`` of the neural networks.
    drive : LabDrive, optional
        The drive in the loops; default the one identified on the training runs (e.g.
        ``LabDrive()``, the plain integrator of the executed command, to see what the drive
        model changes).

    Returns
    -------
    InLoopReport

    Raises
    ------
    FileNotFoundError
        If a log of the split is missing.
    """
    root = Path(data_dir)
    folder = root / "softneck"
    bench = load_softneck_cross_run(folder, IN_LOOP_PROTOCOL)
    train_keys, test_keys = SOFTNECK_CROSS_RUN[IN_LOOP_PROTOCOL]
    raw_train = [load_softneck_log(folder / k) for k in train_keys]
    raw_tests = {k: load_softneck_log(folder / k) for k in test_keys}
    fit = identify_drive(raw_train)
    drift = pd.concat(
        [
            fit.drift(raw_train).assign(split="train"),
            fit.drift(list(raw_tests.values())).assign(split="test"),
        ],
        ignore_index=True,
    )
    engine = fit.drive if drive is None else drive
    parameters = root / "softneck_adaptive"
    train = list(bench.train) if isinstance(bench.train, list) else [bench.train]
    rows = []
    for name in method_names or list(methods()):
        logger.info("in-loop protocol: %s", name)
        settings, model, train_time = _fit_method(name, train, quick, seed)
        for key, log in raw_tests.items():
            start = time.perf_counter()
            result = in_loop_on_log(
                model,
                log,
                drive=engine,
                adaptive_parameters=parameters if parameters.is_dir() else None,
            )
            rows.append(
                {
                    "method": name,
                    "test": key,
                    **result.summary(),
                    "settings": settings,
                    "train_time_s": train_time,
                    "loop_time_s": time.perf_counter() - start,
                }
            )
    return InLoopReport(pd.DataFrame(rows), engine, drift)
