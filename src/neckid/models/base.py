"""What every identified model shares: the fitted check, results, the NARX loop, simulators.

Contracts (the architecture page, docs/architecture.md, shows where each part lives):

- ``fit(data)`` takes an :class:`~neckid.IOData` or a list of them and returns ``self``; learned
  values end in ``_``.
- ``predict(data)`` is one-step-ahead: the regressor uses the *measured* past outputs.
- ``simulate(data, initial=None)`` is a free run: the regressor uses the model's *own* past
  outputs. ``data`` may hold inputs only when ``initial`` gives the first ``max_lag_`` outputs.
- Both return a :class:`ModelResult` of the same length as ``data``; its first ``n_initial``
  samples (``n_initial = max_lag_``) are the measured (or given) outputs, used as initial
  conditions and skipped by :meth:`ModelResult.fit_percent`.
- ``simulator()`` gives an object with ``reset(y0, u0)`` and ``step(u) -> y`` for closed loops;
  after ``reset(y0=y[:max_lag_], u0=u[:max_lag_])``, stepping ``u[max_lag_:]`` gives what
  ``simulate`` gives.
- Hyper-parameters are keyword-only after ``lags`` and declared once in
  ``_parameter_constraints`` (checked at ``fit`` by :func:`neckid.utils.checks.validate_parameters`);
  a model is fitted when it has ``max_lag_`` (:meth:`Estimator.__sklearn_is_fitted__`).

Every estimator subclasses :class:`Estimator`; the contract test (``tests/test_contract.py``) runs
over every method of :func:`neckid.methods`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike
from sklearn.base import BaseEstimator

from neckid.data.iodata import IOData, as_experiments
from neckid.models.domain import Domain, box_shares, regressor_box, regressor_domain
from neckid.models.envelope import input_reach, reach_widening
from neckid.models.facts import ModelFacts
from neckid.models.io import ModelFile
from neckid.models.results import (
    DIVERGENCE_SPANS,
    EXTRAPOLATION_WARNING,
    DivergenceError,
    ExtrapolationWarning,
    ModelResult,
    NotFittedError,
    RunChecks,
    check_is_fitted,
)
from neckid.regressors import Lags, ResolvedLags
from neckid.systems import HistoryMap, StateMap, history_rows
from neckid.utils.checks import TIME_JITTER_TOLERANCE, check_finite, validate_parameters
from neckid.utils.types import FloatArray

__all__ = [
    "DIVERGENCE_SPANS",
    "EXTRAPOLATION_WARNING",
    "DivergenceError",
    "Estimator",
    "ExtrapolationWarning",
    "ModelResult",
    "NarxModel",
    "NarxSimulator",
    "NotFittedError",
    "check_is_fitted",
    "history_rows",
]


#: Largest magnitude a training value may have: its square times a record length stays finite.
LARGEST_VALUE = 1e150


class Estimator(BaseEstimator, ModelFile, ModelFacts):
    """What every neckid estimator shares (see the module docstring for the contract).

    What a fitted model tells about itself (its preprocessing, lags, training ranges, Set
    Membership prior, state order) is :class:`~neckid.models.facts.ModelFacts`.

    Subclasses declare ``_parameter_constraints`` (one entry per ``__init__`` argument), call
    :meth:`_validate_params` at the start of ``fit``, and set ``max_lag_``, ``ts_``,
    ``n_inputs_``, ``n_outputs_``, ``input_names_``, ``output_names_`` and ``output_units_``
    when fitted.
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {}

    #: True for output-error models, whose best one-step predictor is their free run: their
    #: ``predict`` returns a result of kind ``"simulation"`` and says so.
    predicts_by_simulation: ClassVar[bool] = False

    max_lag_: int
    ts_: float
    n_inputs_: int
    n_outputs_: int
    input_names_: tuple[str, ...]
    output_names_: tuple[str, ...]
    output_units_: tuple[str, ...]

    def __sklearn_is_fitted__(self) -> bool:
        """Whether ``fit`` has run (the one fitted check of every neckid model)."""
        return hasattr(self, "max_lag_")

    def _validate_params(self) -> None:
        validate_parameters(self)

    def _check_training(self, experiments: Sequence[IOData]) -> None:
        """Refuse training data with nothing to identify or values whose squares overflow.

        Records the range of every channel over the training data (``training_ranges_``).
        """
        if experiments[0].n_outputs == 0:
            raise ValueError("data has no output channel to identify")
        y = np.vstack([d.y for d in experiments])
        ranges: dict[str, tuple[float, float]] = {}
        constant = np.flatnonzero(np.ptp(y, axis=0) == 0)
        if constant.size:
            name = experiments[0].output_names[int(constant[0])]
            raise ValueError(
                f"output {name!r} is constant ({float(y[0, constant[0]]):g}) over the training data;"
                " there is nothing to identify"
            )
        for kind, names, values in (
            ("input", experiments[0].input_names, np.vstack([d.u for d in experiments])),
            ("output", experiments[0].output_names, y),
        ):
            if values.size == 0:
                continue
            peak = np.max(np.abs(values), axis=0)
            big = np.flatnonzero(peak > LARGEST_VALUE)
            if big.size:
                raise ValueError(
                    f"{kind} {names[int(big[0])]!r} reaches {peak[big[0]]:.3g}: sums of squares"
                    f" of values above {LARGEST_VALUE:.0e} overflow; rescale the channel (e.g. to"
                    " SI units)"
                )
            for j, name in enumerate(names):
                ranges[name] = (float(values[:, j].min()), float(values[:, j].max()))
        self.training_ranges_ = ranges

    def divergence_envelope(
        self, spans: float = DIVERGENCE_SPANS, data: IOData | None = None
    ) -> dict[str, tuple[float, float]]:
        """Per output, the values a free run may take: the training range widened on each side.

        ``[low − spans · (high − low), high + spans · (high − low)]`` of the output's training
        range, in its units. A free run that leaves it raises :class:`DivergenceError` (a run
        there is a runaway, not a prediction: no model here was identified on such values).
        With ``data``, each side widens further by what the log's inputs reaching beyond their
        training ranges can explain (:mod:`neckid.models.envelope`: the ℓ1 norm of a linear
        model's impulse response times the reach; a conservative relative extension for the
        other models), so that a model following its inputs is not taken for a runaway.

        Parameters
        ----------
        spans : float, default DIVERGENCE_SPANS (10)
            How many widths of the training range the envelope adds on each side.
        data : IOData, optional
            The log the free run reads (its inputs, conditions included); without it, the
            envelope for inputs inside their training ranges.

        Returns
        -------
        dict of str to (float, float)
            Output name -> (lowest, highest); empty for a model without training ranges (an
            old model file).

        Examples
        --------
        >>> import numpy as np
        >>> from neckid import IOData, Lags, LinearARX
        >>> u = np.sin(np.arange(200) / 10.0)
        >>> y = np.convolve(u, [0.0, 0.5, 0.25])[:200]
        >>> model = LinearARX(Lags.arx(1, 2)).fit(IOData(u, y, ts=0.1))
        >>> low, high = model.divergence_envelope(spans=1.0)["y"]
        >>> bool(low < y.min() and high > y.max())
        True
        """
        ranges: dict[str, tuple[float, float]] = getattr(self, "training_ranges_", {})
        names = [n for n in getattr(self, "output_names_", ()) if n in ranges]
        widths = np.array([ranges[n][1] - ranges[n][0] for n in names], dtype=np.float64)
        extra = np.zeros(len(names))
        if data is not None and names and data.n_inputs:
            reach = input_reach(ranges, data)
            if any(r > 0 for r, _ in reach.values()):
                gains = self._impulse_norms() if len(names) == self.n_outputs_ else None
                order = self.input_names_ if gains is not None else data.input_names
                extra = reach_widening(reach, order, widths, gains)
        return {
            name: (ranges[name][0] - spans * w - e, ranges[name][1] + spans * w + e)
            for name, w, e in zip(names, widths.tolist(), extra.tolist(), strict=True)
        }

    def _impulse_norms(self) -> FloatArray | None:
        """``||h_{o,i}||_1`` per output and input of a linear model (None: not a linear model).

        Over the inputs the model reads, in the order of its ``input_names_``; ``inf`` for an
        unstable one (:func:`neckid.models.envelope.impulse_l1`).
        """
        return None

    def _warn_extrapolation(
        self, data: IOData, result: ModelResult, checks: RunChecks | None = None
    ) -> None:
        """Record and warn about a log outside the channels' and regressors' training ranges.

        ``checks``: the shares as the run counted them (else counted here).
        """
        outside = self.extrapolation(data) if checks is None else checks.extrapolation
        result.extras["extrapolation"] = outside
        far = {k: v for k, v in outside.items() if v > EXTRAPOLATION_WARNING}
        terms: dict[str, float] = {}
        box = getattr(self, "regressor_ranges_", None)
        if box and data.n_outputs == self.n_outputs_ and data.n_samples > self.max_lag_:
            counted = None if checks is None else checks.domain
            share, by_term = self._domain_shares(data) if counted is None else counted
            result.extras["outside_domain"] = share
            terms = {k: v for k, v in by_term.items() if v > EXTRAPOLATION_WARNING}
        if far or terms:
            shares = ", ".join(f"{k} {v:.0%}" for k, v in far.items()) or "no channel"
            detail = ", ".join(f"{k} {v:.0%}" for k, v in terms.items())
            warnings.warn(
                f"{data.name or 'the log'} leaves the range the {type(self).__name__} was"
                f" identified on ({shares} of the samples outside it"
                + (f"; regressor terms outside their training range: {detail}" if detail else "")
                + "): expect a poor fit there",
                ExtrapolationWarning,
                stacklevel=4,
            )

    def _domain_shares(self, data: IOData) -> tuple[float, dict[str, float]]:
        """Share of the samples outside the regressors' training box, in all and by term.

        ``Domain.share`` and ``Domain.by_term`` of :func:`regressor_domain` (no nearest-regressor
        measure), counted in one compiled pass (:func:`~neckid.models.domain.box_shares`).
        """
        return box_shares(self, data)

    def first_runaway(
        self, y: FloatArray, start: int, data: IOData | None = None
    ) -> tuple[int, int] | None:
        """The first sample from ``start`` on where a run ``y`` leaves the divergence envelope.

        Returns ``(sample, output)``, or None when every output stays inside
        :meth:`divergence_envelope` (of the log ``data`` the run read, when given; non-finite
        values are not counted here).
        """
        envelope = self.divergence_envelope(data=data)
        first: tuple[int, int] | None = None
        for j, name in enumerate(self.output_names_):
            if name not in envelope:
                continue
            low, high = envelope[name]
            with np.errstate(invalid="ignore"):
                out = np.flatnonzero((y[start:, j] < low) | (y[start:, j] > high))
            if out.size and (first is None or out[0] + start < first[0]):
                first = (int(out[0]) + start, j)
        return first

    def _check_envelope(
        self, data: IOData, y: FloatArray, result: ModelResult, checks: RunChecks | None = None
    ) -> None:
        """Raise :class:`DivergenceError` if the free run ``y`` leaves the divergence envelope.

        ``checks``: the first runaway sample as the run found it (else looked for here).
        """
        first = (
            self.first_runaway(y, self.max_lag_, data) if checks is None else checks.first_runaway
        )
        if first is None:
            return
        row, j = first
        name, unit = self.output_names_[j], self.output_units_[j]
        low, high = self.divergence_envelope(data=data)[name]
        shown = f" {unit}" if unit else ""
        raise DivergenceError(
            f"the {type(self).__name__} free run ran away: output {name!r} = {y[row, j]:.4g}{shown}"
            f" at sample {row} (t = {data.time[row]:.6g} s) of {data.name or 'the log'} leaves"
            f" [{low:.4g}, {high:.4g}]{shown}, its training range widened {DIVERGENCE_SPANS:g}"
            " times its width on each side and by what the log's inputs beyond their training"
            " ranges can explain; the model is unstable, or the log leaves the region it was"
            " identified on (the whole run is in the exception's .result)",
            result,
        )

    def domain(self, data: IOData, *, nearest: bool = True) -> Domain:
        """Which samples of ``data`` lie outside the regressors this model was identified on.

        See :func:`neckid.models.domain.regressor_domain` (the training box of every regressor
        term and, for Set Membership models, the distance to the nearest training regressor).
        """
        check_is_fitted(self)
        return regressor_domain(self, data, nearest=nearest)

    def extrapolation(self, data: IOData) -> dict[str, float]:
        """Share of the samples of each channel of ``data`` outside the range seen in training.

        A model identified on 0–15° says little about a log that spends half its time at 30°:
        this is the first thing to look at when a fit is poor. Channels the model was not
        trained on (or a model built without data) are left out.

        Returns
        -------
        dict of str to float
            Channel name -> share in [0, 1].
        """
        ranges: dict[str, tuple[float, float]] = getattr(self, "training_ranges_", {})
        shares = {}
        for name in (*data.input_names, *data.output_names):
            if name in ranges:
                low, high = ranges[name]
                values = data.channel(name)
                shares[name] = float(np.mean((values < low) | (values > high)))
        return shares

    def _condition_names(self, fitting: bool = False) -> tuple[str, ...]:
        """The experimental conditions the model takes as inputs (from its lags)."""
        resolved = None if fitting else getattr(self, "lags_", None)
        if isinstance(resolved, ResolvedLags):
            return resolved.conditions
        lags = getattr(self, "lags", None)
        return lags.conditions if isinstance(lags, Lags) else ()

    def _with_conditions(self, data: Any, fitting: bool = False) -> Any:
        """``data`` (one log or a list) with the model's conditions appended as inputs.

        Every public entry point (``fit``, ``predict``, ``simulate``, ...) calls it first, so a
        log that carries ``conditions={"payload": 0.4}`` runs through a model identified with
        ``Lags(..., conditions=["payload"])`` as it is.
        """
        names = self._condition_names(fitting)
        if not names:
            return data
        if fitting:  # a label condition: one input per label of the training logs (one-hot)
            names = tuple(IOData.label_indicators(names, as_experiments(data)))
        if isinstance(data, IOData):
            return data.conditions_as_inputs(names)
        return [d.conditions_as_inputs(names) for d in as_experiments(data)]

    def _set_channels(self, data: IOData) -> None:
        self.input_names_ = tuple(data.input_names)
        self.output_names_ = tuple(data.output_names)
        self.output_units_ = tuple(data.output_units)
        self.input_units_ = tuple(data.input_units)
        self.n_inputs_ = data.n_inputs
        self.n_outputs_ = data.n_outputs
        self.ts_ = float(data.ts)

    def _channels_meta(self) -> dict[str, Any]:
        return {
            "input_names": list(self.input_names_),
            "output_names": list(self.output_names_),
            "output_units": list(self.output_units_),
            "input_units": list(getattr(self, "input_units_", ())),
            "training_ranges": {
                k: list(v) for k, v in getattr(self, "training_ranges_", {}).items()
            },
            "regressor_ranges": {
                k: list(v) for k, v in getattr(self, "regressor_ranges_", {}).items()
            },
        }

    def _restore_channels(self, meta: Any, lags: ResolvedLags | None = None) -> None:
        names = meta.get("output_names")
        self.output_names_ = tuple(names if names is not None else lags.output_names)  # type: ignore[union-attr]
        inputs = meta.get("input_names")
        self.input_names_ = tuple(inputs if inputs is not None else lags.input_names)  # type: ignore[union-attr]
        units = meta.get("output_units")
        self.output_units_ = tuple(units) if units is not None else ("",) * len(self.output_names_)
        # Model files written before input units were recorded: unknown ('') units.
        input_units = meta.get("input_units") or ("",) * len(self.input_names_)
        self.input_units_ = tuple(str(u) for u in input_units)
        self.n_inputs_ = len(self.input_names_)
        self.n_outputs_ = len(self.output_names_)
        ranges = meta.get("training_ranges") or {}
        self.training_ranges_ = {str(k): (float(v[0]), float(v[1])) for k, v in ranges.items()}
        # Model files written before the regressor ranges were recorded have none.
        terms = meta.get("regressor_ranges") or {}
        self.regressor_ranges_ = {str(k): (float(v[0]), float(v[1])) for k, v in terms.items()}

    def _check_inputs(self, data: IOData) -> None:
        ts = self.ts_
        if math.isfinite(ts) and abs(data.ts - ts) > TIME_JITTER_TOLERANCE * ts:
            raise ValueError(
                f"data is sampled every {data.ts:.6g} s but the model every {ts:.6g} s; a"
                " discrete-time model only runs at its own sampling period: resample the log"
                " (or identify a model at this period)"
            )
        if tuple(data.input_names) != self.input_names_:
            raise ValueError(
                f"data has inputs {list(data.input_names)}, but the model was fitted on"
                f" {list(self.input_names_)}; use data.select(inputs=...) to match"
            )
        if data.n_outputs and tuple(data.output_names) != self.output_names_:
            raise ValueError(
                f"data has outputs {list(data.output_names)}, but the model was fitted on"
                f" {list(self.output_names_)}; use data.select(outputs=...) to match"
            )
        model_units = (*getattr(self, "input_units_", ()), *self.output_units_)
        log_units = (*data.input_units, *(data.output_units if data.n_outputs else ()))
        names = (*data.input_names, *data.output_names)
        for name, ours, theirs in zip(names, model_units, log_units, strict=False):
            if ours and theirs and ours != theirs:
                raise ValueError(
                    f"{data.name or 'the log'} has {name} in {theirs}, but the model was"
                    f" identified with {name} in {ours}: convert the log's {name} to {ours}"
                    " (or identify a model in these units)"
                )

    def _initial_outputs(
        self, data: IOData, initial: ArrayLike | None, *, filled: bool = True
    ) -> FloatArray:
        """The output array a free run starts from: ``(n_samples, n_outputs)``.

        Its first ``max_lag_`` rows are the initial conditions: ``initial`` when given (one row,
        repeated, or ``max_lag_`` rows, oldest first), else the measured outputs of ``data``.
        The other rows are the measured outputs when there are any, zeros otherwise; a free run
        overwrites them (``filled=False`` leaves them unset, for a free run that writes every
        one: no copy of the measured outputs).
        """
        self._check_inputs(data)
        m = self.max_lag_
        if data.n_samples <= m:
            raise ValueError(
                f"data has {data.n_samples} samples, too few for lags up to {m}: it needs at least"
                f" {m + 1}"
            )
        if initial is None and data.n_outputs == 0:
            raise ValueError(
                f"data holds inputs only: give initial= the first {m} output sample(s),"
                f" shape ({self.n_outputs_},) or ({m}, {self.n_outputs_})"
            )
        if not filled:
            y = np.empty((data.n_samples, self.n_outputs_))
            if initial is None:
                y[:m] = data.y[:m]
        elif data.n_outputs:
            y = np.array(data.y, dtype=np.float64)
        else:
            y = np.zeros((data.n_samples, self.n_outputs_))
        if initial is not None:
            rows = history_rows(initial, max(m, 1), self.n_outputs_, "initial")
            y[:m] = rows[-m:] if m else y[:0]
        return y

    def _result(
        self,
        kind: Literal["prediction", "simulation"],
        data: IOData,
        y: FloatArray,
        lower: FloatArray | None = None,
        upper: FloatArray | None = None,
        extras: dict[str, Any] | None = None,
        checks: RunChecks | None = None,
    ) -> ModelResult:
        """The result of a run, checked: the extrapolation warning, divergence errors.

        ``checks`` (a compiled run's own counts, :class:`~neckid.models.results.RunChecks`)
        replaces the passes over the samples these checks make otherwise.
        """
        result = ModelResult.from_data(
            kind,
            data,
            y,
            self.max_lag_,
            self.output_names_,
            self.output_units_,
            lower,
            upper,
            extras,
            None if checks is None else checks.time,
        )
        if kind == "simulation":
            self._warn_extrapolation(data, result, checks)
        if checks is None:
            bad = np.flatnonzero(~np.isfinite(y[self.max_lag_ :]).all(axis=1))
            row = int(bad[0]) + self.max_lag_ if bad.size else None
        else:
            row = checks.first_non_finite
        if row is not None:
            what = "free run" if kind == "simulation" else "prediction"
            raise DivergenceError(
                f"the {type(self).__name__} {what} diverged: output {y[row].tolist()} at sample"
                f" {row} (t = {data.time[row]:.6g} s) of {data.name or 'the log'} is not finite;"
                " the model is unstable, or the log leaves the region it was identified on"
                " (the whole run is in the exception's .result)",
                result,
            )
        if kind == "simulation":
            self._check_envelope(data, y, result, checks)
        return result

    def _check_state(self) -> None:
        """Check a loaded model's values (``load_model`` calls it); raise ``ValueError`` naming them."""
        validate_parameters(self)
        if not (math.isnan(self.ts_) or (math.isfinite(self.ts_) and self.ts_ > 0)):
            raise ValueError(f"ts must be a positive number of seconds; got {self.ts_!r}")
        if isinstance(self.max_lag_, bool) or not isinstance(self.max_lag_, int | np.integer):
            raise ValueError(f"max_lag must be a whole number; got {self.max_lag_!r}")
        if self.n_outputs_ < 1 or len(self.output_units_) != self.n_outputs_:
            raise ValueError(
                f"output_names {list(self.output_names_)} and output_units"
                f" {list(self.output_units_)} must be non-empty and of the same length"
            )

    @staticmethod
    def _check_shape(name: str, array: Any, shape: tuple[int, ...]) -> None:
        """Refuse a learned array of the wrong shape or with a non-finite value."""
        if np.shape(array) != shape:
            raise ValueError(f"{name} must have shape {shape}; got {np.shape(array)}")
        if not np.all(np.isfinite(array)):
            raise ValueError(f"{name} holds a non-finite value")

    def fit_percent(self, data: IOData) -> FloatArray:
        """Free-run NRMSE fit [%] per output on ``data`` (MATLAB ``compare``)."""
        return self.simulate(data).fit_percent(data)

    def simulate(
        self, data: IOData, initial: ArrayLike | None = None
    ) -> ModelResult:  # pragma: no cover - every estimator implements it
        """Free-run simulation (see the module docstring for the contract)."""
        raise NotImplementedError

    def state_map(self, bounds: bool = False) -> StateMap:
        """The model's state functions, for python-control (:func:`neckid.export.control.to_iosystem`).

        The generic map (:class:`~neckid.systems.HistoryMap`): the state is the simulator's
        history, ``x = [y(t−m), …, y(t−1), u(t−m), …, u(t−1)]`` with
        ``m = max(max_lag_, 1)``, in the output and input units. Models whose simulator keeps
        something else give their own map.

        Parameters
        ----------
        bounds : bool, default False
            Add the outputs ``<output>_lower`` and ``<output>_upper`` (the step's band) when the
            simulator has ``step_bounds``; ignored otherwise.

        Returns
        -------
        StateMap
            A :class:`~neckid.systems.HistoryMap` here.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        """
        check_is_fitted(self)
        return HistoryMap(self, bounds)


