"""Experimental conditions: named constants of one experiment (payload, controller, neck type).

A run of the real neck differs from the next by what is on its head and what drives it. An
:class:`~neckid.IOData` keeps such facts as *conditions*: a name, a value that is constant over the
experiment (a number with a unit, or a label), and a unit. A model uses chosen numeric conditions
as extra regressor inputs through ``Lags(..., conditions=["payload"])``: each becomes a constant
input channel (:meth:`neckid.IOData.conditions_as_inputs`) with lag 0, so a model identified on
several payloads can interpolate between them and says so when a log's payload is outside the
ones it has seen (:meth:`neckid.models.base.Estimator.extrapolation`).

Examples
--------
>>> from neckid.data.conditions import parse_condition
>>> parse_condition("payload=0.4kg")
('payload', 0.4, 'kg')
>>> parse_condition("controller=ada")
('controller', 'ada', '')
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any

import numpy as np

__all__ = [
    "ConditionValue",
    "append_conditions",
    "check_conditions",
    "conditions_from_name",
    "label_indicators",
    "parse_condition",
]

ConditionValue = float | str

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\-]*$")
_NUMBER_UNIT = re.compile(r"^([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)(\s*)(.*)$")
#: What starts a number: a value starting so must be a number with an optional unit.
_NUMBER_START = re.compile(r"^[-+]?\.?\d")
#: A unit: starts with a letter (or %, °, µ), then letters, digits and ^ / * · . _ -.
_UNIT = re.compile(r"^[A-Za-z%°µμΩ][\w%°µμΩ^/*·.\-]*$")


def _check_name(name: object, argument: str) -> str:
    if not isinstance(name, str) or not _NAME.match(name):
        raise ValueError(
            f"{argument} has a condition named {name!r}; a name starts with a letter or _ and"
            " holds letters, digits, _, . or - (e.g. 'payload')"
        )
    return name


def _check_value(name: str, value: object, argument: str) -> ConditionValue:
    if isinstance(value, bool) or value is None:
        raise ValueError(f"{argument}[{name!r}] must be a number or a label (str); got {value!r}")
    if isinstance(value, str):
        if not value.strip():
            raise ValueError(f"{argument}[{name!r}] is an empty label")
        return value
    if isinstance(value, int | float | np.integer | np.floating):
        number = float(value)
        if not math.isfinite(number):
            raise ValueError(f"{argument}[{name!r}] must be finite; got {value!r}")
        return number
    raise ValueError(
        f"{argument}[{name!r}] must be a number or a label (str); got {type(value).__name__}"
    )


def check_conditions(
    values: Mapping[str, object] | None,
    units: Mapping[str, str] | None,
    channel_names: tuple[str, ...] = (),
    argument: str = "conditions",
) -> tuple[Mapping[str, ConditionValue], Mapping[str, str]]:
    """Validate conditions and their units; return read-only mappings (numbers as float).

    Parameters
    ----------
    values : mapping of str to float or str, optional
        Condition name -> value: a number (payload in kg) or a label (controller name).
    units : mapping of str to str, optional
        Condition name -> unit (free text, ``"kg"``); every name must be a condition.
    channel_names : tuple of str
        Names of the log's channels: a condition may not share one.
    argument : str
        How error messages name ``values``.

    Raises
    ------
    ValueError
        Naming the condition: a bad name, a value that is not a finite number or a label, a name
        shared with a channel, a unit for a condition that does not exist.
    """
    checked: dict[str, ConditionValue] = {}
    if values is not None:
        if not isinstance(values, Mapping):
            raise ValueError(
                f"{argument} must be a mapping of name to value; got {type(values).__name__}"
            )
        for name, value in values.items():
            checked[_check_name(name, argument)] = _check_value(name, value, argument)
    clash = sorted(set(checked) & set(channel_names))
    if clash:
        raise ValueError(
            f"{argument} names {clash[0]!r}, which is already a channel of the log; a condition"
            " is a constant of the experiment and needs its own name"
        )
    unit_map: dict[str, str] = {}
    for name, unit in (units or {}).items():
        if name not in checked:
            raise ValueError(
                f"condition_units gives a unit for {name!r}, which is not a condition; the"
                f" conditions are {sorted(checked)}"
            )
        if not isinstance(unit, str):
            raise ValueError(f"condition_units[{name!r}] must be a str; got {unit!r}")
        unit_map[name] = unit
    for name in checked:
        unit_map.setdefault(name, "")
    return MappingProxyType(checked), MappingProxyType(unit_map)


def parse_condition(text: str) -> tuple[str, ConditionValue, str]:
    """Read ``name=value`` (value a number with an optional unit, or a label) from the command line.

    Examples
    --------
    >>> parse_condition("payload=0.2 kg")
    ('payload', 0.2, 'kg')
    >>> parse_condition("temperature=-3e1degC")
    ('temperature', -30.0, 'degC')
    """
    name, sep, raw = text.partition("=")
    name = name.strip()
    if not sep or not name or not raw.strip():
        raise ValueError(f"--condition takes name=value (e.g. payload=0.4kg); got {text!r}")
    _check_name(name, "--condition")
    value = raw.strip()
    match = _NUMBER_UNIT.match(value)
    if match is None or not _NUMBER_START.match(value):
        return name, value, ""  # a label: it does not start with a number
    number_text, space, unit = match.groups()
    if re.match(r"^[,']\d", unit) or (space and re.match(r"^\d", unit)):
        raise ValueError(
            f"--condition {name}={value!r}: the number holds a decimal comma or a thousands"
            " separator; write it with a decimal point and no separators (e.g."
            f" {name}=0.4kg, {name}=1200g)"
        )
    if unit and not _UNIT.match(unit):
        raise ValueError(
            f"--condition {name}={value!r}: {unit!r} after the number {number_text} is not a"
            " unit; a unit starts with a letter, e.g. kg, g, deg, %, m/s2 (a label must not"
            " start with a digit)"
        )
    number = float(number_text)
    if not math.isfinite(number):
        raise ValueError(f"--condition {name} must be finite; got {value!r}")
    return name, number, unit


def conditions_from_name(
    file_name: str, patterns: Sequence[str], units: Sequence[str] = ()
) -> tuple[dict[str, ConditionValue], dict[str, str]]:
    r"""Conditions read from a log's file name by patterns ``NAME=REGEX`` (one group each).

    Parameters
    ----------
    file_name : str
        The log's file name (no folder), e.g. ``"neck3_payload=200g_run2.csv"``.
    patterns : sequence of str
        ``NAME=REGEX``: ``REGEX`` (Python :mod:`re`, searched anywhere in the name) holds one
        capture group, the value: a number (read with its unit, when given) or a label.
    units : sequence of str, default ()
        The unit of each pattern's value, in the order of ``patterns`` (``"g"``): none, one per
        pattern, or one for a single pattern.

    Returns
    -------
    values, units : dict
        Name -> value and name -> unit.

    Raises
    ------
    ValueError
        For a pattern without ``=``, a bad name or regular expression, a regular expression
        without exactly one group, units that do not pair with the patterns, or a file name the
        pattern does not match (the message names both).

    Examples
    --------
    >>> conditions_from_name("spring_payload=200g_2.csv", [r"payload=(\d+)g"], ["g"])
    ({'payload': 200.0}, {'payload': 'g'})
    >>> conditions_from_name("neckB-run4.csv", [r"neck=neck([A-Z])"])
    ({'neck': 'B'}, {'neck': ''})
    """
    if units and len(units) != len(patterns):
        raise ValueError(
            f"--condition-unit was given {len(units)} time(s) for {len(patterns)}"
            " --condition-from-name pattern(s); give one unit per pattern, in the same order"
        )
    values: dict[str, ConditionValue] = {}
    found_units: dict[str, str] = {}
    for i, text in enumerate(patterns):
        name, sep, regex = text.partition("=")
        name = name.strip()
        if not sep or not name or not regex:
            raise ValueError(
                f"--condition-from-name takes NAME=REGEX with one group, e.g."
                f" 'payload=(\\d+)g'; got {text!r}"
            )
        _check_name(name, "--condition-from-name")
        try:
            compiled = re.compile(regex)
        except re.error as exc:
            raise ValueError(
                f"--condition-from-name {text!r}: not a regular expression ({exc})"
            ) from None
        if compiled.groups != 1:
            raise ValueError(
                f"--condition-from-name {text!r} holds {compiled.groups} groups; it needs exactly"
                " one, around the value (e.g. 'payload=(\\d+)g')"
            )
        match = compiled.search(file_name)
        if match is None or match.group(1) is None:
            raise ValueError(
                f"--condition-from-name {text!r} does not match the file name {file_name!r}"
                f" (give its {name} in a sidecar or with --condition)"
            )
        unit = units[i].strip() if units else ""
        _, value, _ = parse_condition(f"{name}={match.group(1)}")
        values[name], found_units[name] = value, unit
    return values, found_units


def append_conditions(data_in: Any, names: Sequence[str]) -> Any:
    """:meth:`neckid.IOData.conditions_as_inputs`: the log with the conditions ``names`` as inputs.

    A number is one constant input; a label ``c`` asked for as ``"c=A"`` is the indicator 1 when
    the log's ``c`` is ``"A"``, else 0; a log whose label is none of those asked for is refused.
    """
    data = data_in
    labels: dict[str, list[str]] = {}
    for name in names:
        if name in data.input_names:
            continue
        condition, _, label = name.partition("=")
        if label and isinstance(data_in.conditions.get(condition), str):
            labels.setdefault(condition, []).append(label)
            value: float = 1.0 if data_in.conditions[condition] == label else 0.0
            data = data._with_constant_input(name, value, "")
            continue
        if name not in data.conditions:
            raise KeyError(
                f"the model uses condition {name!r}, which {data.name or 'the log'} does not"
                f" have; its conditions are {dict(data.conditions)} (set it with"
                f" data.with_conditions({condition}=...) or --condition {condition}=...)"
            )
        if isinstance(data.conditions[name], str):
            raise ValueError(
                f"condition {name!r} of {data.name or 'the log'} is a label"
                f" ({data.conditions[name]!r}): as an input it is one-hot encoded, one input"
                f" per label (Lags(..., conditions=[{name!r}]) does that when it fits)"
            )
        data = data._with_constant_input(
            name, float(data.conditions[name]), data.condition_units.get(name, ""), drop=True
        )
    for condition, known in labels.items():
        if data_in.conditions[condition] not in known:
            raise ValueError(
                f"{data_in.name or 'the log'} has {condition}={data_in.conditions[condition]!r}, a"
                f" label the model was not identified with (it knows {', '.join(known)}):"
                " identify a model with runs of it"
            )
    return data


def label_indicators(names: Sequence[str], logs: Sequence[Any]) -> list[str]:
    """:meth:`neckid.IOData.label_indicators`: each label condition as its one-hot input names."""
    out: list[str] = []
    for name in names:
        values = {d.conditions.get(name) for d in logs}
        labels = sorted(v for v in values if isinstance(v, str))
        if labels and name not in logs[0].input_names:
            out.extend(f"{name}={label}" for label in labels)
        else:
            out.append(name)
    return out
