"""The compiled free-run refinement of the subspace model (issue 42): Jacobian and steps."""

from __future__ import annotations

import numpy as np
import pytest

from neckid import IOData
from neckid.models.linear import SubspaceStateSpace
from neckid.models.linear import subspace_refine as refine
from neckid.models.linear.subspace_steps import initial_states, state_space_run


def _system(seed: int = 0) -> tuple[tuple[np.ndarray, ...], list[tuple[np.ndarray, np.ndarray]]]:
    """A stable 3-state, 2-input, 2-output model and two runs of its noise-free free run."""
    rng = np.random.default_rng(seed)
    a = np.array([[0.8, 0.2, 0.0], [-0.2, 0.8, 0.1], [0.0, 0.0, -0.5]])
    b, c = rng.normal(size=(3, 2)), rng.normal(size=(2, 3))
    d, offset = rng.normal(size=(2, 2)), rng.normal(size=2)
    runs = []
    for length in (160, 120):
        u = rng.normal(size=(length, 2))
        runs.append((u, state_space_run(a, b, c, d, offset, u, rng.normal(size=3))[0]))
    return (a, b, c, d, offset), runs


@pytest.mark.parametrize("options", [(True, True), (False, True), (False, False)])
def test_jacobian_matches_finite_differences(options: tuple[bool, bool]) -> None:
    """At the true matrices (first samples fitted exactly) the Jacobian is the exact one."""
    model, runs = _system()
    feedthrough, intercept = options
    model = (*model[:3], model[3] * feedthrough, model[4] * intercept)
    runs = [(u, state_space_run(*model, u, np.ones(3))[0]) for u, _ in runs]
    scale = np.array([1.5, 0.7])
    problem = refine._Problem(model, runs, options, 6, 1.0, scale)
    theta = refine._pack(model, *options)
    error = problem.residuals(theta)
    assert error is not None and np.max(np.abs(error)) < 1e-9
    step = 1e-6
    columns = []
    for k in range(theta.size):
        shift = np.zeros(theta.size)
        shift[k] = step
        plus, minus = problem.residuals(theta + shift), problem.residuals(theta - shift)
        assert plus is not None and minus is not None
        columns.append((plus - minus) / (2 * step))
    numeric = np.column_stack(columns)
    hessian, gradient = problem.normal_equations(theta, np.ones(error.size))
    np.testing.assert_allclose(hessian, numeric.T @ numeric, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(gradient, numeric.sum(axis=0), rtol=1e-5, atol=1e-5)


def test_sensitivities_run_is_the_free_run() -> None:
    """The kernel's outputs are those of ``state_space_run`` (the same arithmetic order)."""
    model, runs = _system(1)
    u = runs[0][0]
    x0 = np.array([0.3, -0.2, 0.1])
    y, jac, free = refine.sensitivities(*model, u, x0, True, True)
    np.testing.assert_array_equal(y, state_space_run(*model, u, x0)[0])
    assert jac.shape == (u.shape[0] * 2, 9 + 6 + 6 + 4 + 2)
    np.testing.assert_allclose(free[2:4], model[2] @ model[0], rtol=1e-14)


def test_refinement_recovers_a_perturbed_model() -> None:
    """From perturbed matrices, the steps bring the free-run error of noise-free data near 0."""
    model, runs = _system(2)
    rng = np.random.default_rng(3)
    start = tuple(m + 0.05 * rng.normal(size=m.shape) for m in model)
    before = refine._Problem(start, runs, (True, True), 6, 1.0, None)
    start_error = before.residuals(refine._pack(start, True, True))
    assert start_error is not None
    refined = refine.refine_free_run(start, runs, True, True, 200, 6)
    states = initial_states(refined, runs, 6)
    rms = [
        np.sqrt(np.mean((state_space_run(*refined, u, x)[0][6:] - y[6:]) ** 2))
        for (u, y), x in zip(runs, states, strict=True)
    ]
    assert max(rms) < 1e-3 * np.sqrt(np.mean(start_error**2))


def test_unstable_start_comes_back_unchanged() -> None:
    """A start beyond the mode bound gives the estimate back (nothing refined)."""
    model, runs = _system(4)
    bounded = refine.refine_free_run(model, runs, True, True, 20, 6, radius=0.5)
    assert bounded is model


def test_fit_refines_on_data() -> None:
    """``SubspaceStateSpace`` keeps a refinement that lowers the training free-run error."""
    rng = np.random.default_rng(5)
    u = rng.normal(size=600)
    y = np.zeros(600)
    for t in range(2, 600):
        y[t] = 1.5 * y[t - 1] - 0.7 * y[t - 2] + u[t - 1] + 0.3 * np.tanh(u[t - 2])
    data = IOData(u, y + 0.01 * rng.normal(size=600), ts=0.1)
    plain = SubspaceStateSpace(order=2, refine=False).fit(data)
    refined = SubspaceStateSpace(order=2).fit(data)
    assert refined.refined_
    error = [np.mean((m.simulate(data).y[10:, 0] - data.y[10:, 0]) ** 2) for m in (plain, refined)]
    assert error[1] < error[0]