def _stacked_rows(
    resolved: ResolvedLags, experiments: Sequence[IOData]
) -> tuple[FloatArray, FloatArray]:
    """The regressor rows and targets of several experiments, one block of rows after the other.

    Each experiment's rows are built (:meth:`ResolvedLags.build_one`, which refuses one too short
    for the lags, before anything is allocated here) and copied into its block at once.
    """
    sizes = [d.n_samples - resolved.max_lag for d in experiments]
    for d, size in zip(experiments, sizes, strict=True):
        if size < 1:
            resolved.build_one(d)  # raises, naming the record
    x = np.empty((sum(sizes), resolved.n_terms))
    y = np.empty((sum(sizes), len(resolved.output_names)))
    first = 0
    for d, size in zip(experiments, sizes, strict=True):
        x[first : first + size], y[first : first + size] = resolved.build_one(d)
        first += size
    return x, y


class NarxModel(Estimator):
    """Base class of the models whose one-step map is ``y(t) = f(w(t))`` over a :class:`Lags` regressor.

    Subclasses implement ``_fit_regression(x, y)`` (set learned attributes) and
    ``_predict_rows(x) -> y`` (the map on a regressor matrix). ``fit``, ``predict``, ``simulate``
    and ``simulator`` come from here; a subclass may replace ``simulate`` with a compiled loop.
    """

    lags: Lags | None

    # ------------------------------------------------------------------ to implement
    def _fit_regression(self, x: FloatArray, y: FloatArray) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _predict_rows(self, x: FloatArray) -> FloatArray:  # pragma: no cover - abstract
        raise NotImplementedError

    # ------------------------------------------------------------------ shared
    def _narx_meta(self) -> dict[str, Any]:
        """What every NARX model file stores besides its own arrays."""
        check_is_fitted(self)
        return {
            "lags": self.lags_.to_dict(),
            "ts": self.ts_,
            "n_samples": self.n_samples_,
            **self._channels_meta(),
        }

    def _restore_narx_meta(self, meta: Any) -> None:
        self.lags_ = ResolvedLags.from_dict(meta["lags"])
        self.lags = self.lags_.to_lags()
        self._restore_channels(meta, self.lags_)
        self.ts_ = float(meta["ts"])
        self.n_samples_ = int(meta["n_samples"])
        self.max_lag_ = self.lags_.max_lag

    def _check_state(self) -> None:
        super()._check_state()
        if self.max_lag_ != self.lags_.max_lag or self.n_samples_ < 1:
            raise ValueError(
                f"max_lag {self.max_lag_!r} and n_samples {self.n_samples_!r} do not fit the lags"
                f" {self.lags_.to_lags()!r}"
            )

    def _lags(self) -> Lags:
        if self.lags is None:
            raise ValueError(f"{type(self).__name__} needs lags=Lags(...); got None")
        if not isinstance(self.lags, Lags):
            raise TypeError(f"lags must be a neckid.Lags; got {type(self.lags).__name__}")
        return self.lags

    def _prepare_fit(self, data: IOData | Sequence[IOData]) -> tuple[FloatArray, FloatArray]:
        """Check the settings and the data; return the training regressor rows and their targets.

        ``x`` is a new array that the caller may take over (Set Membership scales and reorders
        it in place). ``y`` may be a read-only view of the data's outputs (one experiment): a
        caller must not write into it. Several experiments are built one after the other into
        one preallocated pair of arrays, so that only one experiment's rows exist twice at a
        time (not every experiment's rows and their stack).
        """
        self._validate_params()
        experiments = as_experiments(self._with_conditions(data, fitting=True))
        lags = self._lags()
        resolved = lags.resolve(experiments)
        self._check_training(experiments)
        if len(experiments) == 1:
            x, y = resolved.build_one(experiments[0])
        else:
            x, y = _stacked_rows(resolved, experiments)
        self.lags_ = resolved
        self._set_channels(experiments[0])
        self.n_samples_ = int(x.shape[0])
        self.regressor_ranges_ = regressor_box(x, resolved.names)
        return x, y

    def _mark_fitted(self) -> None:
        self.max_lag_ = self.lags_.max_lag

    def fit(self, data: IOData | Sequence[IOData]) -> NarxModel:
        """Fit the model on one experiment or a list of them (regressors never straddle two)."""
        x, y = self._prepare_fit(data)
        self._fit_regression(x, y)
        self._mark_fitted()
        return self

    def predict(self, data: IOData) -> ModelResult:
        """One-step-ahead prediction: the regressor holds the measured past outputs."""
        check_is_fitted(self)
        data = self._with_conditions(data)
        self._check_inputs(data)
        x, _ = self.lags_.build_one(data)
        y = np.array(data.y, dtype=np.float64)
        y[self.lags_.max_lag :] = self._predict_rows(x)
        return self._result("prediction", data, y)

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free-run simulation: the regressor holds the model's own past outputs.

        Parameters
        ----------
        data : IOData
            The inputs; its first ``max_lag_`` measured outputs are the initial conditions unless
            ``initial`` is given (then ``data`` may hold inputs only).
        initial : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
            The first outputs (oldest first; one row is repeated).
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y0 = self._initial_outputs(data, initial)
        with np.errstate(over="ignore", invalid="ignore"):  # divergence is reported below
            y = _free_run(self.lags_, self._predict_rows, data.u, y0)
        return self._result("simulation", data, y)

    def simulator(self) -> NarxSimulator:
        """A stateful simulator with ``reset(y0=..., u0=...)`` and ``step(u) -> y``."""
        check_is_fitted(self)
        return NarxSimulator(self.lags_, self._predict_rows)


