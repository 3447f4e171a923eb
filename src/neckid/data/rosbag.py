"""Read ROS 2 bags (rosbag2, sqlite3 ``.db3`` or MCAP storage) for :meth:`neckid.IOData.from_rosbag`.

Soft-neck experiments run under ROS 2 are recorded with ``ros2 bag record``: every topic keeps its
own rate and its own time stamps. :func:`load_rosbag` takes one numeric field from each chosen topic
and resamples all of them onto one uniform time grid, so that the log can be identified like any
other. Each channel is described by a :class:`RosbagChannel` (topic, field path, input or output,
unit).

The bags are read with the pure-Python `rosbags <https://gitlab.com/ternaris/rosbags>`_ package
(no ROS installation needed), an optional dependency: ``pip install 'neckid[ros]'``. Message types
are taken from the definitions stored in the bag, so custom messages are read without their ROS
package; bags without stored definitions fall back to the standard ROS 2 Humble types.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import re
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from neckid.data.channels import as_2d
from neckid.utils.checks import check_ts

__all__ = ["GAP_FACTOR", "ROSBAGS_MISSING", "RosbagChannel", "rosbag_fields"]

logger = logging.getLogger(__name__)

#: Message of the ImportError raised when the optional dependency ``rosbags`` is missing.
ROSBAGS_MISSING = (
    "reading ROS 2 bags needs the optional dependency rosbags: pip install 'neckid[ros]'"
)

#: A gap between two messages of a topic longer than this many of its median periods is reported.
GAP_FACTOR = 5.0

_FIELD_PATH = re.compile(r"[A-Za-z_]\w*(?:\.[A-Za-z_]\w*|\[-?\d+\])*", re.ASCII)
_FIELD_STEP = re.compile(r"([A-Za-z_]\w*)|\[(-?\d+)\]", re.ASCII)


class RosbagChannel(NamedTuple):
    """Where one channel of a ROS 2 bag lives and what it is.

    Attributes
    ----------
    topic : str
        Topic name as recorded, with its leading slash (``"/motor/cmd"``).
    field : str
        Path to a numeric field of the message: attribute names joined by dots and integer
        indexes in brackets, such as ``"data"``, ``"vector.x"``, ``"position[0]"`` or
        ``"pose.pose.orientation.z"``. A negative index counts from the end of the array.
    kind : {"input", "output"}
        Whether the channel becomes an input (``u``) or an output (``y``) of the log.
    unit : str, default ""
        Free-text unit of the values (``"rad/s"``, ``"deg"``); ROS messages do not carry units.

    Examples
    --------
    >>> from neckid.datasets import RosbagChannel
    >>> RosbagChannel("/imu/tilt", "vector.x", "output", "deg")
    RosbagChannel(topic='/imu/tilt', field='vector.x', kind='output', unit='deg')
    """

    topic: str
    field: str
    kind: Literal["input", "output"]
    unit: str = ""


@dataclasses.dataclass
class _Topic:
    """The channels read from one topic, and the stamps and values collected so far."""

    fields: list[str]
    steps: list[tuple[str | int, ...]]
    stamps_ns: list[int] = dataclasses.field(default_factory=list)
    values: list[list[float]] = dataclasses.field(default_factory=list)
    uses_header: bool = False


def _import_rosbags() -> tuple[Any, Any, Any]:
    """Return ``(AnyReader, AnyReaderError, ROS 2 Humble typestore)``; ImportError if missing."""
    try:
        from rosbags.highlevel import AnyReader, AnyReaderError
        from rosbags.typesys import Stores, get_typestore
    except ImportError as exc:
        # Only a missing rosbags itself is the optional dependency; anything else is a real error.
        if exc.name is None or exc.name.split(".")[0] != "rosbags":
            raise
        raise ImportError(ROSBAGS_MISSING) from exc
    return AnyReader, AnyReaderError, get_typestore(Stores.ROS2_HUMBLE)


def _as_channel(name: object, spec: object) -> RosbagChannel:
    """Check one entry of ``channels`` and return it as a :class:`RosbagChannel`."""
    if not isinstance(name, str) or not name:
        raise TypeError(f"channel names must be non-empty strings; got {name!r}")
    if isinstance(spec, str) or not isinstance(spec, Sequence) or len(spec) not in (3, 4):
        raise TypeError(
            f"channel {name!r} must be (topic, field, kind) or (topic, field, kind, unit);"
            f" got {spec!r}"
        )
    topic, field, kind, *rest = spec
    unit = rest[0] if rest else ""
    for argument, value in (("topic", topic), ("field", field), ("unit", unit)):
        if not isinstance(value, str):
            raise TypeError(f"channel {name!r}: {argument} must be a string; got {value!r}")
    if kind not in ("input", "output"):
        raise ValueError(f"channel {name!r}: kind must be 'input' or 'output'; got {kind!r}")
    if not _FIELD_PATH.fullmatch(field):
        raise ValueError(
            f"channel {name!r}: field {field!r} is not a field path; write attribute names joined"
            " by dots and indexes in brackets, such as 'vector.x' or 'position[0]'"
        )
    return RosbagChannel(topic, field, kind, unit)


def _parse_field(field: str) -> tuple[str | int, ...]:
    """Split a checked field path into attribute names (str) and indexes (int)."""
    return tuple(name if name else int(index) for name, index in _FIELD_STEP.findall(field))


def _type_name(value: object) -> str:
    """ROS type name of a message (``std_msgs/msg/Float64``), else the Python type name."""
    return str(getattr(type(value), "__msgtype__", type(value).__name__))


def _field_value(message: object, steps: tuple[str | int, ...], field: str, where: str) -> float:
    """Follow ``steps`` into ``message`` and return a finite float, or say what went wrong."""
    value: Any = message
    done = ""  # the part of the path followed so far
    for step in steps:
        if isinstance(step, str):
            # Types built from a bag's definitions carry ``__msgtype__`` as a field; not data.
            names = (
                [f.name for f in dataclasses.fields(value) if not f.name.startswith("__")]
                if dataclasses.is_dataclass(value)
                else []
            )
            if step not in names:
                holder = f"{done!r} of {_type_name(message)}" if done else "the message"
                known = f"its fields are {names}" if names else "it has no fields"
                raise KeyError(
                    f"{where}: field {field!r} does not exist on {_type_name(message)}: {holder}"
                    f" is a {_type_name(value)} with no field {step!r}; {known}"
                )
            value = getattr(value, step)
            done = f"{done}.{step}" if done else step
        else:
            if isinstance(value, str) or not hasattr(value, "__len__"):
                raise KeyError(
                    f"{where}: field {field!r} does not exist on {_type_name(message)}: {done!r}"
                    f" is a {_type_name(value)}, not an array, and cannot take the index [{step}]"
                )
            if not -len(value) <= step < len(value):
                raise ValueError(
                    f"{where}: field {field!r}: index {step} is out of range for {done!r}, which"
                    f" holds {len(value)} elements in this message"
                )
            value = value[step]
            done = f"{done}[{step}]"
    if isinstance(value, bool | np.bool_):
        return float(value)
    if not isinstance(value, int | float | np.integer | np.floating):
        if dataclasses.is_dataclass(value):
            hint = "; name one of its numeric fields"
        elif hasattr(value, "__len__") and not isinstance(value, str):
            hint = "; pick one element with an index such as '[0]'"
        else:
            hint = ""
        raise ValueError(
            f"{where}: field {field!r} of {_type_name(message)} is not a number; it holds a"
            f" {_type_name(value)} ({value!r:.60}){hint}"
        )
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(
            f"{where}: field {field!r} holds the non-finite value {number!r}; clean the bag or"
            " leave the channel out"
        )
    return number


def _one_line(exc: BaseException) -> str:
    """The text of an exception from rosbags on one line (YAML errors span several)."""
    return " ".join(str(exc).split())


def _header_stamp_ns(message: object) -> int | None:
    """``header.stamp`` in nanoseconds, or ``None`` when the message has no standard header."""
    stamp = getattr(getattr(message, "header", None), "stamp", None)
    if stamp is None or not hasattr(stamp, "sec") or not hasattr(stamp, "nanosec"):
        return None
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _read_bag(
    bag: Path,
    topics: dict[str, _Topic],
    stamps: Literal["header", "receive"],
) -> int:
    """Read the chosen topics of a bag into ``topics``; return the bag's start time in ns."""
    any_reader, reader_error, humble = _import_rosbags()
    if not bag.exists():
        raise FileNotFoundError(f"{bag}: no such ROS 2 bag (folder or .db3/.mcap file)")
    try:
        reader = any_reader([bag], default_typestore=humble)
        reader.open()
    except (reader_error, FileNotFoundError) as exc:
        # rosbags raises FileNotFoundError for a part of the bag (metadata.yaml, a storage file)
        # that is missing; the path itself exists, so the bag is what cannot be opened.
        raise ValueError(f"{bag.name}: cannot be opened as a ROS 2 bag: {_one_line(exc)}") from exc
    try:
        recorded = {c.topic: c.msgtype for c in reader.connections}
        for topic in topics:
            if topic not in recorded:
                listing = ", ".join(f"{t!r} ({m})" for t, m in sorted(recorded.items()))
                raise KeyError(
                    f"{bag.name}: topic {topic!r} is not in the bag; its topics are"
                    f" {listing or 'none'}"
                )
        counts = dict.fromkeys(topics, 0)
        connections = [c for c in reader.connections if c.topic in topics]
        for connection, receive_ns, raw in reader.messages(connections=connections):
            collected = topics[connection.topic]
            where = (
                f"{bag.name}, topic {connection.topic!r}, message index {counts[connection.topic]}"
            )
            counts[connection.topic] += 1
            try:
                message = reader.deserialize(raw, connection.msgtype)
            except reader_error as exc:
                raise ValueError(
                    f"{where}: cannot decode the {connection.msgtype}: {_one_line(exc)}"
                ) from exc
            for column, field in enumerate(collected.fields):
                collected.values[column].append(
                    _field_value(message, collected.steps[column], field, where)
                )
            header_ns = _header_stamp_ns(message) if stamps == "header" else None
            collected.uses_header = header_ns is not None
            collected.stamps_ns.append(receive_ns if header_ns is None else header_ns)
        return int(reader.start_time)
    finally:
        reader.close()


