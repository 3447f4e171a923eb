"""Checks of a model file that comes from anywhere: sizes, shapes, dtypes and header numbers.

:func:`neckid.models.io.load_model` reads files that were written by another version, edited by
hand, cut short by a full disk or crafted to do harm. Whatever they hold, they are refused with
one line naming the file, the entry or header key and the value, before anything is allocated:

- :func:`read_arrays` reads the archive entry by entry. Before any array is allocated, every
  entry must be a ``.npy`` array whose header declares a shape and dtype that fill exactly the
  bytes the zip directory gives it (a damaged or crafted header declaring ``10**12`` values in
  a few bytes is refused); an archive whose arrays would inflate to more than
  :data:`MAX_INFLATION` times its size (a zip bomb: 1.6 MB on disk, 1.6 GB of zeros once read)
  is refused, and so are arrays that need more than half the memory the machine has available
  (:func:`neckid.utils.memory.check_allocation`); dtypes no neckid model writes (complex, Python
  objects, records, dates, text, bytes) are refused by entry.
- :func:`check_header_numbers`: every ``ts`` of the JSON header is a positive finite number of
  seconds, every ``n_samples`` a whole number >= 0, every training and regressor range a pair
  of finite numbers ``[low, high]`` with ``low <= high``.
- :func:`check_array_kinds`, once the model is rebuilt: each entry holds the kind of values
  (real, integer, boolean) that its class writes there, so a boolean or integer array is never
  read silently as real numbers, nor real numbers as flags or indices.
"""

from __future__ import annotations

import lzma
import math
import struct
import zipfile
import zlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from neckid.utils.checks import check_ts
from neckid.utils.memory import check_allocation, describe_bytes

__all__ = [
    "HEADER_ENTRY",
    "MAX_INFLATION",
    "check_array_kinds",
    "check_header_numbers",
    "read_arrays",
]

#: How many times its size on disk an archive may inflate to once its arrays are read, beyond
#: :data:`_INFLATION_FLOOR` bytes: the learned arrays of a model (real numbers) compress a few
#: times at most; a zip bomb inflates about a thousand times.
MAX_INFLATION = 200

#: Below this many bytes of arrays, the inflation is not checked (a small model of zeros is fine).
_INFLATION_FLOOR = 64 * 2**20

#: More entries than this is not a model file (a model writes a few dozen arrays).
_MAX_ENTRIES = 10_000

#: The entry holding the JSON header (see :mod:`neckid.models.io`).
HEADER_ENTRY = "__neckid__"

#: What the zip and NumPy readers raise on a damaged archive or entry.
_READ_ERRORS: tuple[type[BaseException], ...] = (
    OSError,
    EOFError,
    zipfile.BadZipFile,
    zlib.error,
    lzma.LZMAError,
    struct.error,
    NotImplementedError,  # a compression method or zip version zipfile does not support
    RuntimeError,  # an encrypted entry
    KeyError,  # an entry listed in the directory but missing
    ValueError,  # a malformed .npy header, a short read, a name that is not text
    OverflowError,
)

#: dtype kinds a model file never holds, and how a message calls them.
_REFUSED_KINDS = {
    "c": "complex numbers",
    "O": "Python objects",
    "V": "records",
    "M": "dates",
    "m": "durations",
    "S": "bytes",
    "U": "text",
}

#: What an entry may hold instead of what its class writes: integers and flags are read as
#: each other when they hold only 0 and 1 (see :func:`check_array_kinds`).
_KIND_NAMES = {"f": "real numbers", "i": "integers", "u": "integers", "b": "booleans"}


@dataclass(frozen=True)
class _Entry:
    """One ``.npy`` entry of the archive, from its header: what it declares, before reading."""

    name: str
    info: zipfile.ZipInfo
    shape: tuple[int, ...]
    dtype: np.dtype[Any]


def read_arrays(path: Path) -> dict[str, NDArray[Any]]:
    """Every array of the model file ``path``, each checked before it is allocated.

    Raises
    ------
    ValueError
        If the file is not a readable ``.npz`` archive, an entry is not a ``.npy`` array, its
        declared shape and dtype do not fill exactly its bytes, the arrays would take more
        than half the memory the machine has available, the archive inflates more than
        :data:`MAX_INFLATION` times its size, or an entry holds complex numbers, Python
        objects, records, dates, text or bytes. The message starts with the path and names
        the entry.
    """
    with path.open("rb") as handle:
        if handle.read(6) == b"\x93NUMPY":
            raise ValueError(
                f"{path} is not a neckid model file (a single .npy array, not an .npz archive)"
            )
    try:
        archive = zipfile.ZipFile(path)
    except _READ_ERRORS as exc:
        raise _not_a_model_file(path, None, exc) from None
    with archive:
        entries = [_entry(path, archive, info) for info in _listed(path, archive)]
        _check_total(path, entries)
        return {entry.name: _read_entry(path, archive, entry) for entry in entries}


