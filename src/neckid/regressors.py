"""Lags: which past samples of which signal form a NARX regressor.

A NARX model predicts every output at time ``t`` from a regressor

    w(t) = [y_1(t - l) for l in output lags of y_1, ..., u_1(t - l) for l in input lags of u_1, ...]

Output lags are >= 1 (the output at ``t`` is the target). Input lags are >= 0 (lag 0, the input at
``t`` itself, is allowed: the seed paper's eq. 1 includes u(t)).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from neckid.data.iodata import IOData, as_experiments
from neckid.utils.checks import check_lag_list
from neckid.utils.memory import check_allocation

__all__ = ["Lags", "ResolvedLags"]

LagSpec = int | Sequence[int] | Mapping[str, int | Sequence[int]] | None


def _lag_list(
    value: int | Sequence[int], argument: str, minimum: int, int_means_from: int
) -> tuple[int, ...]:
    if isinstance(value, bool):
        raise TypeError(f"{argument} must be an int or a list of ints; got {value!r}")
    if isinstance(value, int | np.integer):
        n = int(value)
        if n < 0:
            raise ValueError(f"{argument} must be >= 0 when given as an order; got {n}")
        return tuple(range(int_means_from, int_means_from + n))
    if isinstance(value, str | bytes) or not hasattr(value, "__iter__"):
        raise TypeError(f"{argument} must be an int or a list of ints; got {value!r}")
    return check_lag_list(list(value), argument, minimum)


@dataclass(frozen=True)
class ResolvedLags:
    """Lags bound to the channels of a data set: one row per regressor term.

    Attributes
    ----------
    source : ndarray of int, shape (n_terms,)
        0 for an output term, 1 for an input term.
    channel : ndarray of int, shape (n_terms,)
        Index of the channel among the outputs or inputs.
    lag : ndarray of int, shape (n_terms,)
        How many samples back.
    names : tuple of str
        Human-readable term names such as ``"incl(t-1)"``.
    input_names, output_names : tuple of str
        The channels the lags were resolved against.
    max_lag : int
        Largest lag; the first ``max_lag`` samples of a record are initial conditions.
    conditions : tuple of str
        The inputs that are experimental conditions (constant per experiment, lag 0), made from
        a log's conditions by :meth:`neckid.IOData.conditions_as_inputs`.
    """

    source: NDArray[np.int64]
    channel: NDArray[np.int64]
    lag: NDArray[np.int64]
    names: tuple[str, ...]
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]
    max_lag: int
    conditions: tuple[str, ...] = ()

    @property
    def n_terms(self) -> int:
        """Number of regressor components."""
        return len(self.names)

    def check_compatible(self, data: IOData, argument: str = "data") -> None:
        """Raise ``ValueError`` when ``data`` lacks the channels these lags were built for."""
        if data.input_names != self.input_names or data.output_names != self.output_names:
            raise ValueError(
                f"{argument} has channels {list(data.input_names)} -> {list(data.output_names)}, but the"
                f" model was fitted on {list(self.input_names)} -> {list(self.output_names)};"
                " use data.select(inputs=..., outputs=...) to match"
            )

    def build_one(self, data: IOData) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Regressors and targets of one experiment: rows ``t = max_lag .. n_samples - 1``."""
        self.check_compatible(data)
        n = data.n_samples
        rows = n - self.max_lag
        if rows < 1:
            raise ValueError(
                f"{data.name or 'the record'} has {n} samples, too few for lags up to {self.max_lag}:"
                f" it needs at least {self.max_lag + 1}"
            )
        check_allocation(
            16.0 * rows * self.n_terms,  # the matrix and one copy (stacking experiments)
            f"the regressor of {data.name or 'the record'} ({rows:,} rows x {self.n_terms:,}"
            " terms)",
            "use fewer lags, or fewer or shorter logs (or resample them to a longer period)",
        )
        x = np.empty((rows, self.n_terms))
        start = self.max_lag
        for j in range(self.n_terms):
            signal = data.y if self.source[j] == 0 else data.u
            lag = int(self.lag[j])
            x[:, j] = signal[start - lag : n - lag, self.channel[j]]
        return x, np.ascontiguousarray(data.y[start:])

    def regressor_from_history(
        self, y_hist: NDArray[np.float64], u_hist: NDArray[np.float64], t: int
    ) -> NDArray[np.float64]:
        """The regressor at time ``t`` from output and input histories (rows are time)."""
        out = np.empty(self.n_terms)
        for j in range(self.n_terms):
            signal = y_hist if self.source[j] == 0 else u_hist
            out[j] = signal[t - self.lag[j], self.channel[j]]
        return out

    def to_lags(self) -> Lags:
        """The :class:`Lags` (per channel, by name) that resolve to these terms."""
        outputs: dict[str, list[int]] = {n: [] for n in self.output_names}
        inputs: dict[str, list[int]] = {n: [] for n in self.input_names}
        for s, c, lag in zip(self.source, self.channel, self.lag, strict=True):
            if s == 0:
                outputs[self.output_names[c]].append(int(lag))
            else:
                inputs[self.input_names[c]].append(int(lag))
        return Lags(outputs=outputs, inputs=inputs, conditions=self.conditions)

    def to_dict(self) -> dict[str, object]:
        """JSON-serialisable description (for model files)."""
        return {
            "source": self.source.tolist(),
            "channel": self.channel.tolist(),
            "lag": self.lag.tolist(),
            "names": list(self.names),
            "input_names": list(self.input_names),
            "output_names": list(self.output_names),
            "max_lag": self.max_lag,
            "conditions": list(self.conditions),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, object]) -> ResolvedLags:
        """Inverse of :meth:`to_dict`."""
        return cls(
            source=np.asarray(d["source"], dtype=np.int64),
            channel=np.asarray(d["channel"], dtype=np.int64),
            lag=np.asarray(d["lag"], dtype=np.int64),
            names=tuple(d["names"]),  # type: ignore[arg-type]
            input_names=tuple(d["input_names"]),  # type: ignore[arg-type]
            output_names=tuple(d["output_names"]),  # type: ignore[arg-type]
            max_lag=int(d["max_lag"]),  # type: ignore[call-overload]
            conditions=tuple(d.get("conditions") or ()),  # type: ignore[arg-type]
        )


