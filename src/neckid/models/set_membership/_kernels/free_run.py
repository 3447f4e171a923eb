"""The compiled free run of a Set Membership model: regressor from its own history, bounds, feedback.

At each sample the regressor is built from the simulated past outputs and the measured inputs,
the linear part is added, both optimal bounds are evaluated on the kd-tree
(:class:`~neckid.models.set_membership._kernels.tree.SMTree`, the same branch and bound as its
``bounds``) and the central value, their mean, is fed back as the next past output.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from neckid.models.set_membership._kernels.tree import STACK_DEPTH, SMTree, query_one
from neckid.utils.progress import task
from neckid.utils.types import FloatArray, IntArray

__all__ = ["free_run"]


@njit(cache=True)
def _free_run_kernel(
    first: int,
    stop: int,
    u: FloatArray,
    y: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    source: IntArray,
    channel: IntArray,
    lag: IntArray,
    max_lag: int,
    weights: FloatArray,
    coef: FloatArray,
    intercept: FloatArray,
    epsilon: FloatArray,
    gamma: FloatArray,
    points: FloatArray,
    targets: FloatArray,
    start: IntArray,
    end: IntArray,
    left: IntArray,
    right: IntArray,
    lo: FloatArray,
    hi: FloatArray,
    ymin: FloatArray,
    ymax: FloatArray,
) -> None:
    n_terms = source.shape[0]
    n_out = y.shape[1]
    w = np.empty(n_terms)
    ws = np.empty(n_terms)
    node_stack = np.empty(STACK_DEPTH, np.int64)
    dist_stack = np.empty(STACK_DEPTH)
    no_points = np.empty((0, n_out))
    for t in range(max(first, max_lag), stop):
        for k in range(n_terms):
            if source[k] == 0:
                w[k] = y[t - lag[k], channel[k]]
            else:
                w[k] = u[t - lag[k], channel[k]]
            ws[k] = w[k] * weights[k]
        for c in range(n_out):
            linear = intercept[c]
            for k in range(n_terms):
                linear += w[k] * coef[k, c]
            low, high = query_one(
                ws,
                points,
                targets,
                c,
                gamma[c],
                start,
                end,
                left,
                right,
                lo,
                hi,
                ymin,
                ymax,
                node_stack,
                dist_stack,
                no_points,
            )
            f_lower = low - epsilon[c]
            f_upper = high + epsilon[c]
            lower[t, c] = linear + f_lower
            upper[t, c] = linear + f_upper
            y[t, c] = linear + 0.5 * (f_lower + f_upper)


#: Samples a long free run computes per compiled call, between progress reports.
FREE_RUN_CHUNK = 50_000


def free_run(
    tree: SMTree,
    u: FloatArray,
    y_initial: FloatArray,
    source: IntArray,
    channel: IntArray,
    lag: IntArray,
    max_lag: int,
    weights: FloatArray,
    coef: FloatArray,
    intercept: FloatArray,
    epsilon: FloatArray,
    gamma: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Compiled free run; returns ``(y, lower, upper)``, each ``(n_samples, n_outputs)``.

    The first ``max_lag`` rows of ``y`` are ``y_initial``'s (initial conditions); the bounds there
    are NaN.
    """
    y = np.array(y_initial, dtype=np.float64, order="C")
    lower = np.full(y.shape, np.nan)
    upper = np.full(y.shape, np.nan)
    arguments: tuple[Any, ...] = (
        np.ascontiguousarray(u, dtype=np.float64),
        y,
        lower,
        upper,
        np.ascontiguousarray(source, dtype=np.int64),
        np.ascontiguousarray(channel, dtype=np.int64),
        np.ascontiguousarray(lag, dtype=np.int64),
        int(max_lag),
        np.ascontiguousarray(weights, dtype=np.float64),
        np.ascontiguousarray(coef, dtype=np.float64),
        np.ascontiguousarray(intercept, dtype=np.float64),
        np.ascontiguousarray(epsilon, dtype=np.float64),
        np.ascontiguousarray(gamma, dtype=np.float64),
        *tree.kernel_arrays(),
    )
    n = y.shape[0]
    steps = max(n - int(max_lag), 0)
    if steps <= FREE_RUN_CHUNK:  # one call: nothing worth reporting
        _free_run_kernel(int(max_lag), n, *arguments)
        return y, lower, upper
    # A long run goes in blocks (the same loop, resumed): its progress and time left are shown.
    with task("Set Membership free run", total=steps) as advance:
        for first in range(int(max_lag), n, FREE_RUN_CHUNK):
            stop = min(first + FREE_RUN_CHUNK, n)
            _free_run_kernel(first, stop, *arguments)
            advance(stop - first)
    return y, lower, upper
