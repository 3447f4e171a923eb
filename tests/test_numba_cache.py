"""Where numba caches neckid's kernels: beside the sources when writable, else a user folder.

A read-only install is imitated without special rights (the tests may run as root, for whom
permission bits do not stop a write): every package folder gets a *file* named ``__pycache__``,
so neither Python nor numba can create the folder there, and ``HOME`` points below a file, so
numba's own user-wide fallback (``~/.cache/numba``) cannot be created either. numba then refuses
to import a kernel module unless ``NUMBA_CACHE_DIR`` names a usable folder.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import neckid
from neckid.utils.numba_cache import choose_cache_dir

SOURCE = Path(neckid.__file__).resolve().parent


def read_only_copy(root: Path) -> Path:
    """A copy of the neckid sources whose folders cannot hold a ``__pycache__`` folder."""
    package = root / "neckid"
    shutil.copytree(SOURCE, package, ignore=shutil.ignore_patterns("__pycache__"))
    for init in package.rglob("__init__.py"):
        (init.parent / "__pycache__").write_text("in the way\n")
    return package


def a_file(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("not a folder\n")
    return path


def test_the_user_choice_and_a_writable_install_leave_numba_alone(tmp_path: Path) -> None:
    package = tmp_path / "site" / "neckid"
    (package / "models").mkdir(parents=True)
    (package / "models" / "__init__.py").write_text("")
    assert choose_cache_dir(package, {}) is None
    assert choose_cache_dir(package, {"NUMBA_CACHE_DIR": str(tmp_path / "mine")}) is None
    (package / "models" / "__pycache__").write_text("in the way\n")
    assert choose_cache_dir(package, {"NUMBA_CACHE_DIR": str(tmp_path / "mine")}) is None


def test_a_read_only_install_caches_in_the_user_cache_folder(tmp_path: Path) -> None:
    package = read_only_copy(tmp_path / "site")
    cache = tmp_path / "cache"
    chosen = choose_cache_dir(package, {"XDG_CACHE_HOME": str(cache)})
    assert chosen == str(cache / "neckid" / "numba")
    assert Path(chosen).is_dir()


def test_a_relative_xdg_cache_home_is_ignored(tmp_path: Path, monkeypatch) -> None:
    package = read_only_copy(tmp_path / "site")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    chosen = choose_cache_dir(package, {"XDG_CACHE_HOME": "relative/cache"})
    assert chosen == str(tmp_path / "home" / ".cache" / "neckid" / "numba")


def test_without_a_writable_home_the_temporary_folder_is_used(tmp_path: Path, monkeypatch) -> None:
    package = read_only_copy(tmp_path / "site")
    blocked = a_file(tmp_path / "blocked")
    monkeypatch.setenv("HOME", str(blocked / "home"))
    monkeypatch.setattr("tempfile.gettempdir", lambda: str(tmp_path / "tmp"))
    chosen = choose_cache_dir(package, {"XDG_CACHE_HOME": str(blocked / "cache")})
    assert chosen is not None
    assert Path(chosen).parent == tmp_path / "tmp" and Path(chosen).name.startswith("neckid-numba")


@pytest.mark.parametrize("xdg", [True, False])
def test_a_read_only_install_imports_and_reuses_its_compiled_kernels(
    tmp_path: Path, xdg: bool
) -> None:
    site = tmp_path / "site"
    read_only_copy(site)
    blocked = a_file(tmp_path / "blocked")
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    env.update(PYTHONPATH=str(site), HOME=str(blocked / "home"), TMPDIR=str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    if xdg:
        env["XDG_CACHE_HOME"] = str(tmp_path / "cache")
    expected = tmp_path / "cache" / "neckid" / "numba" if xdg else tmp_path / "tmp"
    # A small kernel: compiled in the first process, loaded from the cache in the second.
    code = (
        "import neckid, os\n"
        "from neckid.models.neural._kernels import _tanh\n"
        "assert neckid.__file__.startswith(os.environ['PYTHONPATH']), neckid.__file__\n"
        "assert abs(_tanh(0.5) - 0.46211715726000974) < 1e-15\n"
        "print(os.environ['NUMBA_CACHE_DIR'], _tanh.stats.cache_hits.total(), sep='|')\n"
    )
    hits = []
    for _ in range(2):
        done = subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=False
        )
        assert done.returncode == 0, done.stderr
        folder, count = done.stdout.strip().split("|")
        assert Path(folder).resolve().is_relative_to(expected.resolve())
        hits.append(int(count))
    assert hits == [0, 1]
    assert list(Path(folder).rglob("_kernels._tanh-*.nbi"))
    assert not list((site / "neckid").rglob("*.nbi"))
