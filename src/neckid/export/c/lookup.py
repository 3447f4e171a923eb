"""Which function writes a model as C: its registry entry's :attr:`~neckid.registry.Method.c_export`."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

from neckid.export.c.program import CModel

__all__ = ["exporter_of"]


def exporter_of(model: Any) -> Callable[[Any], CModel] | None:
    """The ``c_export`` function of ``model``'s method, or ``None``.

    The method is :func:`neckid.registry.method_of`'s (the class and the settings that make the
    method); a model of no method's settings takes the first method of its class (or of a base
    class).
    """
    from neckid.registry import method_of, methods

    method = method_of(model)
    if method is not None:
        text: str | None = method.c_export
    else:
        by_class: dict[str, str] = {}
        for entry in methods().values():
            by_class.setdefault(entry.class_name, entry.c_export)
        names = [cls.__name__ for cls in type(model).__mro__]
        text = next((by_class[n] for n in names if n in by_class), None)
    if not text:
        return None
    module, _, function = text.partition(":")
    exporter: Callable[[Any], CModel] = getattr(importlib.import_module(module), function)
    return exporter
