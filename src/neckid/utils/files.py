"""Writing outputs safely: never over an input, never half a file, one run per output.

- :func:`check_output_file` refuses an output path that is one of the inputs, that exists (unless
  ``force``), that is not a regular file (a folder, a named pipe, a device; even with ``force``),
  whose name is no file name (``''``, ``.``, ``..``) or whose extension does not match what is
  written, or whose folder is missing or read-only, *before* any long computation. It also
  *claims* the path for the run: a lock (``filelock``) is held from this check to the end of the
  run, so a second run writing the same file is refused, and the final rename cannot overwrite a
  file that appeared in the meantime unless ``force``. :func:`release_outputs` ends the claims
  (the command line does it when a command ends).
- :func:`atomic_path` gives a temporary name in the target's folder and renames it into place
  only when the writing finished, so an interrupted run leaves the old file (or none), never a
  half-written one; once a stop signal was received (:mod:`neckid.utils.interrupt`) it renames
  nothing. The file gets the permissions the user's umask gives (``0644`` under umask
  ``022``), or those of the file it replaces. Temporary files left by a killed run into the same
  place are removed first.
- :func:`output_folder` locks a folder for one run (``filelock``), stages every file in a hidden
  sub-folder and moves them in together at the end; a second run into the same folder is refused
  with a message naming the lock; staging folders of a killed run are removed.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
import secrets
import shutil
import stat
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from neckid.utils.interrupt import check as check_interrupted
from neckid.utils.interrupt import deferred

__all__ = [
    "OutputError",
    "StagedFolder",
    "atomic_path",
    "check_output_file",
    "disk_full_message",
    "lock_path",
    "output_folder",
    "output_name",
    "recording_outputs",
    "release_outputs",
    "write_json",
]

#: The extensions an option's file may have, by option, when the caller gives none: what the
#: command line writes there (a figure as PNG, a model as ``.npz``, a simulation as CSV).
WRITTEN_AS: dict[str, tuple[str, ...]] = {
    "--plot": (".png",),
    "--save": (".npz",),
    "--out": (".csv",),
    "--json": (".json",),
}

#: The suffix of the atomic writer's temporary files (``.NAME.<random>.part`` beside NAME).
_PART = ".part"


def lock_path(folder: Path) -> Path:
    """Where the lock of an output (a folder or a file) lives: the temporary directory.

    Named after the output's resolved path and kept out of its folder, so that a finished run
    leaves only its outputs there.
    """
    key = hashlib.sha1(str(Path(folder).resolve()).encode("utf-8")).hexdigest()[:16]
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


def _kind(path: Path) -> str | None:
    """What ``path`` is when it is not a regular file (``"a folder"``, ...); None otherwise.

    A symbolic link is judged by what it points to; a dangling link counts as absent.
    """
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError:
        return None  # unreadable: the write itself will say why
    if stat.S_ISREG(mode):
        return None
    for test, name in (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a named pipe"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return name
    return "not a regular file"  # pragma: no cover - a door, a whiteout...


def _refuse_degenerate(target: Path, given: str | Path, option: str) -> None:
    if target.name in ("", ".", "..") or str(given).strip() == "":
        raise OutputError(
            f"{option} {str(given)!r} names no file; give a file name such as"
            f" {'out' + WRITTEN_AS.get(option, ('.csv',))[0]!r}"
        )


def _refuse_special(target: Path, option: str, suffixes: Sequence[str] | None = None) -> None:
    kind = _kind(target)
    if kind == "a folder":
        example = target / f"out{(suffixes or WRITTEN_AS.get(option) or ('.csv',))[0]}"
        raise OutputError(
            f"{option} {str(target)!r} is a folder; give a file name, e.g. {str(example)!r}"
        )
    if kind is not None:
        raise OutputError(
            f"{option} {str(target)!r} is {kind}, not a regular file; neckid replaces only regular"
            " files, even with --force: give the name of a file"
        )


def output_name(path: str | Path, suffix: str, *, option: str = "--save") -> Path:
    """``path`` with ``suffix`` appended when it has another one; degenerate names refused.

    Examples
    --------
    >>> output_name("model", ".npz").name, output_name("m.npz", ".npz").name
    ('model.npz', 'm.npz')
    >>> output_name("..", ".npz")
    Traceback (most recent call last):
    ...
    neckid.utils.files.OutputError: --save '..' names no file; give a file name such as 'out.npz'
    """
    target = Path(path)
    _refuse_degenerate(target, path, option)
    return (
        target
        if target.suffix.lower() == suffix.lower()
        else target.with_name(target.name + suffix)
    )


@dataclass
class _Claim:
    lock: Any  # filelock.FileLock
    force: bool
    option: str


#: The outputs this process has claimed (resolved path -> claim), until :func:`release_outputs`.
_CLAIMS: dict[str, _Claim] = {}


def _key(target: Path) -> str:
    return str(target.resolve())


def _new_lock(target: Path) -> Any:
    from filelock import FileLock

    return FileLock(lock_path(target))


def _busy(option: str, target: Path) -> OutputError:
    return OutputError(
        f"another neckid run is writing {option} {str(target)!r} (it holds the lock"
        f" {str(lock_path(target))!r}); wait for it to finish or choose another name"
    )


def _acquire(target: Path, option: str) -> Any:
    from filelock import Timeout

    lock = _new_lock(target)
    try:
        lock.acquire(timeout=0)
    except Timeout:
        raise _busy(option, target) from None
    return lock


#: The lists of :func:`recording_outputs` blocks running (innermost last).
_RECORDERS: list[list[str]] = []


@contextlib.contextmanager
def recording_outputs() -> Iterator[list[str]]:
    """Yield a list that gets every output (file, folder) put in place inside the block, in order.

    What an interrupted command had written before it stopped (the command line says so).
    """
    written: list[str] = []
    _RECORDERS.append(written)
    try:
        yield written
    finally:
        _RECORDERS.remove(written)


def _written(target: Path) -> None:
    for recorder in _RECORDERS:
        recorder.append(str(target))


def release_outputs() -> None:
    """End every claim of :func:`check_output_file` in this process (its locks are released)."""
    while _CLAIMS:
        _, claim = _CLAIMS.popitem()
        with contextlib.suppress(Exception):
            claim.lock.release(force=True)


def _exists(target: Path) -> bool:
    return os.path.lexists(target)


def check_output_file(
    path: str | Path,
    *,
    force: bool = False,
    inputs: Iterable[str | Path] = (),
    option: str = "--out",
    suffixes: Sequence[str] | None = None,
) -> Path:
    """Check that ``path`` can be written as an output and claim it; return it as a Path.

    The claim is a lock held until :func:`release_outputs` (the command line releases it when
    the command ends): the existence check here and the final rename of :func:`atomic_path`
    happen under that one lock, so two runs cannot both write the file.

    Parameters
    ----------
    suffixes : sequence of str, optional
        The extensions the file may have (case-insensitive), for what is written into it;
        default :data:`WRITTEN_AS` of ``option`` (no check for another option).

    Raises
    ------
    OutputError
        If ``path`` names no file (``''``, ``.``, ``..``), has an extension that is not one of
        ``suffixes``, is one of ``inputs`` (even with ``force``), is a folder, a named pipe, a
        device or a socket (even with ``force``), exists and ``force`` is false, or another run
        is writing it.
    FileNotFoundError
        If its folder does not exist.
    PermissionError
        If its folder cannot be written.
    """
    target = Path(path)
    _refuse_degenerate(target, path, option)
    for given in inputs:
        if _same_file(target, Path(given)) or target.resolve() == Path(given).resolve():
            raise OutputError(
                f"{option} {str(target)!r} is an input of this command; it would be overwritten:"
                " choose another file"
            )
    allowed = tuple(suffixes) if suffixes is not None else WRITTEN_AS.get(option)
    _refuse_special(target, option, allowed)
    if allowed and target.suffix.lower() not in {s.lower() for s in allowed}:
        what = " or ".join(allowed)
        raise OutputError(
            f"{option} {str(target)!r}: the file is written as {what[1:].upper()}, so its name"
            f" must end in {what}; got {target.suffix or 'no extension'!r}"
        )
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"{option}: folder {str(folder)!r} does not exist; create it first")
    if not os.access(folder, os.W_OK):
        raise PermissionError(f"{option}: folder {str(folder)!r} is not writable")
    key = _key(target)
    if key not in _CLAIMS:
        _CLAIMS[key] = _Claim(_acquire(target, option), force, option)
    claim = _CLAIMS[key]
    claim.force = force
    if _exists(target) and not force:
        release = _CLAIMS.pop(key)
        release.lock.release(force=True)
        raise OutputError(
            f"{option} {str(target)!r} exists already; use --force to overwrite it or choose"
            " another name"
        )
    _remove_stale(target)
    return target


def disk_full_message(error: OSError) -> str | None:
    """The message for a write that failed for want of space, else None.

    ENOSPC, or Python's "no usable temporary directory" (ENOENT), which a full disk causes.
    """
    import errno

    if error.errno == errno.ENOSPC:
        where = f" holding {str(error.filename)!r}" if error.filename else ""
        return (
            f"no space left on the device{where}: free some space or write elsewhere (outputs"
            " are written whole or not at all: nothing was left half written)"
        )
    if "No usable temporary directory" in str(error):
        folder = os.environ.get("TMPDIR", "/tmp")
        with contextlib.suppress(OSError):
            free = shutil.disk_usage(folder).free
            folder = f"{folder} ({free / 1e6:.3g} MB free)"
        return (
            f"no room for temporary files in {folder}: the disk is full or not writable; free"
            " some space, or set TMPDIR to a folder with room"
        )
    return None


def _remove_stale(target: Path) -> None:
    """Remove the temporary files a killed run left beside ``target`` (under its lock)."""
    prefix = f".{target.name}."
    folder = target.parent if str(target.parent) else Path(".")
    with contextlib.suppress(OSError):
        for entry in os.scandir(folder):
            if (
                entry.name.startswith(prefix)
                and entry.name.endswith(_PART)
                and entry.is_file(follow_symlinks=False)
            ):
                with contextlib.suppress(OSError):
                    os.unlink(entry.path)


def _temporary(target: Path) -> tuple[Path, int]:
    """A new empty file beside ``target`` and its mode (0o666 less the umask)."""
    folder = target.parent if str(target.parent) else Path(".")
    for _ in range(100):
        name = folder / f".{target.name}.{secrets.token_hex(4)}{_PART}"
        try:
            handle = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        mode = stat.S_IMODE(os.fstat(handle).st_mode)
        os.close(handle)
        return name, mode
    raise FileExistsError(
        f"cannot create a temporary file beside {str(target)!r}"
    )  # pragma: no cover


def _place(temporary: Path, target: Path, claim: _Claim | None) -> None:
    """Move ``temporary`` onto ``target``; without ``force`` never over a file that appeared."""
    _refuse_special(target, claim.option if claim else "output")
    if claim is None or claim.force:
        os.replace(temporary, target)
        return
    try:
        os.link(temporary, target)  # fails if target exists: no window for another writer
    except FileExistsError:
        raise OutputError(
            f"{claim.option} {str(target)!r} was created by another program during the run; it"
            " was not overwritten: rerun with --force or choose another name"
        ) from None
    except OSError:  # a file system without hard links: checked under the lock, then renamed
        if _exists(target):
            raise OutputError(
                f"{claim.option} {str(target)!r} was created by another program during the run;"
                " it was not overwritten: rerun with --force or choose another name"
            ) from None
        os.replace(temporary, target)
        return
    os.unlink(temporary)


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path``; renamed onto ``path`` when the block ends normally.

    On an exception (a failed write, Ctrl-C, SIGTERM in the command line) the temporary file is
    removed and ``path`` is left as it was. The file gets the mode the umask gives a new file,
    or the mode of the regular file it replaces. ``path`` is locked while the block runs (or
    for the whole run, when :func:`check_output_file` claimed it); temporary files of a killed
    run beside it are removed first. Only a regular file is ever replaced.

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
    _refuse_degenerate(target, path, "output")
    claim = _CLAIMS.get(_key(target))
    lock = None if claim is not None else _acquire(target, "output")
    try:
        _refuse_special(target, claim.option if claim else "output")
        _remove_stale(target)
        temporary, mode = _temporary(target)
        try:
            yield temporary
            # Once a stop was asked for, nothing is put in place (even when the interrupt was
            # swallowed on the way: the file stays as it was).
            check_interrupted()
            with contextlib.suppress(OSError):
                old = os.stat(target)
                if stat.S_ISREG(old.st_mode):
                    mode = stat.S_IMODE(old.st_mode)
            os.chmod(temporary, mode)
            with deferred():  # the rename is not cut in half by a signal
                _place(temporary, target, claim)
                _written(target)
        finally:
            if os.path.lexists(temporary):
                temporary.unlink()
    finally:
        if lock is not None:
            lock.release()


def write_json(path: str | Path, document: Any) -> None:
    """Write ``document`` as indented JSON to ``path`` atomically (:func:`atomic_path`).

    Non-finite floats are written as ``null`` (JSON has no ``NaN`` nor ``Infinity``); NumPy
    scalars and arrays as numbers and lists.
    """
    import json

    with atomic_path(path) as temporary:
        temporary.write_text(json.dumps(_plain_json(document), indent=2), encoding="utf-8")


def _plain_json(value: Any) -> Any:
    """``value`` with NumPy types as Python ones and non-finite floats as ``None``."""
    if isinstance(value, dict):
        return {str(k): _plain_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain_json(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, str):
        return _plain_json(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


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

    Staging folders (``.staging-*``) that a killed run left are removed once the lock is held.
    A folder this run created is removed again when the run fails (it is empty then).

    Raises
    ------
    OutputError
        If ``folder`` names no folder (``''``), is a file, holds files already and ``force`` is
        false, or another run holds its lock.
    """
    from filelock import FileLock, Timeout

    if str(folder).strip() == "":
        raise OutputError("--out '' names no folder; give a folder name such as 'neckid-demo'")
    target = Path(folder)
    if target.exists() and not target.is_dir():
        raise OutputError(f"--out {str(target)!r} is a file; give a folder")
    created = not target.exists()
    target.mkdir(parents=True, exist_ok=True)
    lock = FileLock(lock_path(target))
    try:
        lock.acquire(timeout=0)
    except Timeout:
        raise OutputError(
            f"another neckid run is writing into {str(target)!r} (it holds the lock"
            f" {str(lock_path(target))!r}); wait for it to finish or choose another folder"
        ) from None
    for stale in target.glob(".staging-*"):  # a killed run's: nobody else holds the lock
        if stale.is_dir() and not stale.is_symlink():
            shutil.rmtree(stale, ignore_errors=True)
    if not force and any(not p.name.startswith(".staging-") for p in target.iterdir()):
        lock.release()
        raise OutputError(
            f"--out {str(target)!r} holds files already; use --force to replace them or choose"
            " another folder"
        )
    staging = Path(tempfile.mkdtemp(prefix=".staging-", dir=target))
    finished = False
    try:
        yield StagedFolder(target, staging)
        check_interrupted()  # stopped: none of the run's files is moved in
        with deferred():  # moved in together: a signal waits until the last one is in place
            for item in sorted(staging.iterdir()):
                os.replace(item, target / item.name)
            finished = True
            _written(target)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        if created and not finished:  # a run that failed leaves no empty folder of its own
            with contextlib.suppress(OSError):
                target.rmdir()
        lock.release()  # the empty lock file stays in the temporary directory: removing it races
