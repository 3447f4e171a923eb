"""Peers: another toolkit's model on the same split, selected by the same rule, in the same run.

The benchmark's peer is SysIdentPy's FROLS polynomial NARX (Lacerda, Martins & Nepomuceno 2020),
the Python toolkit a researcher would otherwise pick: forward orthogonal least squares selects
the monomials of a degree-3 polynomial of the regressor one by one (Billings, Chen & Korenberg
1989), the number kept by Akaike's criterion, and the kept ones are fitted by least squares on
the one-step error. :class:`FrolsPeer` wraps it in the estimator contract the benchmark needs
(``fit(IOData)``, ``max_lag_``, ``simulate(IOData)``), so the peer gets the data set's lag grid,
the hold-out selection and the free-run protocol of every neckid method.

The second peer is PySINDy's ``DiscreteSINDy`` (``pysindy-stlsq``,
:mod:`neckid.experiments.benchmark.peers_sindy`), beside neckid's ``sindy``; the third
pykoopman's EDMDc (``pykoopman-edmdc``, :mod:`neckid.experiments.benchmark.peers_koopman`, in an
interpreter of its own), beside neckid's ``koopman``.

SysIdentPy and PySINDy are not dependencies of neckid: ``pip install "neckid[peers]"``. Without it the
benchmark writes one row per test record that says so (:func:`peer_unavailable`).

References
----------
W. R. Lacerda Jr, L. P. C. Martins, S. A. M. Nepomuceno, "SysIdentPy: A Python package for System
Identification using NARMAX models", Journal of Open Source Software 5(54), 2384, 2020.
S. A. Billings, S. Chen, M. J. Korenberg, "Identification of MIMO non-linear systems using a
forward-regression orthogonal estimator", International Journal of Control 49(6), 2157-2189, 1989.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Sequence
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator

from neckid.data.iodata import IOData, as_experiments
from neckid.experiments.benchmark.settings import (
    PEER_METHODS,
    PUBLIC_BENCHMARKS,
    Candidate,
    lag_grid,
)
from neckid.models.base import ModelResult, NotFittedError
from neckid.regressors import Lags
from neckid.utils.types import FloatArray

__all__ = ["PEER_METHODS", "FrolsPeer", "peer_candidates", "peer_unavailable"]

#: Polynomial degree and the number of terms the information criterion is evaluated over.
FROLS_DEGREE = 3
FROLS_INFO_VALUES = 40


def peer_unavailable(name: str) -> str | None:
    """Why peer ``name`` cannot run here (one line), or None when it can."""
    if name not in PEER_METHODS:
        raise ValueError(f"peer must be one of {list(PEER_METHODS)}; got {name!r}")
    if name == "pysindy-stlsq":
        from neckid.experiments.benchmark.peers_sindy import pysindy_unavailable

        return pysindy_unavailable()
    if name == "pykoopman-edmdc":
        from neckid.experiments.benchmark.peers_koopman import pykoopman_unavailable

        return pykoopman_unavailable()
    if importlib.util.find_spec("sysidentpy") is None:
        return 'skipped: SysIdentPy is not installed (pip install "neckid[peers]")'
    try:
        importlib.import_module("sysidentpy.model_structure_selection")
    except Exception as exc:  # installed but broken (e.g. built against another NumPy)
        return f"skipped: SysIdentPy is installed but does not import: {type(exc).__name__}: {exc}"
    return None


def peer_candidates(name: str, benchmark: str, quick: bool = False) -> list[Candidate]:
    """The peer's candidates on a public data set: one per regressor of the data set's lag grid.

    The same grid and the same hold-out rule as neckid's methods (the soft-neck protocols have
    two inputs, which this peer does not take: none there).
    """
    if peer_unavailable(name) is not None or benchmark not in PUBLIC_BENCHMARKS:
        return []
    if name == "pysindy-stlsq":
        from neckid.experiments.benchmark.peers_sindy import PYSINDY_THRESHOLDS, PySindyPeer

        thresholds = PYSINDY_THRESHOLDS[:2] if quick else PYSINDY_THRESHOLDS
        return [
            (f"lags={lags!r}, degree=3, STLSQ threshold={t:g}", PySindyPeer(lags, threshold=t))
            for lags in lag_grid(benchmark, quick)
            for t in thresholds
        ]
    if name == "pykoopman-edmdc":
        from neckid.experiments.benchmark.peers_koopman import PYKOOPMAN_CENTERS, PyKoopmanPeer

        centers = PYKOOPMAN_CENTERS[:1] if quick else PYKOOPMAN_CENTERS
        return [
            (f"lags={lags!r}, time delays + {n} thin-plate RBFs", PyKoopmanPeer(lags, n_centers=n))
            for lags in lag_grid(benchmark, quick)
            for n in centers
        ]
    info = 10 if quick else FROLS_INFO_VALUES
    return [
        (
            f"lags={lags!r}, degree={FROLS_DEGREE}, AIC over {info} terms",
            FrolsPeer(lags, n_info_values=info),
        )
        for lags in lag_grid(benchmark, quick)
    ]


def _input_ahead(u: FloatArray) -> FloatArray:
    """``u`` one sample ahead, so that SysIdentPy's ``x(k−1)`` is ``u(k)`` (its lags start at 1)."""
    return np.concatenate([u[1:], u[-1:]])[:, None]


