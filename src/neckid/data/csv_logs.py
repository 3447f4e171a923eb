"""Reading a CSV log: the checks :func:`~neckid.data.readers.file_fields` runs on the text.

:func:`pandas.read_csv` reads what it can; here a binary file (a model file, a Parquet file named
``.csv``) is named for what it is, comment lines (``#``) above the header are skipped, a header
that repeats a name is refused, a last line cut short (fewer fields) is refused and one without
a line break (a writer still writing may have cut its last number) is left out with a warning,
and a file that is not text in its encoding is reported with the first bad byte and its line.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from neckid.utils.formats import not_this_kind

__all__ = ["not_text_message", "read_csv_frame"]


def read_csv_frame(path: str | Path, **read_csv: Any) -> pd.DataFrame:
    """A CSV log as a DataFrame, checked as :func:`file_fields` checks it.

    Comment lines (``#``) above the header are skipped; a header repeating a name, a last line
    with fewer fields than the header (refused) or without a line break (left out, with a
    warning naming it) are dealt with as :func:`file_fields` does. Errors are ValueErrors that
    name the file.
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not a csv file")
    if not path.exists():
        raise FileNotFoundError(f"csv file {str(path)!r} does not exist")
    if path.stat().st_size == 0:
        raise ValueError(f"log file {str(path)!r} is empty")
    return _read_csv(path, dict(read_csv))


def _leading_comments(path: Path, read_csv: Mapping[str, Any]) -> int:
    """How many lines above the header start with ``#`` (skipped, unless the caller decides)."""
    if {"skiprows", "header", "comment", "names"} & set(read_csv):
        return 0
    count = 0
    with path.open("rb") as handle:
        for line in handle:
            if not line.lstrip(b"\xef\xbb\xbf").lstrip().startswith(b"#"):
                break
            count += 1
            if count > 10_000:
                break
    return count


def _numbers_follow(path: Path, comments: int, read_csv: Mapping[str, Any]) -> bool:
    """Whether the line after the ``comments`` leading comment lines starts with a number."""
    separator = str(read_csv.get("sep", read_csv.get("delimiter", ",")) or ",")
    with path.open("rb") as handle:
        for _ in range(comments):
            handle.readline()
        line = handle.readline(4096).decode("utf-8", errors="replace")
    try:
        float(line.split(separator)[0].strip())
    except ValueError:
        return False
    return True


def _read_csv(path: Path, read_csv: dict[str, Any]) -> pd.DataFrame:
    """``pandas.read_csv`` whose failures are ValueErrors naming the file and the reason."""
    binary = not_this_kind(path, "a CSV log (text)")
    if binary is not None:
        raise ValueError(
            f"{binary}: a log is a CSV file, or a Parquet or .mat file by its extension (.parquet,"
            " .mat); a model file goes where the command takes a model"
        )
    comments = _leading_comments(path, read_csv)
    commented_header = comments > 0 and _numbers_follow(path, comments, read_csv)
    if comments:
        # "#time,command,...": the last comment line is the header when numbers follow it.
        read_csv = {**read_csv, "skiprows": comments - commented_header}
    try:
        frame = pd.read_csv(path, **read_csv)
        if commented_header and len(frame.columns):
            first = str(frame.columns[0])
            frame = frame.rename(columns={first: first.lstrip("#").strip()})
        _check_header(path, frame, read_csv)
        frame = _check_last_line(path, frame, read_csv)
    except UnicodeDecodeError as exc:
        encoding = str(read_csv.get("encoding") or "utf-8")
        message = not_text_message(path, path.read_bytes(), encoding, exc)
        raise ValueError(f"{message}; save it as UTF-8 text or pass encoding=...") from None
    except pd.errors.EmptyDataError:
        raise ValueError(
            f"{path.name} holds no CSV header and no data (only blank lines or spaces)"
        ) from None
    except pd.errors.ParserError as exc:
        reason = " ".join(str(exc).replace("Error tokenizing data. C error: ", "").split())
        raise ValueError(f"{path.name}: cannot parse as CSV: {reason}") from None
    return frame


#: read_csv options under which the last line's fields are counted (others change what a line is).
_PLAIN_CSV_OPTIONS = frozenset(
    {"sep", "delimiter", "encoding", "header", "names", "dtype", "skiprows"}
)


def _check_last_line(path: Path, frame: pd.DataFrame, read_csv: dict[str, Any]) -> pd.DataFrame:
    """Refuse a CSV whose last line has fewer fields than the header: a line cut short.

    A writer still writing leaves such a line; pandas would fill the missing cells with NaN. A
    last line with every field but no line break may be cut inside its last number (``0.12``
    of ``0.1234``), which would be read as another number: it is left out, with a warning that
    names it. Returns the frame (without that line).
    """
    import csv
    import io

    separator = read_csv.get("sep", read_csv.get("delimiter", ","))
    if set(read_csv) - _PLAIN_CSV_OPTIONS or not isinstance(separator, str) or len(separator) != 1:
        return frame
    if not len(frame) or not len(frame.columns):
        return frame
    with path.open("rb") as handle:
        size = handle.seek(0, io.SEEK_END)
        handle.seek(max(0, size - 65536))
        tail = handle.read()
    lines = [line for line in tail.splitlines() if line.strip()]
    if not lines:
        return frame
    encoding = str(read_csv.get("encoding") or "utf-8")
    try:
        last = lines[-1].decode(encoding)
    except (UnicodeDecodeError, LookupError):
        return frame  # the reader reports the encoding
    if last.count('"') % 2:
        return frame  # a quoted field over several lines: pandas parsed it
    fields = next(csv.reader([last], delimiter=separator), [])
    row = len(frame) - 1
    broken = tail.endswith((b"\n", b"\r"))
    if 0 < len(fields) < len(frame.columns):
        ends = "" if broken else " and no line break"
        raise ValueError(
            f"{path.name}: the last line (row {row}, {last[:60]!r}) has {len(fields)} field(s)"
            f" where the header has {len(frame.columns)}{ends}: the file seems cut short (a"
            " writer still writing?); wait until it is complete, or drop that line"
        )
    if not broken and len(frame) > 1:
        warnings.warn(
            f"{path.name}: the last line (row {row}, {last[:60]!r}) has no line break: it may be"
            " cut short (a writer still writing?), so it is left out; end the file with a line"
            " break to keep it",
            UserWarning,
            stacklevel=4,
        )
        return frame.iloc[:-1]
    return frame


def not_text_message(path: Path, data: bytes, encoding: str, error: UnicodeDecodeError) -> str:
    """The message for a file that is not text in ``encoding``: the first bad byte and its line.

    ``error`` is the decoder's error; the position is found again by decoding ``data`` (the whole
    file) here, since a CSV parser reports it within a field.
    """
    try:
        data.decode(encoding)
    except UnicodeDecodeError as exc:
        offset = exc.start
    except LookupError:  # an encoding Python does not know: pandas would have said so first
        return f"{path.name} is not a text CSV: {error.reason}"
    else:
        return f"{path.name} is not a text CSV: {error.reason}"
    line = data.count(b"\n", 0, offset) + 1
    return (
        f"{path.name} is not a text CSV (byte 0x{data[offset]:02x} at offset {offset}, line"
        f" {line}, is not valid {encoding})"
    )


def _header_hint(frame: pd.DataFrame) -> str:
    """Why the named columns may be missing: another separator, or no header row."""
    names = [str(c) for c in frame.columns]
    if len(names) == 1:
        for separator in (";", "\t", "|", " "):
            if separator in names[0]:
                return f"; the header is one column holding {separator!r}: pass sep={separator!r}"
    try:
        [float(n) for n in names]
    except ValueError:
        return ""
    return (
        "; the first row holds numbers, not names: the file has no header row; pass"
        " header=None, names=[...] to name the columns"
    )


def _check_header(path: Path, frame: pd.DataFrame, read_csv: dict[str, Any]) -> None:
    """Refuse a CSV whose header repeats a column name (pandas would rename the second one)."""
    if read_csv.get("header", "infer") is None or not len(frame.columns):
        return
    first = pd.read_csv(
        path,
        nrows=1,
        header=None,
        dtype=str,
        keep_default_na=False,
        **{k: v for k, v in read_csv.items() if k not in ("header", "dtype", "keep_default_na")},
    )
    names = [str(n).strip() for n in first.iloc[0].tolist()]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(
            f"{path.name}: column name {repeated[0]!r} appears {names.count(repeated[0])} times in"
            " the header; rename the columns so that each is unique"
        )