def _relative_ns(bag: str, topic: str, data: _Topic, start_ns: int) -> NDArray[np.int64]:
    """Stamps of a topic in nanoseconds after ``start_ns``; refuse too few or unordered ones."""
    if len(data.stamps_ns) < 2:
        raise ValueError(
            f"{bag}: topic {topic!r} holds {len(data.stamps_ns)} message(s); a channel needs at"
            " least 2 to be resampled"
        )
    # Subtract in integer nanoseconds: float64 seconds since 1970 would lose the microseconds.
    relative = np.array([s - start_ns for s in data.stamps_ns], dtype=np.int64)
    backwards = np.flatnonzero(np.diff(relative) <= 0)
    if backwards.size:
        k = int(backwards[0]) + 1
        source = "header.stamp" if data.uses_header else "receive time"
        hint = (
            "; if the publisher does not fill header.stamp, pass stamps='receive'"
            if data.uses_header
            else ""
        )
        raise ValueError(
            f"{bag}: topic {topic!r}, message index {k}: {source} {relative[k] / 1e9:.9g} s"
            f" does not come after the previous message's {relative[k - 1] / 1e9:.9g} s"
            f" ({backwards.size} such message(s)); stamps must increase{hint}"
        )
    return relative


def _common_grid(bag: str, times: dict[str, NDArray[np.float64]], ts: float) -> NDArray[np.float64]:
    """Times every ``ts`` seconds from the latest first stamp up to the earliest last stamp."""
    first = max(time[0] for time in times.values())
    last = min(time[-1] for time in times.values())
    if last <= first:
        spans = ", ".join(f"{t!r} {time[0]:.6g} to {time[-1]:.6g} s" for t, time in times.items())
        raise ValueError(
            f"{bag}: the channels do not overlap in time (seconds after the bag's start): {spans}"
        )
    # The tolerance keeps the last grid time when (last - first) / ts is an integer up to rounding.
    n_samples = math.floor((last - first) / ts + 1e-9) + 1
    if n_samples < 2:
        raise ValueError(
            f"{bag}: the channels overlap for {last - first:.6g} s only (from {first:.6g} to"
            f" {last:.6g} s after the bag's start), less than one period ts={ts:g} s; pass a"
            " smaller ts"
        )
    return first + ts * np.arange(n_samples)


