"""What a model run gives back, and the errors and warnings that say a run cannot be trusted.

- :class:`ModelResult`: the outputs of a prediction or a free run, with time, names, units, the
  band (if any) and what it is;
- :class:`NotFittedError`, :func:`check_is_fitted`: a model used before ``fit``;
- :class:`DivergenceError`: a free run that left the finite numbers or the divergence envelope
  of the training outputs (:data:`DIVERGENCE_SPANS`);
- :class:`ExtrapolationWarning`: a log that leaves the range the model was identified on;
- :class:`RunChecks`: what those checks found, when a compiled run counted them itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from sklearn.exceptions import NotFittedError as _SklearnNotFittedError

from neckid.data.iodata import IOData
from neckid.metrics import fit_percent, mae, rmse
from neckid.utils.types import FloatArray

__all__ = [
    "DIVERGENCE_SPANS",
    "EXTRAPOLATION_WARNING",
    "DivergenceError",
    "ExtrapolationWarning",
    "ModelResult",
    "NotFittedError",
    "RunChecks",
    "check_is_fitted",
]


class NotFittedError(_SklearnNotFittedError):
    """Raised when a model is used before ``fit``.

    A subclass of scikit-learn's ``NotFittedError`` (itself a ``ValueError`` and an
    ``AttributeError``), so scikit-learn's tools recognise it.
    """


def check_is_fitted(model: Any) -> None:
    """Raise :class:`NotFittedError` unless ``model`` is fitted (its ``__sklearn_is_fitted__``)."""
    fitted = getattr(model, "__sklearn_is_fitted__", None)
    if fitted is None or not fitted():
        raise NotFittedError(
            f"this {type(model).__name__} is not fitted yet; call fit(data) before using it"
        )


class ExtrapolationWarning(UserWarning):
    """A log leaves the range of values the model was identified on (see ``Estimator.extrapolation``)."""


#: Share of samples outside the training range above which a simulation warns.
EXTRAPOLATION_WARNING = 0.05

#: A free run whose output leaves its training range widened by this many times the range's
#: width on each side has run away: it raises :class:`DivergenceError` as a non-finite run does
#: (:meth:`Estimator.divergence_envelope`).
DIVERGENCE_SPANS = 10.0


class DivergenceError(ValueError, ArithmeticError):
    """A free run left the finite numbers (an unstable model, or a log far outside the data).

    The message names the first non-finite sample and its time; :attr:`result` holds the whole
    run, for a user who wants to look at it anyway.
    """

    def __init__(self, message: str, result: ModelResult) -> None:
        super().__init__(message)
        self.result = result


@dataclass(frozen=True)
class RunChecks:
    """What the per-sample checks of a free run found, counted by the run itself.

    A compiled free run that walks the samples anyway (``LinearARX.simulate`` with one output)
    counts what ``Estimator._result`` would otherwise find in passes of its own; it hands this
    over and ``_result`` reads it instead: the same numbers, the same warning and errors.

    Attributes
    ----------
    time : ndarray, shape (n_samples,)
        The result's time stamps (``IOData.time`` of the log), in seconds.
    extrapolation : dict of str to float
        ``Estimator.extrapolation(data)``: channel -> share of the samples outside its
        training range.
    domain : (float, dict of str to float) or None
        ``Estimator._domain_shares(data)``: the share of the samples outside the regressors'
        training box, and by term; None when not counted.
    first_non_finite : int or None
        The first sample from ``max_lag_`` on with a non-finite output.
    first_runaway : (int, int) or None
        ``Estimator.first_runaway(y, max_lag_)``: sample and output of the first value outside
        the divergence envelope.
    """

    time: FloatArray
    extrapolation: dict[str, float]
    domain: tuple[float, dict[str, float]] | None
    first_non_finite: int | None
    first_runaway: tuple[int, int] | None


@dataclass(frozen=True)
class ModelResult:
    """The output of ``predict`` or ``simulate``.

    Attributes
    ----------
    kind : {"prediction", "simulation"}
        One-step-ahead prediction (measured past outputs) or free-run simulation (own outputs).
    time : ndarray, shape (n_samples,)
        Seconds.
    y : ndarray, shape (n_samples, n_outputs)
        The model's output (the central estimate for Set Membership).
    output_names : tuple of str
        Names of the output channels.
    n_initial : int
        The first ``n_initial`` samples are the measured outputs (initial conditions), not model
        output; figures of merit skip them.
    lower, upper : ndarray, shape (n_samples, n_outputs), optional
        Guaranteed bounds beside the central estimate (Set Membership), ``None`` otherwise.
    extras : dict
        Model-specific series (the scheduled model's rate, gain and pole).
    output_units : tuple of str
        Unit of each output (``""`` when unknown).
    u : ndarray, shape (n_samples, n_inputs), optional
        The inputs the result was computed from.
    input_names, input_units : tuple of str
        Names and units of those inputs.
    """

    kind: Literal["prediction", "simulation"]
    time: FloatArray
    y: FloatArray
    output_names: tuple[str, ...]
    n_initial: int
    lower: FloatArray | None = None
    upper: FloatArray | None = None
    extras: dict[str, Any] = field(default_factory=dict)
    output_units: tuple[str, ...] = ()
    u: FloatArray | None = None
    input_names: tuple[str, ...] = ()
    input_units: tuple[str, ...] = ()

    @classmethod
    def from_data(
        cls,
        kind: Literal["prediction", "simulation"],
        data: IOData,
        y: FloatArray,
        n_initial: int,
        output_names: Sequence[str],
        output_units: Sequence[str] | None = None,
        lower: FloatArray | None = None,
        upper: FloatArray | None = None,
        extras: dict[str, Any] | None = None,
        time: FloatArray | None = None,
    ) -> ModelResult:
        """A result on the time base and inputs of ``data`` (outputs named by the model).

        ``time``, when given, is ``data.time`` already computed (by a compiled run).
        """
        units = tuple(output_units) if output_units is not None else ("",) * len(output_names)
        return cls(
            kind,
            data.time if time is None else time,
            y,
            tuple(output_names),
            int(n_initial),
            lower,
            upper,
            extras or {},
            units,
            data.u,
            tuple(data.input_names),
            tuple(data.input_units),
        )

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self.y.shape[0])

    def fit_percent(self, data: IOData | ArrayLike) -> FloatArray:
        """MATLAB ``compare`` fit per output against the measured outputs, skipping ``n_initial``."""
        y_true = data.y if isinstance(data, IOData) else np.asarray(data, dtype=np.float64)
        return fit_percent(y_true, self.y, skip=self.n_initial)

    def rmse(self, data: IOData | ArrayLike) -> FloatArray:
        """Root-mean-square error per output, skipping ``n_initial``."""
        y_true = data.y if isinstance(data, IOData) else np.asarray(data, dtype=np.float64)
        return rmse(y_true, self.y, skip=self.n_initial)

    def mae(self, data: IOData | ArrayLike) -> FloatArray:
        """Mean absolute error per output, skipping ``n_initial``."""
        y_true = data.y if isinstance(data, IOData) else np.asarray(data, dtype=np.float64)
        return mae(y_true, self.y, skip=self.n_initial)

    def to_frame(self) -> pd.DataFrame:
        """A DataFrame: time, the inputs, each output, and ``<name>_lower`` / ``<name>_upper``.

        ``frame.attrs`` keeps ``kind``, ``n_initial`` and ``units`` (channel -> unit, time in s).
        """
        columns: dict[str, FloatArray] = {"time": self.time}
        units = {"time": "s"}
        if self.u is not None:
            for j, n in enumerate(self.input_names):
                columns[n] = self.u[:, j]
                units[n] = self.input_units[j] if j < len(self.input_units) else ""
        for j, n in enumerate(self.output_names):
            unit = self.output_units[j] if j < len(self.output_units) else ""
            units[n] = unit
            columns[n] = self.y[:, j]
            if self.lower is not None and self.upper is not None:
                columns[f"{n}_lower"] = self.lower[:, j]
                columns[f"{n}_upper"] = self.upper[:, j]
                units[f"{n}_lower"] = units[f"{n}_upper"] = unit
        frame = pd.DataFrame(columns)
        frame.attrs["units"] = units
        frame.attrs["kind"] = self.kind
        frame.attrs["n_initial"] = self.n_initial
        return frame
