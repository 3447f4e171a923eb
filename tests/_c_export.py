"""What the C-export tests share: compiling an export with the system's ``cc`` and running it."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from neckid.export.c import write_c

#: Flags every export compiles with, warnings as errors: the generated code is clean C99.
CFLAGS = ["-O2", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror"]


def compiler() -> str:
    """The system's C compiler, or the test is skipped (naming what is missing)."""
    found = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if found is None:
        pytest.skip("no C compiler (cc, gcc or clang) on PATH: the C exports cannot be compiled")
    return found


def build(obj: Any, folder: Path, name: str = "model", **options: Any) -> Path:
    """Export ``obj`` with its driver into ``folder``, compile it; return the program."""
    cc = compiler()
    write_c(obj, folder, name, driver=True, **options)
    program = folder / "run"
    sources = [str(folder / f"{name}.c"), str(folder / f"{name}_main.c")]
    result = subprocess.run(
        [cc, *CFLAGS, *sources, "-lm", "-o", str(program)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    return program


def run(program: Path, rows: np.ndarray) -> np.ndarray:
    """The program's output rows on the input ``rows`` (exact: hexadecimal both ways)."""
    lines = [str(rows.shape[0])] + [" ".join(float(v).hex() for v in row) for row in rows]
    result = subprocess.run(
        [str(program)], input="\n".join(lines) + "\n", capture_output=True, text=True, check=True
    )
    return np.array(
        [[float.fromhex(v) for v in line.split()] for line in result.stdout.splitlines()]
    )


def relative_error(got: np.ndarray, want: np.ndarray) -> float:
    """``max |got - want| / max |want|`` (the scale of the run), 0 when both are zero."""
    scale = float(np.max(np.abs(want)))
    return float(np.max(np.abs(got - want))) / (scale if scale > 0 else 1.0)
