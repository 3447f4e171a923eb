r"""Preprocessing that travels with a model: small steps on an :class:`~neckid.IOData`, in order.

A model identified on preprocessed logs only makes sense on logs preprocessed the same way: the
benchmark's motor *displacement* (the motor position minus its first sample, because the encoder
zero and the tendon slack differ between runs) is one case. A :class:`Pipeline` of steps says what
was done; it is plain JSON (:meth:`Pipeline.to_list`), stored in the model file and applied again
to every new log (``neckid validate``, ``simulate``, ``info --model``;
:func:`neckid.cli.workflow.prepare_log` in Python).

The steps (channels are named as the model names them, after any ``--map``; time in seconds):

- :class:`Relative`: a channel minus its value at the log's first sample;
- :class:`RemoveOffset`: a channel minus its mean over a rest window;
- :class:`LowPass`: a first-order low-pass filter, Tustin (bilinear) discretisation;
- :class:`Resample`: linear interpolation onto another sampling period;
- :class:`Restamp`: what to do with repeated time stamps when a log is read;
- :class:`Tilt`: the wrap-free tilt vector from inclination and orientation outputs
  (:func:`neckid.data.tilt.tilt_log`).

Every step is immutable, returns a new log and never changes the one it is given.

Examples
--------
>>> import numpy as np
>>> from neckid import IOData
>>> from neckid.data.preprocess import Pipeline, Relative
>>> log = IOData(u=[1.5, 2.5, 3.5], y=[0.0, 1.0, 2.0], ts=0.025,
...              input_names=["motor_position"], output_names=["inclination"])
>>> pipeline = Pipeline([Relative("motor_position")])
>>> pipeline.apply(log).channel("motor_position")
array([0., 1., 2.])
>>> pipeline.to_list()
[{'step': 'relative', 'channel': 'motor_position'}]
>>> Pipeline.from_list(pipeline.to_list()) == pipeline
True
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Literal, TypeVar, overload

import numpy as np

from neckid.data.iodata import IOData
from neckid.utils.memory import check_allocation
from neckid.utils.types import FloatArray

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "STEPS",
    "LowPass",
    "Pipeline",
    "Relative",
    "RemoveOffset",
    "Resample",
    "Restamp",
    "Step",
    "Tilt",
]

StepT = TypeVar("StepT", bound="Step")


def _text(kind: str, key: str, value: object) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ValueError(
            f"preprocessing step {kind!r}: {key!r} must be a channel name (non-empty text); got"
            f" {value!r}"
        )
    return value


def _number(kind: str, key: str, value: object, unit: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ValueError(
            f"preprocessing step {kind!r}: {key!r} must be a number of {unit}; got {value!r}"
        )
    number = float(value)
    if not math.isfinite(number) or (positive and number <= 0):
        need = "a positive" if positive else "a finite"
        raise ValueError(
            f"preprocessing step {kind!r}: {key!r} must be {need} number of {unit}; got {value!r}"
        )
    return number


def _choice(kind: str, key: str, value: object, choices: Sequence[str]) -> str:
    if value not in choices:
        raise ValueError(
            f"preprocessing step {kind!r}: {key!r} must be one of {list(choices)}; got {value!r}"
        )
    return str(value)


def _replace_channel(data: IOData, name: str, values: FloatArray) -> IOData:
    """``data`` with channel ``name`` (an input or an output) holding ``values``."""
    if name in data.input_names:
        u = np.array(data.u, dtype=np.float64)
        u[:, data.input_names.index(name)] = values
        return data.replace(u=u)
    y = np.array(data.y, dtype=np.float64)
    y[:, data.output_names.index(name)] = values
    return data.replace(y=y)


def _column(data: IOData, name: str, step: Step) -> FloatArray:
    try:
        return np.asarray(data.channel(name), dtype=np.float64)
    except KeyError:
        raise KeyError(
            f"preprocessing step {step.describe()}: {data.name or 'the log'} has no channel"
            f" {name!r}; its inputs are {list(data.input_names)}, its outputs"
            f" {list(data.output_names)}"
        ) from None


@dataclass(frozen=True)
class Step:
    """One preprocessing step: ``apply(data) -> IOData``, and plain JSON both ways.

    Subclasses are frozen dataclasses whose fields are the JSON keys (besides ``"step"``, the
    step's :attr:`kind`); their ``__post_init__`` checks the values.
    """

    kind: ClassVar[str] = ""

    def apply(self, data: IOData) -> IOData:  # pragma: no cover - abstract
        """The preprocessed log (a new one; ``data`` is not changed)."""
        raise NotImplementedError

    def describe(self) -> str:  # pragma: no cover - abstract
        """A short text for messages (``relative motor_position``)."""
        raise NotImplementedError

    def sources(self, names: Sequence[str]) -> list[str]:
        """The channels to read from a log to get ``names`` after this step (most steps: same)."""
        return list(names)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON: ``{"step": kind, field: value, ...}``."""
        return {"step": self.kind, **dataclasses.asdict(self)}

    @classmethod
    def from_dict(cls: type[StepT], item: object) -> StepT:
        """A step from :meth:`to_dict`'s JSON; every key and value is checked.

        Called on :class:`Step` itself, the ``"step"`` key picks the class.

        Raises
        ------
        ValueError
            If ``item`` is not a JSON object, names an unknown step, lacks a key, has a key the
            step does not take, or holds a value of the wrong kind (the message names the key
            and the value).
        """
        if not isinstance(item, Mapping):
            raise ValueError(
                f"a preprocessing step must be a JSON object such as {{'step': 'relative',"
                f" 'channel': 'motor_position'}}; got {item!r}"
            )
        kind = item.get("step")
        target: type[Step] = cls
        if cls is Step or not cls.kind:
            if kind not in STEPS:
                raise ValueError(
                    f"unknown preprocessing step {kind!r} (key 'step'); known: {sorted(STEPS)}"
                )
            target = STEPS[str(kind)]
        elif kind != cls.kind:
            raise ValueError(f"'step' must be {cls.kind!r} for {cls.__name__}; got {kind!r}")
        fields = {f.name: f for f in dataclasses.fields(target)}
        unknown = sorted(set(item) - set(fields) - {"step"})
        if unknown:
            raise ValueError(
                f"preprocessing step {target.kind!r} has no key {unknown[0]!r} (value"
                f" {item[unknown[0]]!r}); its keys are {['step', *fields]}"
            )
        missing = [
            name
            for name, f in fields.items()
            if name not in item
            and f.default is dataclasses.MISSING
            and f.default_factory is dataclasses.MISSING
        ]
        if missing:
            raise ValueError(f"preprocessing step {target.kind!r} needs the key {missing[0]!r}")
        step = target(**{k: v for k, v in item.items() if k != "step"})
        return step  # type: ignore[return-value]


@dataclass(frozen=True)
class Relative(Step):
    r"""A channel relative to its first sample: :math:`x'(k) = x(k) - x(0)`, in the channel's unit.

    The benchmark's motor displacement: ``Relative("motor_position")`` [rad] (the encoder zero
    and the tendon slack differ between runs, while every run starts at rest).

    Parameters
    ----------
    channel : str
        An input or an output.

    Examples
    --------
    >>> from neckid import IOData
    >>> Relative("u").apply(IOData(u=[2.0, 3.0, 5.0], ts=1.0)).u.ravel()
    array([0., 1., 3.])
    """

    kind: ClassVar[str] = "relative"
    channel: str

    def __post_init__(self) -> None:
        _text(self.kind, "channel", self.channel)

    def apply(self, data: IOData) -> IOData:
        """The log with the channel minus its value at the first sample."""
        x = _column(data, self.channel, self)
        return _replace_channel(data, self.channel, x - x[0])

    def describe(self) -> str:
        """``relative CHANNEL``."""
        return f"relative {self.channel}"


@dataclass(frozen=True)
class RemoveOffset(Step):
    r"""A channel minus its mean over a rest window: :math:`x'(k) = x(k) - \bar x`.

    :math:`\bar x` is the mean of the samples with ``start <= t - t0 < stop``, times in seconds
    from the log's first sample (so one window fits logs whose clocks start elsewhere). Unit
    unchanged.

    Parameters
    ----------
    channel : str
        An input or an output.
    start, stop : float
        The rest window [s from the first sample], ``0 <= start < stop``.

    Raises
    ------
    ValueError
        From :meth:`apply` when the window holds no sample of the log.

    Examples
    --------
    >>> from neckid import IOData
    >>> log = IOData(u=[1.0, 3.0, 7.0, 9.0], ts=0.5, t0=20.0)
    >>> RemoveOffset("u", 0.0, 1.0).apply(log).u.ravel()      # mean of t - t0 in [0, 1): 2
    array([-1.,  1.,  5.,  7.])
    """

    kind: ClassVar[str] = "offset"
    channel: str
    start: float
    stop: float

    def __post_init__(self) -> None:
        _text(self.kind, "channel", self.channel)
        start = _number(self.kind, "start", self.start, "seconds")
        stop = _number(self.kind, "stop", self.stop, "seconds")
        if start < 0 or stop <= start:
            raise ValueError(
                f"preprocessing step 'offset': the window needs 0 <= 'start' < 'stop' [s]; got"
                f" start={self.start!r}, stop={self.stop!r}"
            )
        object.__setattr__(self, "start", start)
        object.__setattr__(self, "stop", stop)

    def apply(self, data: IOData) -> IOData:
        """The log with the channel minus its mean over the window."""
        x = _column(data, self.channel, self)
        elapsed = data.ts * np.arange(data.n_samples)
        inside = (elapsed >= self.start - 1e-9 * data.ts) & (elapsed < self.stop - 1e-9 * data.ts)
        if not inside.any():
            raise ValueError(
                f"preprocessing step {self.describe()}: the window holds no sample of"
                f" {data.name or 'the log'}, which lasts {data.duration:g} s"
            )
        return _replace_channel(data, self.channel, x - float(np.mean(x[inside])))

    def describe(self) -> str:
        """``offset CHANNEL over START..STOP s``."""
        return f"offset of {self.channel} over {self.start:g}..{self.stop:g} s"


@dataclass(frozen=True)
class LowPass(Step):
    r"""A first-order low-pass filter :math:`H(s) = \omega_c / (s + \omega_c)`, Tustin-discretised.

    With :math:`s \leftarrow \frac{2}{T_s}\frac{z - 1}{z + 1}` (no prewarping):

    .. math:: y(k) = a\,(x(k) + x(k-1)) + b\,y(k-1), \quad
              a = \frac{\omega_c T_s}{2 + \omega_c T_s}, \quad
              b = \frac{2 - \omega_c T_s}{2 + \omega_c T_s}.

    The lab's filtered inclination is ``LowPass("inclination", 1.0)`` (1 rad/s at 0.025 s,
    started at rest). Unit unchanged.

    Parameters
    ----------
    channel : str
        An input or an output.
    cutoff : float
        :math:`\omega_c` [rad/s], > 0.
    initial : {"rest", "steady"}, default "rest"
        ``"rest"``: :math:`x(-1) = y(-1) = 0`, so :math:`y(0) = a\,x(0)` (the lab's filter);
        ``"steady"``: :math:`y(0) = x(0)` (no start transient on a log that starts away from 0).

    Examples
    --------
    >>> from neckid import IOData
    >>> step = LowPass("u", cutoff=2.0, initial="steady")          # a = 1/3, b = 1/3 at ts = 0.5
    >>> step.apply(IOData(u=[3.0, 3.0, 6.0], ts=0.5)).u.ravel()
    array([3., 3., 4.])
    """

    kind: ClassVar[str] = "lowpass"
    channel: str
    cutoff: float
    initial: Literal["rest", "steady"] = "rest"

    def __post_init__(self) -> None:
        _text(self.kind, "channel", self.channel)
        cutoff = _number(self.kind, "cutoff", self.cutoff, "rad/s", positive=True)
        object.__setattr__(self, "cutoff", cutoff)
        _choice(self.kind, "initial", self.initial, ("rest", "steady"))

    def apply(self, data: IOData) -> IOData:
        """The log with the channel filtered."""
        from scipy.signal import lfilter

        x = _column(data, self.channel, self)
        wt = self.cutoff * data.ts
        a, b = wt / (2.0 + wt), (2.0 - wt) / (2.0 + wt)
        if self.initial == "rest":
            y = lfilter([a, a], [1.0, -b], x)
        else:  # y(0) = x(0): the state of the filter in steady state on x(0)
            y = lfilter([a, a], [1.0, -b], x, zi=[(1.0 - a) * x[0]])[0]
        return _replace_channel(data, self.channel, np.asarray(y, dtype=np.float64))

    def describe(self) -> str:
        """``low-pass CHANNEL at CUTOFF rad/s``."""
        return f"low-pass {self.channel} at {self.cutoff:g} rad/s"


@dataclass(frozen=True)
class Resample(Step):
    r"""Every channel onto the period ``ts`` by linear interpolation.

    New times :math:`t'_k = t_0 + k\,T'_s` for :math:`k = 0 \ldots \lfloor (t_{n-1} - t_0) /
    T'_s \rfloor`; each channel is interpolated linearly between its two neighbouring samples.
    Sub-sampling does not filter: put a :class:`LowPass` first when going much slower.

    Parameters
    ----------
    ts : float
        The new sampling period [s], > 0.

    Examples
    --------
    >>> from neckid import IOData
    >>> out = Resample(0.5).apply(IOData(u=[0.0, 1.0, 2.0], ts=1.0))
    >>> out.ts, out.u.ravel()
    (0.5, array([0. , 0.5, 1. , 1.5, 2. ]))
    """

    kind: ClassVar[str] = "resample"
    ts: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "ts", _number(self.kind, "ts", self.ts, "seconds", positive=True))

    def apply(self, data: IOData) -> IOData:
        """The log on the new grid (the same log when it is already at ``ts``)."""
        if math.isclose(data.ts, self.ts, rel_tol=1e-9):
            return data
        span = (data.n_samples - 1) * data.ts
        count = span / self.ts + 1.0  # inf for a step that underflows
        what = f"resampling {data.name or 'the log'} ({data.duration:g} s) every {self.ts:g} s"
        advice = (
            f"the resampling period {self.ts:g} s (--resample) is far too short for this log:"
            f" give one near the log's own ({data.ts:g} s)"
        )
        if not math.isfinite(count):
            raise ValueError(f"{what} makes more samples than a float counts: {advice}")
        # a tiny step is refused here, before the allocator sees it (the log, its times, a copy)
        check_allocation(
            8.0 * count * (data.u.shape[1] + data.y.shape[1] + 2),
            f"{what} ({count:.3g} samples)",
            advice,
        )
        n_new = math.floor(span / self.ts + 1e-9) + 1
        old = data.ts * np.arange(data.n_samples)
        new = self.ts * np.arange(n_new)

        def interpolate(values: FloatArray) -> FloatArray:
            columns = [np.interp(new, old, values[:, j]) for j in range(values.shape[1])]
            return np.column_stack(columns) if columns else np.zeros((n_new, 0))

        return data.replace(u=interpolate(data.u), y=interpolate(data.y), ts=self.ts)

    def describe(self) -> str:
        """``resample to TS s``."""
        return f"resample to {self.ts:g} s"


