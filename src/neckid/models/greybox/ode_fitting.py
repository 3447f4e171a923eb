r"""Fitting a grey-box structure on its free-run error: bounded least squares from several starts.

The parameters :math:`\theta` (and, with ``initial_state="estimated"``, the initial state of each
training experiment) minimise the free-run (output-error, simulation-error) cost over every
training experiment,

.. math::

    V(\theta) = \sum_{e} \sum_{t \ge 1} \lVert y_e(t) - \hat y_e(t; \theta, x_{0,e}) \rVert^2,

the criterion of MATLAB's ``nlgreyest`` (Ljung 1999, §5.3 and §7.3), by
``scipy.optimize.least_squares`` with bounds (trust-region reflective; Branch, Coleman & Li 1999)
and finite-difference Jacobians. Parameters with ``log_scale`` are searched as
:math:`\log\theta`.

**Starts.** The structure's initial guesses, then ``n_starts - 1`` points of a scrambled Halton
sequence (seeded by ``random_state``) in the parameters' box (log box for ``log_scale``; a
side without a bound spans ``initial ± (1 + |initial|)``). Every start gets
:data:`SCREEN_EVALUATIONS` cost evaluations; the :data:`REFINED_STARTS` best go on to
``max_iter``, and the lowest cost wins (a two-stage multi-start: the simulation-error cost of a
model with saturations has several minima).

BLAS is held to one thread during the fit (the Jacobians are small; threads only contend).

**Divergence.** A free run that is not finite, runs away or leaves the divergence envelope (the
training range widened ``DIVERGENCE_SPANS`` times its width on each side, as every neckid free
run) costs, from its first such sample on, twice the envelope's width per sample: larger than
any run inside it, and smaller the later it leaves, so the search is led back. A winner whose
run still leaves the envelope is refused (``ValueError``).

References
----------
L. Ljung, *System Identification: Theory for the User*, 2nd ed., Prentice Hall, 1999.

M. A. Branch, T. F. Coleman and Y. Li, "A subspace, interior, and conjugate gradient method for
large-scale bound-constrained minimization problems", *SIAM J. Sci. Comput.* 21(1), 1–23, 1999.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import OptimizeResult, least_squares
from scipy.stats import qmc
from threadpoolctl import threadpool_limits

from neckid.models.greybox.ode_kernels import evaluate, free_run
from neckid.models.greybox.structure import GreyBoxStructure
from neckid.models.results import DIVERGENCE_SPANS
from neckid.utils.progress import task
from neckid.utils.types import FloatArray

__all__ = [
    "DIFF_STEP",
    "REFINED_STARTS",
    "SCREEN_EVALUATIONS",
    "OdeProblem",
    "OdeSolution",
    "fit_structure",
]

#: Cost evaluations every start gets before the best ones are refined.
SCREEN_EVALUATIONS = 20
#: Starts refined to ``max_iter`` evaluations after the screening.
REFINED_STARTS = 3
#: Relative step of the finite-difference Jacobian (``least_squares(diff_step=...)``).
DIFF_STEP = 1e-6


@dataclass(frozen=True)
class OdeProblem:
    """The training data of a fit, as the free run reads it.

    ``runs`` holds ``(u, y)`` per experiment (C-contiguous ``float64``, ``(n, n_inputs)`` and
    ``(n, n_outputs)``); ``envelope`` the lowest and highest value a free run may take per output,
    ``(2, n_outputs)``.
    """

    structure: GreyBoxStructure
    runs: Sequence[tuple[FloatArray, FloatArray]]
    period: float
    substeps: int
    estimate_initial: bool
    envelope: FloatArray


@dataclass(frozen=True)
class OdeSolution:
    """What a fit found.

    ``parameters`` ``(n_parameters,)`` in the structure's order; ``initial_states``
    ``(n_experiments, n_states)``; ``rmse`` the free-run RMSE per output over the training
    experiments (from sample 1 on); ``start_costs`` the mean square error of every start after
    its screening; ``evaluations`` the free runs of every experiment the fit took.
    """

    parameters: FloatArray
    initial_states: FloatArray
    rmse: FloatArray
    start_costs: FloatArray
    evaluations: int


class _Search:
    """The search vector ``z``: the free parameters (log where asked), then the initial states."""

    def __init__(self, problem: OdeProblem) -> None:
        self.problem = problem
        structure = problem.structure
        self.free = np.array([not p.fixed for p in structure.parameters])
        self.log = np.array([p.log_scale for p in structure.parameters])[self.free]
        self.base = structure.initial_values()
        low = np.array([p.lower for p in structure.parameters])[self.free]
        high = np.array([p.upper for p in structure.parameters])[self.free]
        self.low = np.where(self.log, np.log(np.where(self.log, low, 1.0)), low)
        self.high = np.where(self.log, np.log(np.where(self.log, high, 1.0)), high)
        state_low, state_high = structure.state_bounds()
        n_runs = len(problem.runs) if problem.estimate_initial else 0
        self.state_low = np.tile(state_low, n_runs)
        self.state_high = np.tile(state_high, n_runs)

    def parameters(self, z: FloatArray) -> FloatArray:
        values = self.base.copy()
        head = z[: self.low.size]
        values[self.free] = np.where(self.log, np.exp(head), head)
        return values

    def encode(self, parameters: FloatArray) -> FloatArray:
        free = parameters[self.free]
        return np.where(self.log, np.log(np.where(self.log, free, 1.0)), free)

    def initial_states(self, z: FloatArray, parameters: FloatArray) -> FloatArray:
        structure = self.problem.structure
        if self.problem.estimate_initial:
            return z[self.low.size :].reshape(len(self.problem.runs), structure.n_states)
        return self.rule_states(parameters)

    def rule_states(self, parameters: FloatArray) -> FloatArray:
        """The structure's initial state of every experiment, held in the state bounds."""
        structure = self.problem.structure
        low, high = structure.state_bounds()
        rows = [
            evaluate(structure.initial_state, y[0], u[0], parameters) for u, y in self.problem.runs
        ]
        return np.clip(np.vstack(rows), low, high)

    def bounds(self) -> tuple[FloatArray, FloatArray]:
        return (
            np.concatenate([self.low, self.state_low]),
            np.concatenate([self.high, self.state_high]),
        )

    def starts(self, n_starts: int, seed: int | np.random.Generator | None) -> list[FloatArray]:
        """The initial guesses, then ``n_starts - 1`` Halton points of the parameters' box."""
        first = self.encode(self.base)
        points = [first]
        if n_starts > 1 and first.size:
            spread = 1.0 + np.abs(first)
            low = np.where(np.isfinite(self.low), self.low, first - spread)
            high = np.where(np.isfinite(self.high), self.high, first + spread)
            halton = qmc.Halton(first.size, scramble=True, rng=np.random.default_rng(seed))
            points += list(low + (high - low) * halton.random(n_starts - 1))
        if not self.problem.estimate_initial:
            return points
        return [np.concatenate([p, self.rule_states(self.parameters(p)).ravel()]) for p in points]


