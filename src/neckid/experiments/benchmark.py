"""Benchmark the identification methods on real data, next to published figures of merit.

:func:`run_benchmark` runs linear ARX, Set Membership (pure, with a linear part, and on the free
run of a parallel linear model: :class:`~neckid.ParallelSetMembership`), neural NARX and, on the
soft-neck logs, the CFF-RLS scheduled model, on

- the four public benchmarks of :mod:`neckid.datasets.benchmarks`, with the official protocol of
  each (train on the training record, free-run simulation of every test record, the number of
  initial samples the protocol gives, RMSE in the unit the literature uses);
- the UC3M soft-neck logs, with the protocol of ``docs/benchmarks.md`` (identify on
  ``stair/ada000response.csv``, validate by free run on every other log that has the raw
  inclination; see :func:`softneck_protocol`).

Hyper-parameters (lags, and for the neural network the restart) are chosen per method on the
training record only: every candidate is fitted on its first 75 % and ranked by free-run RMSE on
the last 25 %, then the best one is refitted on the whole training record. Test records are never
looked at before the final simulation.
"""

from __future__ import annotations

import importlib
import itertools
import json
import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from neckid.data import IOData
from neckid.datasets.benchmarks import (
    BenchmarkData,
    load_bouc_wen,
    load_cascaded_tanks,
    load_robot_arm,
    load_silverbox,
)
from neckid.datasets.softneck import load_softneck_directory
from neckid.metrics import fit_percent, rmse
from neckid.regressors import Lags

__all__ = [
    "BENCHMARKS",
    "METHODS",
    "PUBLISHED",
    "SOFTNECK_TRAINING_LOG",
    "BenchmarkReport",
    "run_benchmark",
    "softneck_protocol",
]

logger = logging.getLogger(__name__)

#: The methods, by key, with their labels in the tables.
METHODS: dict[str, str] = {
    "arx": "linear ARX",
    "sm": "Set Membership",
    "sm_linear": "Set Membership + linear part",
    "sm_parallel": "Set Membership on a parallel linear model",
    "neural": "neural NARX",
    "scheduled": "scheduled CFF-RLS",
}

#: The data sets, by key, in the order they run.
BENCHMARKS = ("softneck", "cascaded_tanks", "silverbox", "bouc_wen", "robot_arm")

#: The log the soft-neck model is identified on (relative to the ``softneck`` folder).
SOFTNECK_TRAINING_LOG = "stair/ada000response.csv"

#: Published free-run figures from SOURCE.md: benchmark -> test -> method -> RMSE (benchmark unit).
PUBLISHED: dict[str, dict[str, dict[str, float]]] = {
    "cascaded_tanks": {
        "validation": {
            "best linear approximation": 0.75,
            "ARX": 0.685,
            "GP-NARX": 0.622,
            "Volterra": 0.54,
            "GP state-space": 0.45,
            "polynomial NARX": 0.413,
            "GRU": 0.396,
            "nonlinear state-space": 0.34,
            "neural continuous-time": 0.33,
            "grey box with overflow": 0.18,
        }
    },
    "silverbox": {
        "multisine": {"polynomial NARX": 7.73, "GRU": 1.49, "LSTM": 1.50},
        "arrow_full": {"polynomial NARX": 4.15, "GRU": 2.80, "LSTM": 2.68},
        "arrow_no_extrapolation": {"polynomial NARX": 2.23, "GRU": 0.95, "LSTM": 0.96},
    },
    "bouc_wen": {
        "multisine": {
            "dynoNet": 4.52e-5,
            "local model network NFIR": 16.3e-5,
            "polynomial nonlinear state-space": 1.87e-5,
        }
    },
}

#: Where the published figures come from.
PUBLISHED_SOURCES = {
    "cascaded_tanks": "Forgione & Piga, Eur. J. Control 2021; Champneys et al. 2024",
    "silverbox": "benchmarks/SOURCE.md (polynomial NARX; GRU and LSTM)",
    "bouc_wen": "benchmarks/SOURCE.md (dynoNet paper, Forgione & Piga 2021)",
}

#: Share of the training record used to fit the candidates during selection.
SELECTION_FRACTION = 0.75


