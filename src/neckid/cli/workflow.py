"""The pieces the command line shares with scripts: read a log, parse a lag text, build an estimator."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np

from neckid.cli.lag_text import (
    format_lags,
    lone_lag_note,
    parse_lags,
    parse_order_grid,
    parse_orders,
)
from neckid.data.iodata import IOData
from neckid.data.preprocess import (
    LowPass,
    Pipeline,
    Relative,
    RemoveOffset,
    Resample,
    Restamp,
    Tilt,
)
from neckid.regressors import Lags

__all__ = [
    "describe_log",
    "describe_model",
    "fit_model",
    "format_lags",
    "lone_lag_note",
    "make_estimator",
    "map_channels",
    "parse_channels",
    "parse_lags",
    "parse_mapping",
    "parse_order_grid",
    "parse_orders",
    "pipeline_from_options",
    "prepare_log",
    "read_log",
    "read_log_for_model",
]


def read_log(
    path: str | Path,
    inputs: Sequence[str] | None = None,
    outputs: Sequence[str] | None = None,
    *,
    time: str | None = "time",
    ts: float | None = None,
    layout: Literal["csv", "softneck", "rosbag"] = "csv",
    sep: str = ",",
    channels: Sequence[str] = (),
    conditions: Sequence[str] = (),
    tilt: bool = False,
    maps: Mapping[str, str] | None = None,
    preprocessing: Pipeline | None = None,
) -> IOData:
    r"""Read a log for identification, with its experimental conditions, renamed and preprocessed.

    Parameters
    ----------
    path : path
        A CSV with a header row (``layout="csv"``), a Parquet or ``.mat`` file (by extension), or
        one of the lab's headerless soft-neck logs (``layout="softneck"``, see
        :func:`neckid.datasets.load_softneck_log`).
    inputs, outputs : sequence of str
        Channel names. Required for CSV/Parquet/MAT; for soft-neck logs they select among the
        loader's named channels (default: all of them).
    time, ts : see :meth:`IOData.from_csv`.
    layout : {"csv", "softneck"}
        How the file is laid out.
    sep : str, default ","
        Column separator of a CSV log (``";"`` for logs written with a decimal comma locale,
        a tab for tab-separated ones).
    channels : sequence of str
        With ``layout="rosbag"``: one ``NAME=TOPIC:FIELD:KIND[:UNIT]`` per channel, e.g.
        ``inclination=/imu/tilt:vector.x:output:deg`` (see :meth:`IOData.from_rosbag`);
        ``inputs``/``outputs`` then select among them.
    conditions : sequence of str
        ``name=value`` conditions of the experiment (``"payload=0.4kg"``). They override those of
        the log's sidecar ``<stem>.conditions.json`` (:func:`neckid.data.sidecar.read_sidecar`),
        which override those the loader reads from a soft-neck file name.
    tilt : bool, default False
        A 3-D neck's log: read its ``inclination`` and ``orientation`` outputs [deg] and return
        the tilt vector ``tilt_x``, ``tilt_y`` [deg] in their place (:mod:`neckid.data.tilt`).
        ``tilt_x``/``tilt_y`` among ``outputs`` (a model's channels) stand for those two.
    maps : mapping of str to str, optional
        Log channel name -> model channel name (what :func:`parse_mapping` returns): ``inputs``,
        ``outputs``, ``tilt`` and ``preprocessing`` use the model's names, the file is read by
        the log's. The conditions (file name, sidecar, ``conditions``) are kept.
    preprocessing : Pipeline, optional
        Applied last (:mod:`neckid.data.preprocess`); ``inputs``/``outputs`` name the channels
        after it (with a :class:`~neckid.data.preprocess.Tilt` step, ``tilt_x``/``tilt_y`` are
        read as inclination and orientation). A :class:`~neckid.data.preprocess.Restamp` step
        decides what happens to repeated time stamps while the file is read.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "run.csv")
    >>> _ = open(path, "w").write("time,pos,incl\n0,1.5,0\n0.02,2.5,0.1\n0.04,3.5,0.3\n")
    >>> data = read_log(path, ["motor_position"], ["incl"], maps={"pos": "motor_position"},
    ...                 preprocessing=Pipeline([Relative("motor_position")]))
    >>> data.channel("motor_position")
    array([0., 1., 2.])
    """
    from neckid.data.sidecar import apply_conditions

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"log file {str(path)!r} does not exist")
    pipeline = preprocessing if preprocessing is not None else Pipeline()
    if inputs is not None:
        inputs = pipeline.sources(inputs)
    if outputs is not None:
        outputs = pipeline.sources(outputs)
    step = pipeline.find(Tilt)
    tilt = tilt and step is None  # a Tilt step does it once, after the renaming
    if tilt or step is not None:
        if tilt:
            outputs = [*dict.fromkeys(_POLAR.get(name, name) for name in outputs or ())]
        polar = (step.inclination, step.orientation) if step else ("inclination", "orientation")
        missing = [name for name in polar if name not in (outputs or ())]
        if missing:
            raise ValueError(
                f"--tilt needs the outputs inclination and orientation; --outputs lacks {missing}"
            )
    mapping = dict(maps or {})
    to_log = {model: log for log, model in mapping.items()}
    if inputs is not None:
        inputs = [to_log.get(n, n) for n in inputs]
    if outputs is not None:
        outputs = [to_log.get(n, n) for n in outputs]
    restamp = pipeline.find(Restamp)
    data = _read_channels(path, inputs, outputs, time, ts, layout, sep, channels, restamp)
    if mapping:
        data = map_channels(data, mapping)
    if tilt:
        data = data.with_tilt()
    return pipeline.apply(apply_conditions(data, path, conditions))


#: With ``tilt=True``, the tilt-vector channel a model names and the log channel it comes from.
_POLAR = {"tilt_x": "inclination", "tilt_y": "orientation"}


def _read_channels(
    path: Path,
    inputs: Sequence[str] | None,
    outputs: Sequence[str] | None,
    time: str | None,
    ts: float | None,
    layout: str,
    sep: str,
    channels: Sequence[str],
    restamp: Restamp | None = None,
) -> IOData:
    if layout == "rosbag":
        data = IOData.from_rosbag(path, parse_channels(channels), ts=ts)
        wanted_in = list(inputs) if inputs else list(data.input_names)
        wanted_out = list(outputs) if outputs else list(data.output_names)
        return data.select(inputs=wanted_in, outputs=wanted_out)
    if layout == "softneck":
        from neckid.datasets import load_softneck_log

        keep_all = restamp is None or restamp.keep == "all"
        data = load_softneck_log(path, repeated_stamps="restamp" if keep_all else "drop")
        if ts is not None and abs(data.ts - ts) > 0.01 * ts:  # read by its time column
            message = f"--ts {ts:g} contradicts its time column, whose stamps are {data.ts:.6g} s"
            raise ValueError(f"{path.name}: {message} apart: drop --ts")
        if not inputs or not outputs:
            raise ValueError(
                f"--inputs and --outputs are required with --layout softneck: {path.name} has"
                f" inputs {list(data.input_names)} and outputs {list(data.output_names)}"
                " (inclination_filtered is derived from inclination; control_filtered is internal"
                " to the controller)"
            )
        return data.select(inputs=list(inputs), outputs=list(outputs))
    if layout != "csv":
        raise ValueError(f"layout must be 'csv', 'softneck' or 'rosbag'; got {layout!r}")
    if not inputs:
        raise ValueError("--inputs is required for a CSV log: name the input column(s)")
    if path.suffix.lower() not in (".parquet", ".mat"):
        _refuse_headerless(path, sep)
    suffix = path.suffix.lower()
    # With --ts, the time column is only checked against it (the reader refuses a contradiction).
    if restamp is not None and ts is None and time is not None and suffix != ".mat":
        return _read_restamped(path, inputs, outputs or (), time, sep, restamp)
    if suffix == ".parquet":
        return IOData.from_parquet(path, list(inputs), list(outputs or ()), time=time, ts=ts)
    if suffix == ".mat":
        return IOData.from_mat(path, list(inputs), list(outputs or ()), time=time, ts=ts)
    if not sep:
        raise ValueError("--sep must be one character or more; got an empty separator")
    return IOData.from_csv(path, list(inputs), list(outputs or ()), time=time, ts=ts, sep=sep)


def _read_restamped(
    path: Path,
    inputs: Sequence[str],
    outputs: Sequence[str],
    time: str,
    sep: str,
    restamp: Restamp,
) -> IOData:
    """A CSV or Parquet log whose repeated time stamps are dealt with by ``restamp`` first."""
    from neckid.data.csv_logs import read_csv_frame

    if path.suffix.lower() == ".parquet":
        from neckid.data.parquet import read_parquet_columns

        frame = read_parquet_columns(path, None)
    else:
        if not sep:
            raise ValueError("--sep must be one character or more; got an empty separator")
        frame = read_csv_frame(path, sep=sep)
    if time not in frame.columns:
        raise KeyError(
            f"{path.name} has no time column {time!r}; it has {list(map(str, frame.columns))}"
            " (give --time NAME)"
        )
    try:
        fields = IOData.from_frame(
            restamp.frame(frame, time), list(inputs), list(outputs), time=time, name=path.name
        )
    except (KeyError, ValueError) as exc:
        message = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
        raise type(exc)(f"{path.name}: {message}") from None
    return fields


def _refuse_headerless(path: Path, sep: str) -> None:
    """Refuse a CSV whose first row holds numbers: a headerless log read as if it had a header."""
    with path.open("rb") as handle:
        first = handle.readline(4096).decode("utf-8", errors="replace").strip()
    fields = [f.strip() for f in first.split(sep)] if first else []
    if len(fields) < 2:
        return
    try:
        [float(f) for f in fields]
    except ValueError:
        return
    from neckid.datasets.softneck import SOFTNECK_LAYOUTS

    layout = SOFTNECK_LAYOUTS.get(len(fields))
    hint = (
        f"; it has {len(fields)} columns like the lab's bench logs: read it with --layout softneck"
        f" (channels {list(layout.columns)})"
        if layout is not None
        else "; add a header row of column names, or read it with --layout softneck if it is a"
        " bench log"
    )
    raise ValueError(
        f"the first row of {path.name} holds numbers ({first[:40]!r}), not column names: a log"
        f" without a header{hint}"
    )


def map_channels(data: IOData, mapping: Mapping[str, str]) -> IOData:
    """Rename channels of ``data``: ``mapping`` goes from the log's name to the model's.

    Everything else is kept: units, the start time, the name and the conditions.

    Examples
    --------
    >>> log = IOData([1.0, 2.0], [0.0, 1.0], ts=0.1, output_names=["inclination_filtered"])
    >>> map_channels(log, {"inclination_filtered": "inclination"}).output_names
    ('inclination',)
    """
    unknown = [k for k in mapping if k not in (*data.input_names, *data.output_names)]
    if unknown:
        raise KeyError(
            f"--map names {unknown}, which the log does not have; it has"
            f" {[*data.input_names, *data.output_names]}"
        )
    return data.replace(
        input_names=[mapping.get(n, n) for n in data.input_names],
        output_names=[mapping.get(n, n) for n in data.output_names],
    )


def _split_option(text: str, option: str, fields: int, example: str) -> list[str]:
    parts = [p.strip() for p in text.rsplit(":", fields - 1)]
    if len(parts) != fields or not all(parts):
        raise ValueError(f"{option} must look like {example}; got {text!r}")
    return parts


def _option_number(text: str, option: str, whole: str) -> float:
    """``text`` as a number; the caller names the option."""
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"{text!r} is not a number") from None


def pipeline_from_options(
    *,
    relative: Sequence[str] = (),
    offsets: Sequence[str] = (),
    lowpass: Sequence[str] = (),
    resample: float | None = None,
    restamp: bool = False,
    tilt: bool = False,
) -> Pipeline:
    """The preprocessing the command line's options ask for, in a fixed order.

    The order is: restamp, tilt, relative, offset, low-pass, resample (each option in the order
    given). Channel names are the model's (after ``--map``).

    Parameters
    ----------
    relative : sequence of str
        ``--relative CHANNEL``: :class:`~neckid.data.preprocess.Relative`.
    offsets : sequence of str
        ``--offset CHANNEL:START:STOP`` [s from the first sample]:
        :class:`~neckid.data.preprocess.RemoveOffset`.
    lowpass : sequence of str
        ``--lowpass CHANNEL:CUTOFF`` [rad/s]: :class:`~neckid.data.preprocess.LowPass`.
    resample : float, optional
        ``--resample TS`` [s]: :class:`~neckid.data.preprocess.Resample`.
    restamp, tilt : bool
        ``--restamp`` (keep the first row of a repeated stamp) and ``--tilt``.

    Examples
    --------
    >>> pipeline_from_options(relative=["motor_position"], lowpass=["inclination:1"]).describe()
    'relative motor_position; low-pass inclination at 1 rad/s'
    """
    steps: list[Any] = [Restamp()] if restamp else []
    if tilt:
        steps.append(Tilt())

    def build(option: str, text: str, make: Any) -> None:
        try:
            steps.append(make())
        except ValueError as exc:
            reason = str(exc).split(": ", 1)[-1] if str(exc).startswith("preprocessing") else exc
            raise ValueError(f"{option} {text!r}: {reason}") from None

    for text in relative:
        build("--relative", text, lambda text=text: Relative(text.strip()))
    for text in offsets:
        channel, start, stop = _split_option(
            text, "--offset", 3, "CHANNEL:START:STOP in seconds, e.g. inclination:0:2"
        )
        build(
            "--offset",
            text,
            lambda c=channel, a=start, b=stop, t=text: RemoveOffset(
                c, _option_number(a, "--offset", t), _option_number(b, "--offset", t)
            ),
        )
    for text in lowpass:
        channel, cutoff = _split_option(
            text, "--lowpass", 2, "CHANNEL:CUTOFF in rad/s, e.g. inclination:1"
        )
        build(
            "--lowpass",
            text,
            lambda c=channel, w=cutoff, t=text: LowPass(c, _option_number(w, "--lowpass", t)),
        )
    if resample is not None:
        build("--resample", str(resample), lambda: Resample(resample))
    return Pipeline(steps)


def fit_model(
    estimator: Any, data: IOData | Sequence[IOData], preprocessing: Pipeline | None = None
) -> Any:
    """Fit ``estimator`` on ``data`` through ``preprocessing`` and record it with the model.

    The pipeline is applied to ``data`` (which is not changed), the estimator fitted, and the
    pipeline kept as ``estimator.preprocessing_``: ``save`` writes it into the model file,
    :func:`~neckid.models.io.load_model` restores it and :func:`prepare_log` applies it again.

    Returns
    -------
    estimator
        Fitted.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> log = IOData(np.sin(np.arange(50.0)) + 3, np.cos(np.arange(50.0)), ts=0.02)
    >>> model = fit_model(LinearARX(Lags.arx(1, 1)), log, Pipeline([Relative("u")]))
    >>> model.preprocessing_.describe()
    'relative u'
    """
    pipeline = preprocessing if preprocessing is not None else Pipeline()
    estimator.fit(pipeline.apply(data))
    estimator.preprocessing_ = pipeline
    return estimator


def prepare_log(model: Any, data: IOData) -> IOData:
    """``data`` through the preprocessing the model was identified with (none: ``data`` itself).

    Give it the raw log: a step such as a low-pass filter applied twice is not the same.
    """
    pipeline = model.preprocessing_
    return pipeline.apply(data) if pipeline is not None else data


def read_log_for_model(
    model: Any,
    path: str | Path,
    *,
    time: str | None = "time",
    ts: float | None = None,
    layout: Literal["csv", "softneck", "rosbag"] = "csv",
    sep: str = ",",
    channels: Sequence[str] = (),
    maps: Mapping[str, str] | None = None,
    conditions: Sequence[str] = (),
    tilt: bool = False,
) -> tuple[IOData, Pipeline | None]:
    """Read a log with the channels a fitted model needs, through the model's preprocessing.

    The model's inputs (but the conditions it takes, which come from the file name, a sidecar
    or ``conditions``) and outputs are read, renamed by ``maps`` (log name -> model name),
    and passed through ``model.preprocessing_`` when it has one (:func:`read_log`).

    Returns
    -------
    data : IOData
        Ready for ``model.simulate``.
    preprocessing : Pipeline or None
        The model's steps that were applied (None for a model without any).
    """
    pipeline = model.preprocessing_
    if pipeline is not None and not len(pipeline):
        pipeline = None
    used = set(model._condition_names())
    inputs = [n for n in model.input_names_ if n not in used]
    _check_mapping_names(maps or {}, [*inputs, *model.output_names_], pipeline, tilt)
    data = read_log(
        path,
        inputs,
        list(model.output_names_),
        time=time,
        ts=ts,
        layout=layout,
        sep=sep,
        channels=channels,
        conditions=conditions,
        tilt=tilt,
        maps=maps,
        preprocessing=pipeline,
    )
    return data, pipeline


def _check_mapping_names(
    maps: Mapping[str, str], channels: Sequence[str], pipeline: Pipeline | None, tilt: bool
) -> None:
    """Refuse a ``--map MODEL=LOG`` whose model channel the model does not read, naming it."""
    known = {*channels, *(pipeline.sources(list(channels)) if pipeline is not None else ())}
    if tilt or (pipeline is not None and pipeline.find(Tilt) is not None):
        known |= {"inclination", "orientation"}
    for log, name in ((log, name) for log, name in maps.items() if name not in known):
        raise ValueError(
            f"--map {name}={log}: the model has no channel {name!r} (it reads"
            f" {', '.join(sorted(known))}); write --map MODEL_CHANNEL=LOG_COLUMN"
        )


def parse_channels(texts: Sequence[str]) -> dict[str, tuple[str, ...]]:
    """Read ``NAME=TOPIC:FIELD:KIND[:UNIT]`` channel specifications of a ROS 2 bag.

    Examples
    --------
    >>> parse_channels(["inclination=/imu/tilt:vector.x:output:deg"])
    {'inclination': ('/imu/tilt', 'vector.x', 'output', 'deg')}
    """
    if not texts:
        raise ValueError(
            "--layout rosbag needs --channel NAME=TOPIC:FIELD:KIND[:UNIT] for each channel, e.g."
            " --channel inclination=/imu/tilt:vector.x:output:deg"
        )
    channels: dict[str, tuple[str, ...]] = {}
    for text in texts:
        name, sep, rest = text.partition("=")
        parts = tuple(p.strip() for p in rest.split(":"))
        if not sep or not name.strip() or len(parts) not in (3, 4) or not all(parts[:3]):
            raise ValueError(
                f"--channel must look like NAME=TOPIC:FIELD:KIND[:UNIT], e.g."
                f" inclination=/imu/tilt:vector.x:output:deg; got {text!r}"
            )
        channels[name.strip()] = parts
    return channels


def parse_mapping(texts: Sequence[str]) -> dict[str, str]:
    """Read ``MODEL_CHANNEL=LOG_CHANNEL`` pairs; return log name -> model name.

    Examples
    --------
    >>> parse_mapping(["inclination=inclination_filtered"])
    {'inclination_filtered': 'inclination'}
    """
    mapping: dict[str, str] = {}
    for text in texts:
        model_name, sep, log_name = text.partition("=")
        if not sep or not model_name.strip() or not log_name.strip():
            raise ValueError(
                f"--map must look like MODEL_CHANNEL=LOG_CHANNEL, e.g."
                f" inclination=inclination_filtered; got {text!r}"
            )
        mapping[log_name.strip()] = model_name.strip()
    return mapping


def make_estimator(method: str, lags: Lags, *, random_state: int | None = 0, **options: Any) -> Any:
    """Build an unfitted estimator by its name in :func:`neckid.methods` (deprecated spellings warn).

    ``random_state`` is passed to the methods that have one (the neural NARX).
    """
    from neckid.registry import get_method

    entry = get_method(method)
    if "random_state" in entry.estimator_class()._parameter_constraints:
        options = {"random_state": random_state, **options}
    return entry.make(lags, **options)


def describe_log(
    path: str | Path,
    *,
    layout: Literal["csv", "softneck", "rosbag"] = "csv",
    time: str = "time",
    sep: str = ",",
    maps: Mapping[str, str] | None = None,
    conditions: Sequence[str] = (),
    channels_spec: Sequence[str] = (),
) -> dict[str, Any]:
    """What a log holds, before any identification: channels, units, duration, sampling, gaps.

    Parameters
    ----------
    path : path
        A CSV log with a header row, a Parquet or ``.mat`` file (by extension), or a bench log
        with ``layout="softneck"``.
    layout, sep : as in :func:`read_log`.
    time : str, default "time"
        The time column of a CSV log [s].
    maps : mapping of str to str, optional
        Log channel name -> model channel name: channels are listed by the model's name (with
        ``"column"``, the log's).
    conditions : sequence of str
        ``name=value`` conditions, over the sidecar's, over those of a soft-neck file name.
    channels_spec : sequence of str
        With ``layout="rosbag"``: ``NAME=TOPIC:FIELD:KIND[:UNIT]`` per channel, as for
        :func:`read_log`.

    Returns
    -------
    dict
        ``{"file", "samples", "duration_s", "ts_s", "max_step_s", "gaps", "repeated_stamps",
        "channels", "conditions", "condition_units", "skipped"}``; ``channels`` maps each column to
        ``{"kind", "unit", "min", "max", "mean"}``. A gap is a time step more than 1.5 times
        the median one; a repeated stamp, a step of zero.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"log file {str(path)!r} does not exist")
    channels: dict[str, dict[str, Any]] = {}
    skipped: list[str] = []
    found: tuple[Mapping[str, Any], Mapping[str, str]] = ({}, {})
    if layout in ("softneck", "rosbag"):
        if layout == "softneck":
            from neckid.datasets import load_softneck_log

            data = load_softneck_log(path)
        else:
            if not channels_spec:
                raise ValueError(
                    "--channel is required with --layout rosbag: NAME=TOPIC:FIELD:KIND[:UNIT]"
                    " for each channel to describe"
                )
            data = read_log(path, layout="rosbag", channels=channels_spec)
        found = (data.conditions, data.condition_units)
        t = data.time
        for kind, names, units, values in (
            ("input", data.input_names, data.input_units, data.u),
            ("output", data.output_names, data.output_units, data.y),
        ):
            for j, name in enumerate(names):
                channels[name] = {"kind": kind, "unit": units[j], "values": values[:, j]}
    else:
        t, channels, skipped = _table_channels(path, sep, time)
    steps = np.diff(t)
    median = float(np.median(steps)) if steps.size else float("nan")
    summary = {}
    for name, channel in channels.items():
        values = channel.pop("values")
        finite = values[np.isfinite(values)]
        summary[name] = {
            **channel,
            "min": float(finite.min()) if finite.size else float("nan"),
            "max": float(finite.max()) if finite.size else float("nan"),
            "mean": float(finite.mean()) if finite.size else float("nan"),
            "non_numeric": int(values.size - finite.size),
        }
    mapping = dict(maps or {})
    unknown = [k for k in mapping if k not in summary]
    if unknown:
        raise KeyError(
            f"--map names {unknown}, which the log does not have; it has {list(summary)}"
        )
    summary = {
        mapping.get(k, k): {**v, "column": k} if k in mapping else v for k, v in summary.items()
    }
    found_values, found_units = _log_conditions(path, found, conditions)
    return {
        "file": path.name,
        "samples": int(t.size),
        "duration_s": float(t[-1] - t[0]) if t.size > 1 else 0.0,
        "ts_s": median,
        "max_step_s": float(steps.max()) if steps.size else float("nan"),
        "gaps": int(np.sum(steps > 1.5 * median)) if steps.size else 0,
        "repeated_stamps": int(np.sum(steps == 0)) if steps.size else 0,
        "channels": summary,
        "conditions": found_values,
        "condition_units": found_units,
        "skipped": skipped,
    }


