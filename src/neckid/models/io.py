"""Model files: NumPy ``.npz`` archives of plain arrays plus one JSON document, never pickle.

Format (version 1)
------------------
An uncompressed or compressed ``.npz`` (a zip of ``.npy`` files) holding

- ``__neckid__``: a 0-d unicode array with a JSON object
  ``{"format": "neckid-model", "version": 1, "class": "<ClassName>", "neckid_version": "...",
  "meta": {...}}``; ``meta`` holds hyper-parameters and scalar results;
- one numeric array per learned array (names chosen by the model class).

``meta`` may hold ``"preprocessing"``: the steps the model's logs went through
(:class:`neckid.data.preprocess.Pipeline`, :meth:`~neckid.data.preprocess.Pipeline.to_list`),
written from the model's ``preprocessing_`` and restored into it by :func:`load_model`; files
without the key load as they always did.

It is read entry by entry with NumPy's ``.npy`` reader and ``allow_pickle=False``, so opening a file
from someone else cannot run code; every entry's declared shape, dtype and size, and the header's
numbers, are checked before anything is allocated (:mod:`neckid.models.io_checks`). Any tool that
reads ``.npz`` and JSON (NumPy, MATLAB via a zip reader, Julia's NPZ) can read it.
"""

from __future__ import annotations

import importlib
import json
import math
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from neckid._version import __version__
from neckid.models.io_checks import (
    HEADER_ENTRY,
    check_array_kinds,
    check_header_numbers,
    read_arrays,
)
from neckid.regressors import ResolvedLags

__all__ = [
    "FORMAT_VERSION",
    "ModelFile",
    "load_model",
    "read_model_file",
    "write_model_file",
]

FORMAT_VERSION = 1
_META_KEY = HEADER_ENTRY


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
    if path.suffix.lower() != ".npz":
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
    from neckid.utils.files import atomic_path

    with atomic_path(path) as temporary, temporary.open("wb") as handle:
        np.savez_compressed(handle, **payload)  # type: ignore[arg-type]
    return path


