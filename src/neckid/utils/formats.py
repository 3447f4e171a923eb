"""What a file is, by its first bytes: so that a message names the file the user gave for what it is.

A model file given where a log or a controller file belongs, or a log saved with an upper-case
extension (``MODEL.NPZ``), would otherwise be read as text and fail as a UTF-8 decode error deep
inside a reader. :func:`file_format` looks at the signature instead of the name.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["FORMAT_NAMES", "file_format", "not_this_kind"]

#: What each signature found by :func:`file_format` is, in words.
FORMAT_NAMES = {
    "npz": "a NumPy .npz archive (a neckid model file?)",
    "zip": "a zip archive",
    "parquet": "a Parquet file",
    "hdf5": "an HDF5 file (MATLAB v7.3?)",
    "mat": "a MATLAB .mat file",
    "gzip": "a gzip-compressed file",
    "sqlite": "an SQLite database (a ROS 2 bag?)",
}


def file_format(path: str | Path) -> str | None:
    r"""The format a file's first bytes say it is (a key of :data:`FORMAT_NAMES`), else None.

    None for text files (CSV, JSON) and for what is not recognised; an unreadable file is None
    too (its reader reports why).

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "x.csv")
    >>> _ = open(path, "w").write("time,u\n0,1\n")
    >>> file_format(path) is None
    True
    """
    try:
        with Path(path).open("rb") as handle:
            head = handle.read(520)
    except OSError:
        return None
    if head.startswith(b"PK\x03\x04") or head.startswith(b"PK\x05\x06"):
        return "npz" if (b".npy" in head[:200]) else "zip"
    if head.startswith(b"PAR1"):
        return "parquet"
    hdf5 = b"\x89HDF\r\n\x1a\n"
    if head.startswith(hdf5) or head[512:520] == hdf5:
        return "hdf5"
    if head.startswith(b"MATLAB "):
        return "mat"
    if head.startswith(b"\x1f\x8b"):
        return "gzip"
    if head.startswith(b"SQLite format 3\x00"):
        return "sqlite"
    return None


def not_this_kind(path: str | Path, expected: str) -> str | None:
    """The message for a binary file given where ``expected`` (e.g. "a CSV log") belongs.

    None when the file's first bytes are not a known binary format (it may be what is expected).
    """
    found = file_format(path)
    if found is None:
        return None
    return f"{Path(path).name} is {FORMAT_NAMES[found]}, not {expected}"
