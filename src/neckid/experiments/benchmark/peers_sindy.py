"""The PySINDy peer: PySINDy 2.1's ``DiscreteSINDy`` (STLSQ) on the same split, lag grid and rule.

:class:`PySindyPeer` hands PySINDy a delay-embedded state, ``x_k = (y(k), …, y(k − n_a + 1))``,
and the inputs the neckid regressor reads, ``u_k = (u(k + 1 − l))`` for each input lag ``l``
(``l = 0``: the input at the time of the new output), so that ``x_{k+1} = Ξ Θ(x_k, u_k)`` is a
NARX with the same regressor as neckid's; PySINDy identifies every state row (the shift rows
too) with its ``PolynomialLibrary`` and ``STLSQ``. The signals are divided by their training root
mean square (not centred: a monomial stays one monomial), so that STLSQ's threshold, on raw
coefficients in PySINDy, is in comparable units on every data set. The candidates are the
lag grid × :data:`PYSINDY_THRESHOLDS`, ranked by the benchmark's hold-out free run like every
method.

The free run uses PySINDy's fitted coefficients and library exponents
(``model.coefficients()``, ``feature_library.powers_``) in a compiled loop:
``DiscreteSINDy.simulate`` steps through scikit-learn once per sample (about 8 ms a step here,
minutes per candidate on Silverbox); :meth:`PySindyPeer.check_simulate` compares the two on a
record's first samples (``tests/test_benchmark_peers_sindy.py``).

References
----------
B. M. de Silva, K. Champion, M. Quade, J.-C. Loiseau, J. N. Kutz, S. L. Brunton, "PySINDy: a
Python package for the sparse identification of nonlinear dynamical systems from data", Journal
of Open Source Software 5(49), 2104, 2020; A. A. Kaptanoglu et al., "PySINDy: a comprehensive
Python package for robust sparse system identification", JOSS 7(69), 3994, 2022.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Sequence
from typing import Any

import numpy as np
from numba import njit
from sklearn.base import BaseEstimator

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import ModelResult, NotFittedError
from neckid.regressors import Lags
from neckid.utils.types import FloatArray, IntArray

__all__ = ["PYSINDY_DEGREE", "PYSINDY_THRESHOLDS", "PySindyPeer", "pysindy_unavailable"]

#: Degree of the peer's polynomial library (neckid's ``sindy``: 3).
PYSINDY_DEGREE = 3

#: STLSQ thresholds the benchmark ranks (PySINDy's default 0.1 among them), on coefficients of
#: the RMS-scaled signals.
PYSINDY_THRESHOLDS: tuple[float, ...] = (0.1, 0.03, 0.01, 0.003, 0.001)


def pysindy_unavailable() -> str | None:
    """Why PySINDy cannot run here (one line), or None when it can."""
    if importlib.util.find_spec("pysindy") is None:
        return 'skipped: PySINDy is not installed (pip install "neckid[peers]")'
    try:
        importlib.import_module("pysindy")
    except Exception as exc:  # installed but broken (e.g. built against another NumPy)
        return f"skipped: PySINDy is installed but does not import: {type(exc).__name__}: {exc}"
    return None


@njit(cache=True)
def _run(x: FloatArray, u: FloatArray, powers: IntArray, coef: FloatArray) -> None:
    """``x[k+1] = coef @ Θ(x[k], u[k])`` in place from row 0, Θ the monomials of ``powers``."""
    n_x = x.shape[1]
    z = np.empty(n_x + u.shape[1])
    theta = np.empty(powers.shape[0])
    for k in range(x.shape[0] - 1):
        z[:n_x] = x[k]
        z[n_x:] = u[k]
        for f in range(powers.shape[0]):
            value = 1.0
            for j in range(z.shape[0]):
                for _ in range(powers[f, j]):
                    value *= z[j]
            theta[f] = value
        for i in range(n_x):
            acc = 0.0
            for f in range(powers.shape[0]):
                acc += coef[i, f] * theta[f]
            x[k + 1, i] = acc


class PySindyPeer(BaseEstimator):
    """PySINDy's ``DiscreteSINDy`` with STLSQ behind the benchmark's estimator contract.

    Parameters
    ----------
    lags : Lags
        Output lags ``1..n_a`` (contiguous) and input lags ``>= 0`` of a single-output record.
    threshold : float, default 0.1
        STLSQ's threshold (PySINDy's default), on the RMS-scaled signals.
    degree : int, default 3
        Degree of PySINDy's ``PolynomialLibrary``.
    """

    def __init__(
        self, lags: Lags | None = None, threshold: float = 0.1, degree: int = PYSINDY_DEGREE
    ) -> None:
        self.lags = lags
        self.threshold = threshold
        self.degree = degree

    def __sklearn_is_fitted__(self) -> bool:
        return hasattr(self, "model_")

    def _layout(self, data: IOData) -> tuple[int, list[int]]:
        if self.lags is None:
            raise ValueError("PySindyPeer needs lags")
        if data.n_outputs != 1:
            raise ValueError(f"the PySINDy peer runs on one output; the data have {data.n_outputs}")
        r = self.lags.resolve(data)
        outputs = sorted(int(k) for k in r.lag[r.source == 0])
        if not outputs or outputs != list(range(1, len(outputs) + 1)):
            raise ValueError(f"the PySINDy peer needs output lags 1..n; got {outputs}")
        inputs = [
            (int(c), int(k)) for s, c, k in zip(r.source, r.channel, r.lag, strict=True) if s == 1
        ]
        self.inputs_ = inputs
        return len(outputs), [k for _, k in inputs]

    def _states(self, y: FloatArray, u: FloatArray, na: int) -> tuple[FloatArray, FloatArray, int]:
        """States ``x_k`` and inputs ``u_k`` for ``k = start .. n − 2`` (row 0 at ``start``)."""
        m = max([na, *(k for _, k in self.inputs_)])
        start = m - 1  # x_start holds y(m-1) .. y(m-na), the history of the first output y(m)
        n = y.shape[0]
        x = np.column_stack([y[start - i : n - i] for i in range(na)])
        cols = [u[start + 1 - k : n + 1 - k, c] for c, k in self.inputs_]
        last = min(len(c) for c in cols) if cols else x.shape[0]
        x = x[:last]
        uk = np.column_stack([c[:last] for c in cols]) if cols else np.zeros((last, 0))
        return x, uk, start

    def fit(self, data: IOData | Sequence[IOData]) -> PySindyPeer:
        """STLSQ on one training record."""
        experiments = as_experiments(data, "data")
        if len(experiments) != 1:
            raise ValueError(f"the PySINDy peer fits one training record; got {len(experiments)}")
        record = experiments[0]
        na, input_lags = self._layout(record)
        reason = pysindy_unavailable()
        if reason is not None:
            raise ImportError(reason.removeprefix("skipped: "))
        import pysindy as ps

        self.y_scale_ = float(np.sqrt(np.mean(record.y[:, 0] ** 2))) or 1.0
        self.u_scale_ = np.where(
            np.sqrt(np.mean(record.u**2, axis=0)) > 0, np.sqrt(np.mean(record.u**2, axis=0)), 1.0
        )
        x, uk, _ = self._states(record.y[:, :1] / self.y_scale_, record.u / self.u_scale_, na)
        model = ps.DiscreteSINDy(
            optimizer=ps.STLSQ(threshold=float(self.threshold)),
            feature_library=ps.PolynomialLibrary(degree=int(self.degree)),
        )
        with np.errstate(all="ignore"):
            model.fit(x, t=1, u=uk)
        self.model_ = model
        self.coef_ = np.ascontiguousarray(model.coefficients(), dtype=np.float64)
        self.powers_ = np.ascontiguousarray(model.feature_library.powers_, dtype=np.int64)
        self.n_states_ = na
        self.max_lag_ = int(max([na, *input_lags]))
        self.n_terms_ = int(np.count_nonzero(self.coef_[0]))
        return self

    def _free_run(self, data: IOData) -> tuple[FloatArray, FloatArray, int]:
        na = self.n_states_
        x, uk, start = self._states(data.y[:, :1] / self.y_scale_, data.u / self.u_scale_, na)
        x = np.ascontiguousarray(x)
        x[1:] = 0.0
        with np.errstate(all="ignore"):
            _run(x, np.ascontiguousarray(uk), self.powers_, self.coef_)
        return x, uk, start

    def simulate(self, data: IOData, initial: Any = None) -> ModelResult:
        """Free run from the first ``max_lag_`` measured outputs of ``data``."""
        if not self.__sklearn_is_fitted__():
            raise NotFittedError("this PySindyPeer is not fitted yet; call fit(data) first")
        if initial is not None:
            raise ValueError("the PySINDy peer starts from the record's first max_lag_ outputs")
        x, _, start = self._free_run(data)
        y = np.array(data.y[:, :1], dtype=np.float64)
        y[start + 1 : start + 1 + x.shape[0] - 1, 0] = x[1:, 0] * self.y_scale_
        return ModelResult(
            kind="simulation",
            time=np.asarray(data.time, dtype=np.float64),
            y=y,
            output_names=tuple(data.output_names[:1]),
            n_initial=self.max_lag_,
        )

    def check_simulate(self, data: IOData, steps: int = 200) -> float:
        """Largest difference of the compiled free run from ``DiscreteSINDy.simulate`` (scaled)."""
        x, uk, _ = self._free_run(data)
        steps = min(steps, x.shape[0])
        reference = self.model_.simulate(x[0], t=steps, u=uk[:steps])
        return float(np.max(np.abs(reference - x[:steps])))