def _table_channels(
    path: Path, sep: str, time: str
) -> tuple[Any, dict[str, dict[str, Any]], list[str]]:
    """A CSV, Parquet or ``.mat`` log's time [s], its columns as channels, what is not a channel."""
    import pandas as pd

    from neckid.data.tables import whole_table

    if path.stat().st_size == 0:
        raise ValueError(f"log file {str(path)!r} is empty")
    if path.suffix.lower() not in (".parquet", ".mat"):
        _refuse_headerless(path, sep)
    table = whole_table(path, sep=sep, time=time)
    frame = table["frame"]
    if time not in frame.columns:
        raise KeyError(
            f"{path.name} has no time column {time!r}; it has {list(map(str, frame.columns))}"
            " (give --time NAME)"
        )
    t = pd.to_numeric(frame[time], errors="coerce").to_numpy(dtype=np.float64)
    channels: dict[str, dict[str, Any]] = {}
    for name in frame.columns:
        if name != time:
            values = pd.to_numeric(frame[name], errors="coerce").to_numpy(dtype=np.float64)
            channels[str(name)] = {"kind": "column", "unit": "", "values": values}
    return t, channels, table["skipped"]


def _log_conditions(
    path: Path, found: tuple[Mapping[str, Any], Mapping[str, str]], given: Sequence[str]
) -> tuple[dict[str, Any], dict[str, str]]:
    """A log's conditions: the loader's, then its sidecar's, then the given ones (last wins)."""
    from neckid.data.conditions import parse_condition
    from neckid.data.sidecar import read_sidecar

    values, units = dict(found[0]), dict(found[1])
    sidecar_values, sidecar_units = read_sidecar(path)
    values.update(sidecar_values)
    units.update(sidecar_units)
    for text in given:
        name, value, unit = parse_condition(text)
        values[name] = value
        if unit or name not in units:
            units[name] = unit
    return values, {k: v for k, v in units.items() if k in values and v}


