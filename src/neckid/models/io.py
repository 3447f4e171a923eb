"""Model files: NumPy ``.npz`` archives of plain arrays plus one JSON document, never pickle.

Format (version 1)
------------------
An uncompressed or compressed ``.npz`` (a zip of ``.npy`` files) holding

- ``__neckid__``: a 0-d unicode array with a JSON object
  ``{"format": "neckid-model", "version": 1, "class": "<ClassName>", "neckid_version": "...",
  "meta": {...}}``; ``meta`` holds hyper-parameters and scalar results;
- one numeric array per learned array (names chosen by the model class).

It is read with ``numpy.load(path, allow_pickle=False)``, so opening a file from someone else cannot
run code. Any tool that reads ``.npz`` and JSON (NumPy, MATLAB via a zip reader, Julia's NPZ) can
read it.
"""

from __future__ import annotations

import importlib
import json
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from neckid._version import __version__

__all__ = [
    "FORMAT_VERSION",
    "ModelFile",
    "load_model",
    "read_model_file",
    "write_model_file",
]

FORMAT_VERSION = 1
_META_KEY = "__neckid__"


class SavableModel(Protocol):
    """What a model class provides to be saved and loaded."""

    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]: ...

    @classmethod
    def _from_state(cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]) -> Any: ...


def write_model_file(
    path: str | Path, class_name: str, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
) -> Path:
    """Write a model file; returns the path written (``.npz`` is appended if missing)."""
    path = Path(path)
    if path.suffix != ".npz":
        path = path.with_name(path.name + ".npz")
    header = {
        "format": "neckid-model",
        "version": FORMAT_VERSION,
        "class": class_name,
        "neckid_version": __version__,
        "meta": meta,
    }
    payload: dict[str, NDArray[Any]] = {}
    for key, value in arrays.items():
        if key == _META_KEY:
            raise ValueError(f"array name {key!r} is reserved")
        array = np.asarray(value)
        if array.dtype == object:
            raise TypeError(
                f"array {key!r} has dtype object, which cannot be stored without pickle"
            )
        payload[key] = array
    payload[_META_KEY] = np.array(json.dumps(header, allow_nan=True))
    from neckid.outputs import atomic_path

    with atomic_path(path) as temporary, temporary.open("wb") as handle:
        np.savez_compressed(handle, **payload)  # type: ignore[arg-type]
    return path


def read_model_file(path: str | Path) -> tuple[str, dict[str, NDArray[Any]], dict[str, Any]]:
    """Read a model file; returns ``(class_name, arrays, meta)``.

    Raises
    ------
    ValueError
        If the file is not a neckid model file or its format version is newer than this neckid.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"model file {str(path)!r} does not exist")
    if path.stat().st_size == 0:
        raise ValueError(f"{path} is not a neckid model file (it is empty)")
    try:
        with np.load(path, allow_pickle=False) as archive:
            if not isinstance(archive, np.lib.npyio.NpzFile):
                raise ValueError("a single .npy array, not an .npz archive")
            arrays = {k: archive[k] for k in archive.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        reason = str(exc).split(";")[0] if "allow_pickle" not in str(exc) else "not an .npz archive"
        raise ValueError(f"{path} is not a neckid model file ({reason})") from None
    if _META_KEY not in arrays:
        raise ValueError(
            f"{path} is an .npz file but not a neckid model file (no {_META_KEY!r} entry)"
        )
    try:
        header = json.loads(str(arrays.pop(_META_KEY)))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: the {_META_KEY!r} header is not valid JSON: {exc}") from exc
    if not isinstance(header, dict) or not isinstance(header.get("meta", {}), dict):
        raise ValueError(
            f"{path}: the {_META_KEY!r} header must be a JSON object with a 'meta' object; got"
            f" {type(header).__name__}"
        )
    if header.get("format") != "neckid-model":
        raise ValueError(f"{path} is not a neckid model file (format={header.get('format')!r})")
    if int(header.get("version", 0)) > FORMAT_VERSION:
        raise ValueError(
            f"{path} has model-file version {header['version']}, newer than this neckid reads"
            f" ({FORMAT_VERSION}); upgrade neckid"
        )
    return str(header["class"]), arrays, dict(header.get("meta", {}))


def load_model(path: str | Path) -> Any:
    """Load any model saved with ``model.save(path)``.

    Raises
    ------
    ValueError
        If the file names a model class this neckid does not know.
    """
    from neckid.registry import model_classes

    class_name, arrays, meta = read_model_file(path)
    classes = model_classes()
    if class_name not in classes:
        raise ValueError(
            f"{path} holds a {class_name!r}, which this neckid cannot load; known: {sorted(classes)}"
        )
    cls = getattr(importlib.import_module(classes[class_name]), class_name)
    try:
        model = cls._from_state(arrays, meta)
        model._check_state()
    except KeyError as exc:
        raise ValueError(
            f"{path}: this {class_name} file has no {exc.args[0]!r} entry; it is damaged or was"
            " not written by neckid"
        ) from None
    except (TypeError, ValueError, IndexError) as exc:
        raise ValueError(f"{path}: invalid {class_name} file: {exc}") from None
    return model


class ModelFile:
    """Mixin giving a model ``save(path)`` and ``Class.load(path)``.

    The class implements ``_get_state() -> (arrays, meta)`` (raising ``NotFittedError`` when not
    fitted) and the classmethod ``_from_state(arrays, meta)``; ``load_model`` finds the class
    through :func:`neckid.registry.model_classes`.
    """

    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:  # pragma: no cover
        raise NotImplementedError

    def save(self, path: str | Path) -> Path:
        """Save the fitted model to ``path`` (``.npz`` of arrays + JSON metadata, no pickle).

        Returns the path written (``.npz`` is appended when missing).
        """
        arrays, meta = self._get_state()
        return write_model_file(path, type(self).__name__, arrays, meta)

    @classmethod
    def load(cls, path: str | Path) -> Any:
        """Load a model saved by :meth:`save`; raises ``TypeError`` if the file holds another class."""
        model = load_model(path)
        if not isinstance(model, cls):
            raise TypeError(f"{path} holds a {type(model).__name__}, not a {cls.__name__}")
        return model