def _not_a_model_file(path: Path, entry: str | None, error: BaseException) -> ValueError:
    """The error for what the zip or NumPy readers raised: one line, naming file and entry."""
    reason = " ".join(str(error).split()) or type(error).__name__
    where = f"entry {entry!r}: " if entry is not None else ""
    return ValueError(f"{path} is not a neckid model file ({where}{reason[:300]})")


def _listed(path: Path, archive: zipfile.ZipFile) -> list[zipfile.ZipInfo]:
    """The archive's entries: ``.npy`` files, each named once."""
    infos = archive.infolist()
    if len(infos) > _MAX_ENTRIES:
        raise ValueError(
            f"{path} is not a neckid model file (it has {len(infos)} entries; a model has a few"
            f" dozen, at most {_MAX_ENTRIES})"
        )
    seen: set[str] = set()
    for info in infos:
        name = info.filename
        if not name.endswith(".npy") or info.is_dir():
            raise ValueError(
                f"{path} is not a neckid model file (entry {name!r} is not a NumPy .npy array;"
                " a model file holds only .npy arrays)"
            )
        if name in seen:
            raise ValueError(f"{path} is damaged: entry {name!r} appears twice in the archive")
        seen.add(name)
    return infos


def _entry(path: Path, archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> _Entry:
    """Read an entry's ``.npy`` header (not its data) and check what it declares."""
    name = info.filename[: -len(".npy")]
    fmt = np.lib.format
    try:
        with archive.open(info) as handle:
            version = fmt.read_magic(handle)
            if version == (1, 0):
                shape, _, dtype = fmt.read_array_header_1_0(handle)
            elif version == (2, 0):
                shape, _, dtype = fmt.read_array_header_2_0(handle)
            else:
                raise ValueError(f".npy format version {version} is not supported")
            offset = handle.tell()
    except _READ_ERRORS as exc:
        raise _not_a_model_file(path, name, exc) from None
    if dtype.kind in _REFUSED_KINDS and not (name == HEADER_ENTRY and dtype.kind == "U"):
        why = ", which would need pickle to read" if dtype.kind == "O" else ""
        raise ValueError(
            f"{path} is not a neckid model file (entry {name!r} holds"
            f" {_REFUSED_KINDS[dtype.kind]}, dtype {dtype}{why}; a model file holds numbers;"
            " refused)"
        )
    if dtype.hasobject or any(n < 0 for n in shape):
        raise ValueError(f"{path} is damaged: entry {name!r} declares shape {shape} of {dtype}")
    declared = math.prod(shape) * dtype.itemsize
    held = info.file_size - offset
    if declared != held:
        raise ValueError(
            f"{path} is damaged: entry {name!r} declares shape {shape} of {dtype}"
            f" ({describe_bytes(declared)}) but holds {describe_bytes(held)} of values; refused"
            " before reading it"
        )
    return _Entry(name, info, tuple(shape), dtype)


def _check_total(path: Path, entries: list[_Entry]) -> None:
    """Refuse arrays that need more memory than the machine has, or an archive that inflates."""
    total = sum(entry.info.file_size for entry in entries)
    if not entries:
        return
    largest = max(entries, key=lambda e: e.info.file_size)
    on_disk = max(path.stat().st_size, 1)
    alone = f"entry {largest.name!r} alone {describe_bytes(largest.info.file_size)}"
    if total > _INFLATION_FLOOR and total > MAX_INFLATION * on_disk:
        raise ValueError(
            f"{path} is damaged: its {describe_bytes(on_disk)} inflate to"
            f" {describe_bytes(total)} of arrays ({total / on_disk:.0f} times; {alone}), while a"
            " model's arrays compress a few times at most: a zip bomb or a damaged archive;"
            " refused before reading it"
        )
    check_allocation(
        total,
        f"{path}: reading its arrays ({alone})",
        "refused before reading them; the file is damaged, or load it on a machine with more"
        " memory",
    )


def _read_entry(path: Path, archive: zipfile.ZipFile, entry: _Entry) -> NDArray[Any]:
    """The array of an entry whose header was checked; never unpickled."""
    try:
        with archive.open(entry.info) as handle:
            array = np.lib.format.read_array(handle, allow_pickle=False)
    except _READ_ERRORS as exc:
        raise _not_a_model_file(path, entry.name, exc) from None
    return np.asarray(array)


# ------------------------------------------------------------------------------ the JSON header
def _walk(meta: Mapping[str, Any]) -> Iterator[tuple[str, str, Any]]:
    """``(dotted key, last key, value)`` of every object member of the header, at any depth.

    Iterative: a header nested as deep as the JSON reader allows does not exhaust the stack.
    """
    stack: list[tuple[str, Any]] = [("meta", meta)]
    while stack:
        where, node = stack.pop()
        if isinstance(node, dict):
            for key, value in node.items():
                dotted = f"{where}.{key}"
                yield dotted, str(key), value
                stack.append((dotted, value))
        elif isinstance(node, list):
            stack.extend((f"{where}[{i}]", value) for i, value in enumerate(node))


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def check_header_numbers(path: Path, meta: Mapping[str, Any]) -> None:
    """Refuse a header whose ``ts``, ``n_samples`` or ranges cannot be a fitted model's.

    Every member named ``ts`` (the model's, and its parts': ``linear.ts``, ``submodels.1.ts``)
    must be a positive finite number of seconds up to ``1e6``
    (:func:`~neckid.utils.checks.check_ts`); every ``n_samples`` a whole number >= 0; every
    ``training_ranges`` and ``regressor_ranges`` an object of ``[low, high]`` pairs of finite
    numbers with ``low <= high``.

    Raises
    ------
    ValueError
        Naming the file, the header key (``meta.training_ranges.command``) and its value.

    Examples
    --------
    >>> check_header_numbers(Path("m.npz"), {"ts": 0.02, "training_ranges": {"u": [-1.0, 1.0]}})
    >>> check_header_numbers(Path("m.npz"), {"linear": {"ts": float("nan")}})
    Traceback (most recent call last):
    ...
    ValueError: m.npz: header key 'meta.linear.ts': ts must be a positive number of seconds; got nan
    """
    for dotted, key, value in _walk(meta):
        if key == "ts":
            try:
                check_ts(value)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{path}: header key {dotted!r}: {exc}") from None
        elif key == "n_samples" and (
            isinstance(value, bool) or not isinstance(value, int) or value < 0
        ):
            raise ValueError(
                f"{path}: header key {dotted!r} must be a whole number >= 0; got {_shown(value)}"
            )
        elif key in ("training_ranges", "regressor_ranges") and value is not None:
            _check_ranges(path, dotted, value)


def _check_ranges(path: Path, dotted: str, ranges: Any) -> None:
    if not isinstance(ranges, dict):
        raise ValueError(
            f"{path}: header key {dotted!r} must be an object of [low, high] pairs; got"
            f" {_shown(ranges)}"
        )
    for name, pair in ranges.items():
        numbers = (
            isinstance(pair, list)
            and len(pair) == 2
            and all(isinstance(v, int | float) and not isinstance(v, bool) for v in pair)
        )
        if not numbers or not all(math.isfinite(v) for v in pair) or pair[0] > pair[1]:
            raise ValueError(
                f"{path}: header key {f'{dotted}.{name}'!r} must be [low, high], two finite"
                f" numbers with low <= high; got {_shown(pair)}"
            )


# ------------------------------------------------------------------------------ after the load
def check_array_kinds(
    path: Path, class_name: str, arrays: Mapping[str, NDArray[Any]], written: Mapping[str, Any]
) -> None:
    """Refuse an entry that holds another kind of values than its class writes there.

    ``written`` holds the arrays the rebuilt model would write (its ``_get_state()``). Real
    numbers must be stored as real numbers: booleans or integers there are a hand edit that
    the class would read silently as numbers. Integers and booleans are read as each other
    only when they hold nothing but 0 and 1.

    Raises
    ------
    ValueError
        Naming the file, the entry, what it holds and what the class writes there.
    """
    for name, expected in written.items():
        if name not in arrays:
            continue  # written by a newer class: the class read the file without it
        got, want = arrays[name].dtype.kind, np.asarray(expected).dtype.kind
        if got == want or {got, want} <= {"i", "u"}:
            continue
        if {got, want} <= {"i", "u", "b"} and np.isin(arrays[name], (0, 1)).all():
            continue
        raise ValueError(
            f"{path}: entry {name!r} holds {_KIND_NAMES.get(got, got)} (dtype"
            f" {arrays[name].dtype}); a {class_name} file holds {_KIND_NAMES.get(want, want)}"
            f" there (dtype {np.asarray(expected).dtype}): it was edited or damaged"
        )
