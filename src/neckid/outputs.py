"""Writing outputs safely: never over an input, never half a file, one run per output folder.

- :func:`check_output_file` refuses an output path that is one of the inputs, that exists (unless
  ``force``), or whose folder is missing or read-only, *before* any long computation.
- :func:`atomic_path` gives a temporary name in the target's folder and renames it into place
  only when the writing finished, so an interrupted run leaves the old file (or none), never a
  half-written one.
- :func:`output_folder` locks a folder for one run (``filelock``), stages every file in a hidden
  sub-folder and moves them in together at the end; a second run into the same folder is refused
  with a message naming the lock.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

__all__ = [
    "OutputError",
    "StagedFolder",
    "atomic_path",
    "check_output_file",
    "lock_path",
    "output_folder",
]


def lock_path(folder: Path) -> Path:
    """Where the lock of an output folder lives: the temporary directory, named after the folder.

    Kept out of the folder itself so that a finished run leaves only its outputs there.
    """
    key = hashlib.sha1(str(folder.resolve()).encode("utf-8")).hexdigest()[:16]
    locks = Path(tempfile.gettempdir()) / "neckid-locks"
    locks.mkdir(exist_ok=True)
    return locks / f"{key}.lock"


class OutputError(FileExistsError):
    """An output cannot be written where it was asked (exists, is an input, is locked, ...)."""


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def check_output_file(
    path: str | Path,
    *,
    force: bool = False,
    inputs: Iterable[str | Path] = (),
    option: str = "--out",
) -> Path:
    """Check that ``path`` can be written as an output; return it as a :class:`~pathlib.Path`.

    Raises
    ------
    OutputError
        If ``path`` is one of ``inputs`` (even with ``force``), exists and ``force`` is false, or
        is a folder.
    FileNotFoundError
        If its folder does not exist.
    PermissionError
        If its folder cannot be written.
    """
    target = Path(path)
    for given in inputs:
        if _same_file(target, Path(given)) or target.resolve() == Path(given).resolve():
            raise OutputError(
                f"{option} {str(target)!r} is an input of this command; it would be overwritten:"
                " choose another file"
            )
    if target.is_dir():
        raise OutputError(f"{option} {str(target)!r} is a folder; give a file name")
    if target.exists() and not force:
        raise OutputError(
            f"{option} {str(target)!r} exists already; use --force to overwrite it or choose"
            " another name"
        )
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"{option}: folder {str(folder)!r} does not exist; create it first")
    if not os.access(folder, os.W_OK):
        raise PermissionError(f"{option}: folder {str(folder)!r} is not writable")
    return target


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path``; renamed onto ``path`` when the block ends normally.

    On an exception (a failed write, Ctrl-C) the temporary file is removed and ``path`` is left
    as it was.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_path(folder / "a.txt") as tmp:
    ...     _ = tmp.write_text("done")
    >>> (folder / "a.txt").read_text(), sorted(p.name for p in folder.iterdir())
    ('done', ['a.txt'])
    """
    target = Path(path)
    handle, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=target.parent)
    os.close(handle)
    temporary = Path(name)
    try:
        yield temporary
        os.replace(temporary, target)
    finally:
        if temporary.exists():
            temporary.unlink()


class StagedFolder:
    """Files of one run, written in a hidden staging folder and moved into place together."""

    def __init__(self, folder: Path, staging: Path) -> None:
        self.folder = folder
        self.staging = staging

    def path(self, name: str) -> Path:
        """Where to write the output ``name`` during the run (inside the staging folder)."""
        return self.staging / name

    def final(self, name: str) -> Path:
        """Where ``name`` will be once the run has finished."""
        return self.folder / name


@contextlib.contextmanager
def output_folder(folder: str | Path, *, force: bool = False) -> Iterator[StagedFolder]:
    """Lock ``folder`` for one run and stage its files; move them in when the block ends normally.

    Raises
    ------
    OutputError
        If ``folder`` is a file, holds files already and ``force`` is false, or another run holds
        its lock.
    """
    from filelock import FileLock, Timeout

    target = Path(folder)
    if target.exists() and not target.is_dir():
        raise OutputError(f"--out {str(target)!r} is a file; give a folder")
    target.mkdir(parents=True, exist_ok=True)
    lock = FileLock(lock_path(target))
    try:
        lock.acquire(timeout=0)
    except Timeout:
        raise OutputError(
            f"another neckid run is writing into {str(target)!r} (it holds the lock"
            f" {str(lock_path(target))!r}); wait for it to finish or choose another folder"
        ) from None
    if not force and any(not p.name.startswith(".staging-") for p in target.iterdir()):
        lock.release()
        raise OutputError(
            f"--out {str(target)!r} holds files already; use --force to replace them or choose"
            " another folder"
        )
    staging = Path(tempfile.mkdtemp(prefix=".staging-", dir=target))
    try:
        yield StagedFolder(target, staging)
        for item in sorted(staging.iterdir()):
            os.replace(item, target / item.name)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        lock.release()  # the empty lock file stays in the temporary directory: removing it races
