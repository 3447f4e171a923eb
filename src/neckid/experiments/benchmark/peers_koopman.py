"""The pykoopman peer: pykoopman 1.2's EDMDc on the same split, lag grid and rule as ``koopman``.

:class:`PyKoopmanPeer` hands pykoopman a state and a control built from the neckid regressor:
the control ``c(t) = u(t + 1 − d)`` (``d`` the smallest input lag, so that ``y(t+1)`` reads
``c(t)`` as EDMDc's ``z(t+1) = A z(t) + B c(t)`` needs), the state ``x(t) = [y(t), c(t−1)]``
with pykoopman's ``TimeDelay`` of ``k = max(n_a − 1, l_max − d − 1, 0)`` delays (so that the
lifted state holds every output and input lag of the regressor) plus its
``RadialBasisFunction`` (thin-plate, random centres, seeded) of the current state; every
signal standardised by its training mean and standard deviation (pykoopman's kernel width is 1
in the data's units). The candidates are the lag grid × :data:`PYKOOPMAN_CENTERS`, ranked by the
benchmark's hold-out free run like every method; the free run is pykoopman's ``simulate`` from
the ``k + 1`` state rows before the first simulated sample.

pykoopman 1.2.1 pins NumPy 1.26, scikit-learn 1.1.3 and torch 2.1: it cannot share neckid's
environment (NumPy 2.4). It runs in an interpreter of its own, named by the environment
variable ``NECKID_PYKOOPMAN_PYTHON`` (``python -m venv /tmp/pyk && /tmp/pyk/bin/pip install
pykoopman``), through :mod:`._pykoopman_worker` with ``.npz`` files of plain arrays; when
pykoopman imports here, the same worker runs in this interpreter. ``fit`` keeps the training
record and checks it runs; each ``simulate`` fits again in the worker (seeded: the same model)
and runs the record.

References
----------
S. E. Pan, E. Kaiser, B. M. de Silva, J. N. Kutz, S. L. Brunton, "PyKoopman: a Python package
for data-driven approximation of the Koopman operator", Journal of Open Source Software 9(94),
5881, 2024.
"""

from __future__ import annotations

import functools
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import ModelResult, NotFittedError
from neckid.regressors import Lags
from neckid.utils.types import FloatArray

__all__ = ["PYKOOPMAN_CENTERS", "PYTHON_VARIABLE", "PyKoopmanPeer", "pykoopman_unavailable"]

#: Numbers of RBF centres the benchmark ranks.
PYKOOPMAN_CENTERS: tuple[int, ...] = (10, 50)

#: The environment variable naming the interpreter pykoopman runs in.
PYTHON_VARIABLE = "NECKID_PYKOOPMAN_PYTHON"

_WORKER = Path(__file__).with_name("_pykoopman_worker.py")

#: Seconds one worker run may take.
_TIMEOUT = 1800.0


def _interpreter() -> str | None:
    """The interpreter pykoopman runs in: ``NECKID_PYKOOPMAN_PYTHON``, else this one if it imports."""
    named = os.environ.get(PYTHON_VARIABLE)
    if named:
        return named
    return sys.executable if importlib.util.find_spec("pykoopman") is not None else None


def pykoopman_unavailable() -> str | None:
    """Why pykoopman cannot run (one line), or None when it can."""
    return _probe(_interpreter())