# ---------------------------------------------------------------------------- the report
@dataclass(frozen=True)
class BenchmarkReport:
    """What :func:`run_benchmark` measured.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per (benchmark, test, method) with columns ``benchmark``, ``test``, ``method``,
        ``rmse`` (free run, in ``rmse_unit``), ``rmse_unit``, ``fit_percent`` (NRMSE fit),
        ``n_initial`` (initial samples skipped), ``train_time_s`` (selection and final fit),
        ``simulate_time_s``, ``settings`` (the chosen hyper-parameters) and ``note``. On the
        soft-neck logs a row with ``test == "mean"`` holds the mean over the validation logs.
    published : pandas.DataFrame
        The published figures next to which the table is read: ``benchmark``, ``test``,
        ``method``, ``rmse``, ``rmse_unit``, ``source``.
    details : dict
        JSON-serialisable extras: the command settings, the selection scores of every candidate,
        per benchmark the protocol text, and for the soft-neck logs the per-log difference
        ``fit(sm) - fit(arx)``.
    """

    table: pd.DataFrame
    published: pd.DataFrame
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The whole report as a JSON-serialisable dict (``table`` and ``published`` as records)."""
        return {
            "table": _records(self.table),
            "published": _records(self.published),
            "details": self.details,
        }

    def comparison(self) -> pd.DataFrame:
        """Our RMSE beside the published ones: one row per (benchmark, test, method)."""
        ours = self.table[["benchmark", "test", "method", "rmse", "rmse_unit"]].assign(
            source="neckid"
        )
        return pd.concat([ours, self.published], ignore_index=True)

    def write(self, output_dir: str | Path) -> dict[str, Path]:
        """Write ``benchmark.csv``, ``published.csv`` and ``benchmark.json`` into a folder.

        Returns
        -------
        dict of str to Path
            The files written, by kind (``"table"``, ``"published"``, ``"json"``).
        """
        folder = Path(output_dir)
        folder.mkdir(parents=True, exist_ok=True)
        paths = {
            "table": folder / "benchmark.csv",
            "published": folder / "published.csv",
            "json": folder / "benchmark.json",
        }
        self.table.to_csv(paths["table"], index=False)
        self.published.to_csv(paths["published"], index=False)
        paths["json"].write_text(json.dumps(self.to_dict(), indent=2, default=_json_default))
        return paths

    def rich_table(self) -> Any:
        """A :class:`rich.table.Table` of the results, for the CLI to print."""
        from rich.table import Table

        table = Table(title="neckid benchmark (free-run simulation)")
        for column in (
            "benchmark",
            "test",
            "method",
            "RMSE",
            "fit %",
            "published (RMSE)",
            "train s",
            "sim s",
            "note",
        ):
            table.add_column(column)
        for row in self.table.itertuples(index=False):
            published = PUBLISHED.get(str(row.benchmark), {}).get(str(row.test), {})
            best = ", ".join(f"{k} {v:.3g}" for k, v in list(published.items())[:3])
            table.add_row(
                str(row.benchmark),
                str(row.test),
                str(row.method),
                _fmt(row.rmse, f" {row.rmse_unit!s}" if row.rmse_unit else ""),
                _fmt(row.fit_percent),
                best,
                _fmt(row.train_time_s),
                _fmt(row.simulate_time_s),
                str(row.note or ""),
            )
        return table


def _fmt(value: Any, suffix: str = "") -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return f"{float(value):.4g}{suffix}"


def _json_default(value: Any) -> Any:
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def _records(frame: pd.DataFrame) -> list[dict[str, Any]]:
    out = []
    for record in frame.to_dict(orient="records"):
        out.append(
            {
                str(k): (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in record.items()
            }
        )
    return out


# ---------------------------------------------------------------------------- the soft-neck protocol
def softneck_protocol(log: IOData) -> IOData:
    """The channels the soft-neck benchmark identifies: motor displacement and velocity -> inclination.

    Parameters
    ----------
    log : IOData
        A soft-neck log from :func:`~neckid.datasets.load_softneck_log` with the raw inclination
        (6- or 7-column layout).

    Returns
    -------
    IOData
        Inputs ``motor_displacement`` [rad] (the motor position minus its value at the first
        sample: the encoder zero and the tendon slack differ between runs, while every log starts
        with the neck at rest near 0 deg) and ``motor_velocity`` [rad/s] (measured); output
        ``inclination`` [deg] (raw).

    Raises
    ------
    KeyError
        If the log lacks one of those channels (3-column logs have no raw inclination).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> log = IOData(u=np.column_stack([1.5 + np.arange(4.0), np.ones(4)]), y=np.arange(4.0),
    ...              ts=0.025, input_names=["motor_position", "motor_velocity"],
    ...              output_names=["inclination"])
    >>> softneck_protocol(log).channel("motor_displacement")
    array([0., 1., 2., 3.])
    """
    data = log.select(inputs=["motor_position", "motor_velocity"], outputs=["inclination"])
    u = np.array(data.u)
    u[:, 0] -= u[0, 0]
    return IOData(
        u,
        data.y,
        ts=data.ts,
        input_names=["motor_displacement", "motor_velocity"],
        output_names=["inclination"],
        input_units=["rad", "rad/s"],
        output_units=["deg"],
        t0=data.t0,
        name=log.name,
    )


def _load_softneck(folder: Path, quick: bool) -> BenchmarkData:
    logs = load_softneck_directory(folder)
    if SOFTNECK_TRAINING_LOG not in logs:
        raise FileNotFoundError(
            f"the soft-neck protocol identifies on {SOFTNECK_TRAINING_LOG}; it is not under {folder}"
        )
    usable = {
        key: softneck_protocol(log)
        for key, log in logs.items()
        if "inclination" in log.output_names
    }
    train = usable.pop(SOFTNECK_TRAINING_LOG)
    if quick:
        usable = dict(list(usable.items())[:3])
    if not usable:
        raise FileNotFoundError(f"no validation log with a raw inclination under {folder}")
    return BenchmarkData(
        name="softneck",
        train=train,
        tests=usable,
        n_initial=None,
        description=(
            f"UC3M soft-neck bench: identify on {SOFTNECK_TRAINING_LOG} (motor displacement [rad]"
            " and measured motor velocity [rad/s] -> raw inclination [deg]); free-run validation"
            " on every other log with a raw inclination; NRMSE fit per log and their mean."
        ),
        citation="github.com/munozyanez/phd_Archived @a9198c8 (see datasets.softneck)",
        source=str(folder),
        rmse_unit="deg",
    )


# ---------------------------------------------------------------------------- methods
@dataclass(frozen=True)
class _Candidate:
    """One hyper-parameter setting of a method."""

    settings: str
    build: Callable[[], Any]


def _import(module: str, name: str) -> Any:
    return getattr(importlib.import_module(module), name)


def _lag_grid(benchmark: str, quick: bool) -> list[Lags]:
    """Candidate regressors per data set (ranked on the training record)."""
    grids: dict[str, list[Lags]] = {
        "softneck": [
            Lags.arx(1, 1, 1),
            Lags.arx(2, 2, 1),
            Lags.arx(3, 3, 1),
            Lags.arx(1, 1, 0),
            Lags.arx(2, 2, 0),
        ],
        "cascaded_tanks": [Lags.arx(2, 2, 1), Lags.arx(3, 3, 1), Lags.arx(4, 4, 1)],
        # Duffing oscillator: second order in the output, the input at t..t-3 (lag 0 included).
        "silverbox": [Lags.arx(2, 3, 0), Lags.arx(2, 4, 0), Lags.arx(3, 4, 0)],
        "bouc_wen": [Lags.arx(5, 5, 0)],
        "robot_arm": [Lags.arx(2, 2, 1), Lags.arx(4, 4, 1)],
    }
    grid = grids[benchmark]
    return grid[1:2] if quick else grid


#: Candidate noise bounds of Set Membership, as multiples of the one-step residual RMS of a linear
#: ARX on the same regressor (training record); ``None`` is SetMembership's own knee rule.
SM_EPSILON_FACTORS: tuple[float | None, ...] = (None, 1.0, 3.0)

#: On the large records (Silverbox, Bouc-Wen) the knee is left out: it needs γ*(ε) on a 48-point
#: grid over all pairs (minutes), where a given ε needs it at one ε (seconds).
SM_EPSILON_FACTORS_LARGE: tuple[float | None, ...] = (0.5, 1.0)

#: Candidate ``input_weight`` of SM with a linear part: the linear part carries the input
#: dynamics, and a light input weight lets the SM residual depend mostly on the past outputs.
SM_INPUT_WEIGHTS: tuple[float, ...] = (1.0, 0.1, 0.03)


#: Candidate SM regressors of the parallel model: lags of the linear model's simulated output and
#: of the inputs.
SM_PARALLEL_REGRESSORS: tuple[tuple[tuple[int, ...], tuple[int, ...]], ...] = (
    ((0,), ()),
    ((0, 1), ()),
    ((0, 1, 2), ()),
    ((0, 1), (1,)),
)

#: Candidate noise bounds of the parallel model, as multiples of the RMS free-run error of the
#: linear ARX on the training record; ``None`` is the knee rule.
SM_PARALLEL_EPSILON_FACTORS: tuple[float | None, ...] = (None, 0.25, 1.0)


def _parallel_candidates(benchmark: str, quick: bool, train: IOData) -> list[_Candidate]:
    model = _import("neckid.models.sm_parallel", "ParallelSetMembership")
    large = benchmark in ("silverbox", "bouc_wen")
    regressors = SM_PARALLEL_REGRESSORS[1:2] if quick else SM_PARALLEL_REGRESSORS
    factors: tuple[float | None, ...] = (
        (None,)
        if quick
        else SM_PARALLEL_EPSILON_FACTORS[1:]
        if large
        else SM_PARALLEL_EPSILON_FACTORS
    )
    candidates = []
    for lags in _lag_grid(benchmark, quick):
        try:
            scale = _arx_error_scale(lags, train, free_run=True)
        except ValueError:
            continue  # an unstable linear model cannot run in parallel
        for (linear_lags, input_lags), factor in itertools.product(regressors, factors):
            epsilon = None if factor is None else factor * scale
            label = "knee" if epsilon is None else f"{factor:g} x {scale:.3g}"
            candidates.append(
                _Candidate(
                    f"lags={lags!r}, linear_lags={list(linear_lags)},"
                    f" input_lags={list(input_lags)}, epsilon={label}",
                    _bind(
                        model,
                        lags=lags,
                        linear_lags=linear_lags,
                        input_lags=input_lags,
                        epsilon=epsilon,
                        progress=False,
                    ),
                )
            )
    return candidates


def _arx_error_scale(lags: Lags, train: IOData, free_run: bool = False) -> float:
    """RMS error of a linear ARX with these lags on the training record.

    The one-step residual by default; with ``free_run``, the free-run error (``ValueError`` when
    the ARX diverges).
    """
    arx = _import("neckid.models.arx", "LinearARX")
    model = arx(lags).fit(train)
    result = model.simulate(train) if free_run else model.predict(train)
    value = float(rmse(train.y, result.y, skip=result.n_initial)[0])
    if free_run and not math.isfinite(value):
        raise ValueError(f"the linear ARX with {lags!r} diverges on the training record")
    return value


def _candidates(
    method: str, benchmark: str, quick: bool, seed: int, train: IOData
) -> list[_Candidate]:
    """The hyper-parameter candidates of a method on a data set."""
    lags_grid = _lag_grid(benchmark, quick)
    if method == "arx":
        arx = _import("neckid.models.arx", "LinearARX")
        return [_Candidate(f"lags={lags!r}", _bind(arx, lags=lags)) for lags in lags_grid]
    if method in ("sm", "sm_linear"):
        sm = _import("neckid.models.set_membership", "SetMembership")
        linear = method == "sm_linear"
        large = benchmark in ("silverbox", "bouc_wen")
        full_grid = SM_EPSILON_FACTORS_LARGE if large else SM_EPSILON_FACTORS
        factors: tuple[float | None, ...] = (None,) if quick else full_grid
        weights = SM_INPUT_WEIGHTS if linear and not quick else (1.0,)
        candidates = []
        for lags in lags_grid:
            noise = _arx_error_scale(lags, train)
            for factor, weight in itertools.product(factors, weights):
                epsilon = None if factor is None else factor * noise
                label = "knee" if epsilon is None else f"{factor:g} x {noise:.3g}"
                candidates.append(
                    _Candidate(
                        f"lags={lags!r}, epsilon={label}, input_weight={weight:g}",
                        _bind(
                            sm,
                            lags=lags,
                            linear_part=linear,
                            epsilon=epsilon,
                            input_weight=weight,
                            progress=False,
                        ),
                    )
                )
        return candidates
    if method == "sm_parallel":
        return _parallel_candidates(benchmark, quick, train)
    if method == "neural":
        neural = _import("neckid.models.neural", "NeuralNARX")
        sizes = (10,) if quick else (25, 25)
        max_iter = 30 if quick else 300
        return [
            _Candidate(
                f"lags={lags!r}, hidden={sizes}",
                _bind(
                    neural,
                    lags=lags,
                    hidden_layer_sizes=sizes,
                    max_iter=max_iter,
                    random_state=seed,
                ),
            )
            for lags in lags_grid
        ]
    if method == "scheduled":
        return _scheduled_candidates(quick)
    raise ValueError(f"method must be one of {list(METHODS)}; got {method!r}")


def _bind(cls: Any, **params: Any) -> Callable[[], Any]:
    def build() -> Any:
        return cls(**params)

    return build


#: Staircase segments of the soft-neck training log [s from its first sample]: 10 deg for 20 s,
#: then 15, 20, 25, 30, 25, 20, 15 deg for 10 s each. Each is one operating point.
SOFTNECK_STAIR_EDGES = (0.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0)


class ScheduledFromStairs:
    """The seed paper's scheduled model identified from the stairs of one staircase log.

    Every stair of the training log is an operating point: CFF-RLS
    (:func:`~neckid.experiments.operating_points.operating_points_from_logs`) identifies the
    first-order model from motor velocity [rad/s] to inclination rate [deg/s] on it (after
    ``skip`` samples of transient), and :class:`~neckid.models.scheduled.GainScheduledModel` fits
    lines ``N(i)``, ``P(i)`` through the points. Simulation is the scheduled model's free run.

    Parameters
    ----------
    forgetting_factor : float, default 0.98
        CFF-RLS forgetting factor (the seed paper's value).
    skip : int, default 40
        Samples left out at the start of every stair (1 s).
    window : int, default 100
        Convergence window of the RLS estimate, in samples.
    edges : sequence of float, optional
        Stair boundaries in seconds from the log's first sample; default
        :data:`SOFTNECK_STAIR_EDGES`.
    """

    def __init__(
        self,
        forgetting_factor: float = 0.98,
        skip: int = 40,
        window: int = 100,
        edges: Sequence[float] | None = None,
    ) -> None:
        self.forgetting_factor = forgetting_factor
        self.skip = skip
        self.window = window
        self.edges = edges

    def fit(self, data: IOData) -> ScheduledFromStairs:
        """Identify one operating point per stair of ``data`` and fit the schedule."""
        operating_points = _import(
            "neckid.experiments.operating_points", "operating_points_from_logs"
        )
        scheduled = _import("neckid.models.scheduled", "GainScheduledModel")
        edges = tuple(SOFTNECK_STAIR_EDGES if self.edges is None else self.edges)
        stairs = []
        for start, stop in itertools.pairwise(edges):
            if data.t0 + start >= data.time[-1]:
                break
            stairs.append(data.time_slice(data.t0 + start, data.t0 + stop))
        self.operating_points_ = operating_points(
            stairs,
            input="motor_velocity",
            output="inclination",
            skip=self.skip,
            forgetting_factor=self.forgetting_factor,
            window=self.window,
        )
        self.model_ = scheduled(ts=data.ts, input="motor_velocity", output="inclination").fit(
            self.operating_points_, converged_only=False
        )
        return self

    def simulate(self, data: IOData) -> Any:
        """Free run of the scheduled model from the first measured inclination."""
        return self.model_.simulate(data)


def _scheduled_candidates(quick: bool) -> list[_Candidate]:
    window = 50 if quick else 100
    return [
        _Candidate(
            f"forgetting_factor=0.98, skip=40, window={window}",
            _bind(ScheduledFromStairs, window=window),
        )
    ]


# ---------------------------------------------------------------------------- evaluation
def _max_lag(model: Any) -> int:
    if hasattr(model, "max_lag_"):
        return int(model.max_lag_)
    resolved = getattr(model, "lags_", None)
    return int(resolved.max_lag) if resolved is not None else 1


def _free_run(model: Any, record: IOData, n_initial: int | None) -> tuple[np.ndarray, int]:
    """Simulate ``record`` in free run; return the simulated outputs and the samples to skip.

    With ``n_initial`` (the protocol's initial samples) the simulation starts at
    ``n_initial - max_lag`` so that the model's initial conditions are the last ``max_lag`` of the
    ``n_initial`` samples, and the figure of merit starts at ``n_initial``. Without, the model
    takes the first ``max_lag`` samples.
    """
    lag = _max_lag(model)
    if n_initial is None or n_initial < lag:
        start, skip = 0, lag
    else:
        start, skip = n_initial - lag, n_initial
    result = model.simulate(record[start:] if start else record)
    y = np.array(record.y)
    y[start:] = result.y
    return y, skip


def _first_non_finite(y: np.ndarray, skip: int) -> int | None:
    """Index of the first non-finite simulated sample after ``skip``, or None."""
    bad = np.flatnonzero(~np.isfinite(y[skip:]).all(axis=1))
    return int(bad[0]) + skip if bad.size else None


def _split_training(train: IOData) -> tuple[IOData, IOData]:
    return train.split(SELECTION_FRACTION)


def _select(
    candidates: Sequence[_Candidate], train: IOData, n_initial: int | None
) -> tuple[_Candidate, list[dict[str, Any]]]:
    """Rank the candidates by free-run RMSE on the held-out end of the training record."""
    if len(candidates) == 1:
        return candidates[0], []
    fit_part, check_part = _split_training(train)
    scores: list[dict[str, Any]] = []
    for candidate in candidates:
        try:
            model = candidate.build().fit(fit_part)
        except ValueError as exc:  # e.g. an SM prior that no Lipschitz function satisfies
            scores.append(
                {"settings": candidate.settings, "holdout_rmse": math.inf, "error": str(exc)}
            )
            continue
        y, skip = _free_run(model, check_part, n_initial)
        diverged = _first_non_finite(y, skip)
        value = math.inf if diverged is not None else float(rmse(check_part.y, y, skip=skip)[0])
        scores.append({"settings": candidate.settings, "holdout_rmse": value})
    if all(math.isinf(float(s["holdout_rmse"])) for s in scores):
        raise ValueError(f"every candidate failed or diverged on the held-out end: {scores}")
    best = int(np.argmin([float(s["holdout_rmse"]) for s in scores]))
    return candidates[best], scores


def _quick_subset(bench: BenchmarkData) -> BenchmarkData:
    """Short records for a smoke run: 1500 training and 600 test samples at most."""

    def head(record: IOData, n: int) -> IOData:
        return record[: min(n, record.n_samples)]

    return BenchmarkData(
        name=bench.name,
        train=head(bench.train, 1500),
        tests={k: head(v, 600) for k, v in bench.tests.items()},
        n_initial=bench.n_initial,
        description=bench.description + " (quick: shortened records)",
        citation=bench.citation,
        source=bench.source,
        rmse_unit=bench.rmse_unit,
        rmse_scale=bench.rmse_scale,
    )


def _locate(data_dir: Path, name: str) -> Path | None:
    for folder in (data_dir / "benchmarks" / name, data_dir / name):
        if folder.is_dir():
            return folder
    return None


def _load(name: str, data_dir: Path, quick: bool) -> BenchmarkData | None:
    folder = _locate(data_dir, name)
    if folder is None:
        return None
    if name == "softneck":
        return _load_softneck(folder, quick)
    loaders: dict[str, Callable[[Path], BenchmarkData]] = {
        "cascaded_tanks": load_cascaded_tanks,
        "silverbox": load_silverbox,
        "bouc_wen": load_bouc_wen,
        "robot_arm": load_robot_arm,
    }
    return loaders[name](folder)


def _run_method(
    method: str,
    bench: BenchmarkData,
    quick: bool,
    seed: int,
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Select, fit and simulate one method on one data set; return table rows and details."""
    start = time.perf_counter()
    candidates = _candidates(method, bench.name, quick, seed, bench.train)
    chosen, scores = _select(candidates, bench.train, bench.n_initial)
    model = chosen.build().fit(bench.train)
    train_time = time.perf_counter() - start
    rows = []
    for test_name, record in bench.tests.items():
        t0 = time.perf_counter()
        y, skip = _free_run(model, record, bench.n_initial)
        sim_time = time.perf_counter() - t0
        diverged = _first_non_finite(y, skip)
        note = ""
        if diverged is None:
            error = float(rmse(record.y, y, skip=skip)[0]) * bench.rmse_scale
            fit = float(fit_percent(record.y, y, skip=skip)[0])
        else:
            error, fit = math.inf, -math.inf
            note = f"free run diverged at sample {diverged}"
        rows.append(
            {
                "benchmark": bench.name,
                "test": test_name,
                "method": method,
                "rmse": error,
                "rmse_unit": bench.rmse_unit,
                "fit_percent": fit,
                "n_initial": skip,
                "train_time_s": train_time,
                "simulate_time_s": sim_time,
                "settings": chosen.settings,
                "note": note,
            }
        )
    details = {"selection": scores, "chosen": chosen.settings}
    return rows, details


def _failed_rows(method: str, bench: BenchmarkData, note: str) -> list[dict[str, Any]]:
    return [
        {
            "benchmark": bench.name,
            "test": test_name,
            "method": method,
            "rmse": math.nan,
            "rmse_unit": bench.rmse_unit,
            "fit_percent": math.nan,
            "n_initial": bench.n_initial,
            "train_time_s": math.nan,
            "simulate_time_s": math.nan,
            "settings": "",
            "note": note,
        }
        for test_name in bench.tests
    ]


def _softneck_summary(rows: list[dict[str, Any]]) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Mean fit per method over the validation logs, and fit(sm) - fit(arx) per log."""
    frame = pd.DataFrame(rows)
    summary_rows = []
    for method, group in frame.groupby("method", sort=False):
        summary_rows.append(
            {
                "benchmark": "softneck",
                "test": "mean",
                "method": method,
                "rmse": float(group["rmse"].mean()),
                "rmse_unit": "deg",
                "fit_percent": float(group["fit_percent"].mean()),
                "n_initial": math.nan,
                "train_time_s": float(group["train_time_s"].iloc[0]),
                "simulate_time_s": float(group["simulate_time_s"].sum()),
                "settings": str(group["settings"].iloc[0]),
                "note": f"mean over {len(group)} validation logs",
            }
        )
    details: dict[str, Any] = {}
    fits = frame.pivot(index="test", columns="method", values="fit_percent")
    for method in ("sm", "sm_linear", "sm_parallel", "neural", "scheduled"):
        if method in fits and "arx" in fits:
            margin = (fits[method] - fits["arx"]).dropna()
            details[f"{method}_minus_arx"] = {str(k): float(v) for k, v in margin.items()}
            details[f"{method}_beats_arx_by_5_on_every_log"] = bool(
                len(margin) == len(fits) and (margin >= 5.0).all()
            )
    return summary_rows, details


def _published_frame(names: Sequence[str]) -> pd.DataFrame:
    rows = []
    units = {"cascaded_tanks": "V", "silverbox": "mV", "bouc_wen": "m"}
    for name in names:
        for test, methods in PUBLISHED.get(name, {}).items():
            for method, value in methods.items():
                rows.append(
                    {
                        "benchmark": name,
                        "test": test,
                        "method": method,
                        "rmse": value,
                        "rmse_unit": units[name],
                        "source": PUBLISHED_SOURCES[name],
                    }
                )
    columns = ["benchmark", "test", "method", "rmse", "rmse_unit", "source"]
    return pd.DataFrame(rows, columns=columns)


def run_benchmark(
    data_dir: str | Path,
    methods: Sequence[str] = tuple(METHODS),
    *,
    benchmarks: Sequence[str] | None = None,
    quick: bool = False,
    seed: int = 0,
    errors: Literal["record", "raise"] = "record",
    output_dir: str | Path | None = None,
) -> BenchmarkReport:
    """Run the identification methods on the real data sets found under ``data_dir``.

    Parameters
    ----------
    data_dir : str or Path
        The folder that holds ``softneck/`` and ``benchmarks/<name>/`` (the layout of the shared
        data folder); ``<name>/`` directly under it works too. Data sets not found are skipped
        (listed in ``details["missing"]``).
    methods : sequence of str, default all
        Keys of :data:`METHODS`: ``"arx"``, ``"sm"``, ``"sm_linear"``, ``"sm_parallel"``,
        ``"neural"``, ``"scheduled"`` (the scheduled model runs on the soft-neck logs only).
    benchmarks : sequence of str, optional
        Keys of :data:`BENCHMARKS` to run; default all that are found.
    quick : bool, default False
        A smoke run: at most 1500 training and 600 test samples per record, three soft-neck
        validation logs, one hyper-parameter candidate, a small network. Not for reporting.
    seed : int, default 0
        Seed of the neural network's initialisation and batches.
    errors : {"record", "raise"}, default "record"
        What to do when a method fails on a data set (or its model module is missing):
        ``"record"`` logs a warning and puts the message in the ``note`` column; ``"raise"``
        re-raises.
    output_dir : str or Path, optional
        When given, the report is written there (:meth:`BenchmarkReport.write`).

    Returns
    -------
    BenchmarkReport
        The table (free-run RMSE in each benchmark's unit, NRMSE fit, wall times), the published
        figures, and details.

    Raises
    ------
    ValueError
        If a method or benchmark key is unknown.
    FileNotFoundError
        If ``data_dir`` is not a folder.

    Notes
    -----
    Protocols: see the module docstring and ``docs/benchmarks.md``. RMSE and fit skip the
    protocol's initial samples (Silverbox: 50) or, where the protocol gives none, the model's own
    ``max_lag`` samples. Wall times are measured with :func:`time.perf_counter` on whatever
    machine runs this; they include the hyper-parameter selection.
    """
    root = Path(data_dir)
    if not root.is_dir():
        raise FileNotFoundError(f"data_dir {root} is not a folder")
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise ValueError(f"methods must be among {list(METHODS)}; got {unknown}")
    names = list(BENCHMARKS if benchmarks is None else benchmarks)
    bad = [b for b in names if b not in BENCHMARKS]
    if bad:
        raise ValueError(f"benchmarks must be among {list(BENCHMARKS)}; got {bad}")
    if errors not in ("record", "raise"):
        raise ValueError(f"errors must be 'record' or 'raise'; got {errors!r}")

    rows: list[dict[str, Any]] = []
    details: dict[str, Any] = {
        "settings": {
            "data_dir": str(root),
            "methods": list(methods),
            "quick": quick,
            "seed": seed,
            "selection_fraction": SELECTION_FRACTION,
        },
        "missing": [],
        "benchmarks": {},
    }
    ran: list[str] = []
    for name in names:
        bench = _load(name, root, quick)
        if bench is None:
            details["missing"].append(name)
            continue
        if quick:
            bench = _quick_subset(bench)
        ran.append(name)
        bench_details: dict[str, Any] = {
            "description": bench.description,
            "citation": bench.citation,
            "n_train": bench.train.n_samples,
            "tests": {k: v.n_samples for k, v in bench.tests.items()},
            "methods": {},
        }
        bench_rows: list[dict[str, Any]] = []
        for method in methods:
            if method == "scheduled" and name != "softneck":
                continue
            logger.info("benchmark %s: %s", name, method)
            try:
                method_rows, method_details = _run_method(method, bench, quick, seed)
            except Exception as exc:  # a failing method must not stop the others
                if errors == "raise":
                    raise
                logger.warning("%s on %s failed: %s", method, name, exc, exc_info=True)
                method_rows = _failed_rows(method, bench, f"failed: {type(exc).__name__}: {exc}")
                method_details = {"error": f"{type(exc).__name__}: {exc}"}
            bench_rows.extend(method_rows)
            bench_details["methods"][method] = method_details
        if name == "softneck" and bench_rows:
            finished = [r for r in bench_rows if not math.isnan(r["fit_percent"])]
            if finished:
                summary, margins = _softneck_summary(finished)
                bench_rows.extend(summary)
                bench_details.update(margins)
        rows.extend(bench_rows)
        details["benchmarks"][name] = bench_details
    columns = [
        "benchmark",
        "test",
        "method",
        "rmse",
        "rmse_unit",
        "fit_percent",
        "n_initial",
        "train_time_s",
        "simulate_time_s",
        "settings",
        "note",
    ]
    report = BenchmarkReport(
        table=pd.DataFrame(rows, columns=columns),
        published=_published_frame(ran),
        details=details,
    )
    if output_dir is not None:
        report.write(output_dir)
    return report


def published_table() -> Mapping[str, Mapping[str, Mapping[str, float]]]:
    """The published figures (:data:`PUBLISHED`), benchmark -> test -> method -> RMSE."""
    return PUBLISHED