@dataclass(frozen=True)
class Restamp(Step):
    r"""What to do with repeated time stamps when a log is read (a table's time column).

    An :class:`~neckid.IOData` is uniform by construction, so :meth:`apply` changes nothing; the
    step acts where a table is read (:func:`neckid.cli.workflow.read_log` with a pipeline holding it,
    ``neckid identify --restamp``), before the stamps are checked, through :meth:`stamps`:

    - ``keep="first"``: of each run of equal stamps :math:`t_k = t_{k-1} = \ldots` only the first
      row is kept (a logger that wrote a sample twice);
    - ``keep="all"``: every row is kept and time is rebuilt as :math:`t_0 + k\,T_s`, with
      :math:`T_s` the median positive step (a logger whose clock restarts while the rows are
      consecutive periods, as the bench's staircase logs).

    Parameters
    ----------
    keep : {"first", "all"}, default "first"

    Examples
    --------
    >>> keep, t = Restamp().stamps([0.0, 0.1, 0.1, 0.2])
    >>> keep.tolist(), t.tolist()
    ([True, True, False, True], [0.0, 0.1, 0.2])
    """

    kind: ClassVar[str] = "restamp"
    keep: Literal["first", "all"] = "first"

    def __post_init__(self) -> None:
        _choice(self.kind, "keep", self.keep, ("first", "all"))

    def apply(self, data: IOData) -> IOData:
        """``data`` itself: a uniform log has no repeated stamp."""
        return data

    def stamps(self, time: Any) -> tuple[np.ndarray, FloatArray]:
        """``(rows kept, their new time stamps [s])`` for a column of stamps."""
        t = np.asarray(time, dtype=np.float64).ravel()
        repeated = np.zeros(t.size, dtype=bool)
        repeated[1:] = t[1:] == t[:-1]
        if self.keep == "first":
            return ~repeated, t[~repeated]
        steps = np.diff(t)
        positive = steps[steps > 0]
        ts = float(np.median(positive)) if positive.size else 1.0
        return np.ones(t.size, dtype=bool), t[0] + ts * np.arange(t.size)

    def frame(self, table: pd.DataFrame, time: str) -> pd.DataFrame:
        """A table with its ``time`` column restamped (rows dropped with ``keep="first"``)."""
        import pandas as pd

        stamps = pd.to_numeric(table[time], errors="coerce").to_numpy(dtype=np.float64)
        keep, t = self.stamps(stamps)
        out = table.loc[keep].reset_index(drop=True)
        out[time] = t
        return out

    def describe(self) -> str:
        """``restamp (keep first)``."""
        return f"restamp repeated time stamps (keep {self.keep})"