def rosbag_fields(
    path: str | Path,
    channels: Mapping[str, RosbagChannel | tuple[str, str, str] | tuple[str, str, str, str]],
    *,
    ts: float | None = None,
    name: str | None = None,
    stamps: Literal["header", "receive"] = "header",
) -> dict[str, Any]:
    r"""Read chosen numeric fields of a ROS 2 bag, resampled onto one uniform time grid.

    Returns the keyword arguments of :class:`~neckid.IOData` (this module does not import it, so
    that ``neckid.data.iodata`` can call it); :meth:`neckid.IOData.from_rosbag` and
    :func:`neckid.datasets.load_rosbag` return the log itself.

    Parameters
    ----------
    path : str or Path
        The bag: the folder ``ros2 bag record`` writes (with ``metadata.yaml`` and the ``.db3``
        or ``.mcap`` files). rosbags 0.11 and later also open a single ``.db3`` / ``.mcap`` file.
    channels : mapping of str to RosbagChannel or tuple
        Channel name -> ``(topic, field, kind, unit)`` (see :class:`RosbagChannel`; ``unit`` may
        be left out of a plain tuple). For example ``{"velocity_command": ("/motor/cmd", "data",
        "input", "rad/s"), "inclination": ("/imu/tilt", "vector.x", "output", "deg")}``. Inputs
        and outputs keep the order of the mapping; several channels may read one topic. At least
        one channel must be an input.
    ts : float, optional
        Sampling period of the grid in seconds. Default: the median period of the slowest
        channel (the largest median time step among the chosen topics).
    name : str, optional
        Label of the log; default the bag's file or folder name.
    stamps : {"header", "receive"}, default "header"
        Time of each message. ``"header"``: its ``header.stamp`` (the time the publisher gave
        the data) when the message type has a ``header``, else the time the recorder received
        it. ``"receive"``: always the receive time (for publishers that leave the stamp empty).

    Returns
    -------
    IOData
        Inputs and outputs sampled every ``ts`` seconds, with the channels' names and units;
        ``t0`` is the first grid time in seconds after the bag's start (the receive time of its
        first message, on any topic).

    Raises
    ------
    ImportError
        If the optional dependency ``rosbags`` is not installed.
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the bag cannot be opened or a message cannot be decoded; a field holds something other
        than a finite number, or an index beyond the array (the message says which message);
        a topic holds fewer than 2 messages or its stamps do not increase; the channels do not
        overlap in time (the message lists each topic's span), or overlap for less than ``ts``;
        or ``channels`` is malformed (bad kind, bad field path, no input).
    KeyError
        If a topic is not in the bag (the message lists the topics there are) or a field path
        does not exist on the topic's message type (the message names the type and its fields).
    TypeError
        If a channel is not a 3- or 4-tuple of strings.

    Notes
    -----
    Resampling. Let :math:`t^{(c)}_k` be the stamps of channel :math:`c` (seconds after the
    bag's start). The grid runs from the latest first stamp to the earliest last stamp,

    .. math:: t_n = t_{\mathrm{start}} + n\,T_s,\quad
              t_{\mathrm{start}} = \max_c t^{(c)}_0,\quad
              t_n \le \min_c t^{(c)}_{\mathrm{last}},

    so every channel is interpolated, never extrapolated. Each channel is linearly interpolated
    between its two neighbouring messages (:func:`numpy.interp`). Linear interpolation was chosen
    over a zero-order hold because the logged signals (motor velocities, inclinations) are
    samples of continuous quantities: its error is of order :math:`T^2 \ddot x / 8` for a message
    period :math:`T`, and it adds no delay, where a zero-order hold lags by half a message period
    on average, which an identified model would mistake for dead time. The cost: a step in a
    piecewise-constant command is spread over one of its message periods.

    No anti-aliasing filter is applied: on a grid slower than a channel's rate, that channel is
    sampled, not averaged. A gap longer than ``GAP_FACTOR`` (5) of a topic's median periods
    inside the grid is bridged by the straight line and reported with a warning.

    Header stamps and receive times share one clock when the publishers and the recorder do
    (both system time, or both ``/clock`` with ``use_sim_time``). Messages are decoded with the
    type definitions stored in the bag, so custom message types need no ROS package; bags
    without stored definitions are decoded with the ROS 2 Humble types.

    Examples
    --------
    Write a small bag with rosbags (a command at 100 Hz) and read it back:

    >>> import os, tempfile
    >>> import pytest
    >>> rosbag2 = pytest.importorskip("rosbags.rosbag2")
    >>> from rosbags.typesys import Stores, get_typestore
    >>> from neckid.datasets import load_rosbag
    >>> types = get_typestore(Stores.ROS2_HUMBLE)
    >>> Float64 = types.types["std_msgs/msg/Float64"]
    >>> folder = os.path.join(tempfile.mkdtemp(), "run1")
    >>> with rosbag2.Writer(folder, version=8) as writer:
    ...     cmd = writer.add_connection("/motor/cmd", "std_msgs/msg/Float64", typestore=types)
    ...     for k in range(101):  # 1 s at 100 Hz, data = 2 k
    ...         raw = types.serialize_cdr(Float64(data=2.0 * k), "std_msgs/msg/Float64")
    ...         writer.write(cmd, 10**18 + k * 10**7, bytes(raw))
    >>> data = load_rosbag(folder, {"cmd": ("/motor/cmd", "data", "input", "rad/s")}, ts=0.02)  # or IOData.from_rosbag
    >>> data
    IOData(n_samples=51, ts=0.02, inputs=['cmd'], outputs=[], name='run1')
    >>> data.t0, data.unit("cmd"), data.u[:3].ravel()
    (0.0, 'rad/s', array([0., 4., 8.]))
    """
    bag = Path(path)
    if not isinstance(channels, Mapping):
        raise TypeError(
            "channels must be a mapping of channel name -> (topic, field, kind, unit);"
            f" got {type(channels).__name__}"
        )
    if not channels:
        raise ValueError("channels is empty; name at least one input channel")
    specs = {n: _as_channel(n, spec) for n, spec in channels.items()}
    if not any(c.kind == "input" for c in specs.values()):
        raise ValueError(
            f"channels must include at least one kind 'input'; got only outputs {list(specs)}"
        )
    if stamps not in ("header", "receive"):
        raise ValueError(f"stamps must be 'header' or 'receive'; got {stamps!r}")
    ts_value = None if ts is None else check_ts(ts)

    topics: dict[str, _Topic] = {}
    for spec in specs.values():
        wanted = topics.setdefault(spec.topic, _Topic([], []))
        wanted.fields.append(spec.field)
        wanted.steps.append(_parse_field(spec.field))
        wanted.values.append([])
    start_ns = _read_bag(bag, topics, stamps)

    stamps_ns = {t: _relative_ns(bag.name, t, data, start_ns) for t, data in topics.items()}
    times = {t: relative / 1e9 for t, relative in stamps_ns.items()}
    periods = {t: float(np.median(np.diff(relative))) / 1e9 for t, relative in stamps_ns.items()}
    ts_value = max(periods.values()) if ts_value is None else ts_value
    grid = _common_grid(bag.name, times, ts_value)

    for topic, time in times.items():
        steps = np.diff(time)
        inside = (time[:-1] < grid[-1]) & (time[1:] > grid[0])
        gaps = np.flatnonzero(inside & (steps > GAP_FACTOR * periods[topic]))
        if gaps.size:
            widest = int(gaps[np.argmax(steps[gaps])])
            warnings.warn(
                f"{bag.name}: topic {topic!r} has {gaps.size} gap(s) longer than {GAP_FACTOR:g}"
                f" median periods ({periods[topic]:.6g} s), the widest {steps[widest]:.6g} s after"
                f" {time[widest]:.6g} s; the resampled channel follows a straight line there",
                stacklevel=2,
            )

    columns: dict[str, NDArray[np.float64]] = {}
    for channel_name, spec in specs.items():
        topic_data = topics[spec.topic]
        raw = topic_data.values[topic_data.fields.index(spec.field)]
        # Counts beyond 2**53, dates: refused by name, never rounded by the interpolation.
        values = as_2d(raw, f"{bag.name}: {spec.topic}:{spec.field}", names=[channel_name])
        columns[channel_name] = np.interp(grid, times[spec.topic], values[:, 0])
    inputs = [n for n, c in specs.items() if c.kind == "input"]
    outputs = [n for n, c in specs.items() if c.kind == "output"]
    logger.info(
        "%s: %d channels from %d topics resampled to %d samples every %g s from %g s",
        bag.name,
        len(specs),
        len(topics),
        grid.size,
        ts_value,
        grid[0],
    )
    return dict(
        u=np.column_stack([columns[n] for n in inputs]),
        y=np.column_stack([columns[n] for n in outputs]) if outputs else None,
        ts=ts_value,
        input_names=inputs,
        output_names=outputs,
        input_units=[specs[n].unit for n in inputs],
        output_units=[specs[n].unit for n in outputs],
        t0=float(grid[0]),
        name=bag.name if name is None else name,
    )
