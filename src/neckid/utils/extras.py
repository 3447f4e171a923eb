"""neckid's optional dependencies, and what to install when one is missing.

Parquet files need pyarrow, MATLAB v7.3 files and the Bouc-Wen benchmark h5py, ROS 2 bags
rosbags, a Dask cluster distributed, the benchmark's peer SysIdentPy. A missing one is the
user's environment, not a fault of neckid: :func:`missing_extra_message` turns the
``ImportError`` into the line that says what to install (the command line exits with status 2).
"""

from __future__ import annotations

__all__ = ["OPTIONAL_MODULES", "missing_extra_message"]

#: Optional top-level module -> (the pip package, neckid's extra that installs it).
OPTIONAL_MODULES = {
    "pyarrow": ("pyarrow", "parquet"),
    "fastparquet": ("pyarrow", "parquet"),
    "h5py": ("h5py", "data"),
    "rosbags": ("rosbags", "ros"),
    "distributed": ("distributed", "dask"),
    "dask": ("distributed", "dask"),
    "sysidentpy": ("sysidentpy", "peers"),
    "padasip": ("padasip", "bench"),
    "osqp": ("osqp", "mpc"),
}


def missing_extra_message(error: ImportError) -> str | None:
    """What to install for ``error``, when it is an optional dependency that is missing; else None.

    Examples
    --------
    >>> missing_extra_message(ModuleNotFoundError("No module named 'pyarrow'", name="pyarrow"))
    "the optional dependency pyarrow is not installed (No module named 'pyarrow'): pip install 'neckid[parquet]' (or pip install pyarrow)"
    >>> missing_extra_message(ImportError("cannot import name 'x' from 'neckid'")) is None
    True
    """
    name = (getattr(error, "name", None) or "").partition(".")[0]
    text = str(error)
    found = name if name in OPTIONAL_MODULES else None
    if found is None:  # pandas and others say it in words: "Missing optional dependency 'pyarrow'"
        found = next((m for m in OPTIONAL_MODULES if f"'{m}'" in text or f" {m} " in text), None)
    if found is None:
        return None
    package, extra = OPTIONAL_MODULES[found]
    reason = " ".join(text.split())[:200]
    if "pip install" in reason:  # neckid's own message says what to install already
        return reason
    return (
        f"the optional dependency {package} is not installed ({reason}): pip install"
        f" 'neckid[{extra}]' (or pip install {package})"
    )
