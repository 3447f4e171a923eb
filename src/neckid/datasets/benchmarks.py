"""Loaders for four public nonlinear system-identification benchmarks, with their official splits.

Each loader takes a path (the benchmark's folder or its file; the data are not shipped with neckid)
and returns a :class:`BenchmarkData`: the training record, the test records by name, how many
initial test samples the protocol gives to the model, and the source and citation.

=================  ==========================================================================
benchmark          loader
=================  ==========================================================================
Cascaded tanks     :func:`load_cascaded_tanks` (``dataBenchmark.csv``)
Silverbox          :func:`load_silverbox` (``SNLS80mV.csv``)
Bouc-Wen           :func:`load_bouc_wen` (``train.h5``, ``[uy]val_{multisine,sinesweep}.mat``)
Robot arm (DaISy)  :func:`load_robot_arm` (``robot_arm.dat``)
=================  ==========================================================================
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from neckid.data.iodata import IOData

__all__ = [
    "SILVERBOX_TS",
    "BenchmarkData",
    "load_bouc_wen",
    "load_cascaded_tanks",
    "load_robot_arm",
    "load_silverbox",
]

#: Silverbox sampling period in seconds: fs = 10^7 / 2^14 = 610.35 Hz.
SILVERBOX_TS = 2.0**14 / 1.0e7


@dataclass(frozen=True)
class BenchmarkData:
    """A benchmark's official training record and test records.

    Attributes
    ----------
    name : str
        Short name (``"silverbox"``).
    train : IOData or list of IOData
        The training record (or records: one per experiment, in the cross-run protocols). Choose
        hyper-parameters on it (or on a part of it), never on the tests.
    tests : dict of str to IOData
        The test records by name, each evaluated by free-run simulation.
    n_initial : int or None
        Number of measured samples at the start of each test record that the protocol hands to
        the model as initial conditions (left out of the figure of merit); ``None`` when the
        protocol says nothing, and a model then uses its own ``max_lag`` samples.
    description : str
        What the system is, the signals, units and protocol.
    citation : str
        The reference to cite.
    source : str
        Where the files come from.
    rmse_unit : str
        Unit in which the benchmark's literature reports the RMSE (``"mV"`` for Silverbox).
    rmse_scale : float
        Factor from the output unit to ``rmse_unit`` (1000 from V to mV).
    """

    name: str
    train: IOData | list[IOData]
    tests: dict[str, IOData]
    n_initial: int | None
    description: str
    citation: str
    source: str
    rmse_unit: str
    rmse_scale: float = 1.0
    extras: Mapping[str, object] = field(default_factory=dict)

    def __repr__(self) -> str:
        records = [self.train] if isinstance(self.train, IOData) else self.train
        return (
            f"BenchmarkData(name={self.name!r}, train={sum(r.n_samples for r in records)} samples,"
            f" tests={ {k: v.n_samples for k, v in self.tests.items()} }, n_initial={self.n_initial})"
        )


def _file(path: str | Path, default_name: str) -> Path:
    """``path`` itself if it is a file, else ``path / default_name``; refuse what does not exist."""
    p = Path(path)
    if p.is_dir():
        p = p / default_name
    if not p.is_file():
        raise FileNotFoundError(
            f"{p} not found; pass the benchmark's folder or the path of {default_name}"
        )
    return p


def _csv_columns(path: Path, columns: list[str]) -> pd.DataFrame:
    frame = pd.read_csv(path)
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise ValueError(
            f"{path.name}: columns {missing} are missing; it has {[str(c) for c in frame.columns]}"
        )
    return frame


def _column(frame: pd.DataFrame, name: str, path: Path) -> NDArray[np.float64]:
    values = pd.to_numeric(frame[name], errors="coerce").to_numpy(dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        row = int(bad[0])
        raise ValueError(
            f"{path.name}: column {name!r} has {frame[name].iloc[row]!r} at data row {row}"
            f" (file line {row + 2}), not a finite number"
        )
    return values


# ---------------------------------------------------------------------------- cascaded tanks
def load_cascaded_tanks(path: str | Path) -> BenchmarkData:
    r"""Cascaded tanks benchmark: pump voltage -> water level of the lower tank (real lab data).

    Two records of 1024 samples, ``Ts = 4 s``: estimation (``uEst``, ``yEst``) and validation
    (``uVal``, ``yVal``). Protocol: train on the estimation record, simulate the validation record
    in free run from its input, RMSE in volts over the validation record. The level sensor saturates
    at 10 V when the upper tank overflows.

    Parameters
    ----------
    path : str or Path
        ``dataBenchmark.csv`` (columns ``uEst, uVal, yEst, yVal, Ts``) or its folder.

    Returns
    -------
    BenchmarkData
        ``train`` and ``tests["validation"]``, input ``pump_voltage`` [V], output
        ``level_lower`` [V]; ``n_initial`` is ``None`` (the protocol leaves the initial state to
        the model; the models here take their first ``max_lag`` measured outputs).

    Raises
    ------
    FileNotFoundError
        If the file is not there.
    ValueError
        If a column is missing or holds a non-number.

    Notes
    -----
    Source: forgi86/sysid-neural-continuous @956aa7e, ``examples/CTS/data/dataBenchmark.csv``;
    data licence CC BY-SA 4.0 (4TU.ResearchData, doi:10.4121/12960104).

    Citation: M. Schoukens, P. Mattsson, T. Wigren and J.-P. Noël, "Cascaded tanks benchmark
    combining soft and hard nonlinearities", Workshop on Nonlinear System Identification
    Benchmarks, Brussels, 2016.

    Examples
    --------
    >>> import os, tempfile
    >>> from neckid.datasets import load_cascaded_tanks
    >>> path = os.path.join(tempfile.mkdtemp(), "dataBenchmark.csv")
    >>> rows = ['"uEst","uVal","yEst","yVal","Ts",'] + [
    ...     f"{3 + k % 2},{4 - k % 2},{5 + 0.1 * k},{4 + 0.1 * k},{4 if k == 0 else ''},"
    ...     for k in range(6)]
    >>> _ = open(path, "w").write("\n".join(rows))
    >>> bench = load_cascaded_tanks(path)
    >>> bench.train.ts, bench.train.input_names, list(bench.tests)
    (4.0, ('pump_voltage',), ['validation'])
    """
    file = _file(path, "dataBenchmark.csv")
    frame = _csv_columns(file, ["uEst", "uVal", "yEst", "yVal", "Ts"])
    ts_values = pd.to_numeric(frame["Ts"], errors="coerce").dropna().to_numpy()
    if ts_values.size == 0 or not np.isfinite(ts_values[0]) or ts_values[0] <= 0:
        raise ValueError(f"{file.name}: column 'Ts' must hold a positive sampling period in row 0")
    ts = float(ts_values[0])

    def record(u: str, y: str, label: str) -> IOData:
        return IOData(
            u=_column(frame, u, file),
            y=_column(frame, y, file),
            ts=ts,
            input_names=["pump_voltage"],
            output_names=["level_lower"],
            input_units=["V"],
            output_units=["V"],
            name=f"cascaded_tanks/{label}",
        )

    return BenchmarkData(
        name="cascaded_tanks",
        train=record("uEst", "yEst", "estimation"),
        tests={"validation": record("uVal", "yVal", "validation")},
        n_initial=None,
        description=(
            "Cascaded tanks (real): pump voltage [V] -> lower tank level [V], Ts = 4 s, 1024 + 1024"
            " samples; output saturates at 10 V (overflow). Train on the estimation record,"
            " free-run simulation RMSE [V] on the validation record."
        ),
        citation=(
            "M. Schoukens, P. Mattsson, T. Wigren, J.-P. Noël, 'Cascaded tanks benchmark combining"
            " soft and hard nonlinearities', Workshop on Nonlinear System Identification"
            " Benchmarks, 2016. Data: 4TU.ResearchData doi:10.4121/12960104 (CC BY-SA 4.0)."
        ),
        source="forgi86/sysid-neural-continuous @956aa7e: examples/CTS/data/dataBenchmark.csv",
        rmse_unit="V",
    )


# ---------------------------------------------------------------------------- silverbox
#: Official Silverbox splits of SNLS80mV (sample indices, Python slices).
SILVERBOX_SPLITS: dict[str, tuple[int, int]] = {
    "train": (40650, 105712),
    "multisine": (105712, 127400),
    "arrow_full": (100, 40575),
    "arrow_no_extrapolation": (100, 32100),
}


def load_silverbox(path: str | Path) -> BenchmarkData:
    """Silverbox benchmark (electronic Duffing oscillator, real): V1 -> V2 [V] at 610.35 Hz.

    Official splits of ``SNLS80mV.csv`` (131,072 samples), as Python slices: training
    ``[40650:105712]``; tests ``multisine`` ``[105712:127400]``, ``arrow_full`` ``[100:40575]``
    (the arrow head, its last part extrapolates in amplitude) and ``arrow_no_extrapolation``
    ``[100:32100]``. The first 50 samples of each test record initialise the model
    (``n_initial = 50``); free-run simulation RMSE is reported in millivolts.

    Parameters
    ----------
    path : str or Path
        ``SNLS80mV.csv`` (columns ``V1, V2``) or its folder.

    Returns
    -------
    BenchmarkData
        Input ``V1`` [V], output ``V2`` [V], ``ts = 2^14 / 10^7`` s; ``rmse_unit="mV"``,
        ``rmse_scale=1000``. Each record's ``t0`` is its start index times ``ts``.

    Raises
    ------
    FileNotFoundError
        If the file is not there.
    ValueError
        If a column is missing, holds a non-number, or the file is shorter than 127,400 samples.

    Notes
    -----
    ``Schroeder80mV.csv`` beside it (a Schroeder-phase multisine) is not part of the protocol and
    is not read.

    Source: forgi86/pytorch-ident @f00d79f, ``examples/statespace/silverbox/SilverboxFiles/``.

    Citation: T. Wigren and J. Schoukens, "Three free data sets for development and benchmarking
    in nonlinear system identification", European Control Conference (ECC), Zürich, 2013,
    pp. 2933-2938.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from neckid.datasets import load_silverbox
    >>> path = os.path.join(tempfile.mkdtemp(), "SNLS80mV.csv")
    >>> v = np.random.default_rng(0).normal(size=(131072, 2))
    >>> pd_frame = __import__("pandas").DataFrame(v, columns=["V1", "V2"])
    >>> pd_frame.to_csv(path, index=False)
    >>> bench = load_silverbox(path)
    >>> bench.train.n_samples, bench.tests["multisine"].n_samples, bench.n_initial
    (65062, 21688, 50)
    """
    file = _file(path, "SNLS80mV.csv")
    frame = _csv_columns(file, ["V1", "V2"])
    needed = max(stop for _, stop in SILVERBOX_SPLITS.values())
    if len(frame) < needed:
        raise ValueError(
            f"{file.name} has {len(frame)} samples; the Silverbox splits need {needed} (131,072 in"
            " the official file)"
        )
    whole = IOData(
        u=_column(frame, "V1", file),
        y=_column(frame, "V2", file),
        ts=SILVERBOX_TS,
        input_names=["V1"],
        output_names=["V2"],
        input_units=["V"],
        output_units=["V"],
        name="silverbox",
    )

    def part(label: str) -> IOData:
        start, stop = SILVERBOX_SPLITS[label]
        return whole[start:stop].renamed(f"silverbox/{label}")

    return BenchmarkData(
        name="silverbox",
        train=part("train"),
        tests={k: part(k) for k in ("multisine", "arrow_full", "arrow_no_extrapolation")},
        n_initial=50,
        description=(
            "Silverbox (real electronic Duffing oscillator): V1 -> V2 [V], fs = 610.35 Hz. Train"
            " SNLS80mV[40650:105712]; tests multisine [105712:127400], arrow head [100:40575] and,"
            " without extrapolation, [100:32100]; first 50 test samples initialise; free-run RMSE"
            " in mV."
        ),
        citation=(
            "T. Wigren and J. Schoukens, 'Three free data sets for development and benchmarking in"
            " nonlinear system identification', European Control Conference, 2013, pp. 2933-2938."
        ),
        source="forgi86/pytorch-ident @f00d79f: examples/statespace/silverbox/SilverboxFiles/",
        rmse_unit="mV",
        rmse_scale=1000.0,
    )


# ---------------------------------------------------------------------------- Bouc-Wen
def _mat_vector(path: Path, variable: str) -> NDArray[np.float64]:
    from scipy.io import loadmat

    content = loadmat(path)
    if variable not in content:
        names = sorted(k for k in content if not k.startswith("__"))
        raise ValueError(f"{path.name} has no variable {variable!r}; it has {names}")
    values = np.asarray(content[variable], dtype=np.float64).ravel()
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise ValueError(f"{path.name}: {variable}[{int(bad[0])}] is not finite")
    return values


def load_bouc_wen(path: str | Path) -> BenchmarkData:
    """Bouc-Wen hysteresis benchmark (simulated): force [N] -> displacement [m] at 750 Hz.

    Training: ``train.h5`` (group ``multisine``, datasets ``u``, ``y``, ``fs``; 40,960 samples
    generated with the official generator). Tests: the official validation signals
    ``uval_multisine.mat`` / ``yval_multisine.mat`` (8,192 samples) and ``uval_sinesweep.mat`` /
    ``yval_sinesweep.mat`` (153,000 samples). Free-run simulation; the literature reports RMSE
    in metres (and fit) on the multisine test.

    Parameters
    ----------
    path : str or Path
        The folder that holds the six files.

    Returns
    -------
    BenchmarkData
        Input ``force`` [N], output ``displacement`` [m], ``ts = 1/750`` s; tests ``multisine``
        and ``sinesweep``; ``n_initial`` is ``None``.

    Raises
    ------
    ImportError
        If h5py is missing (install the ``data`` extra: ``pip install "neckid[data]"``).
    FileNotFoundError
        If a file is not there.
    ValueError
        If a variable is missing or not finite, or input and output lengths differ.

    Notes
    -----
    Source: forgi86/dynonet @0bdf706, ``examples/BW/BoucWenFiles/Test signals/Validation signals/``
    (the ``.mat`` files) and ``examples/BW/data/`` (``train.h5``).

    Citation: J.-P. Noël and M. Schoukens, "Hysteretic benchmark with a dynamic nonlinearity",
    Workshop on Nonlinear System Identification Benchmarks, Brussels, 2016.
    """
    try:
        import h5py
    except ImportError as exc:
        raise ImportError(
            "load_bouc_wen needs h5py to read train.h5; install it with"
            ' `pip install "neckid[data]"` (or `pip install h5py`)'
        ) from exc
    folder = Path(path)
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder} is not a folder; pass the folder of the Bouc-Wen files")
    train_file = _file(folder, "train.h5")
    with h5py.File(train_file, "r") as handle:
        try:
            group = handle["multisine"]
            u_train = np.asarray(group["u"][()], dtype=np.float64).ravel()
            y_train = np.asarray(group["y"][()], dtype=np.float64).ravel()
            fs = float(np.asarray(group["fs"][()]).ravel()[0])
        except KeyError as exc:
            raise ValueError(
                f"{train_file.name} must hold multisine/u, multisine/y and multisine/fs: {exc}"
            ) from exc
    if not np.isfinite(fs) or fs <= 0:
        raise ValueError(f"{train_file.name}: multisine/fs must be a positive rate; got {fs!r}")
    ts = 1.0 / fs
    names = {
        "input_names": ["force"],
        "output_names": ["displacement"],
        "input_units": ["N"],
        "output_units": ["m"],
    }
    train = IOData(u_train, y_train, ts=ts, name="bouc_wen/train", **names)  # type: ignore[arg-type]
    tests = {}
    for label in ("multisine", "sinesweep"):
        u = _mat_vector(_file(folder, f"uval_{label}.mat"), f"uval_{label}")
        y = _mat_vector(_file(folder, f"yval_{label}.mat"), f"yval_{label}")
        if u.size != y.size:
            raise ValueError(
                f"bouc_wen {label}: {u.size} input samples but {y.size} output samples"
            )
        tests[label] = IOData(u, y, ts=ts, name=f"bouc_wen/{label}", **names)  # type: ignore[arg-type]
    return BenchmarkData(
        name="bouc_wen",
        train=train,
        tests=tests,
        n_initial=None,
        description=(
            "Bouc-Wen hysteresis (simulated with the official code): force [N] -> displacement [m],"
            " 750 Hz. Train train.h5 (40,960 samples); tests: multisine (8,192) and sine sweep"
            " (153,000) validation signals; free-run simulation RMSE [m]."
        ),
        citation=(
            "J.-P. Noël and M. Schoukens, 'Hysteretic benchmark with a dynamic nonlinearity',"
            " Workshop on Nonlinear System Identification Benchmarks, 2016."
        ),
        source="forgi86/dynonet @0bdf706: examples/BW/BoucWenFiles/Test signals/Validation signals/",
        rmse_unit="m",
    )


# ---------------------------------------------------------------------------- robot arm
#: Our split of the robot-arm record (there is no official one): first half trains, second tests.
ROBOT_ARM_SPLIT = 512


def load_robot_arm(path: str | Path, ts: float = 1.0) -> BenchmarkData:
    """DaISy flexible robot arm (real): reaction torque -> arm acceleration, 1024 samples.

    There is no official split and no published table. neckid uses the first 512 samples for
    training and the last 512 as the ``"second_half"`` test (free-run simulation).

    Parameters
    ----------
    path : str or Path
        ``robot_arm.dat`` (two whitespace-separated columns) or its folder.
    ts : float, default 1.0
        Sampling period in seconds; the DaISy file does not give one, so time is in samples.

    Returns
    -------
    BenchmarkData
        Input ``torque``, output ``acceleration`` (units not given by the source).

    Raises
    ------
    FileNotFoundError
        If the file is not there.
    ValueError
        If the file does not hold two numeric columns.

    Notes
    -----
    Source: paaraujo/QNN @9442985, ``data/robot_arm.dat``.

    Citation: B. De Moor, P. De Gersem, B. De Schutter and W. Favoreel, "DAISY: A database for
    identification of systems", Journal A, 38(3):4-5, 1997 (data set 96-009).
    """
    file = _file(path, "robot_arm.dat")
    try:
        values = np.loadtxt(file, dtype=np.float64, ndmin=2)
    except ValueError as exc:
        raise ValueError(f"{file.name} must hold two numeric columns: {exc}") from exc
    if values.shape[1] != 2:
        raise ValueError(f"{file.name} must hold two columns; got {values.shape[1]}")
    if values.shape[0] <= ROBOT_ARM_SPLIT:
        raise ValueError(f"{file.name} has {values.shape[0]} rows; the split needs more than 512")
    whole = IOData(
        values[:, 0],
        values[:, 1],
        ts=ts,
        input_names=["torque"],
        output_names=["acceleration"],
        name="robot_arm",
    )
    return BenchmarkData(
        name="robot_arm",
        train=whole[:ROBOT_ARM_SPLIT].renamed("robot_arm/first_half"),
        tests={"second_half": whole[ROBOT_ARM_SPLIT:].renamed("robot_arm/second_half")},
        n_initial=None,
        description=(
            "DaISy flexible robot arm (real): reaction torque -> arm acceleration, 1024 samples."
            " No official split: neckid trains on samples [0:512] and tests on [512:1024]."
        ),
        citation=(
            "B. De Moor, P. De Gersem, B. De Schutter, W. Favoreel, 'DAISY: A database for"
            " identification of systems', Journal A 38(3):4-5, 1997."
        ),
        source="paaraujo/QNN @9442985: data/robot_arm.dat",
        rmse_unit="",
    )
