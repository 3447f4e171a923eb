"""A log's conditions sidecar: ``run.csv`` -> ``run.conditions.json``, and conditions given as text.

The sidecar is a JSON object: name -> a number, a label, or ``{"value": ..., "unit": ...}``;
see :mod:`neckid.data.conditions` for what a condition is.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from neckid.data.conditions import ConditionValue, check_conditions, parse_condition

if TYPE_CHECKING:
    from neckid.data.iodata import IOData

__all__ = ["apply_conditions", "read_sidecar", "sidecar_path"]


def sidecar_path(log: str | Path) -> Path:
    """Where a log's conditions sidecar lives: ``run.csv`` -> ``run.conditions.json``."""
    log = Path(log)
    return log.with_name(log.stem + ".conditions.json")


def read_sidecar(log: str | Path) -> tuple[dict[str, ConditionValue], dict[str, str]]:
    """The conditions of a log from its sidecar (:func:`sidecar_path`), empty when there is none.

    The sidecar is a JSON object: name -> a number, a label, or ``{"value": ..., "unit": ...}``,
    e.g. ``{"payload": {"value": 0.4, "unit": "kg"}, "controller": "ada"}``.

    Raises
    ------
    ValueError
        If the sidecar is not such an object; the message names the file and the key.
    """
    path = sidecar_path(log)
    if not path.exists():
        return {}, {}
    try:
        content = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path.name}: not a readable JSON file ({exc})") from None
    if not isinstance(content, dict):
        raise ValueError(f"{path.name}: must hold a JSON object of name -> value")
    values: dict[str, ConditionValue] = {}
    units: dict[str, str] = {}
    for name, entry in content.items():
        if isinstance(entry, dict):
            if set(entry) - {"value", "unit"} or "value" not in entry:
                raise ValueError(
                    f'{path.name}: {name!r} must be a value or {{"value": ..., "unit": ...}};'
                    f" got keys {sorted(entry)}"
                )
            values[name] = entry["value"]
            units[name] = str(entry.get("unit", ""))
        else:
            values[name] = entry
    try:
        check_conditions(values, units, argument=path.name)
    except ValueError as exc:
        raise ValueError(str(exc)) from None
    return values, units


def apply_conditions(data: IOData, log: str | Path | None, given: Sequence[str] = ()) -> IOData:
    """``data`` with the conditions of its sidecar, then those given as ``name=value`` text.

    Given values win over the sidecar's, which win over those the loader found (file names).
    """
    values: dict[str, ConditionValue] = {}
    units: dict[str, str] = {}
    if log is not None:
        values, units = read_sidecar(log)
    for text in given:
        name, value, unit = parse_condition(text)
        values[name] = value
        if unit or name not in units:
            units[name] = unit
    if not values:
        return data
    return data.with_conditions(units=units, **values)