def read_model_file(path: str | Path) -> tuple[str, dict[str, NDArray[Any]], dict[str, Any]]:
    """Read a model file; returns ``(class_name, arrays, meta)``.

    Nothing in the file is unpickled (``allow_pickle=False``): an array of Python objects is
    refused, never loaded.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file is not a neckid model file (not a readable ``.npz`` archive, an array that would
        need pickle, no or a malformed ``__neckid__`` header), is damaged (an entry whose declared
        shape does not fill its bytes, arrays larger than a model may take, an archive that
        inflates like a zip bomb, complex numbers, records, dates or text in an entry), its header
        holds a ``ts``, ``n_samples`` or training range that no fitted model has, or its format
        version is newer than this neckid. The message starts with the path and names the entry
        or header key (:mod:`neckid.models.io_checks`).
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not a neckid model file")
    if not path.is_file():
        raise FileNotFoundError(f"model file {str(path)!r} does not exist")
    if path.stat().st_size == 0:
        raise ValueError(f"{path} is not a neckid model file (it is empty)")
    arrays = read_arrays(path)
    if _META_KEY not in arrays:
        raise ValueError(
            f"{path} is an .npz file but not a neckid model file (no {_META_KEY!r} entry)"
        )
    header_array = arrays.pop(_META_KEY)
    if header_array.dtype.kind != "U" or header_array.ndim != 0:
        raise ValueError(
            f"{path}: the {_META_KEY!r} entry must be a text scalar holding JSON; got an array of"
            f" dtype {header_array.dtype} and shape {header_array.shape}"
        )
    try:
        header = json.loads(str(header_array))
    except ValueError as exc:  # not JSON, or an integer of more digits than Python converts
        reason = " ".join(str(exc).split())[:200]
        raise ValueError(f"{path}: the {_META_KEY!r} header is not valid JSON: {reason}") from None
    except RecursionError:
        raise ValueError(
            f"{path}: the {_META_KEY!r} header is nested too deeply to be a neckid header"
        ) from None
    if not isinstance(header, dict):
        raise ValueError(
            f"{path}: the {_META_KEY!r} header must be a JSON object; got a JSON"
            f" {type(header).__name__}"
        )
    if header.get("format") != "neckid-model":
        raise ValueError(f"{path} is not a neckid model file (format={header.get('format')!r})")
    version = header.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise ValueError(
            f"{path}: the model-file version must be a whole number >= 1; got {version!r}"
        )
    if version > FORMAT_VERSION:
        writer = header.get("neckid_version")
        by = f", written by neckid {writer[:40]}" if isinstance(writer, str) else ""
        raise ValueError(
            f"{path} has model-file version {version}{by}, newer than this neckid reads (neckid"
            f" {__version__} reads versions up to {FORMAT_VERSION}); upgrade neckid to load it"
        )
    class_name = header.get("class")
    if not isinstance(class_name, str) or not class_name:
        raise ValueError(
            f"{path}: the {_META_KEY!r} header must name the model class in 'class'; got"
            f" {class_name!r}"
        )
    meta = header.get("meta", {})
    if not isinstance(meta, dict):
        raise ValueError(
            f"{path}: 'meta' in the {_META_KEY!r} header must be a JSON object; got a JSON"
            f" {type(meta).__name__}"
        )
    check_header_numbers(path, meta)
    return class_name, arrays, meta


def load_model(path: str | Path) -> Any:
    """Load any model saved with ``model.save(path)``.

    The loaded model is checked before it is returned: its values (the class's
    ``_check_state``) and that it runs (a free-run simulation of a few zero samples on its own
    channels must give finite outputs). A file that was damaged or edited by hand is refused
    with a message, never half loaded.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file is not a neckid model file (see :func:`read_model_file`), names a model class
        this neckid does not know, holds values that do not make a working model, or holds in an
        entry another kind of values (booleans, integers, real numbers) than its class writes
        there (the message starts with the path and says which entry is wrong).
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
        with np.errstate(all="ignore"):
            model = cls._from_state(arrays, meta)
            model._check_state()
            _check_runs(model)
            _restore_preprocessing(model, meta)
            written = model._get_state()[0]
    except KeyError as exc:
        raise ValueError(
            f"{path}: this {class_name} file has no {exc.args[0]!r} entry; it is damaged or was"
            " not written by neckid"
        ) from None
    # What a damaged or hand-edited value makes a model class raise while it is rebuilt: a
    # string where a number belongs (TypeError, ValueError), a number too large for an integer
    # (OverflowError), an index out of range (IndexError), a JSON list where an object belongs
    # (AttributeError), a zero where a divisor belongs (ZeroDivisionError).
    except (
        TypeError,
        ValueError,
        IndexError,
        OverflowError,
        AttributeError,
        ZeroDivisionError,
    ) as exc:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise ValueError(f"{path}: invalid {class_name} file: {reason}") from exc
    check_array_kinds(Path(path), class_name, arrays, written)
    return model


def _restore_preprocessing(model: Any, meta: Mapping[str, Any]) -> None:
    """Set ``model.preprocessing_`` from the optional ``"preprocessing"`` key of the metadata.

    Files written before preprocessing was recorded have no such key: their models load as they
    were, without the attribute.
    """
    if "channel_map" in meta:
        model.channel_map_ = check_channel_map(meta["channel_map"])
    if "preprocessing" not in meta:
        return
    from neckid.data.preprocess import Pipeline

    model.preprocessing_ = Pipeline.from_list(meta["preprocessing"])


def check_channel_map(mapping: Any) -> dict[str, str]:
    """A model's channel mapping ``{log name: model name}``: names that are non-empty text.

    The mapping a model was identified with (``channel_map_``, the CLI's ``--map``) is stored
    in its file and replayed on new logs of the same rig; a damaged one is refused, naming it.
    """
    if not isinstance(mapping, Mapping):
        raise ValueError(
            f"channel_map must be an object of log name -> model name; got {mapping!r}"
        )
    checked: dict[str, str] = {}
    for log, name in mapping.items():
        if not (isinstance(log, str) and isinstance(name, str) and log.strip() and name.strip()):
            raise ValueError(f"channel_map entry {log!r}: {name!r} must map a name to a name")
        if any(ord(c) < 32 for c in log + name):
            raise ValueError(f"channel_map entry {log!r}: {name!r} holds a control character")
        checked[log] = name
    return checked


#: Longest regressor memory (samples) a loaded model may claim; more is a damaged file.
_MAX_PLAUSIBLE_LAG = 100_000


