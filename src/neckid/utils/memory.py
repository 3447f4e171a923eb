"""How much memory a computation would need, checked against what the machine has, before it starts.

A regressor of a thousand lags on a long log, or a network of a million units, would otherwise
allocate until the operating system kills the process. :func:`check_allocation` refuses such a
setting up front with the estimate and what to change.
"""

from __future__ import annotations

import os

__all__ = ["available_bytes", "check_allocation", "describe_bytes"]

#: Share of the available memory one allocation may take (the rest: copies, the data itself).
MAX_SHARE = 0.5


def available_bytes() -> int | None:
    """Memory the machine can give now [bytes]: ``MemAvailable`` on Linux, else physical memory.

    ``None`` when neither can be read (the check is then skipped).
    """
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, OSError, ValueError):
        return None


def describe_bytes(n_bytes: float) -> str:
    """``n_bytes`` in the largest unit that keeps it at least 1 (B, KB, MB, GB, TB; powers of 1024).

    Examples
    --------
    >>> describe_bytes(3 * 1024**3)
    '3.0 GB'
    """
    value = float(n_bytes)
    for unit in ("B", "KB", "MB", "GB"):
        if value < 1024:
            return f"{value:.1f} {unit}" if unit != "B" else f"{int(value)} B"
        value /= 1024
    return f"{value:.1f} TB"


def check_allocation(
    n_bytes: float, what: str, advice: str, *, available: int | None = None
) -> None:
    """Refuse a computation that would need more than half the available memory.

    Parameters
    ----------
    n_bytes : float
        The estimate of what it needs [bytes].
    what : str
        What needs it, for the message ("the regressor matrix: 2,000,000 rows x 1,500 terms").
    advice : str
        What to change ("use fewer lags, or a shorter log").
    available : int, optional
        Memory available [bytes]; default :func:`available_bytes`.

    Raises
    ------
    MemoryError
        Never: a ``ValueError`` is raised instead, before anything is allocated, with the
        estimate, the memory there is and the advice.

    Examples
    --------
    >>> check_allocation(1e6, "a small matrix", "nothing", available=8 * 1024**3)
    >>> check_allocation(1e12, "the regressor matrix", "use fewer lags", available=8 * 1024**3)
    Traceback (most recent call last):
    ...
    ValueError: the regressor matrix needs about 931.3 GB of memory, and this machine has 8.0 GB available: use fewer lags
    """
    have = available_bytes() if available is None else available
    if have is None or n_bytes <= MAX_SHARE * have:
        return
    raise ValueError(
        f"{what} needs about {describe_bytes(n_bytes)} of memory, and this machine has"
        f" {describe_bytes(have)} available: {advice}"
    )