@functools.lru_cache(maxsize=4)
def _probe(python: str | None) -> str | None:
    """Whether pykoopman imports in ``python`` (asked once per interpreter: it takes seconds)."""
    if python is None:
        return (
            f"skipped: pykoopman is not installed; it pins NumPy 1.26: install it in a venv of its"
            f" own and name its python in {PYTHON_VARIABLE}"
        )
    try:
        done = subprocess.run(
            [python, "-c", "import pykoopman"], capture_output=True, text=True, timeout=300
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"skipped: {PYTHON_VARIABLE}={python} does not run: {exc}"
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        return f"skipped: pykoopman does not import in {python}: {last}"
    return None


class PyKoopmanPeer(BaseEstimator):
    """pykoopman's EDMDc (time delays + thin-plate RBFs) behind the benchmark's estimator contract.

    Parameters
    ----------
    lags : Lags
        The regressor, as for a neckid model (output lags ``1 … n_a``, any input lags).
    n_centers : int, default 50
        RBF centres.
    seed : int, default 0
        Seed of pykoopman's random centres.
    """

    def __init__(self, lags: Lags | None = None, n_centers: int = 50, seed: int = 0) -> None:
        self.lags = lags
        self.n_centers = n_centers
        self.seed = seed

    def __sklearn_is_fitted__(self) -> bool:
        return hasattr(self, "train_")

    def _layout(self, data: IOData) -> tuple[int, int]:
        """``(k, d)``: pykoopman's delays and the smallest input lag."""
        if self.lags is None:
            raise ValueError("PyKoopmanPeer needs lags")
        resolved = self.lags.resolve(data)
        outputs = resolved.lag[resolved.source == 0]
        inputs = resolved.lag[resolved.source == 1]
        if inputs.size == 0:
            raise ValueError(f"the pykoopman peer needs input lags; got {self.lags!r}")
        d = int(inputs.min())
        if d > 1:
            raise ValueError(f"the pykoopman peer takes input lags from 0 or 1; got {self.lags!r}")
        n_a = int(outputs.max()) if outputs.size else 0
        k = max(n_a - 1, int(inputs.max()) - d - 1, 0)
        return k, d

    def _rows(self, data: IOData, d: int) -> tuple[FloatArray, FloatArray]:
        """``x(t) = [y(t), u(t − d)]`` and ``c(t) = u(t + 1 − d)`` (edges held), rows ``t``."""
        u = data.u
        control = np.vstack([u[1 - d :], u[-1:]]) if d == 0 else u
        previous = u if d == 0 else np.vstack([u[:1], u[:-1]])
        return np.hstack([data.y, previous]), np.ascontiguousarray(control)

    def fit(self, data: IOData | Sequence[IOData]) -> PyKoopmanPeer:
        """Keep one training record (EDMDc takes one trajectory here) and check the peer runs on it."""
        experiments = as_experiments(data, "data")
        if len(experiments) != 1:
            raise ValueError(
                f"the pykoopman peer fits one training record; got {len(experiments)} experiments"
            )
        record = experiments[0]
        k, d = self._layout(record)
        self.n_delays_, self.input_lag_ = k, d
        self.max_lag_ = max(self.lags.resolve(record).max_lag, k + 1 + d)  # type: ignore[union-attr]
        self.train_ = record
        self.n_outputs_ = record.n_outputs
        return self

    def simulate(self, data: IOData, initial: Any = None) -> ModelResult:
        """Free run from the first ``max_lag_`` measured samples of ``data`` (pykoopman's simulate)."""
        if not self.__sklearn_is_fitted__():
            raise NotFittedError(
                "this PyKoopmanPeer is not fitted yet; call fit(data) before using it"
            )
        if initial is not None:
            raise ValueError("the pykoopman peer starts from the record's first max_lag_ outputs")
        k, d, s = self.n_delays_, self.input_lag_, self.max_lag_
        x_train, c_train = self._rows(self.train_, d)
        x_run, c_run = self._rows(data, d)
        arrays = {
            "x_train": x_train[d:],
            "c_train": c_train[d:],
            "x0": x_run[s - 1 - k : s],
            "c_run": c_run[s - 1 : data.n_samples - 1],
            "settings": np.array(
                json.dumps(
                    {
                        "n_delays": k,
                        "n_centers": int(self.n_centers),
                        "rbf_type": "thinplate",
                        "seed": int(self.seed),
                    }
                )
            ),
        }
        states = _call_worker(arrays)
        y = np.array(data.y, dtype=np.float64)
        y[s:] = states[:, : self.n_outputs_]
        return ModelResult(
            kind="simulation",
            time=np.asarray(data.time, dtype=np.float64),
            y=y,
            output_names=tuple(data.output_names),
            n_initial=s,
        )


def _call_worker(arrays: dict[str, Any]) -> FloatArray:
    """Run :mod:`._pykoopman_worker` on ``arrays``; its simulated states (``ValueError`` if it failed)."""
    python = _interpreter()
    if python is None:
        raise ImportError(pykoopman_unavailable() or "pykoopman is not installed")
    with tempfile.TemporaryDirectory(prefix="neckid-pykoopman-") as folder:
        source, target = Path(folder) / "in.npz", Path(folder) / "out.npz"
        np.savez(source, **arrays)
        done = subprocess.run(
            [python, str(_WORKER), str(source), str(target)],
            capture_output=True,
            text=True,
            timeout=_TIMEOUT,
        )
        if done.returncode != 0 or not target.is_file():
            last = (done.stderr.strip().splitlines() or ["no message"])[-1]
            raise ValueError(f"the pykoopman worker failed: {last}")
        result = np.load(target, allow_pickle=False)
        if "error" in result:
            raise ValueError(f"pykoopman failed: {result['error']}")
        return np.asarray(result["x"], dtype=np.float64)
