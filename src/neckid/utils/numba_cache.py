"""Where numba keeps neckid's compiled kernels, so that they are compiled once per install.

Every kernel of neckid is ``@njit(cache=True)``: numba compiles it on first call and writes the
machine code to disk, and later processes load it (a fraction of a second instead of several
seconds per kernel). numba (0.68, ``numba/core/caching.py``) looks for a place to write in
this order:

1. ``NUMBA_CACHE_DIR``, when set;
2. the ``__pycache__`` folder beside the kernel's source file, when it can write there (a
   development checkout, a virtual environment owned by the user);
3. ``$XDG_CACHE_HOME/numba`` or ``~/.cache/numba``;

and if none is writable it refuses to *import* the module ("cannot cache function ...: no
locator available"). An install the user cannot write to (system site-packages, a container
image, a shared environment) thus caches in the user's folder when it can and fails to import
when there is no writable home either.

:func:`configure_numba_cache` runs first when ``neckid`` is imported (before any kernel module
imports numba). It leaves numba alone when ``NUMBA_CACHE_DIR`` is set or the package's folders
are writable; otherwise it sets ``NUMBA_CACHE_DIR`` to ``$XDG_CACHE_HOME/neckid/numba`` (default
``~/.cache/neckid/numba``), or, when that cannot be created either, to a folder in the system's
temporary directory, so that importing never fails. It costs a few ``stat`` calls and imports
nothing heavy.
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path

__all__ = ["choose_cache_dir", "configure_numba_cache"]

PACKAGE_DIR = Path(__file__).resolve().parent


def _pycache_writable(folder: Path) -> bool:
    """Whether numba could write ``folder/__pycache__`` (create it, or write into it)."""
    pycache = folder / "__pycache__"
    if pycache.is_dir():
        return os.access(pycache, os.W_OK | os.X_OK)
    if pycache.exists():  # a file in the way
        return False
    return os.access(folder, os.W_OK | os.X_OK)


def _in_tree_writable(package_dir: Path) -> bool:
    """Whether the package folder and its sub-packages can hold numba's cache files."""
    folders = [package_dir]
    try:
        with os.scandir(package_dir) as entries:
            folders += [
                Path(entry.path)
                for entry in entries
                if entry.is_dir() and (Path(entry.path) / "__init__.py").is_file()
            ]
    except OSError:  # not a folder on disk (a zip archive, a frozen application)
        return False
    return all(_pycache_writable(folder) for folder in folders)


def _usable(folder: Path) -> bool:
    """Create ``folder`` if needed; whether it is a folder this process can write into."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return folder.is_dir() and os.access(folder, os.W_OK | os.X_OK)


def choose_cache_dir(
    package_dir: str | os.PathLike[str] = PACKAGE_DIR,
    environ: Mapping[str, str] | None = None,
) -> str | None:
    """The folder ``NUMBA_CACHE_DIR`` should name for neckid's kernels, or None to leave numba be.

    Parameters
    ----------
    package_dir : path, default the installed ``neckid`` folder
        The package whose kernels are cached.
    environ : mapping, default ``os.environ``
        The environment (``NUMBA_CACHE_DIR``, ``XDG_CACHE_HOME``).

    Returns
    -------
    str or None
        None when ``NUMBA_CACHE_DIR`` is set (the user's choice) or numba can cache beside the
        sources; else ``$XDG_CACHE_HOME/neckid/numba`` (``~/.cache/neckid/numba`` when
        ``XDG_CACHE_HOME`` is unset or not absolute), created; else, when that cannot be
        created, ``<temporary directory>/neckid-numba-<user id>``.

    Examples
    --------
    >>> choose_cache_dir(environ={"NUMBA_CACHE_DIR": "/somewhere"}) is None
    True
    """
    env = os.environ if environ is None else environ
    if env.get("NUMBA_CACHE_DIR"):
        return None
    if _in_tree_writable(Path(package_dir)):
        return None
    xdg = env.get("XDG_CACHE_HOME", "")
    base = Path(xdg) if os.path.isabs(xdg) else Path(os.path.expanduser("~")) / ".cache"
    user = os.getuid() if hasattr(os, "getuid") else "user"
    shared = Path(tempfile.gettempdir()) / f"neckid-numba-{user}"
    for candidate in (base / "neckid" / "numba", shared):
        if _usable(candidate):
            return str(candidate)
    return None


def configure_numba_cache() -> str | None:
    """Point ``NUMBA_CACHE_DIR`` at :func:`choose_cache_dir`'s folder when it names one.

    Sets the environment variable (so that worker processes inherit it) and, when numba is
    already imported, has it read its configuration again, so the kernels decorated afterwards
    use the folder.

    Returns
    -------
    str or None
        The folder set, or None when numba was left alone.
    """
    folder = choose_cache_dir()
    if folder is not None:
        os.environ["NUMBA_CACHE_DIR"] = folder
        config = sys.modules.get("numba.core.config")
        if config is not None:
            config.reload_config()
    return folder
