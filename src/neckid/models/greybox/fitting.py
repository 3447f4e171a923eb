r"""Fitting the grey-box neck on its free-run error (variable projection).

For fixed nonlinear parameters — the slack widths :math:`s_j` and the reflection coefficients
of each output's dynamics — the free run is *linear* in the Prandtl–Ishlinskii weights and the
offset (the dynamics are linear and the operators come before them):

.. math::

    \hat y_o(t) = h_o(t) + \sum_i \theta_{o,i}\, G_o[\phi_i](t),

with :math:`h_o` the response to the initial outputs and :math:`\phi_i` the basis of
:func:`basis`. The weights are solved by least squares inside the residual, and
``scipy.optimize.least_squares`` moves only the few nonlinear parameters, within bounds that
keep every pole inside the unit circle (Golub & Pereyra 1973's variable projection, with
finite-difference Jacobians).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from neckid.models.greybox.hysteresis import denominator, dynamics_run, play, reflection
from neckid.utils.types import FloatArray

__all__ = ["REFLECTION_BOUND", "SLACK_GRID", "Problem", "basis", "fit_problem", "free_run_error"]

#: Largest magnitude of a reflection coefficient: every pole stays inside ``|z| < 1``.
REFLECTION_BOUND = 0.9995
#: Slack widths tried before the optimisation, as shares of each input's training range.
SLACK_GRID = (0.0, 0.02, 0.05, 0.1, 0.2)
#: Largest slack width, as a share of the input's training range.
SLACK_LIMIT = 0.5


@dataclass(frozen=True)
class Problem:
    """The training data of a fit, split as the model reads it.

    ``runs`` holds, per experiment, ``(motors (n, J), conditions (n, C), outputs (n, O))``;
    ``radii`` the Prandtl–Ishlinskii radii above the slack ``(J, K)``; ``start`` the samples
    taken as initial conditions; ``envelope`` the lowest and highest value a free run may take
    per output ``(2, O)``; ``spans`` each motor input's training range ``(J,)``; ``radius``
    the largest pole magnitude of the dynamics (:func:`~.hysteresis.denominator`).
    """

    runs: Sequence[tuple[FloatArray, FloatArray, FloatArray]]
    radii: FloatArray
    order: int
    delay: int
    start: int
    envelope: FloatArray
    spans: FloatArray
    radius: float = 1.0


def basis(
    motors: FloatArray, conditions: FloatArray, slack: FloatArray, radii: FloatArray
) -> FloatArray:
    r"""The signals the weights multiply: plays, plays times conditions, conditions, 1.

    Column blocks: :math:`P_{s_j/2 + r_{jk}}[x_j]` for every motor input ``j`` and radius
    ``k``; the same times each condition :math:`p_c` (a condition scales the hysteresis: a
    payload-dependent gain); :math:`p_c` (a condition-dependent offset); the constant 1.

    Returns
    -------
    ndarray, shape (n_samples, J K (1 + C) + C + 1)
    """
    plays = np.hstack(
        [play(motors[:, j], slack[j] / 2.0 + radii[j]) for j in range(motors.shape[1])]
    )
    scaled = [plays * conditions[:, c : c + 1] for c in range(conditions.shape[1])]
    return np.hstack([plays, *scaled, conditions, np.ones((motors.shape[0], 1))])


def _columns(
    problem: Problem, slack: FloatArray, polynomial: FloatArray, output: int
) -> tuple[FloatArray, FloatArray]:
    """Filtered basis ``G_o[phi]`` and targets ``y_o - h_o`` of one output, stacked over the runs."""
    m, d = problem.start, problem.delay
    columns, targets = [], []
    for motors, conditions, y in problem.runs:
        phi = basis(motors, conditions, slack, problem.radii)
        columns.append(dynamics_run(polynomial, phi, np.zeros((m, phi.shape[1])), m, d))
        free = dynamics_run(polynomial, np.zeros((y.shape[0], 1)), y[:m, output : output + 1], m, d)
        targets.append(y[m:, output] - free[:, 0])
    return np.vstack(columns), np.concatenate(targets)


def free_run_error(
    problem: Problem, slack: FloatArray, coefficients: FloatArray
) -> tuple[FloatArray, FloatArray, bool]:
    """Free-run residuals of a candidate, its best weights, and whether its run diverges.

    Parameters
    ----------
    problem : Problem
    slack : ndarray, shape (J,)
        Slack widths, in the inputs' units.
    coefficients : ndarray, shape (O, order)
        Reflection coefficients per output.

    Returns
    -------
    residuals : ndarray
        ``y - yhat`` from sample ``start`` on, every run and output in turn.
    weights : ndarray, shape (O, n_basis)
    diverged : bool
        The free run is not finite or leaves ``problem.envelope`` (the candidate is refused).
    """
    parts, weights, diverged = [], [], False
    for o in range(coefficients.shape[0]):
        polynomial = denominator(coefficients[o], problem.radius)
        columns, target = _columns(problem, slack, polynomial, o)
        with np.errstate(all="ignore"):
            theta = np.linalg.lstsq(columns, target, rcond=None)[0]
            residual = target - columns @ theta
            run = np.concatenate([y[problem.start :, o] for _, _, y in problem.runs]) - residual
        low, high = problem.envelope[:, o]
        if not (np.all(np.isfinite(run)) and run.min() >= low and run.max() <= high):
            diverged = True
        parts.append(residual)
        weights.append(theta)
    return np.concatenate(parts), np.asarray(weights), diverged


def _arx_start(problem: Problem) -> FloatArray:
    """Reflection coefficients of each output's poles in an ARX least-squares fit (the start).

    The ARX polynomial is read at the scale of ``problem.radius`` (``a_i / ρ^i``) and its
    reflection coefficients clipped into the box: poles beyond the radius start on it.
    """
    n, m, d = problem.order, problem.start, problem.delay
    coefficients = []
    for o in range(problem.runs[0][2].shape[1]):
        rows, targets = [], []
        for motors, conditions, y in problem.runs:
            t = np.arange(m, y.shape[0])
            past = [-y[t - i, o] for i in range(1, n + 1)]
            rows.append(np.column_stack([*past, motors[t - d], conditions[t - d], np.ones(t.size)]))
            targets.append(y[t, o])
        theta = np.linalg.lstsq(np.vstack(rows), np.concatenate(targets), rcond=None)[0]
        polynomial = np.concatenate([[1.0], theta[:n]]) / problem.radius ** np.arange(n + 1)
        coefficients.append(reflection(polynomial, REFLECTION_BOUND))
    return np.asarray(coefficients)


def fit_problem(
    problem: Problem, fit_slack: bool, max_iter: int
) -> tuple[FloatArray, FloatArray, FloatArray, float]:
    """Slack widths, reflection coefficients and weights of the smallest free-run error.

    Starts from the ARX poles and the best width of :data:`SLACK_GRID`, then runs
    ``least_squares`` (trust region, bounded) on the nonlinear parameters; a step whose free
    run diverges costs a constant penalty larger than any run inside the envelope, so it is
    never accepted. Returns ``(slack, coefficients, weights, cost)``, cost the mean square.
    """
    n_out, n_motor = problem.runs[0][2].shape[1], problem.spans.size
    ks = _arx_start(problem)
    penalty = 100.0 * float(np.max(problem.envelope[1] - problem.envelope[0]))

    def residuals(x: FloatArray) -> FloatArray:
        slack = x[:n_motor] * problem.spans if fit_slack else np.zeros(n_motor)
        error, _, diverged = free_run_error(problem, slack, x[n_motor:].reshape(n_out, -1))
        return np.full(error.shape, penalty) if diverged else error

    grid = SLACK_GRID if fit_slack else (0.0,)
    starts = [np.concatenate([np.full(n_motor, share), ks.ravel()]) for share in grid]
    costs = [float(np.mean(residuals(x) ** 2)) for x in starts]
    x0 = starts[int(np.argmin(costs))]
    low = np.concatenate([np.zeros(n_motor), np.full(ks.size, -REFLECTION_BOUND)])
    high = np.concatenate(
        [np.full(n_motor, SLACK_LIMIT if fit_slack else 1e-12), np.full(ks.size, REFLECTION_BOUND)]
    )
    x0 = np.clip(x0, low, high - 1e-12)
    solution = least_squares(
        residuals, x0, bounds=(low, high), max_nfev=max_iter, x_scale="jac", diff_step=1e-4
    )
    better = np.sum(residuals(solution.x) ** 2) <= np.sum(residuals(x0) ** 2)
    x = solution.x if better else x0
    slack = x[:n_motor] * problem.spans if fit_slack else np.zeros(n_motor)
    coefficients = x[n_motor:].reshape(n_out, -1)
    error, weights, diverged = free_run_error(problem, slack, coefficients)
    if diverged:
        raise ValueError(
            "every grey-box candidate's free run left the training range widened"
            " DIVERGENCE_SPANS times: the data do not fit this model (check the input units)"
        )
    return slack, coefficients, weights, float(np.mean(error**2))
