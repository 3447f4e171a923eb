"""He & Asada's Lipschitz order index: how many lags a regressor needs, from the data alone.

:func:`lipschitz_quotients` needs no model: for each candidate order it computes the largest
Lipschitz quotients ``|y_i − y_j| / ||x_i − x_j||`` over pairs of regressors and their geometric
mean; the index stops falling steeply at the order the data need.
:func:`neckid.report.selection_plots.plot_lipschitz_index` draws it against the order.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from neckid.data.iodata import IOData, as_experiments
from neckid.regressors import Lags, ResolvedLags
from neckid.utils.types import FloatArray

__all__ = ["lipschitz_quotients"]


# ---------------------------------------------------------------------- Lipschitz index
def _top_quotients(
    x: FloatArray, target: FloatArray, p: int, block_size: int
) -> tuple[FloatArray, int]:
    """The ``p`` largest ``|y_i - y_j| / ||x_i - x_j||`` over pairs ``i < j`` with ``x_i != x_j``.

    Returns the quotients (descending) and the number of pairs skipped because ``x_i == x_j``.
    """
    n = x.shape[0]
    best = np.empty(0)
    skipped = 0
    for start in range(0, n - 1, block_size):
        stop = min(start + block_size, n - 1)
        # Pairs (i, j) with i in [start, stop) and j > i: take j in [start + 1, n) and mask.
        dx = x[start:stop, None, :] - x[None, start + 1 :, :]
        dist = np.sqrt(np.einsum("ijk,ijk->ij", dx, dx))
        dy = np.abs(target[start:stop, None] - target[None, start + 1 :])
        i_idx = np.arange(start, stop)[:, None]
        j_idx = np.arange(start + 1, n)[None, :]
        upper = j_idx > i_idx
        same = upper & (dist == 0)
        skipped += int(same.sum())
        valid = upper & (dist > 0)
        q = dy[valid] / dist[valid]
        pool = np.concatenate([best, q])
        if pool.size > p:
            pool = np.partition(pool, pool.size - p)[pool.size - p :]
        best = pool
    return np.sort(best)[::-1], skipped


def lipschitz_quotients(
    data: IOData | Sequence[IOData],
    max_output_lag: int,
    max_input_lag: int,
    input_delay: int = 1,
    fraction: float = 0.015,
    max_samples: int | None = 1000,
    seed: int | np.random.Generator | None = 0,
    standardize: bool = True,
) -> pd.DataFrame:
    """He & Asada's Lipschitz order index for every output and input order up to the maxima.

    For output order ``na`` and input order ``nb`` the regressor is
    ``x(t) = [y(t-1..t-na) of every output, u(t-d..t-d-nb+1) of every input]`` (``d`` the input
    delay), with ``n = na n_outputs + nb n_inputs`` components. For each output channel the index is

    ``q(n) = (prod_{k=1..p} sqrt(n) q_(k))^(1/p)``, ``q_ij = |y_i - y_j| / ||x_i - x_j||``,

    the geometric mean of the ``p`` largest Lipschitz quotients ``q_(k)`` scaled by ``sqrt(n)``,
    with ``p = max(1, round(fraction * N))`` over ``N`` regressor rows. A missing regressor term
    leaves pairs that are close in ``x`` but far apart in ``y``, so the index falls steeply while
    the order is too small and levels off once it reaches the true order: the order to choose is
    the knee of the curve.

    Parameters
    ----------
    data : IOData or list of IOData
        Records (rows never straddle two experiments).
    max_output_lag : int
        Largest output order tried (>= 0).
    max_input_lag : int
        Largest input order tried (>= 0).
    input_delay : int, default 1
        Input lags start at this delay (0 includes ``u(t)``).
    fraction : float, default 0.015
        ``p / N``; He & Asada recommend 0.01 to 0.02.
    max_samples : int or None, default 1000
        If there are more regressor rows, a random subset of this many rows (the same for every
        order, drawn with ``seed``) is used: the cost grows as ``N^2``. ``None`` uses all rows.
    seed : int, numpy.random.Generator or None, default 0
        Seed of the subsample.
    standardize : bool, default True
        Divide every channel by its standard deviation first, so that inputs and outputs in
        different units weigh alike in ``||x_i - x_j||`` (the index then has the unit 1).

    Returns
    -------
    pandas.DataFrame
        One row per output channel and order pair ``(na, nb) != (0, 0)``: columns ``output``,
        ``output_order``, ``input_order``, ``n_terms``, ``index``, ``n_rows`` (``N``) and ``p``.

    Raises
    ------
    ValueError
        If an order is negative, both are 0, ``fraction`` is not in (0, 1), or the data are too
        short for the largest lag.

    Notes
    -----
    All pairs are formed in blocks of rows (memory ``O(block N n)``), keeping only the running
    ``p`` largest quotients. Pairs with identical regressors are skipped (their quotient is
    undefined). Noise raises the floor of the index; the knee stays where it is as long as the
    noise is small compared with the signal.

    References
    ----------
    .. [1] X. He and H. Asada, "A new method for identifying orders of input-output models for
       nonlinear dynamic systems," in Proc. American Control Conference, San Francisco, 1993,
       pp. 2520-2523.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, size=600)
    >>> y = np.zeros(600)
    >>> for t in range(1, 600):
    ...     y[t] = 0.5 * y[t - 1] + np.sin(2 * u[t - 1])
    >>> table = lipschitz_quotients(IOData(u, y, ts=0.1), max_output_lag=2, max_input_lag=2)
    >>> index = table.set_index(["output_order", "input_order"])["index"]
    >>> bool(index[1, 1] < index[0, 1] / 3 and index[1, 1] < index[1, 0] / 3)
    True
    >>> bool(index[2, 2] > 0.5 * index[1, 1])
    True
    """
    _check_quotient_arguments(max_output_lag, max_input_lag, input_delay, fraction, max_samples)
    experiments = as_experiments(data)
    first = experiments[0]
    if first.n_outputs == 0:
        raise ValueError("data has no output channel; the Lipschitz index needs outputs")
    x_all, y_all, resolved = _quotient_rows(
        experiments, max_output_lag, max_input_lag, input_delay, max_samples, seed, standardize
    )
    n_rows = x_all.shape[0]
    p = max(1, round(fraction * n_rows))
    block = max(1, int(2_000_000 // max(1, n_rows * max(1, resolved.n_terms))))

    records = []
    for na in range(max_output_lag + 1):
        for nb in range(max_input_lag + 1):
            if na == 0 and nb == 0:
                continue
            columns = ((resolved.source == 0) & (resolved.lag <= na)) | (
                (resolved.source == 1) & (resolved.lag < input_delay + nb)
            )
            x = np.ascontiguousarray(x_all[:, columns])
            n_terms = int(columns.sum())
            for j, name in enumerate(first.output_names):
                records.append(
                    {
                        "output": name,
                        "output_order": na,
                        "input_order": nb,
                        "n_terms": n_terms,
                        "index": _lipschitz_index(x, y_all[:, j], n_terms, p, block),
                        "n_rows": n_rows,
                        "p": p,
                    }
                )
    table = pd.DataFrame.from_records(records)
    table.attrs["input_delay"] = int(input_delay)
    table.attrs["reference"] = "He & Asada, ACC 1993"
    return table


def _check_quotient_arguments(
    max_output_lag: int,
    max_input_lag: int,
    input_delay: int,
    fraction: float,
    max_samples: int | None,
) -> None:
    """Raise the ValueError of :func:`lipschitz_quotients` for a bad order, delay, fraction or size."""
    for name, value in (("max_output_lag", max_output_lag), ("max_input_lag", max_input_lag)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
            raise ValueError(f"{name} must be an int >= 0; got {value!r}")
    if max_output_lag == 0 and max_input_lag == 0:
        raise ValueError("max_output_lag and max_input_lag are both 0; there is no order to try")
    if (
        isinstance(input_delay, bool)
        or not isinstance(input_delay, int | np.integer)
        or input_delay < 0
    ):
        raise ValueError(f"input_delay must be an int >= 0; got {input_delay!r}")
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction must be in (0, 1); He & Asada use 0.01-0.02; got {fraction!r}")
    if max_samples is not None and (
        isinstance(max_samples, bool)
        or not isinstance(max_samples, int | np.integer)
        or max_samples < 10
    ):
        raise ValueError(f"max_samples must be an int >= 10 or None; got {max_samples!r}")


def _quotient_rows(
    experiments: list[IOData],
    max_output_lag: int,
    max_input_lag: int,
    input_delay: int,
    max_samples: int | None,
    seed: int | np.random.Generator | None,
    standardize: bool,
) -> tuple[FloatArray, FloatArray, ResolvedLags]:
    """The rows of the largest regressor and their outputs (scaled, subsampled) and its terms."""
    # The largest regressor: every candidate is a subset of its columns, and all use the same rows.
    full = Lags(
        outputs=list(range(1, max_output_lag + 1)),
        inputs=list(range(input_delay, input_delay + max_input_lag)),
    )
    x_all, y_all = full.build(experiments)
    resolved = full.resolve(experiments)
    if standardize:
        y_std = np.concatenate([d.y for d in experiments]).std(axis=0)
        u_std = np.concatenate([d.u for d in experiments]).std(axis=0)
        y_std[y_std == 0] = 1.0
        u_std[u_std == 0] = 1.0
        column_scale = np.where(
            resolved.source == 0, y_std[resolved.channel], u_std[resolved.channel]
        )
        x_all = x_all / column_scale
        y_all = y_all / y_std
    n_rows = x_all.shape[0]
    if max_samples is not None and n_rows > max_samples:
        rng = np.random.default_rng(seed)
        keep = np.sort(rng.choice(n_rows, size=int(max_samples), replace=False))
        x_all, y_all = x_all[keep], y_all[keep]
        n_rows = int(max_samples)
    if n_rows < 2:
        raise ValueError(f"the Lipschitz index needs at least 2 regressor rows; got {n_rows}")
    return x_all, y_all, resolved


def _lipschitz_index(x: FloatArray, y: FloatArray, n_terms: int, p: int, block: int) -> float:
    """He & Asada's index of one output: the geometric mean of the ``p`` largest scaled quotients."""
    top, _ = _top_quotients(x, y, p, block)
    if top.size == 0 or np.any(top == 0):
        return 0.0 if top.size else np.nan
    return float(np.exp(np.mean(np.log(np.sqrt(n_terms) * top))))