@dataclass(frozen=True)
class Tilt(Step):
    r"""The tilt vector from inclination and orientation outputs [deg] (:func:`neckid.data.tilt.tilt_log`).

    ``representation="vector"``: outputs ``tilt_x`` :math:`= i\cos\varphi` and ``tilt_y``
    :math:`= i\sin\varphi` [deg] in place of the two; ``"pitch_roll"``: ``pitch``, ``roll`` [deg].

    Parameters
    ----------
    inclination, orientation : str
        The names of those outputs.
    representation : {"vector", "pitch_roll"}, default "vector"
    """

    kind: ClassVar[str] = "tilt"
    inclination: str = "inclination"
    orientation: str = "orientation"
    representation: Literal["vector", "pitch_roll"] = "vector"

    def __post_init__(self) -> None:
        _text(self.kind, "inclination", self.inclination)
        _text(self.kind, "orientation", self.orientation)
        _choice(self.kind, "representation", self.representation, ("vector", "pitch_roll"))

    def apply(self, data: IOData) -> IOData:
        """The log with the two outputs replaced by the wrap-free pair."""
        from neckid.data.tilt import tilt_log

        return tilt_log(
            data,
            inclination=self.inclination,
            orientation=self.orientation,
            representation=self.representation,
        )

    def sources(self, names: Sequence[str]) -> list[str]:
        """``tilt_x``/``tilt_y`` (or ``pitch``/``roll``) come from the two polar outputs."""
        from neckid.data.tilt import NAMES

        first, second = NAMES[self.representation]
        polar = {first: self.inclination, second: self.orientation}
        return list(dict.fromkeys(polar.get(name, name) for name in names))

    def describe(self) -> str:
        """``tilt vector from INCLINATION, ORIENTATION``."""
        shown = "tilt vector" if self.representation == "vector" else "pitch and roll"
        return f"{shown} from {self.inclination}, {self.orientation}"