class Lags:
    """Which past samples of which signal form a NARX regressor.

    Parameters
    ----------
    outputs : int, sequence of int, or mapping of str to int/sequence, default 0
        Output lags (each >= 1). An int ``n`` means lags ``1..n`` of every output; a list means those
        lags of every output; a mapping gives lags per output channel by name (channels not named get
        none).
    inputs : int, sequence of int, or mapping of str to int/sequence, default 0
        Input lags (each >= 0). An int ``n`` means lags ``1..n`` of every input (one sample of delay);
        a list means those lags of every input; a mapping gives lags per input channel by name.
    conditions : sequence of str, default ()
        Experimental conditions (``IOData.conditions``, e.g. ``"payload"``) used as extra inputs:
        each is a constant input of lag 0 (whatever ``inputs`` says), added to the log by the
        model (:meth:`neckid.IOData.conditions_as_inputs`) when it fits, predicts or simulates.

    Examples
    --------
    The seed paper's regressor ``w(t) = [y(t-1..t-3), u1(t-8..t-10), u2(t-8..t-10), u3(t-8..t-10)]``:

    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> lags = Lags(outputs=3, inputs=[8, 9, 10])
    >>> data = IOData(u=np.random.default_rng(0).normal(size=(50, 3)), y=np.zeros(50), ts=0.02)
    >>> x, y = lags.build(data)
    >>> x.shape, y.shape, lags.max_lag
    ((40, 12), (40, 1), 10)
    >>> lags.resolve(data).names[:4]
    ('y(t-1)', 'y(t-2)', 'y(t-3)', 'u1(t-8)')
    >>> Lags.arx(na=2, nb=2, delay=1)
    Lags(outputs=[1, 2], inputs=[1, 2])

    A payload mass as a constant extra input:

    >>> run = data.with_conditions(payload=0.4)
    >>> Lags(2, 1, conditions=["payload"]).resolve(run.conditions_as_inputs(["payload"])).names
    ('y(t-1)', 'y(t-2)', 'u1(t-1)', 'u2(t-1)', 'u3(t-1)', 'payload(t)')
    """

    def __init__(
        self, outputs: LagSpec = 0, inputs: LagSpec = 0, conditions: Sequence[str] | None = ()
    ) -> None:
        self.outputs = self._normalise(outputs, "outputs", minimum=1)
        self.inputs = self._normalise(inputs, "inputs", minimum=0)
        conditions = () if conditions is None else conditions  # None: no condition
        if isinstance(conditions, str) or not all(isinstance(c, str) for c in conditions):
            raise TypeError(f"conditions must be a list of names (str); got {conditions!r}")
        if len(set(conditions)) != len(tuple(conditions)):
            raise ValueError(f"conditions names a condition twice: {list(conditions)}")
        self.conditions = tuple(conditions)
        if self.max_lag == 0 and not self._has_terms():
            raise ValueError("Lags has no term at all; give output lags, input lags or both")

    def conditioned(self, data: IOData | Sequence[IOData]) -> IOData | Sequence[IOData]:
        """``data`` with this regressor's conditions as inputs, as a model adds them when it fits.

        A label condition becomes its one-hot inputs over the logs given
        (:meth:`neckid.IOData.label_indicators`); conditions that are inputs already, or no
        conditions, leave ``data`` as it is. What :meth:`resolve` and :meth:`build` need when a
        caller holds logs whose conditions are still conditions.
        """
        if not self.conditions:
            return data
        logs = as_experiments(data)
        if all(c in logs[0].input_names for c in self.conditions):
            return data
        names = IOData.label_indicators(self.conditions, logs)
        if all(n in logs[0].input_names for n in names):
            return data
        if isinstance(data, IOData):
            return data.conditions_as_inputs(names)
        return [d.conditions_as_inputs(names) for d in logs]

    @staticmethod
    def _normalise(
        spec: LagSpec, argument: str, minimum: int
    ) -> tuple[int, ...] | dict[str, tuple[int, ...]]:
        if spec is None:
            return ()
        if isinstance(spec, Mapping):
            return {
                str(k): _lag_list(v, f"{argument}[{k!r}]", minimum, int_means_from=1)
                for k, v in spec.items()
            }
        return _lag_list(spec, argument, minimum, int_means_from=1)

    @classmethod
    def arx(cls, na: int, nb: int, delay: int = 1) -> Lags:
        """ARX orders: outputs ``1..na``, inputs ``delay..delay+nb-1`` for every channel."""
        for arg, value, low in (("na", na, 0), ("nb", nb, 0), ("delay", delay, 0)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise TypeError(f"{arg} must be an int; got {value!r}")
            if value < low:
                raise ValueError(f"{arg} must be >= {low}; got {value}")
        return cls(outputs=list(range(1, na + 1)), inputs=list(range(delay, delay + nb)))

    def _has_terms(self) -> bool:
        def any_terms(spec: tuple[int, ...] | dict[str, tuple[int, ...]]) -> bool:
            if isinstance(spec, dict):
                return any(len(v) for v in spec.values())
            return len(spec) > 0

        return any_terms(self.outputs) or any_terms(self.inputs)

    @property
    def max_lag(self) -> int:
        """The largest lag of any term (0 if only lag-0 inputs)."""
        values: list[int] = []
        for spec in (self.outputs, self.inputs):
            if isinstance(spec, dict):
                for v in spec.values():
                    values.extend(v)
            else:
                values.extend(spec)
        return max(values, default=0)

    def __repr__(self) -> str:
        def show(spec: tuple[int, ...] | dict[str, tuple[int, ...]]) -> str:
            if isinstance(spec, dict):
                return repr({k: list(v) for k, v in spec.items()})
            return repr(list(spec))

        extra = f", conditions={list(self.conditions)}" if self.conditions else ""
        return f"Lags(outputs={show(self.outputs)}, inputs={show(self.inputs)}{extra})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Lags):
            return NotImplemented
        return (
            self.outputs == other.outputs
            and self.inputs == other.inputs
            and self.conditions == other.conditions
        )

    __hash__ = None  # type: ignore[assignment]

    def resolve(self, data: IOData | Sequence[IOData]) -> ResolvedLags:
        """Bind the lags to the channels of ``data`` (names are checked here).

        The conditions must be inputs of ``data`` already (``data.conditions_as_inputs``); they
        get lag 0 and no other. A label condition (``neck="A"``) is there as its one-hot
        indicator inputs ``neck=A``, ``neck=B``, ...; the resolved conditions name those.
        """
        first = as_experiments(data)[0]
        conditions: list[str] = []
        missing = []
        for condition in self.conditions:
            indicators = [n for n in first.input_names if n.startswith(f"{condition}=")]
            if condition in first.input_names:
                conditions.append(condition)
            elif indicators:
                conditions.extend(indicators)
            else:
                missing.append(condition)
        if missing:
            raise KeyError(
                f"Lags uses condition {missing[0]!r}, which is not an input of the data; make it"
                f" one with data.conditions_as_inputs({list(self.conditions)})"
            )
        source: list[int] = []
        channel: list[int] = []
        lag: list[int] = []
        names: list[str] = []
        for kind, spec, channel_names, argument in (
            (0, self.outputs, first.output_names, "outputs"),
            (1, self.inputs, first.input_names, "inputs"),
        ):
            if isinstance(spec, dict):
                unknown = [k for k in spec if k not in channel_names]
                if unknown:
                    raise KeyError(
                        f"Lags {argument} names {unknown[0]!r}, which is not an {argument[:-1]} of the"
                        f" data; its {argument} are {list(channel_names)}"
                    )
                per_channel = [spec.get(n, ()) for n in channel_names]
            else:
                per_channel = [spec] * len(channel_names)
            if kind == 1:
                per_channel = [
                    (0,) if n in conditions else lags
                    for n, lags in zip(channel_names, per_channel, strict=True)
                ]
            for c, (n, lags) in enumerate(zip(channel_names, per_channel, strict=True)):
                for lg in lags:
                    source.append(kind)
                    channel.append(c)
                    lag.append(lg)
                    names.append(f"{n}(t)" if lg == 0 else f"{n}(t-{lg})")
        if not names:
            raise ValueError(
                f"{self!r} gives no regressor term for data with inputs {list(first.input_names)}"
                f" and outputs {list(first.output_names)}"
            )
        return ResolvedLags(
            source=np.asarray(source, dtype=np.int64),
            channel=np.asarray(channel, dtype=np.int64),
            lag=np.asarray(lag, dtype=np.int64),
            names=tuple(names),
            input_names=first.input_names,
            output_names=first.output_names,
            max_lag=max(lag),
            conditions=tuple(conditions),
        )

    def build(
        self, data: IOData | Sequence[IOData]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Regressor matrix and targets, stacked over experiments (no row mixes two of them).

        Returns
        -------
        x : ndarray, shape (n_rows, n_terms)
            One regressor per row, for ``t = max_lag .. n_samples - 1`` of each experiment.
        y : ndarray, shape (n_rows, n_outputs)
            The outputs at those ``t``.

        Raises
        ------
        ValueError
            If an experiment is shorter than ``max_lag + 1`` samples.
        """
        experiments = [d.conditions_as_inputs(self.conditions) for d in as_experiments(data)]
        resolved = self.resolve(experiments)
        parts = [resolved.build_one(d) for d in experiments]
        return np.vstack([p[0] for p in parts]), np.vstack([p[1] for p in parts])