def describe_model(model: Any) -> dict[str, Any]:
    """What a fitted model is: method, class, regressor, channels, sampling, training ranges, prior.

    ``conditions`` lists the experimental conditions the model takes as inputs (their training
    ranges are among ``training_ranges``); ``preprocessing``, when the model has steps, lists
    them as JSON (:meth:`neckid.data.preprocess.Pipeline.to_list`).

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> data = IOData(np.sin(np.arange(50.0)), np.cos(np.arange(50.0)), ts=0.02)
    >>> describe_model(LinearARX(Lags.arx(1, 1)).fit(data))["method"]
    'Linear ARX'
    """
    from neckid.registry import method_of

    method = method_of(model)
    lags = model.fitted_lags()
    info: dict[str, Any] = {
        "method": method.label if method is not None else type(model).__name__,
        "method_name": method.name if method is not None else None,
        "class": type(model).__name__,
        "lags": repr(lags.to_lags()) if lags is not None else None,
        "inputs": list(model.input_names_),
        "outputs": list(model.output_names_),
        "output_units": list(model.output_units_),
        "ts_s": float(model.ts_),
        "initial_samples": int(model.max_lag_),
        "training_samples": int(model.training_samples() or 0),
        "training_ranges": {k: list(v) for k, v in model.training_box().items()},
        "conditions": list(model._condition_names()),
    }
    pipeline = model.preprocessing_
    if pipeline is not None and len(pipeline):
        info["preprocessing"] = pipeline.to_list()
    mapping = model.channel_map_
    if mapping:
        info["channel_map"] = dict(mapping)
    prior = model.set_membership_prior()
    if prior is not None:
        horizons = prior.horizons
        if horizons is not None:  # one prior per horizon: {horizon: [value per output]}
            info["horizons"] = list(horizons)
            for key, values in (("epsilon", prior.epsilon), ("gamma", prior.gamma)):
                info[key] = {
                    str(k): [float(v) for v in row] for k, row in zip(horizons, values, strict=True)
                }
        else:
            info["epsilon"] = [float(v) for v in prior.epsilon]
            info["gamma"] = [float(v) for v in prior.gamma]
        info["lipschitz"] = prior.lipschitz
        info["distance"] = prior.distance
        if prior.estimate is not None:
            info["estimate"] = prior.estimate
    order = model.state_order()
    if order is not None:  # subspace model: the order chosen and what it was chosen from
        info["order"] = order.order
        info["singular_values"] = [float(v) for v in order.singular_values]
    return info