class FrolsPeer(BaseEstimator):
    """SysIdentPy's FROLS polynomial NARX behind the benchmark's estimator contract.

    Parameters
    ----------
    lags : Lags
        The regressor, as for a neckid model: output lags ``>= 1`` and input lags ``>= 0`` of a
        single-input single-output data set. SysIdentPy counts input lags from 1, so the input is
        handed to it one sample ahead (``u(t)`` is its ``x(t−1)``).
    degree : int, default 3
        Degree of the polynomial basis.
    n_info_values : int, default 40
        Largest number of terms FROLS considers; Akaike's criterion chooses among them.
    """

    def __init__(
        self,
        lags: Lags | None = None,
        degree: int = FROLS_DEGREE,
        n_info_values: int = FROLS_INFO_VALUES,
    ) -> None:
        self.lags = lags
        self.degree = degree
        self.n_info_values = n_info_values

    def __sklearn_is_fitted__(self) -> bool:
        return hasattr(self, "model_")

    def _sysidentpy_lags(self, data: IOData) -> tuple[list[int], list[int]]:
        if self.lags is None:
            raise ValueError("FrolsPeer needs lags")
        if data.n_inputs != 1 or data.n_outputs != 1:
            raise ValueError(
                "the FROLS peer runs on single-input single-output data; the data have"
                f" {data.n_inputs} inputs and {data.n_outputs} outputs"
            )
        resolved = self.lags.resolve(data)
        outputs = sorted(int(k) for k in resolved.lag[resolved.source == 0])
        inputs = sorted(int(k) + 1 for k in resolved.lag[resolved.source == 1])
        if not outputs or not inputs:
            raise ValueError(f"the FROLS peer needs output and input lags; got {self.lags!r}")
        return outputs, inputs

    def fit(self, data: IOData | Sequence[IOData]) -> FrolsPeer:
        """Select the terms and fit them on one training record (FROLS takes one)."""
        experiments = as_experiments(data, "data")
        if len(experiments) != 1:
            raise ValueError(
                f"the FROLS peer fits one training record; got {len(experiments)} experiments"
            )
        record = experiments[0]
        outputs, inputs = self._sysidentpy_lags(record)
        reason = peer_unavailable("sysidentpy-frols")
        if reason is not None:
            raise ImportError(reason.removeprefix("skipped: "))
        from sysidentpy.basis_function import Polynomial
        from sysidentpy.model_structure_selection import FROLS
        from sysidentpy.parameter_estimation import LeastSquares

        model = FROLS(
            ylag=outputs,
            xlag=inputs,
            order_selection=True,
            info_criteria="aic",
            n_info_values=int(self.n_info_values),
            estimator=LeastSquares(),
            basis_function=Polynomial(degree=int(self.degree)),
            model_type="NARMAX",
        )
        model.fit(X=_input_ahead(record.u[:, 0]), y=record.y[:, :1])
        self.model_ = model
        self.max_lag_ = int(max(max(outputs), max(inputs)))
        self.n_terms_ = len(model.final_model)
        return self

    def simulate(self, data: IOData, initial: Any = None) -> ModelResult:
        """Free run from the first ``max_lag_`` measured outputs of ``data``."""
        if not self.__sklearn_is_fitted__():
            raise NotFittedError("this FrolsPeer is not fitted yet; call fit(data) before using it")
        if initial is not None:
            raise ValueError("the FROLS peer starts from the record's first max_lag_ outputs")
        self._sysidentpy_lags(data)
        with np.errstate(all="ignore"):
            y = self.model_.predict(X=_input_ahead(data.u[:, 0]), y=data.y[: self.max_lag_, :1])
        y = np.asarray(y, dtype=np.float64).reshape(-1, 1)[: data.n_samples]
        return ModelResult(
            kind="simulation",
            time=np.asarray(data.time, dtype=np.float64),
            y=y,
            output_names=tuple(data.output_names),
            n_initial=self.max_lag_,
        )