def _check_lags(
    lags: ResolvedLags, input_names: tuple[str, ...], output_names: tuple[str, ...]
) -> None:
    """Refuse regressor terms that point outside the model's channels or its ``max_lag``."""
    if (lags.input_names, lags.output_names) != (input_names, output_names):
        raise ValueError(
            f"the regressor was built for channels {list(lags.input_names)} ->"
            f" {list(lags.output_names)}, but the model has {list(input_names)} ->"
            f" {list(output_names)}"
        )
    source, channel, lag = lags.source, lags.channel, lags.lag
    n_terms = len(lags.names)
    if any(a.shape != (n_terms,) for a in (source, channel, lag)):
        raise ValueError(
            f"lags 'source', 'channel', 'lag' and 'names' must have one entry per regressor term;"
            f" got shapes {source.shape}, {channel.shape}, {lag.shape} and ({n_terms},)"
        )
    n_channels = np.where(source == 0, len(output_names), len(input_names))
    first_lag = np.where(source == 0, 1, 0)
    bad = (
        ((source != 0) & (source != 1))
        | (channel < 0)
        | (channel >= n_channels)
        | (lag < first_lag)
        | (lag > lags.max_lag)
    )
    if bad.any():
        j = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"regressor term {j} ({lags.names[j]!r}) has source {int(source[j])}, channel"
            f" {int(channel[j])}, lag {int(lag[j])}: source must be 0 (output) or 1 (input), the"
            f" channel one of the {int(n_channels[j])} there are, the lag in"
            f" [{int(first_lag[j])}, max_lag={lags.max_lag}]"
        )
    if n_terms and lags.max_lag != int(lag.max()):
        raise ValueError(f"max_lag {lags.max_lag} is not the largest lag {int(lag.max())}")


def _check_runs(model: Any) -> None:
    """Simulate a few zero samples on the model's own channels; raise if it cannot.

    Catches what the values alone do not show: channel names that are not unique strings,
    regressor indices outside the channels, arrays that do not fit one another.
    """
    from neckid.data.iodata import IOData

    max_lag = model.max_lag_
    if isinstance(max_lag, bool) or not isinstance(max_lag, int | np.integer):
        raise ValueError(f"max_lag must be a whole number; got {max_lag!r}")
    if not 0 <= max_lag <= _MAX_PLAUSIBLE_LAG:
        raise ValueError(f"max_lag must be in [0, {_MAX_PLAUSIBLE_LAG}]; got {max_lag}")
    for argument, names in (
        ("input_names", model.input_names_),
        ("output_names", model.output_names_),
    ):
        if not all(isinstance(n, str) for n in names):
            raise ValueError(f"{argument} must be strings; got {list(names)}")
    # Compiled free-run kernels index the channels with the regressor's (source, channel, lag)
    # without bounds checks: those are checked here, before anything runs.
    parts = [model, *(v for v in vars(model).values() if hasattr(v, "lags_"))]
    for part in parts:
        lags = getattr(part, "lags_", None)
        if isinstance(lags, ResolvedLags):
            _check_lags(lags, tuple(part.input_names_), tuple(part.output_names_))
    n_samples = int(max_lag) + 2
    ts = float(model.ts_) if math.isfinite(model.ts_) else 1.0
    zeros = IOData(
        u=np.zeros((n_samples, len(model.input_names_))),
        y=np.zeros((n_samples, len(model.output_names_))),
        ts=ts,
        input_names=model.input_names_,
        output_names=model.output_names_,
    )
    with warnings.catch_warnings():
        # Zeros may lie outside the range the model was identified on: its extrapolation
        # warning says nothing about the file.
        warnings.simplefilter("ignore")
        model.simulate(zeros)


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
        pipeline = getattr(self, "preprocessing_", None)
        if pipeline is not None and len(pipeline):
            meta = {**meta, "preprocessing": pipeline.to_list()}
        mapping = getattr(self, "channel_map_", None)
        if mapping:
            meta = {**meta, "channel_map": dict(check_channel_map(mapping))}
        return write_model_file(path, type(self).__name__, arrays, meta)

    @classmethod
    def load(cls, path: str | Path) -> Any:
        """Load a model saved by :meth:`save`; raises ``TypeError`` if the file holds another class."""
        model = load_model(path)
        if not isinstance(model, cls):
            raise TypeError(f"{path} holds a {type(model).__name__}, not a {cls.__name__}")
        return model
