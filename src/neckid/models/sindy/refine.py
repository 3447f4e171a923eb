"""Least squares on the free-run error within a budget of free runs, Jacobian by forward differences.

Every evaluation, those of the Jacobian included, is one free run and counts against the budget;
when it is spent the best coefficients seen so far are returned (Levenberg–Marquardt never ends
worse than its start, and neither does this). Levenberg–Marquardt is
:func:`neckid.models.levenberg.fit_least_squares`, which takes the start's errors as given and
builds one Jacobian per iteration (scipy's ``least_squares`` built two more per fit: the start's
for its checks, the end's for its report, each ``n + 1`` free runs of the budget here).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from neckid.models.levenberg import fit_least_squares
from neckid.utils.types import FloatArray

__all__ = ["Refit", "refit_free_run"]

#: Relative step of the forward differences (``sqrt`` of the float64 epsilon).
STEP = float(np.sqrt(np.finfo(np.float64).eps))


class _BudgetSpent(Exception):
    """The budget of free runs is spent."""


@dataclass
class Refit:
    """The best coefficients of a refit, their errors, and the free runs it spent."""

    theta: FloatArray
    errors: FloatArray
    runs: int = 0
    cost: float = field(default=np.inf)


def refit_free_run(
    residuals: Callable[[FloatArray], FloatArray],
    start: FloatArray,
    budget: int,
    advance: Callable[[], object],
) -> Refit:
    """Minimise ``‖residuals(θ)‖²`` from ``start`` with at most ``budget`` calls of ``residuals``."""
    first = residuals(start)
    best = Refit(start.copy(), first, 1, float(first @ first))
    advance()
    last: list[tuple[FloatArray, FloatArray]] = [(start.copy(), first)]

    def fun(theta: FloatArray) -> FloatArray:
        if last and np.array_equal(last[-1][0], theta):
            return last[-1][1]
        if best.runs >= budget:
            raise _BudgetSpent
        errors = residuals(theta)
        best.runs += 1
        advance()
        cost = float(errors @ errors)
        if cost < best.cost:
            best.theta, best.errors, best.cost = theta.copy(), errors, cost
        last[:] = [(theta.copy(), errors)]
        return errors

    def jacobian(theta: FloatArray) -> FloatArray:
        base = fun(theta)
        jac = np.empty((base.size, theta.size))
        for i in range(theta.size):
            step = STEP * max(1.0, abs(float(theta[i])))
            moved = theta.copy()
            moved[i] += step
            jac[:, i] = (fun(moved) - base) / step
        return jac

    with contextlib.suppress(_BudgetSpent):  # the best so far is the result
        fit_least_squares(fun, start, jacobian, max_nfev=budget, f0=first)
    return best
