"""Where a sweep runs: a joblib backend on this machine, or a Dask cluster, with a progress bar.

The sweeps (:func:`neckid.select_lags`, :func:`neckid.selection.lags.score_candidates` and the
benchmark's hyper-parameter selection, :func:`neckid.experiments.benchmark.run_benchmark`) cut
their work into independent units (one candidate on one fold) and hand them to
:func:`run_jobs`, which runs them with :class:`joblib.Parallel` on the backend asked for:

- ``backend=None``: joblib's default (``loky`` processes), or the backend of an active
  ``joblib.parallel_config(...)`` context, so that ``with parallel_config(backend="dask"): ...``
  moves a sweep to a cluster without any argument;
- ``backend="dask"``: the workers of the Dask cluster of the active ``distributed.Client``
  (install the extra: ``pip install neckid[dask]``).

Every unit is a module-level function with picklable arguments (estimators, records, settings),
seeds travel inside the estimators' parameters, and the results come back in the order the units
were given, never in the order they finish: a sweep on a cluster returns what it returns here.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Iterator, Sequence
from contextlib import AbstractContextManager, nullcontext
from typing import Any

from joblib import Parallel, parallel_config

__all__ = ["DASK_INSTALL_HINT", "check_backend", "check_jobs", "run_jobs"]

#: What to do when the Dask backend is asked for and ``distributed`` is missing.
DASK_INSTALL_HINT = "pip install neckid[dask]"


def check_backend(backend: str | None) -> None:
    """Refuse a joblib backend that cannot run here, with one line that says what to do.

    Parameters
    ----------
    backend : str or None
        A joblib backend name (``"loky"``, ``"threading"``, ``"multiprocessing"``,
        ``"sequential"``, ``"dask"``, or one registered with
        ``joblib.register_parallel_backend``); ``None`` is always accepted (the active
        ``joblib.parallel_config``, or joblib's default).

    Raises
    ------
    TypeError
        If ``backend`` is not a str or None.
    ValueError
        If ``backend`` is not a known joblib backend, or is ``"dask"`` and no
        ``distributed.Client`` is active.
    ImportError
        If ``backend`` is ``"dask"`` and the ``distributed`` package is not installed.

    Examples
    --------
    >>> check_backend(None)
    >>> check_backend("threading")
    >>> check_backend("spark")
    Traceback (most recent call last):
    ...
    ValueError: backend must be one of ...; got 'spark'
    """
    if backend is None:
        return
    if not isinstance(backend, str):
        raise TypeError(f"backend must be a joblib backend name (str) or None; got {backend!r}")
    from joblib.parallel import BACKENDS, EXTERNAL_BACKENDS

    known = sorted({*BACKENDS, *EXTERNAL_BACKENDS})
    if backend not in known:
        raise ValueError(
            f"backend must be one of {known} (or a backend registered with"
            f" joblib.register_parallel_backend) or None; got {backend!r}"
        )
    if backend != "dask":
        return
    try:
        from distributed import default_client
    except ImportError as exc:
        raise ImportError(
            f"backend='dask' needs the distributed package, which is not installed:"
            f" {DASK_INSTALL_HINT}"
        ) from exc
    try:
        default_client()
    except ValueError as exc:
        raise ValueError(
            "backend='dask' runs on the cluster of the active distributed.Client, and there is"
            " none: create one first, distributed.Client('tcp://scheduler:8786') for a cluster"
            " or distributed.Client(distributed.LocalCluster()) for this machine"
        ) from exc


def _backend_context(backend: str | None) -> AbstractContextManager[Any]:
    """``parallel_config(backend=...)``, which also registers ``"dask"``; nothing for None."""
    return nullcontext() if backend is None else parallel_config(backend=backend)


def _with_progress(
    results: Iterable[Any],
    total: int,
    label: str,
    units: Sequence[tuple[str, str, float]] | None = None,
) -> Iterator[Any]:
    """Yield ``results`` while :mod:`neckid.utils.progress` counts them.

    Shown by the reporter of the context (the command line's bar, or lines in a log); without
    one, by a rich bar on standard error. With ``units`` (what each is called, its group, its
    cost), the reporter says which unit runs and the time left from their costs
    (:func:`neckid.utils.progress.planned_task`).
    """
    from neckid.utils.progress import TerminalReporter, active, planned_task, reporting, shown_task

    if units is None:
        with shown_task(label, total=total) as advance:
            for result in results:
                yield result
                advance()
        return
    own = reporting(TerminalReporter()) if active() is None else nullcontext()
    with own, planned_task(label, units) as done:
        for result in results:
            yield result
            done()


def check_jobs(n_jobs: Any, argument: str = "n_jobs (--jobs)") -> int | None:
    """The number of parallel workers: None, a positive integer, or -1 (-2 ...: all cores but 1 ...).

    Examples
    --------
    >>> check_jobs(4), check_jobs(-1), check_jobs(None)
    (4, -1, None)
    >>> check_jobs(0)
    Traceback (most recent call last):
    ...
    ValueError: n_jobs (--jobs) must be a positive number of parallel workers, or -1 for one per core; got 0
    """
    if n_jobs is None:
        return None
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, numbers.Integral):
        raise TypeError(f"{argument} must be a whole number of parallel workers; got {n_jobs!r}")
    if n_jobs == 0:
        raise ValueError(
            f"{argument} must be a positive number of parallel workers, or -1 for one per core;"
            f" got {n_jobs}"
        )
    return int(n_jobs)


def run_jobs(
    jobs: Iterable[Any],
    *,
    total: int,
    n_jobs: int | None = None,
    backend: str | None = None,
    progress: bool = False,
    label: str = "fits",
    units: Sequence[tuple[str, str, float]] | None = None,
) -> list[Any]:
    """Run ``joblib.delayed`` calls on a backend; return their results in the order given.

    Parameters
    ----------
    jobs : iterable of joblib delayed calls
        The work units: module-level functions with picklable arguments (they may run in another
        process or on another machine).
    total : int
        The number of units (for the progress bar).
    n_jobs : int or None, default None
        Parallel workers. ``None`` is 1 on joblib's default backend, the ``n_jobs`` of an active
        ``joblib.parallel_config``, or every worker of the cluster with ``backend="dask"``; -1
        means all cores (all Dask workers).
    backend : str or None, default None
        A joblib backend name (see :func:`check_backend`); ``None`` is the active
        ``joblib.parallel_config`` backend, or joblib's default.
    progress : bool, default False
        Show a rich progress bar (on standard error), advanced as results arrive in order.
    label : str, default "fits"
        The text before the bar.
    units : sequence of (str, str, float), optional
        Per unit, in the order of ``jobs``: what the user calls it, its group (units that cost
        alike) and its expected cost; the progress then names the unit that runs and estimates
        the time left from the costs and the times measured
        (:class:`neckid.utils.progress.Plan`).

    Returns
    -------
    list
        One result per unit, in the order of ``jobs`` (not the order in which they finished).

    Raises
    ------
    TypeError, ValueError, ImportError
        From :func:`check_backend`.

    Examples
    --------
    >>> from joblib import delayed
    >>> run_jobs((delayed(pow)(2, k) for k in range(5)), total=5, backend="threading", n_jobs=2)
    [1, 2, 4, 8, 16]
    """
    check_backend(backend)
    check_jobs(n_jobs)
    with _backend_context(backend):
        results = Parallel(n_jobs=n_jobs, return_as="generator")(jobs)
        if progress:
            results = _with_progress(results, total, label, units)
        return list(results)