def _residuals(problem: OdeProblem, search: _Search, z: FloatArray) -> FloatArray:
    """Free-run errors from sample 1 on, every experiment in turn; see the module docstring."""
    parameters = search.parameters(z)
    states = search.initial_states(z, parameters)
    low, high = problem.envelope
    penalty = 2.0 * (high - low)
    parts = []
    for (u, y), x0 in zip(problem.runs, states, strict=True):
        _, simulated = free_run(
            problem.structure, x0, u, parameters, problem.period, problem.substeps
        )
        error = simulated[1:] - y[1:]
        with np.errstate(invalid="ignore"):
            bad = ~np.isfinite(simulated[1:]) | (simulated[1:] < low) | (simulated[1:] > high)
        rows = np.flatnonzero(bad.any(axis=1))
        if rows.size:
            error[rows[0] :] = penalty
        parts.append(error.ravel())
    return np.concatenate(parts)


def _solve(
    problem: OdeProblem, search: _Search, z0: FloatArray, evaluations: int
) -> OptimizeResult:
    low, high = search.bounds()
    z0 = np.clip(z0, low, high)
    return least_squares(
        lambda z: _residuals(problem, search, z),
        z0,
        bounds=(low, high),
        method="trf",
        x_scale="jac",
        diff_step=DIFF_STEP,
        max_nfev=evaluations,
    )


