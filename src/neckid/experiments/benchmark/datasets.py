"""The data sets of the benchmark: where each one is found, how it loads, and its quick subset.

Every data set is a :class:`Protocol` in :data:`PROTOCOLS`: a loader that turns its folder into a
:class:`~neckid.datasets.benchmarks.BenchmarkData` (training record, test records, the protocol's
initial samples, the unit of its literature), and whether the report adds the mean over its test
records. The four public benchmarks use the official protocol of each
(:mod:`neckid.datasets.benchmarks`); the UC3M soft-neck logs use this project's
(:func:`softneck_protocol`, :func:`load_softneck_benchmark`, ``docs/benchmarks/methods.md``).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

from neckid.data.iodata import IOData
from neckid.data.preprocess import Relative
from neckid.datasets.benchmarks import (
    BenchmarkData,
    load_bouc_wen,
    load_cascaded_tanks,
    load_robot_arm,
    load_silverbox,
)
from neckid.datasets.softneck import load_softneck_directory, load_softneck_log

__all__ = [
    "BENCHMARKS",
    "PROTOCOLS",
    "QUICK_TESTS",
    "QUICK_TEST_SAMPLES",
    "QUICK_TRAIN_SAMPLES",
    "SOFTNECK_CROSS_RUN",
    "SOFTNECK_STAIR_EDGES",
    "SOFTNECK_TRAINING_LOG",
    "Protocol",
    "load_benchmark",
    "load_softneck_benchmark",
    "load_softneck_cross_run",
    "locate",
    "quick_subset",
    "softneck_protocol",
]

#: The log the soft-neck model is identified on (relative to the ``softneck`` folder).
SOFTNECK_TRAINING_LOG = "stair/ada000response.csv"

#: Staircase segments of the soft-neck training log [s from its first sample]: 10 deg for 20 s,
#: then 15, 20, 25, 30, 25, 20, 15 deg for 10 s each. Each is one operating point of the
#: scheduled model.
SOFTNECK_STAIR_EDGES = (0.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0)

#: A quick (smoke) run keeps at most this many training samples, test samples and test records.
QUICK_TRAIN_SAMPLES = 1500
QUICK_TEST_SAMPLES = 600
QUICK_TESTS = 3


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
        sample, :class:`~neckid.data.preprocess.Relative`: the encoder zero and the tendon slack differ between runs, while every log starts
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
    data = Relative("motor_position").apply(data)  # the displacement that travels with models
    return IOData(
        data.u,
        data.y,
        ts=data.ts,
        input_names=["motor_displacement", "motor_velocity"],
        output_names=["inclination"],
        input_units=["rad", "rad/s"],
        output_units=["deg"],
        t0=data.t0,
        name=log.name,
        conditions=log.conditions,
        condition_units=log.condition_units,
    )


def load_softneck_benchmark(folder: str | Path) -> BenchmarkData:
    """The soft-neck logs under ``folder`` as a benchmark: :data:`SOFTNECK_TRAINING_LOG` to train.

    Parameters
    ----------
    folder : str or Path
        The ``softneck`` folder (``stair/``, ``step/``, ``id/``).

    Returns
    -------
    BenchmarkData
        ``train``: the training log through :func:`softneck_protocol`; ``tests``: every other log
        with a raw inclination, by its path relative to ``folder`` (3-column logs are left out);
        ``n_initial`` None (each model takes its own ``max_lag_`` samples); RMSE in deg.

    Raises
    ------
    FileNotFoundError
        If the training log, or every validation log, is missing.
    """
    root = Path(folder)
    logs = load_softneck_directory(root)
    if SOFTNECK_TRAINING_LOG not in logs:
        raise FileNotFoundError(
            f"the soft-neck protocol identifies on {SOFTNECK_TRAINING_LOG}; it is not under {root}"
        )
    usable = {
        key: softneck_protocol(log)
        for key, log in logs.items()
        if "inclination" in log.output_names
    }
    train = usable.pop(SOFTNECK_TRAINING_LOG)
    if not usable:
        raise FileNotFoundError(f"no validation log with a raw inclination under {root}")
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
        source=str(root),
        rmse_unit="deg",
    )


#: The cross-run protocols on the staircase logs: (training logs, test logs), relative to the
#: ``softneck`` folder. By payload: the three controllers at 0 g and 600 g train, 200 g and 400 g
#: test (interpolation in payload). By controller: the adaptive and fixed fractional controllers
#: (all payloads) train, the integer PI (all payloads) tests.
SOFTNECK_CROSS_RUN: Mapping[str, tuple[tuple[str, ...], tuple[str, ...]]] = MappingProxyType(
    {
        "softneck-payload": (
            tuple(
                f"stair/{c}{g}response.csv" for c in ("ada", "fra", "int") for g in ("000", "600")
            ),
            tuple(
                f"stair/{c}{g}response.csv" for c in ("ada", "fra", "int") for g in ("200", "400")
            ),
        ),
        "softneck-controller": (
            tuple(
                f"stair/{c}{g}response.csv"
                for c in ("ada", "fra")
                for g in ("000", "200", "400", "600")
            ),
            tuple(f"stair/int{g}response.csv" for g in ("000", "200", "400", "600")),
        ),
    }
)


def load_softneck_cross_run(folder: str | Path, name: str) -> BenchmarkData:
    """A cross-run protocol of :data:`SOFTNECK_CROSS_RUN`: several training runs, other test runs.

    Every log goes through :func:`softneck_protocol` and keeps the conditions of its file name
    (payload [kg], controller), so a model may use the payload as an input.

    Raises
    ------
    FileNotFoundError
        If a log of the protocol is missing under ``folder``.
    """
    root = Path(folder)
    train_keys, test_keys = SOFTNECK_CROSS_RUN[name]
    missing = [k for k in (*train_keys, *test_keys) if not (root / k).is_file()]
    if missing:
        raise FileNotFoundError(f"the {name} protocol needs {missing[0]}; it is not under {root}")
    logs = {k: softneck_protocol(load_softneck_log(root / k)) for k in (*train_keys, *test_keys)}
    split = "payload (train 0 g and 600 g, test 200 g and 400 g)"
    if name == "softneck-controller":
        split = "controller (train adaptive and fixed fractional, test integer PI)"
    return BenchmarkData(
        name=name,
        train=[logs[k] for k in train_keys],
        tests={k: logs[k] for k in test_keys},
        n_initial=None,
        description=(
            f"UC3M soft-neck staircases across runs, split by {split}: identify on"
            f" {len(train_keys)} logs at once (motor displacement [rad], measured motor velocity"
            " [rad/s] and the payload [kg] as a condition -> raw inclination [deg]); free run on"
            " each test log; NRMSE fit per log and their mean."
        ),
        citation="github.com/munozyanez/phd_Archived @a9198c8 (see datasets.softneck)",
        source=str(root),
        rmse_unit="deg",
    )


# ---------------------------------------------------------------------------- the registry
@dataclass(frozen=True)
class Protocol:
    """One data set of the benchmark.

    Attributes
    ----------
    name : str
        Its key (``"cascaded_tanks"``), also the name of its folder.
    load : callable
        ``load(folder) -> BenchmarkData`` with the official split and initial samples.
    mean_over_tests : bool
        The report adds, per method, a row ``test == "mean"`` over the test records and, in the
        details, the per-test difference of fit to the linear ARX (the soft-neck logs).
    folder : str, optional
        The folder it reads, when not ``name`` (the cross-run protocols read ``softneck``).
    needs : tuple of str
        Files (relative to the folder) without which the data set counts as not found.
    """

    name: str
    load: Callable[[Path], BenchmarkData]
    mean_over_tests: bool = False
    folder: str | None = None
    needs: tuple[str, ...] = ()


#: The data sets, by key, in the order they run.
PROTOCOLS: Mapping[str, Protocol] = MappingProxyType(
    {
        p.name: p
        for p in (
            Protocol("softneck", load_softneck_benchmark, mean_over_tests=True),
            *(
                Protocol(
                    key,
                    functools.partial(load_softneck_cross_run, name=key),
                    mean_over_tests=True,
                    folder="softneck",
                    needs=SOFTNECK_CROSS_RUN[key][0] + SOFTNECK_CROSS_RUN[key][1],
                )
                for key in SOFTNECK_CROSS_RUN
            ),
            Protocol("cascaded_tanks", load_cascaded_tanks),
            Protocol("silverbox", load_silverbox),
            Protocol("bouc_wen", load_bouc_wen),
            Protocol("robot_arm", load_robot_arm),
        )
    }
)

#: The data-set keys, in the order they run.
BENCHMARKS: tuple[str, ...] = tuple(PROTOCOLS)


def locate(data_dir: str | Path, name: str) -> Path | None:
    """The folder of data set ``name``: ``data_dir/benchmarks/<name>`` or ``data_dir/<name>``."""
    root = Path(data_dir)
    for folder in (root / "benchmarks" / name, root / name):
        if folder.is_dir():
            return folder
    return None


def quick_subset(bench: BenchmarkData) -> BenchmarkData:
    """Short records for a smoke run: the first :data:`QUICK_TESTS` test records, shortened.

    At most :data:`QUICK_TRAIN_SAMPLES` training and :data:`QUICK_TEST_SAMPLES` test samples.
    """

    def head(record: IOData, n: int) -> IOData:
        return record[: min(n, record.n_samples)]

    tests = list(bench.tests.items())[:QUICK_TESTS]
    train = (
        head(bench.train, QUICK_TRAIN_SAMPLES)
        if isinstance(bench.train, IOData)
        else [head(r, QUICK_TRAIN_SAMPLES // 2) for r in bench.train[:2]]
    )
    return dataclasses.replace(
        bench,
        train=train,
        tests={k: head(v, QUICK_TEST_SAMPLES) for k, v in tests},
        description=bench.description + " (quick: shortened records)",
    )


def load_benchmark(name: str, data_dir: str | Path, *, quick: bool = False) -> BenchmarkData | None:
    """Load data set ``name`` from under ``data_dir``; ``None`` when its folder is not there.

    Parameters
    ----------
    name : str
        A key of :data:`PROTOCOLS`.
    data_dir : str or Path
        The folder holding ``softneck/`` and ``benchmarks/<name>/`` (see :func:`locate`).
    quick : bool, default False
        Return :func:`quick_subset` of it.

    Raises
    ------
    ValueError
        If ``name`` is not a key of :data:`PROTOCOLS`.
    """
    if name not in PROTOCOLS:
        raise ValueError(f"benchmark must be one of {list(PROTOCOLS)}; got {name!r}")
    protocol = PROTOCOLS[name]
    folder = locate(data_dir, protocol.folder or name)
    if folder is None or not all((folder / f).is_file() for f in protocol.needs):
        return None
    bench = protocol.load(folder)
    return quick_subset(bench) if quick else bench