def _free_run(
    resolved: ResolvedLags, predict_rows: Any, u: FloatArray, y_measured: FloatArray
) -> FloatArray:
    """Plain free-run loop; ``predict_rows`` maps ``(1, n_terms) -> (1, n_outputs)``."""
    n = u.shape[0]
    m = resolved.max_lag
    if n <= m:
        raise ValueError(
            f"data has {n} samples, too few for lags up to {m}: it needs at least {m + 1}"
        )
    y = np.array(y_measured, dtype=np.float64)
    for t in range(m, n):
        w = resolved.regressor_from_history(y, u, t)
        y[t] = predict_rows(w[None, :])[0]
    return y


def stepped_run(
    simulator: Any, u: FloatArray, y0: FloatArray, m: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Free run by a simulator with ``step_bounds``: ``(y, lower, upper)`` from the initial rows.

    The simulator is reset on the first ``m`` rows of ``y0`` and ``u``; the bounds of those rows
    are NaN. Overflow is not reported here (the caller's result checks for divergence).
    """
    y = np.array(y0, dtype=np.float64)
    lower, upper = np.full(y.shape, np.nan), np.full(y.shape, np.nan)
    simulator.reset(y0=y[:m] if m else None, u0=u[:m] if m else None)
    with np.errstate(over="ignore", invalid="ignore"):
        for t in range(m, y.shape[0]):
            y[t], lower[t], upper[t] = simulator.step_bounds(u[t])
    return y, lower, upper


class NarxSimulator:
    """Step-by-step free run of a NARX map, for use in a closed loop next to a controller.

    ``reset(y0, u0)`` fills the history with the initial outputs (and inputs); ``step(u)`` takes the
    input at the current time ``t`` and returns the model output ``y(t)``.
    """

    def __init__(self, resolved: ResolvedLags, predict_rows: Any) -> None:
        self._resolved = resolved
        self._predict_rows = predict_rows
        self.n_inputs = len(resolved.input_names)
        self.n_outputs = len(resolved.output_names)
        self.reset()

    def reset(self, y0: ArrayLike | None = None, u0: ArrayLike | None = None) -> None:
        """Start again from a constant history.

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (max_lag, n_outputs), optional
            Past outputs (oldest first); a single row is repeated. Default zeros.
        u0 : array_like, shape (n_inputs,) or (max_lag, n_inputs), optional
            Past inputs (oldest first); a single row is repeated. Default zeros.
        """
        m = max(self._resolved.max_lag, 1)
        self._y = history_rows(y0, m, self.n_outputs, "y0")
        self._u = history_rows(u0, m, self.n_inputs, "u0")

    def _input_row(self, u: ArrayLike) -> FloatArray:
        """The input of one step as a checked row: ``n_inputs`` finite values."""
        u_now = np.asarray(u, dtype=np.float64).reshape(-1)
        if u_now.shape[0] != self.n_inputs:
            raise ValueError(
                f"u must have {self.n_inputs} values (one per input); got {u_now.shape[0]}"
            )
        check_finite(u_now[None, :], "u")
        return u_now

    def step(self, u: ArrayLike) -> FloatArray:
        """Advance one sample with input ``u`` (shape ``(n_inputs,)``); return ``y`` (``(n_outputs,)``)."""
        u_now = self._input_row(u)
        u_hist = np.vstack([self._u, u_now[None, :]])
        y_hist = np.vstack([self._y, np.zeros((1, self.n_outputs))])
        t = u_hist.shape[0] - 1
        w = self._resolved.regressor_from_history(y_hist, u_hist, t)
        y_now = np.asarray(self._predict_rows(w[None, :])[0], dtype=np.float64)
        self._u = u_hist[1:]
        y_hist[-1] = y_now
        self._y = y_hist[1:]
        return y_now.copy()
