"""IOData: the one container for an input/output experiment log.

Time runs down the rows: ``u`` is ``(n_samples, n_inputs)`` and ``y`` is
``(n_samples, n_outputs)``, sampled every ``ts`` seconds from ``t0``. Every
channel has a name and a unit. Angles are in degrees unless a unit says otherwise.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from neckid.data.channels import as_2d, channel_names, channel_units
from neckid.data.conditions import (
    ConditionValue,
    append_conditions,
    check_conditions,
    label_indicators,
)
from neckid.utils.checks import check_finite, check_ts
from neckid.utils.types import FloatArray

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["IOData", "as_experiments"]


class IOData:
    """An input/output experiment log sampled uniformly in time.

    Parameters
    ----------
    u : array_like, shape (n_samples, n_inputs) or (n_samples,)
        Inputs, time down the rows. A 1-D array is one channel.
    y : array_like, shape (n_samples, n_outputs) or (n_samples,), optional
        Outputs, time down the rows. ``None`` gives a log with no output channel (a command sequence).
    ts : float
        Sampling period in seconds, > 0.
    input_names, output_names : sequence of str, optional
        Channel names; default ``u``/``u1, u2, ...`` and ``y``/``y1, y2, ...``.
    input_units, output_units : sequence of str, optional
        Channel units (free text such as ``"rad/s"`` or ``"deg"``); default empty.
    t0 : float, default 0.0
        Time of the first sample, in seconds.
    name : str, optional
        A label for the experiment (for example the file it came from).
    conditions : mapping of str to float or str, optional
        Constants of the experiment (payload mass, controller, ...): a number or a label per name
        (:mod:`neckid.data.conditions`). Models use numeric ones as inputs through
        ``Lags(..., conditions=[...])``.
    condition_units : mapping of str to str, optional
        Unit of each condition (``{"payload": "kg"}``).

    Raises
    ------
    ValueError
        If a channel holds NaN or inf (the message names the channel and the row), the input and
        output lengths differ, ``ts`` is not positive, or the names do not match the channels.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> data = IOData(u=np.ones(5), y=np.arange(5.0), ts=0.02, input_names=["cmd"],
    ...               output_names=["incl"], input_units=["rad/s"], output_units=["deg"])
    >>> data
    IOData(n_samples=5, ts=0.02, inputs=['cmd'], outputs=['incl'])
    >>> data.time
    array([0.  , 0.02, 0.04, 0.06, 0.08])
    >>> data[1:3].y.ravel()
    array([1., 2.])
    """

    __slots__ = (
        "_u",
        "_y",
        "condition_units",
        "conditions",
        "input_names",
        "input_units",
        "name",
        "output_names",
        "output_units",
        "t0",
        "ts",
    )

    def __init__(
        self,
        u: ArrayLike,
        y: ArrayLike | None = None,
        ts: float = 1.0,
        *,
        input_names: Sequence[str] | None = None,
        output_names: Sequence[str] | None = None,
        input_units: Sequence[str] | None = None,
        output_units: Sequence[str] | None = None,
        t0: float = 0.0,
        name: str | None = None,
        conditions: Mapping[str, ConditionValue] | None = None,
        condition_units: Mapping[str, str] | None = None,
    ) -> None:
        u_arr = as_2d(u, "u", names=input_names)
        y_arr = as_2d(y, "y", n_samples=u_arr.shape[0], names=output_names)
        if u_arr.shape[0] != y_arr.shape[0]:
            raise ValueError(
                f"u and y must have the same number of samples (rows); got u with {u_arr.shape[0]}"
                f" and y with {y_arr.shape[0]}"
            )
        if u_arr.shape[0] == 0:
            raise ValueError("an IOData needs at least one sample; got 0 rows")
        self.input_names = channel_names(input_names, u_arr.shape[1], "u", "input_names")
        self.output_names = channel_names(output_names, y_arr.shape[1], "y", "output_names")
        clash = set(self.input_names) & set(self.output_names)
        if clash:
            raise ValueError(f"a name cannot be both an input and an output: {sorted(clash)}")
        check_finite(u_arr, "u", self.input_names)
        check_finite(y_arr, "y", self.output_names)
        self.input_units = channel_units(input_units, u_arr.shape[1], "input_units")
        self.output_units = channel_units(output_units, y_arr.shape[1], "output_units")
        self.ts = check_ts(ts)
        start: Any = t0[()] if isinstance(t0, np.ndarray) and t0.ndim == 0 else t0
        if isinstance(start, bool | np.bool_) or not isinstance(start, numbers.Real):
            raise TypeError(f"t0 must be a number of seconds; got {t0!r}")
        try:
            t0_value = float(start)
        except OverflowError:  # a Python integer beyond the float range
            t0_value = math.inf
        if not math.isfinite(t0_value):
            raise ValueError(f"t0 must be a finite number of seconds; got {t0!r}")
        self.t0 = t0_value
        self.name = name
        self.conditions, self.condition_units = check_conditions(
            conditions, condition_units, self.input_names + self.output_names
        )
        # Own copies, read-only: nothing the user passed in is changed, and nothing changes ours.
        self._u = u_arr.copy()
        self._y = y_arr.copy()
        self._u.flags.writeable = False
        self._y.flags.writeable = False

    # ------------------------------------------------------------------ basic properties
    @property
    def u(self) -> FloatArray:
        """Inputs, shape ``(n_samples, n_inputs)`` (read-only view)."""
        return self._u

    @property
    def y(self) -> FloatArray:
        """Outputs, shape ``(n_samples, n_outputs)`` (read-only view)."""
        return self._y

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self._u.shape[0])

    @property
    def n_inputs(self) -> int:
        """Number of input channels."""
        return int(self._u.shape[1])

    @property
    def n_outputs(self) -> int:
        """Number of output channels."""
        return int(self._y.shape[1])

    @property
    def time(self) -> FloatArray:
        """Time stamps in seconds, ``t0 + k * ts``."""
        return self.t0 + self.ts * np.arange(self.n_samples, dtype=np.float64)

    @property
    def duration(self) -> float:
        """Length of the log in seconds, ``n_samples * ts``."""
        return self.n_samples * self.ts

    def __len__(self) -> int:
        return self.n_samples

    def __repr__(self) -> str:
        label = f", name={self.name!r}" if self.name else ""
        if self.conditions:
            label += f", conditions={dict(self.conditions)!r}"
        return (
            f"IOData(n_samples={self.n_samples}, ts={self.ts!r}, inputs={list(self.input_names)},"
            f" outputs={list(self.output_names)}{label})"
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, IOData):
            return NotImplemented
        return (
            self.ts == other.ts
            and self.t0 == other.t0
            and self.input_names == other.input_names
            and self.output_names == other.output_names
            and self.input_units == other.input_units
            and self.output_units == other.output_units
            and dict(self.conditions) == dict(other.conditions)
            and dict(self.condition_units) == dict(other.condition_units)
            and np.array_equal(self._u, other._u)
            and np.array_equal(self._y, other._y)
        )

    __hash__ = None  # type: ignore[assignment]

    def replace(self, **changes: Any) -> IOData:
        """A new log with the given constructor arguments changed (``u``, ``y``, ``ts``, names, ...).

        Examples
        --------
        >>> IOData(u=[1.0, 2.0], ts=0.1).replace(ts=0.2).ts
        0.2
        """
        fields: dict[str, Any] = {
            "u": self._u,
            "y": self._y,
            "ts": self.ts,
            "input_names": self.input_names,
            "output_names": self.output_names,
            "input_units": self.input_units,
            "output_units": self.output_units,
            "t0": self.t0,
            "name": self.name,
            "conditions": self.conditions,
            "condition_units": self.condition_units,
        }
        fields.update(changes)
        return IOData(**fields)

    def renamed(self, name: str | None) -> IOData:
        """The same log under another experiment name (arrays and channels unchanged).

        Examples
        --------
        >>> IOData(u=[1.0, 2.0], ts=0.1).renamed("run 2").name
        'run 2'
        """
        return self.replace(name=name)

    def with_conditions(
        self, units: Mapping[str, str] | None = None, **values: ConditionValue
    ) -> IOData:
        """The same log with conditions added (or replaced), e.g. ``with_conditions(payload=0.2)``.

        Examples
        --------
        >>> d = IOData(u=[1.0, 2.0], ts=0.1).with_conditions(units={"payload": "kg"}, payload=0.2)
        >>> dict(d.conditions), dict(d.condition_units)
        ({'payload': 0.2}, {'payload': 'kg'})
        """
        merged_units = {**self.condition_units, **(units or {})}
        return self.replace(conditions={**self.conditions, **values}, condition_units=merged_units)

    def conditions_as_inputs(self, names: Sequence[str]) -> IOData:
        """Append conditions as constant input channels (with their units), in order.

        A numeric condition (``payload``) becomes one input of its value. A label condition is
        one-hot encoded: each name ``"neck=A"`` becomes an input that is 1 when the log's
        ``neck`` is ``"A"`` and 0 otherwise (:meth:`label_indicators` lists them for a set of
        logs). Names that are already input channels are left as they are (a log made by this
        method, or one that logged the value as a channel), so calling it twice changes nothing.

        Raises
        ------
        KeyError
            If a name is neither a condition nor an input of this log.
        ValueError
            If a label condition is asked for as a number, or the log's label is none of the
            indicators asked for (a neck the model has not seen).

        Examples
        --------
        >>> d = IOData(u=[1.0, 2.0], ts=0.1, conditions={"payload": 0.2, "neck": "B"})
        >>> d.conditions_as_inputs(["payload"]).channel("payload")
        array([0.2, 0.2])
        >>> d.conditions_as_inputs(["neck=A", "neck=B"]).channel("neck=B")
        array([1., 1.])
        """
        return append_conditions(self, names)

    def _with_constant_input(
        self, name: str, value: float, unit: str, drop: bool = False
    ) -> IOData:
        """The log with one more input, constant ``value``; ``drop``: the condition ``name`` too."""
        keep = {k: v for k, v in self.conditions.items() if not (drop and k == name)}
        keep_units = {k: v for k, v in self.condition_units.items() if not (drop and k == name)}
        return self.replace(
            u=np.hstack([self._u, np.full((self.n_samples, 1), value)]),
            input_names=(*self.input_names, name),
            input_units=(*self.input_units, unit),
            conditions=keep,
            condition_units=keep_units,
        )

    @staticmethod
    def label_indicators(names: Sequence[str], logs: Sequence[IOData]) -> list[str]:
        """``names`` with each label condition replaced by its one-hot inputs over ``logs``.

        Examples
        --------
        >>> runs = [IOData(u=[1.0], ts=0.1, conditions={"neck": n, "payload": 0.2}) for n in "BA"]
        >>> IOData.label_indicators(["payload", "neck"], runs)
        ['payload', 'neck=A', 'neck=B']
        """
        return label_indicators(names, logs)

    # ------------------------------------------------------------------ channel access
    def channel(self, name: str) -> FloatArray:
        """Return one channel (input or output) by name as a 1-D array.

        Raises
        ------
        KeyError
            If no input or output has that name; the message lists the channels there are.
        """
        if name in self.input_names:
            return self._u[:, self.input_names.index(name)]
        if name in self.output_names:
            return self._y[:, self.output_names.index(name)]
        raise KeyError(
            f"no channel named {name!r}; inputs are {list(self.input_names)},"
            f" outputs are {list(self.output_names)}"
        )

    def unit(self, name: str) -> str:
        """Return the unit of a channel by name."""
        if name in self.input_names:
            return self.input_units[self.input_names.index(name)]
        if name in self.output_names:
            return self.output_units[self.output_names.index(name)]
        raise KeyError(f"no channel named {name!r}")

    def select(
        self, inputs: Sequence[str] | None = None, outputs: Sequence[str] | None = None
    ) -> IOData:
        """Keep only the named channels, in the order given.

        Parameters
        ----------
        inputs, outputs : sequence of str, optional
            Channel names to keep; ``None`` keeps all of that kind. A name may be moved between
            kinds: an output named in ``inputs`` becomes an input, and the other way round.

        Raises
        ------
        KeyError
            If a name is not a channel of this log.
        """

        def gather(
            names: Sequence[str] | None, argument: str, default: str
        ) -> tuple[FloatArray, list[str], list[str]]:
            if names is None:
                if default == "inputs":
                    return self._u, list(self.input_names), list(self.input_units)
                return self._y, list(self.output_names), list(self.output_units)
            if isinstance(names, str):
                names = [names]
            columns = []
            for n in names:
                try:
                    columns.append(self.channel(n))
                except KeyError:
                    raise KeyError(
                        f"{argument} names {n!r}, which is not a channel; inputs are"
                        f" {list(self.input_names)}, outputs are {list(self.output_names)}"
                    ) from None
            array = np.column_stack(columns) if columns else np.zeros((self.n_samples, 0))
            return array, list(names), [self.unit(n) for n in names]

        u, un, uu = gather(inputs, "inputs", "inputs")
        y, yn, yu = gather(outputs, "outputs", "outputs")
        return self.replace(
            u=u, y=y, input_names=un, output_names=yn, input_units=uu, output_units=yu
        )

    def with_channel(
        self, name: str, values: ArrayLike, *, unit: str = "", kind: str = "input"
    ) -> IOData:
        """Return a copy with one more channel appended.

        Parameters
        ----------
        name : str
            Name of the new channel; must not exist yet.
        values : array_like, shape (n_samples,)
            The channel's values.
        unit : str, optional
            Its unit.
        kind : {"input", "output"}
            Where to put it.
        """
        channel_names([name], 1, name, "name")  # a name that files can hold
        column = as_2d(values, "values", names=[name])
        if column.shape != (self.n_samples, 1):
            raise ValueError(
                f"channel {name!r} must have shape ({self.n_samples},); got {np.shape(values)}"
            )
        if kind == "input":
            return self.replace(
                u=np.hstack([self._u, column]),
                input_names=(*self.input_names, name),
                input_units=(*self.input_units, unit),
            )
        if kind == "output":
            return self.replace(
                y=np.hstack([self._y, column]),
                output_names=(*self.output_names, name),
                output_units=(*self.output_units, unit),
            )
        raise ValueError(f"kind must be 'input' or 'output'; got {kind!r}")

    def with_derivative(
        self,
        channel: str,
        *,
        name: str | None = None,
        kind: str | None = None,
        method: str = "central",
    ) -> IOData:
        """Return a copy with the numerical time derivative of a channel appended.

        Parameters
        ----------
        channel : str
            The channel to differentiate.
        name : str, optional
            Name of the derived channel; default ``"d(<channel>)/dt"``.
        kind : {"input", "output"}, optional
            Where to put it; default the same kind as ``channel``.
        method : {"central", "backward"}
            ``"central"``: second-order central differences (one-sided at the ends, as
            :func:`numpy.gradient`). ``"backward"``: ``(x[k] - x[k-1]) / ts``, causal, with
            the first sample equal to the second (what a controller on the robot can compute).

        Examples
        --------
        >>> import numpy as np
        >>> d = IOData(u=np.zeros(4), y=[0.0, 1.0, 2.0, 3.0], ts=0.5, output_names=["x"])
        >>> d.with_derivative("x").channel("d(x)/dt")
        array([2., 2., 2., 2.])
        """
        x = self.channel(channel)
        if method == "central":
            dx = np.gradient(x, self.ts) if x.size > 1 else np.zeros_like(x)
        elif method == "backward":
            dx = np.empty_like(x)
            dx[1:] = np.diff(x) / self.ts
            dx[0] = dx[1] if x.size > 1 else 0.0
        else:
            raise ValueError(f"method must be 'central' or 'backward'; got {method!r}")
        if kind is None:
            kind = "input" if channel in self.input_names else "output"
        unit = self.unit(channel)
        return self.with_channel(
            name or f"d({channel})/dt", dx, unit=f"{unit}/s" if unit else "1/s", kind=kind
        )

    def with_tilt(
        self,
        representation: str = "vector",
        *,
        inclination: str = "inclination",
        orientation: str = "orientation",
    ) -> IOData:
        """Inclination and orientation outputs replaced by a wrap-free pair (3-D neck).

        ``"vector"`` gives ``tilt_x``, ``tilt_y`` [deg], ``"pitch_roll"`` gives ``pitch``,
        ``roll`` [deg]; see :func:`neckid.data.tilt.tilt_log`, and :meth:`with_polar` for the way back.
        """
        from neckid.data.tilt import tilt_log

        return tilt_log(
            self,
            inclination=inclination,
            orientation=orientation,
            representation=representation,  # type: ignore[arg-type]
        )

    def with_polar(self, representation: str = "vector") -> IOData:
        """The inverse of :meth:`with_tilt`: outputs ``inclination`` and ``orientation`` [deg]."""
        from neckid.data.tilt import polar_log

        return polar_log(self, representation=representation)  # type: ignore[arg-type]

    # ------------------------------------------------------------------ slicing
    def __getitem__(self, index: slice) -> IOData:
        """Slice by sample index (a ``slice`` with step 1 or a positive step)."""
        if not isinstance(index, slice):
            raise TypeError(
                f"IOData is sliced by sample with a slice, e.g. data[100:200]; got {index!r}"
            )
        start, stop, step = index.indices(self.n_samples)
        if step <= 0:
            raise ValueError(f"slice step must be positive; got {step}")
        if stop <= start:
            raise ValueError(f"slice {index} selects no sample of {self.n_samples}")
        return self.replace(
            u=self._u[start:stop:step],
            y=self._y[start:stop:step],
            ts=self.ts * step,
            t0=self.t0 + start * self.ts,
        )

    def time_slice(self, start: float | None = None, stop: float | None = None) -> IOData:
        """Keep the samples with ``start <= t < stop`` (seconds, on this log's clock)."""
        t = self.time
        lo = 0 if start is None else int(np.searchsorted(t, start - 1e-9 * self.ts, side="left"))
        hi = (
            self.n_samples
            if stop is None
            else int(np.searchsorted(t, stop - 1e-9 * self.ts, side="left"))
        )
        if hi <= lo:
            raise ValueError(
                f"time_slice({start}, {stop}) selects no sample; the log covers"
                f" t = {t[0]:g} .. {t[-1]:g} s"
            )
        return self[lo:hi]

    def split(self, fraction: float = 0.5) -> tuple[IOData, IOData]:
        """Split into a first part holding ``fraction`` of the samples and the rest.

        Examples
        --------
        >>> d = IOData(u=np.arange(10.0), y=np.arange(10.0), ts=1.0)
        >>> a, b = d.split(0.7)
        >>> a.n_samples, b.n_samples, b.t0
        (7, 3, 7.0)
        """
        if not 0.0 < float(fraction) < 1.0:
            raise ValueError(f"fraction must be in (0, 1); got {fraction!r}")
        k = round(self.n_samples * float(fraction))
        if k < 1 or k >= self.n_samples:
            raise ValueError(
                f"fraction={fraction!r} of {self.n_samples} samples leaves an empty part"
            )
        return self[:k], self[k:]

    # ------------------------------------------------------------------ tables and files
    # Reading and checking tables lives in neckid.data.readers (imported on first use: pandas).
    def to_frame(self, time: str | None = "time") -> pd.DataFrame:
        """Return a DataFrame with a time column (seconds) and one column per channel.

        Units are kept in ``DataFrame.attrs["units"]``; the channel kinds and ``ts`` in
        ``attrs["inputs"]``, ``attrs["outputs"]`` and ``attrs["ts"]``.

        Parameters
        ----------
        time : str or None, default "time"
            Name of the time column, ``t0 + k * ts``; ``None`` leaves it out.
        """
        import pandas as pd

        columns: dict[str, FloatArray] = {}
        if time is not None:
            columns[time] = self.time
        for i, n in enumerate(self.input_names):
            columns[n] = self._u[:, i].copy()
        for i, n in enumerate(self.output_names):
            columns[n] = self._y[:, i].copy()
        frame = pd.DataFrame(columns)
        frame.attrs["units"] = dict(
            zip(
                self.input_names + self.output_names,
                self.input_units + self.output_units,
                strict=True,
            )
        )
        frame.attrs["inputs"] = list(self.input_names)
        frame.attrs["outputs"] = list(self.output_names)
        frame.attrs["ts"] = self.ts
        if self.conditions:
            frame.attrs["conditions"] = dict(self.conditions)
            frame.attrs["condition_units"] = dict(self.condition_units)
        return frame

    @classmethod
    def from_frame(
        cls,
        frame: pd.DataFrame,
        inputs: Sequence[str],
        outputs: Sequence[str] = (),
        *,
        time: str | None = None,
        ts: float | None = None,
        units: Mapping[str, str] | None = None,
        name: str | None = None,
    ) -> IOData:
        """Build from a DataFrame, naming the input, output and (optionally) time columns.

        Parameters
        ----------
        frame : pandas.DataFrame
            One row per sample.
        inputs, outputs : sequence of str
            Column names.
        time : str, optional
            Column of time stamps in seconds; they must be sorted, distinct and uniform (5 %).
        ts : float, optional
            Sampling period in seconds, when there is no time column. Exactly one of ``time``
            and ``ts`` must be given.
        units : mapping of str to str, optional
            Unit of each channel by name; ``frame.attrs["units"]`` is used when absent.
        name : str, optional
            A label for the experiment.

        Raises
        ------
        KeyError
            If a named column is not in the table.
        ValueError
            If not exactly one of ``time`` and ``ts`` is given, a column is not numeric, or the
            time stamps are not sorted, distinct and uniform (the message names the row).
        """
        from neckid.data.readers import frame_fields

        fields = frame_fields(frame, inputs, outputs, time=time, ts=ts, units=units)
        return cls(**fields, name=name)

    @classmethod
    def from_csv(
        cls,
        path: str | Path,
        inputs: Sequence[str],
        outputs: Sequence[str] = (),
        *,
        time: str | None = "time",
        ts: float | None = None,
        units: Mapping[str, str] | None = None,
        **read_csv: Any,
    ) -> IOData:
        r"""Read a CSV log (one row per sample, a header row of column names).

        ``time="time"`` reads time stamps from that column; pass ``time=None, ts=...`` (or just
        ``ts=...``) for a log without one. Extra keyword arguments go to :func:`pandas.read_csv`.

        Raises
        ------
        FileNotFoundError
            If ``path`` does not exist.
        KeyError
            If a named column is not in the header (the message lists the columns there are).
        ValueError
            If the file is not a readable CSV log: not text, not parseable, an empty, NaN, inf or
            non-numeric cell, a repeated column name, time stamps that are not sorted and uniform.
            The message starts with the file name and names the column and the row
            (:func:`neckid.data.readers.file_fields`).

        Examples
        --------
        >>> import tempfile, os
        >>> path = os.path.join(tempfile.mkdtemp(), "log.csv")
        >>> _ = open(path, "w").write("time,cmd,incl\n0,1,0\n0.02,1,0.1\n0.04,1,0.3\n")
        >>> IOData.from_csv(path, inputs=["cmd"], outputs=["incl"])
        IOData(n_samples=3, ts=0.02, inputs=['cmd'], outputs=['incl'], name='log.csv')
        """
        return cls._from_file(
            path, "csv", inputs, outputs, time=time, ts=ts, units=units, **read_csv
        )

    @classmethod
    def from_parquet(
        cls,
        path: str | Path,
        inputs: Sequence[str],
        outputs: Sequence[str] = (),
        *,
        time: str | None = "time",
        ts: float | None = None,
        units: Mapping[str, str] | None = None,
    ) -> IOData:
        """Read a Parquet log (needs the ``parquet`` extra: ``pip install neckid[parquet]``)."""
        return cls._from_file(path, "parquet", inputs, outputs, time=time, ts=ts, units=units)

    def to_parquet(self, path: str | Path) -> None:
        """Write a Parquet file with a ``time`` column; units go in the file's metadata.

        Every page carries a checksum, so a file damaged later is refused when it is read
        (:func:`neckid.data.parquet.read_parquet_columns`), never read as other numbers.
        """
        frame = self.to_frame()
        frame.attrs = {"units": frame.attrs["units"]}
        frame.to_parquet(Path(path), index=False, write_page_checksum=True)

    def to_csv(self, path: str | Path) -> None:
        """Write a CSV file with a header row and a ``time`` column (seconds)."""
        self.to_frame().to_csv(Path(path), index=False)

    @classmethod
    def from_rosbag(
        cls,
        path: str | Path,
        channels: Mapping[str, Any],
        *,
        ts: float | None = None,
        name: str | None = None,
        stamps: str = "header",
    ) -> IOData:
        """Read chosen fields of a ROS 2 bag (sqlite3 or MCAP), resampled onto one uniform grid.

        ``channels`` maps a channel name to ``(topic, field, kind, unit)``, e.g.
        ``{"inclination": ("/imu/tilt", "vector.x", "output", "deg")}``. Messages are timed by
        their ``header.stamp`` when they have one (``stamps="receive"``: the recorder's time)
        and interpolated linearly onto a grid of period ``ts`` (default: the median period of
        the slowest topic) over the span every topic covers. Needs the ``[ros]`` extra
        (the ``rosbags`` package, no ROS install). See :func:`neckid.data.rosbag.rosbag_fields`.
        """
        from neckid.data.rosbag import rosbag_fields

        return cls(**rosbag_fields(path, channels, ts=ts, name=name, stamps=stamps))  # type: ignore[arg-type]

    @classmethod
    def from_mat(
        cls,
        path: str | Path,
        inputs: Sequence[str],
        outputs: Sequence[str] = (),
        *,
        time: str | None = None,
        ts: float | str | None = None,
        units: Mapping[str, str] | None = None,
    ) -> IOData:
        """Read a MATLAB ``.mat`` file (v4 to v7.2) whose variables are vectors or 1-column matrices.

        Parameters
        ----------
        inputs, outputs : sequence of str
            Variable names in the file.
        time : str, optional
            Variable of time stamps; otherwise give ``ts``. A scalar variable named by ``ts``
            (a string) is read as the period.
        """
        return cls._from_file(path, "mat", inputs, outputs, time=time, ts=ts, units=units)

    @classmethod
    def _from_file(
        cls,
        path: str | Path,
        kind: Literal["csv", "parquet", "mat"],
        inputs: Sequence[str],
        outputs: Sequence[str],
        **options: Any,
    ) -> IOData:
        """Read a file with :func:`neckid.data.readers.file_fields`; every error names the file."""
        from neckid.data.readers import file_fields

        fields = file_fields(path, kind, inputs, outputs, **options)
        try:
            return cls(**fields)
        except ValueError as exc:  # non-finite values, names: say which file they are in
            raise ValueError(f"{fields['name']}: {exc}") from None

    def to_dict(self) -> dict[str, Any]:
        """Return the metadata (everything but the arrays) as a JSON-serialisable dict."""
        return {
            "ts": self.ts,
            "t0": self.t0,
            "input_names": list(self.input_names),
            "output_names": list(self.output_names),
            "input_units": list(self.input_units),
            "output_units": list(self.output_units),
            "name": self.name,
            "conditions": dict(self.conditions),
            "condition_units": dict(self.condition_units),
        }

    def describe(self) -> str:
        """A one-paragraph human-readable summary (channels, units, ranges)."""
        lines = [repr(self)]
        for kind, names, units, arr in (
            ("input", self.input_names, self.input_units, self._u),
            ("output", self.output_names, self.output_units, self._y),
        ):
            for j, (n, unit) in enumerate(zip(names, units, strict=True)):
                col = arr[:, j]
                lines.append(f"  {kind} {n} [{unit}]: min {col.min():.4g}, max {col.max():.4g}")
        for n, value in self.conditions.items():
            unit = self.condition_units.get(n, "")
            lines.append(
                f"  condition {n} [{unit}]: {value}" if unit else f"  condition {n}: {value}"
            )
        return "\n".join(lines)


def as_experiments(data: IOData | Sequence[IOData], argument: str = "data") -> list[IOData]:
    """Return ``data`` as a list of experiments, checking that they share channels and ``ts``.

    Parameters
    ----------
    data : IOData or sequence of IOData
        One experiment or several; regressors are never built across two experiments.

    Raises
    ------
    TypeError
        If an element is not an IOData.
    ValueError
        If the list is empty, or the experiments differ in channel names or sampling period.
    """
    if isinstance(data, IOData):
        return [data]
    if isinstance(data, str | bytes) or not isinstance(data, Sequence):
        raise TypeError(
            f"{argument} must be an IOData or a list of them; got {type(data).__name__}"
        )
    items = list(data)
    if not items:
        raise ValueError(f"{argument} is an empty list; give at least one IOData")
    for i, d in enumerate(items):
        if not isinstance(d, IOData):
            raise TypeError(f"{argument}[{i}] must be an IOData; got {type(d).__name__}")
    first = items[0]

    def label(i: int, d: IOData) -> str:  # the file the user gave, when the run has its name
        return f"{d.name} ({argument}[{i}])" if d.name else f"{argument}[{i}]"

    for i, d in enumerate(items[1:], start=1):
        if d.input_names != first.input_names or d.output_names != first.output_names:
            raise ValueError(
                f"{label(i, d)} has channels {list(d.input_names)} -> {list(d.output_names)},"
                f" but {label(0, first)} has {list(first.input_names)} ->"
                f" {list(first.output_names)}"
            )
        if not math.isclose(d.ts, first.ts, rel_tol=1e-6):
            raise ValueError(
                f"{label(i, d)} is sampled every {d.ts:.6g} s, but {label(0, first)} every"
                f" {first.ts:.6g} s: runs fitted together share one sampling period; resample"
                " one of them (--resample)"
            )
        _check_same_units(d, first, f"{argument}[{i}]", f"{argument}[0]")
    return items


def _check_same_units(one: IOData, first: IOData, label: str, first_label: str) -> None:
    """Runs fitted together agree on each channel's unit (an empty unit is unknown, not checked)."""
    pairs = zip(
        (*one.input_names, *one.output_names),
        (*one.input_units, *one.output_units),
        (*first.input_units, *first.output_units),
        strict=True,
    )
    for name, unit, first_unit in pairs:
        if unit and first_unit and unit != first_unit:
            raise ValueError(
                f"{label} ({one.name or 'unnamed'}) has {name} in {unit}, but {first_label}"
                f" ({first.name or 'unnamed'}) in {first_unit}: runs fitted together must agree"
                f" on units; convert one of them"
            )
