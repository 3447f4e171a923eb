r"""The order of a subspace model chosen on runs it was not fitted on (``order=None``).

On noisy records the canonical correlations of :func:`.subspace_steps.observability_basis`
often fall without a clear gap, and the largest ratio of consecutive values can sit anywhere
(on the real neck's staircases it picked the largest order the horizon allows). With two or
more experiments, :func:`order_by_folds` chooses the order the way every selection of the
package chooses (:mod:`neckid.data.folds`): each experiment is held out in turn, the model of every
candidate order is identified on the others (steps 1–4 of :mod:`.subspace_steps`, without the
refinement, which would multiply the cost by the number of candidates; the modes bounded as in
the full fit) and run free on the
held-out one from the state of its first ``horizon`` samples; the smallest order whose mean fit
lies within one standard error of the best is chosen (Hastie, Tibshirani & Friedman 2009,
§7.10). One singular value decomposition per fold serves every candidate order.

References
----------
T. Hastie, R. Tibshirani and J. Friedman, *The Elements of Statistical Learning*, 2nd ed.,
Springer, 2009, §7.10 (cross-validation and the one-standard-error rule).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from neckid.data.folds import fold_statistics, one_standard_error
from neckid.metrics import fit_percent
from neckid.models.linear.subspace_steps import (
    bound_modes,
    initial_states,
    observability_basis,
    output_error_regression,
    past_future_factor,
    shift_invariance,
    state_space_run,
)
from neckid.utils.types import FloatArray

__all__ = ["order_by_folds"]


def _held_out_fits(
    training: Sequence[tuple[FloatArray, FloatArray]],
    held_out: tuple[FloatArray, FloatArray],
    horizon: int,
    orders: Sequence[int],
    options: tuple[bool, bool],
    radius: float,
    output_scale: FloatArray,
) -> FloatArray:
    """Free-run fit [%] on ``held_out`` of the model of each order identified on ``training``.

    The fit is the mean over outputs of ``100 (1 − ‖y − ŷ‖ / ‖y − mean(y)‖)`` from sample
    ``horizon`` on; ``-inf`` for an order whose estimate fails or whose run is not finite.
    """
    feedthrough, intercept = options
    u, y = held_out
    m, p = u.shape[1], y.shape[1]
    factor = past_future_factor(training, horizon, intercept)
    left, values = observability_basis(factor, horizon, m, p)
    fits = np.full(len(orders), -np.inf)
    for k, order in enumerate(orders):
        try:
            a, c, _ = shift_invariance(left, values, order, p)
        except ValueError:  # pragma: no cover - an order whose stabilised A is unstable
            continue
        a = bound_modes(a, radius)[0]
        model = (a, c, training, feedthrough, intercept, horizon, output_scale)
        b, d, offset, _ = output_error_regression(*model)
        matrices = (a, b, c, d, offset)
        state = initial_states(matrices, [held_out], horizon, output_scale)[0]
        with np.errstate(all="ignore"):
            run = state_space_run(*matrices, np.ascontiguousarray(u), state)[0]
        if np.all(np.isfinite(run)):
            fits[k] = float(np.mean(fit_percent(y, run, skip=horizon)))
    return fits


def order_by_folds(
    experiments: Sequence[tuple[FloatArray, FloatArray]],
    horizon: int,
    largest: int,
    options: tuple[bool, bool],
    radius: float,
    output_scale: FloatArray,
) -> tuple[int, FloatArray]:
    """The order of the one-standard-error rule over leave-one-experiment-out folds.

    Parameters
    ----------
    experiments : sequence of (u, y)
        Two or more experiments (scaled inputs and outputs, as :mod:`.subspace_steps` takes
        them), each longer than ``2 * horizon`` samples.
    horizon : int
        Block rows of the Hankel matrices; also the samples each held-out run takes its
        initial state from (those are not scored).
    largest : int
        Candidate orders are ``1 … largest``.
    options : (feedthrough, intercept)
    radius : float
        Largest eigenvalue magnitude of ``A`` (:func:`.subspace_steps.bound_modes`).
    output_scale : ndarray, shape (n_outputs,)
        The outputs' scale (:func:`.subspace_steps.initial_state_solver`).

    Returns
    -------
    order : int
        The smallest order whose mean fold fit is at least the best mean minus its standard
        error (:func:`neckid.data.folds.one_standard_error`).
    fold_fits : ndarray, shape (largest, n_experiments)
        Row ``k``: the free-run fit [%] of order ``k + 1`` on each held-out experiment.

    Raises
    ------
    ValueError
        If fewer than two experiments are given, or no order runs on every fold.
    """
    if len(experiments) < 2:
        raise ValueError(f"order_by_folds needs at least 2 experiments; got {len(experiments)}")
    orders = list(range(1, largest + 1))
    columns = []
    for k, held_out in enumerate(experiments):
        training = [run for j, run in enumerate(experiments) if j != k]
        columns.append(
            _held_out_fits(training, held_out, horizon, orders, options, radius, output_scale)
        )
    fold_fits = np.column_stack(columns)
    statistics = [fold_statistics(row) for row in fold_fits]
    means = [mean for mean, _, _ in statistics]
    errors = [se for _, se, _ in statistics]
    accepted = [bool(np.isfinite(mean)) for mean in means]
    pick, _ = one_standard_error(means, errors, orders, accepted)
    return orders[pick], fold_fits