def fit_structure(
    problem: OdeProblem,
    n_starts: int,
    max_iter: int,
    seed: int | np.random.Generator | None,
) -> OdeSolution:
    """Parameters (and initial states) of the smallest free-run error; see the module docstring.

    Raises
    ------
    ValueError
        If the best candidate's free run on a training experiment is not finite or leaves the
        divergence envelope.
    """
    # The Jacobians are small (samples x parameters): BLAS threads only contend for the cores
    # (the tanks fit took 22.8 s with OpenBLAS's 2 threads, 6.1 s with one, load 10 on 2 cores).
    with threadpool_limits(limits=1, user_api="blas"):
        return _fit(problem, n_starts, max_iter, seed)


def _fit(
    problem: OdeProblem,
    n_starts: int,
    max_iter: int,
    seed: int | np.random.Generator | None,
) -> OdeSolution:
    search = _Search(problem)
    starts = search.starts(n_starts, seed)
    n_values = sum(y[1:].size for _, y in problem.runs)
    single = len(starts) == 1 or not search.low.size
    refine = not single and max_iter > SCREEN_EVALUATIONS
    solves = 1 if single else len(starts) + (min(REFINED_STARTS, len(starts)) if refine else 0)
    label = f"grey-box fit of {problem.structure.name!r} (least-squares runs from the starts)"
    with task(label, solves) as advance:
        if single:
            screened = [_solve(problem, search, starts[0], max_iter)]
            advance()
        else:
            screened = []
            for z in starts:
                screened.append(_solve(problem, search, z, min(SCREEN_EVALUATIONS, max_iter)))
                advance()
        start_costs = np.array([2.0 * s.cost / n_values for s in screened])
        refined = screened
        if refine:
            order = np.argsort(start_costs, kind="stable")[:REFINED_STARTS]
            refined = []
            for i in order:
                refined.append(_solve(problem, search, screened[i].x, max_iter))
                advance()
    best = min(refined, key=lambda s: float(s.cost))
    runs = len(problem.runs)
    n_free = best.x.size
    evaluations = runs * sum(int(s.nfev) + n_free * int(s.njev or 0) for s in [*screened, *refined])
    parameters = search.parameters(best.x)
    states = search.initial_states(best.x, parameters)
    error = _residuals(problem, search, best.x)
    _check_inside(problem, parameters, states)
    n_out = problem.structure.n_outputs
    rmse = np.sqrt(np.mean(error.reshape(-1, n_out) ** 2, axis=0))
    return OdeSolution(parameters, np.array(states), rmse, start_costs, evaluations)


def _check_inside(problem: OdeProblem, parameters: FloatArray, states: FloatArray) -> None:
    """Refuse a winner whose free run on a training experiment is not finite or runs away."""
    low, high = problem.envelope
    for i, ((u, _), x0) in enumerate(zip(problem.runs, states, strict=True)):
        _, simulated = free_run(
            problem.structure, x0, u, parameters, problem.period, problem.substeps
        )
        with np.errstate(invalid="ignore"):
            bad = ~np.isfinite(simulated) | (simulated < low) | (simulated > high)
        rows = np.flatnonzero(bad.any(axis=1))
        if rows.size:
            row = int(rows[0])
            value = simulated[row].tolist()
            raise ValueError(
                f"the best grey-box fit of structure {problem.structure.name!r} still runs away"
                f" on training experiment {i}: output {value} at sample {row} leaves the"
                f" training range widened {DIVERGENCE_SPANS:g} times its width (or is not"
                " finite); check the"
                " structure's equations, units, initial guesses and bounds (more n_starts may"
                " find a stable start)"
            )