#: Every step by its JSON ``"step"`` name.
STEPS: dict[str, type[Step]] = {
    cls.kind: cls for cls in (Relative, RemoveOffset, LowPass, Resample, Restamp, Tilt)
}


class Pipeline:
    """Preprocessing steps applied in order; plain JSON both ways.

    Parameters
    ----------
    steps : iterable of Step
        Applied first to last.

    Examples
    --------
    >>> Pipeline([Relative("motor_position"), LowPass("inclination", 1.0)]).describe()
    'relative motor_position; low-pass inclination at 1 rad/s'
    """

    __slots__ = ("_steps",)

    def __init__(self, steps: Iterable[Step] = ()) -> None:
        items = tuple(steps)
        for i, step in enumerate(items):
            if not isinstance(step, Step) or type(step) is Step:
                raise TypeError(
                    f"steps[{i}] must be a preprocessing step (Relative, LowPass, ...); got"
                    f" {type(step).__name__}"
                )
        self._steps = items

    @property
    def steps(self) -> tuple[Step, ...]:
        """The steps, in order."""
        return self._steps

    def __len__(self) -> int:
        return len(self._steps)

    def __iter__(self) -> Iterator[Step]:
        return iter(self._steps)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Pipeline):
            return NotImplemented
        return self._steps == other._steps

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"Pipeline({list(self._steps)!r})"

    @overload
    def apply(self, data: IOData) -> IOData: ...

    @overload
    def apply(self, data: Sequence[IOData]) -> list[IOData]: ...

    def apply(self, data: IOData | Sequence[IOData]) -> IOData | list[IOData]:
        """Every step on ``data`` (one log, or each of a list); the inputs are not changed."""
        if not isinstance(data, IOData):
            return [self.apply(d) for d in data]
        for step in self._steps:
            data = step.apply(data)
        return data

    def sources(self, names: Sequence[str]) -> list[str]:
        """The channels to read from a log to get ``names`` after every step."""
        wanted = list(names)
        for step in reversed(self._steps):
            wanted = step.sources(wanted)
        return wanted

    def find(self, kind: type[StepT]) -> StepT | None:
        """The first step of a class, or None."""
        return next((s for s in self._steps if isinstance(s, kind)), None)

    def describe(self) -> str:
        """The steps as one line of text (``"none"`` when empty)."""
        return "; ".join(s.describe() for s in self._steps) or "none"

    def to_list(self) -> list[dict[str, Any]]:
        """Plain JSON: one object per step (:meth:`Step.to_dict`)."""
        return [s.to_dict() for s in self._steps]

    @classmethod
    def from_list(cls, items: object) -> Pipeline:
        """A pipeline from :meth:`to_list`'s JSON; each step is checked (:meth:`Step.from_dict`).

        Raises
        ------
        ValueError
            If ``items`` is not a list of steps; the message names the step's index, the key
            and the value.
        """
        if isinstance(items, str | bytes | Mapping) or not isinstance(items, Sequence):
            raise ValueError(
                f"preprocessing must be a JSON list of steps; got {type(items).__name__}"
            )
        steps = []
        for i, item in enumerate(items):
            try:
                steps.append(Step.from_dict(item))
            except (TypeError, ValueError) as exc:
                raise ValueError(f"preprocessing[{i}]: {exc}") from None
        return cls(steps)
