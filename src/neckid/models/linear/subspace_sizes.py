"""How much memory a subspace state-space fit of a given order needs, checked before it is spent.

The past-future regression holds a matrix of the logs' windows by ``2 * horizon * (m + p)``
columns; the free-run refinement (``refine=True``) a Jacobian of every output value after the
initial samples by every parameter, ``n * n + n * m + p * n (+ p * m) (+ p)`` of them for order
``n``: an order in the hundreds makes it tens of gigabytes. :func:`check_subspace_sizes` refuses
such an order in terms of the order, before anything is allocated (as the polynomial
state-space model does for its Jacobian).
"""

from __future__ import annotations

from collections.abc import Sequence

from neckid.utils.memory import check_allocation

__all__ = ["check_subspace_sizes"]


def check_subspace_sizes(
    lengths: Sequence[int],
    n_inputs: int,
    n_outputs: int,
    order: int,
    horizon: int,
    *,
    refine: bool,
    feedthrough: bool,
    intercept: bool,
) -> None:
    """Refuse an order whose fit needs more than half the memory available (``ValueError``).

    Examples
    --------
    >>> check_subspace_sizes([2000], 1, 1, 4, 10, refine=True, feedthrough=False, intercept=True)
    """
    m, p, n = int(n_inputs), int(n_outputs), int(order)
    windows = sum(max(0, length - 2 * horizon + 1) for length in lengths)
    columns = 2 * horizon * (m + p) + int(intercept)
    check_allocation(
        8.0 * 2 * windows * columns,  # the matrix and its factorisation's copy
        f"the past-future regression of order {n} ({windows:,} windows x {columns:,} columns)",
        "give a smaller order (--set order=N), or leave it to the singular values",
    )
    if not refine:
        return
    parameters = n * n + n * m + p * n + (p * m if feedthrough else 0) + (p if intercept else 0)
    values = sum(max(0, length - horizon) for length in lengths) * p
    check_allocation(
        8.0 * 3 * values * parameters,  # the Jacobian, its copy, the solver's
        f"the free-run refinement of order {n} (a Jacobian of {values:,} output values x"
        f" {parameters:,} parameters)",
        "give a smaller order (--set order=N), or --set refine=false",
    )
