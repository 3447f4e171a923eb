"""One way to carry a log's options: :class:`LogSpec`, declared once for every command.

A command that reads logs takes its log options through :func:`log_options`: the decorator adds
the options to the command's signature (so typer shows and parses them as its own), builds one
frozen :class:`LogSpec` from them and passes it as the command's ``spec`` argument. The
commands then read through :func:`read_training_logs` (identify, select, compare: channels
named by the user, preprocessing built from the options) or :func:`read_for_model` (validate,
simulate: the channels, preprocessing and channel mapping the model carries), and a fitted
model records the preprocessing and the mapping with :func:`attach_log_options`, so that
``validate`` and ``simulate`` replay both on a new log of the same rig.

Two sets of options:

- **reading** (every command that reads a log): ``--time``, ``--ts``, ``--layout``, ``--sep``,
  ``--channel``, ``--condition``, ``--condition-from-name``, ``--condition-unit``, ``--map``,
  ``--tilt``;
- **training** (identify, select, compare): the reading ones, plus ``--inputs``, ``--outputs``
  and the preprocessing steps ``--relative``, ``--offset``, ``--lowpass``, ``--resample``,
  ``--restamp``.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Literal, TypeVar, get_type_hints

import typer

from neckid.cli._app import (
    CHANNEL_OPTION,
    CONDITION_OPTION,
    INPUTS_HELP,
    LAYOUT_OPTION,
    LOWPASS_OPTION,
    MAP_OPTION,
    OFFSET_OPTION,
    OUTPUTS_HELP,
    RELATIVE_OPTION,
    RESAMPLE_OPTION,
    RESTAMP_OPTION,
    SEP_OPTION,
    TILT_OPTION,
    TIME_OPTION,
    TS_OPTION,
    _sep,
    _split,
    console,
)

__all__ = [
    "LogSpec",
    "attach_log_options",
    "log_options",
    "read_for_model",
    "read_training_logs",
]

F = TypeVar("F", bound=Callable[..., Any])


@dataclass(frozen=True)
class LogSpec:
    """How to read a command's logs: the options the user gave, once per command.

    Attributes
    ----------
    time, ts, layout, sep, channels, conditions, maps, tilt
        The reading options (``--time`` ... ``--tilt``); ``maps`` as ``LOG=MODEL`` texts.
    inputs, outputs : tuple of str or None
        The channels (``--inputs``, ``--outputs``; None when not given, or for a command
        that reads the model's own channels).
    relative, offsets, lowpass, resample, restamp
        The preprocessing steps of identify, select and compare (stored in the model).
    name_patterns, name_units : tuple of str
        ``--condition-from-name NAME=REGEX`` and ``--condition-unit UNIT``: conditions read
        from each log's file name (:func:`neckid.data.conditions.conditions_from_name`), under
        a sidecar's and ``--condition``'s (:meth:`with_name_conditions`).
    """

    time: str = "time"
    ts: float | None = None
    layout: Literal["csv", "softneck", "rosbag"] = "csv"
    sep: str = ","
    channels: tuple[str, ...] = ()
    conditions: tuple[str, ...] = ()
    maps: tuple[str, ...] = ()
    tilt: bool = False
    inputs: tuple[str, ...] | None = None
    outputs: tuple[str, ...] | None = None
    relative: tuple[str, ...] = ()
    offsets: tuple[str, ...] = ()
    lowpass: tuple[str, ...] = ()
    resample: float | None = None
    restamp: bool = False
    name_patterns: tuple[str, ...] = ()
    name_units: tuple[str, ...] = ()

    def with_name_conditions(self, data: Any, path: Path) -> Any:
        """``data`` with the conditions ``--condition-from-name`` reads from ``path``'s name.

        A sidecar's condition and a ``--condition`` of the same name win (they are applied
        already, and the pattern is not even tried on the name); a pattern's condition wins
        over what the loader found in a lab's bench file name.
        """
        if not self.name_patterns:
            return data
        from neckid.data.conditions import conditions_from_name
        from neckid.data.sidecar import read_sidecar

        if self.name_units and len(self.name_units) != len(self.name_patterns):
            conditions_from_name("", self.name_patterns, self.name_units)  # raises: the pairing
        units = self.name_units or ("",) * len(self.name_patterns)
        known = set(read_sidecar(path)[0]) | {c.partition("=")[0].strip() for c in self.conditions}
        pairs = [
            (p, u)
            for p, u in zip(self.name_patterns, units, strict=True)
            if p.partition("=")[0].strip() not in known
        ]
        if not pairs:
            return data
        values, found_units = conditions_from_name(
            Path(path).name, [p for p, _ in pairs], [u for _, u in pairs]
        )
        return data.with_conditions(units=found_units, **values)

    def mapping(self) -> dict[str, str]:
        """``--map`` as ``{log name: model name}`` (checked: one line naming a bad item)."""
        from neckid.cli.workflow import parse_mapping

        return parse_mapping(list(self.maps))

    def pipeline(self) -> Any:
        """The preprocessing the options ask for (a :class:`~neckid.data.preprocess.Pipeline`)."""
        from neckid.cli.workflow import pipeline_from_options

        return pipeline_from_options(
            relative=self.relative,
            offsets=self.offsets,
            lowpass=self.lowpass,
            resample=self.resample,
            restamp=self.restamp,
            tilt=self.tilt,
        )

    def reading(self) -> dict[str, Any]:
        """The keyword arguments of :func:`~neckid.cli.workflow.read_log` these options give."""
        return {
            "time": self.time,
            "ts": self.ts,
            "layout": self.layout,
            "sep": _sep(self.sep),
            "channels": self.channels,
            "conditions": self.conditions,
            "tilt": self.tilt,
        }


CONDITION_FROM_NAME_OPTION = typer.Option(
    None,
    "--condition-from-name",
    metavar="NAME=REGEX",
    help="Read a condition from each log's file name: REGEX (searched in the name) holds one"
    " group, the value, e.g. 'payload=(\\d+)g' (repeat for several; a sidecar or --condition"
    " of the same name wins).",
)
CONDITION_UNIT_OPTION = typer.Option(
    None,
    "--condition-unit",
    metavar="UNIT",
    help="The unit of each --condition-from-name value, in the same order (e.g. g).",
)

# name -> (annotation, typer option): the order is the order of --help
_READING: dict[str, tuple[Any, Any]] = {
    "time": (str, TIME_OPTION),
    "ts": (float, TS_OPTION),
    "layout": (str, LAYOUT_OPTION),
    "sep": (str, SEP_OPTION),
    "channels": (list[str], CHANNEL_OPTION),
    "conditions": (list[str], CONDITION_OPTION),
    "name_patterns": (list[str], CONDITION_FROM_NAME_OPTION),
    "name_units": (list[str], CONDITION_UNIT_OPTION),
    "tilt": (bool, TILT_OPTION),
    "maps": (list[str], MAP_OPTION),
}
_TRAINING: dict[str, tuple[Any, Any]] = {
    "inputs": (str, typer.Option(None, "--inputs", help=INPUTS_HELP)),
    "outputs": (str, typer.Option(None, "--outputs", help=OUTPUTS_HELP)),
    **_READING,
    "relative": (list[str], RELATIVE_OPTION),
    "offsets": (list[str], OFFSET_OPTION),
    "lowpass": (list[str], LOWPASS_OPTION),
    "resample": (float, RESAMPLE_OPTION),
    "restamp": (bool, RESTAMP_OPTION),
}


def _spec_from(values: Mapping[str, Any]) -> LogSpec:
    known = {f.name for f in fields(LogSpec)}
    given: dict[str, Any] = {}
    for name, value in values.items():
        if name not in known or value is None:
            continue
        if name in ("inputs", "outputs"):
            given[name] = tuple(_split(value) or ()) or None
        elif isinstance(value, list | tuple):
            given[name] = tuple(value)
        else:
            given[name] = value
    return LogSpec(**given)


def log_options(*, training: bool) -> Callable[[F], F]:
    """Add the log options to a typer command and hand it one :class:`LogSpec` as ``spec``.

    The command is written as ``def command(..., spec: LogSpec) -> None``; the decorator puts
    the reading options (and with ``training=True`` the channel and preprocessing options) in
    its signature where ``spec`` stood, so that typer declares them, and calls the command with
    ``spec`` built from what the user gave. Place it below ``@handled``.
    """
    table = _TRAINING if training else _READING

    def decorate(command: F) -> F:
        signature = inspect.signature(command)
        hints = get_type_hints(command)
        if "spec" not in signature.parameters:
            raise TypeError(f"{command.__name__} must take a 'spec' parameter")
        parameters: list[inspect.Parameter] = []
        for parameter in signature.parameters.values():
            if parameter.name != "spec":
                parameters.append(parameter.replace(annotation=hints[parameter.name]))
                continue
            parameters.extend(
                inspect.Parameter(
                    name, inspect.Parameter.KEYWORD_ONLY, default=option, annotation=annotation
                )
                for name, (annotation, option) in table.items()
            )

        @functools.wraps(command)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            values = {name: kwargs.pop(name) for name in table if name in kwargs}
            return command(*args, spec=_spec_from(values), **kwargs)

        annotations = {p.name: p.annotation for p in parameters}
        annotations["return"] = hints.get("return", None)
        wrapper.__signature__ = signature.replace(parameters=parameters)  # type: ignore[attr-defined]
        wrapper.__annotations__ = annotations
        return wrapper  # type: ignore[return-value]

    return decorate


def read_training_logs(paths: Sequence[Path], spec: LogSpec) -> tuple[list[Any], Any]:
    """The training logs read by ``spec``, and the preprocessing they went through.

    The same file given twice, by any spelling of its path, is refused.
    """
    from neckid.cli._training import refuse_repeated_paths
    from neckid.cli.workflow import read_log

    refuse_repeated_paths(paths)
    pipeline, mapping = spec.pipeline(), spec.mapping()
    experiments = [
        spec.with_name_conditions(
            read_log(
                path,
                list(spec.inputs) if spec.inputs else None,
                list(spec.outputs) if spec.outputs else None,
                maps=mapping,
                preprocessing=pipeline,
                **spec.reading(),
            ),
            path,
        )
        for path in paths
    ]
    return experiments, pipeline


def attach_log_options(model: Any, spec: LogSpec, pipeline: Any) -> Any:
    """Record with a fitted model what a new log needs: the preprocessing and the ``--map``.

    ``save`` writes both into the model file; :func:`read_for_model` replays them.
    """
    model.preprocessing_ = pipeline
    mapping = spec.mapping()
    if mapping:
        model.channel_map_ = mapping
    return model


def read_for_model(model: Any, path: Path, spec: LogSpec, *, quiet: bool = False) -> Any:
    """The log as ``model`` reads it: its channels, renamed, through its preprocessing.

    The renaming is the user's ``--map`` when given; else the mapping the model was identified
    with (``channel_map_``), for the channels this log does not already name as the model does.
    """
    from neckid.cli.workflow import read_log_for_model

    mapping = spec.mapping()
    stored = not mapping and bool(model.channel_map_)
    if stored:
        mapping = _stored_mapping(model, path, spec)
    data, pipeline = read_log_for_model(model, path, maps=mapping, **spec.reading())
    data = spec.with_name_conditions(data, path)
    if not quiet:
        if stored and mapping:
            shown = ", ".join(f"{log}={name}" for log, name in mapping.items())
            console.print(f"channel mapping from the model: --map {shown}", markup=False)
        if pipeline is not None:
            console.print(f"preprocessing from the model: {pipeline.describe()}", markup=False)
    return data


def _stored_mapping(model: Any, path: Path, spec: LogSpec) -> dict[str, str]:
    """The model's ``{log name: model name}`` entries this log needs.

    A log that already has a column named as the model names it needs no renaming of it; for
    a layout whose columns cannot be listed before reading (ROS 2 bags, the lab's bench
    layout), the whole stored mapping applies.
    """
    mapping = dict(model.channel_map_)
    if spec.layout != "csv":
        return mapping
    try:
        columns = _column_names(Path(path), _sep(spec.sep), spec.time)
    except (OSError, ValueError, KeyError, TypeError):
        return mapping  # the read that follows names what is wrong with the file
    return {log: name for log, name in mapping.items() if name not in columns}


def _column_names(path: Path, sep: str, time: str) -> set[str]:
    """The column names of a CSV (its header row only), Parquet or ``.mat`` log."""
    if path.suffix.lower() in (".parquet", ".mat"):
        from neckid.data.tables import whole_table

        return {str(c) for c in whole_table(path, sep=sep, time=time)["frame"].columns}
    import pandas as pd

    return {str(c) for c in pd.read_csv(path, sep=sep, nrows=0).columns}
