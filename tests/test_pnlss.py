"""The polynomial nonlinear state-space model (``pnlss``): gradients, recovery, safeguard, files.

The compiled free run and sensitivity recursion (``neckid.models.pnlss._kernels``) are checked
against a plain NumPy reference written from the equations (below) and against central finite
differences.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

import neckid
from neckid import IOData
from neckid.models.pnlss import PolynomialStateSpace
from neckid.models.pnlss.fitting import FreeRunProblem, Layout


def _reference_run(layout: Layout, theta, u, x0, box):
    """NumPy free run: ``x+ = A x + B u + E ζ``, ``y = C x + D u + c + F ζ`` (ζ of held z)."""
    a, b, c, d, offset, e, f = layout.unpack(theta)
    powers = layout.tables()[0][-layout.n_nonlinear :]
    center, scale, low, high = box
    x, out = x0.copy(), []
    for t in range(u.shape[0]):
        z = np.clip((np.concatenate([x, u[t]]) - center) / scale, low, high)
        zeta = np.prod(z[None, :] ** powers, axis=1)
        out.append(c @ x + d @ u[t] + offset + f @ zeta)
        x = a @ x + b @ u[t] + e @ zeta
    return np.array(out)


def _problem(seed: int = 0, n_samples: int = 120):
    rng = np.random.default_rng(seed)
    layout = Layout(2, 1, 1, 3, False)
    u = np.ascontiguousarray(rng.uniform(-1, 1, (n_samples, 1)))
    box = (np.zeros(3), np.full(3, 0.8), np.full(3, -1.5), np.full(3, 1.5))
    a = np.array([[0.6, 0.2], [-0.2, 0.5]])
    b, c = np.array([[0.5], [0.3]]), np.array([[1.0, 0.4]])
    k = layout.n_nonlinear
    e, f = 0.05 * rng.normal(size=(2, k)), 0.05 * rng.normal(size=(1, k))
    f[:, ~np.all(layout.tables()[0][-k:, 2:] == 0, axis=1)] = 0.0  # no input monomials in F
    theta = layout.pack((a, b, c, np.zeros((1, 1)), np.array([0.1]), e, f))
    x0 = np.array([0.2, -0.1])
    y = _reference_run(layout, theta, u, x0, box) + 0.01 * rng.normal(size=(n_samples, 1))
    limits = (np.full(1, -50.0), np.full(1, 50.0))
    return FreeRunProblem(layout, [(u, np.ascontiguousarray(y), x0)], box, limits), theta, u, x0


def test_compiled_free_run_equals_the_numpy_reference() -> None:
    problem, theta, u, x0 = _problem()
    expected = _reference_run(problem.layout, theta, u, x0, problem.box)
    y = problem.experiments[0][1]
    np.testing.assert_allclose(problem.run(theta) + y.ravel(), expected.ravel(), atol=1e-12)


def test_exact_jacobian_equals_finite_differences() -> None:
    problem, theta, _, _ = _problem(1)
    free = theta[problem.free] * 1.3  # away from the data-generating point
    jacobian = problem.jacobian(free)
    numeric = np.empty_like(jacobian)
    for q in range(free.size):
        step = 1e-6 * max(1.0, abs(free[q]))
        up, down = free.copy(), free.copy()
        up[q] += step
        down[q] -= step
        numeric[:, q] = (problem.residuals(up) - problem.residuals(down)) / (2 * step)
    np.testing.assert_allclose(jacobian, numeric, rtol=1e-5, atol=1e-7)


def _known_pnlss(n_samples: int, seed: int) -> IOData:
    """Two states, one quadratic term (``x1 u``) in the state equation, output the first state.

    A bilinear term: the model has no constant in its state equation, so a quadratic term in a
    state alone would need the state coordinates of the truth exactly (see docs/pnlss.md).
    """
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1.0, 1.0, n_samples)
    x = np.zeros(2)
    y = np.zeros(n_samples)
    for t in range(n_samples):
        y[t] = x[0]
        x = np.array(
            [0.7 * x[0] + 0.3 * x[1] + 0.5 * u[t], -0.2 * x[0] + 0.4 * x[1] + 0.6 * x[0] * u[t]]
        )
    return IOData(u, y, ts=0.01)


def test_the_fit_recovers_the_free_run_of_a_known_pnlss() -> None:
    train, test = _known_pnlss(1500, 0), _known_pnlss(800, 1)
    linear = neckid.methods()["ss"].make(None, order=2).fit(train)
    model = PolynomialStateSpace(order=2, degree=2, max_iter=60).fit(train)
    assert model.fit_report_["improved"]
    fit = model.fit_percent(test)[0]
    assert fit > 99.0, fit
    assert fit > linear.fit_percent(test)[0] + 1.0  # the quadratic term is what it found


def test_a_diverging_start_is_refused_and_the_model_left_as_it_was() -> None:
    data = _known_pnlss(600, 2)
    model = PolynomialStateSpace(order=2, degree=2, max_iter=5).fit(data)
    model.A_ = np.ascontiguousarray(model.A_ * 3.0)  # an unstable linear part
    before = copy.deepcopy(model.A_)
    with pytest.raises(ValueError, match="leaves the divergence envelope"):
        model.partial_fit(data)
    np.testing.assert_array_equal(model.A_, before)


def test_trial_steps_that_run_away_get_a_large_finite_error() -> None:
    problem, theta, _, _ = _problem(2)
    unstable = theta.copy()
    unstable[:4] *= 4.0  # A: spectral radius > 1
    errors = problem.run(unstable)
    assert np.all(np.isfinite(errors)) and problem.diverged == 1
    assert np.max(np.abs(errors)) > 40.0  # held at the limit (50) from where it left


def test_save_load_round_trip(tmp_path) -> None:
    data = _known_pnlss(600, 3)
    model = PolynomialStateSpace(order=2, degree=3, max_iter=10).fit(data)
    loaded = neckid.load_model(model.save(tmp_path / "pnlss"))
    assert type(loaded) is PolynomialStateSpace
    assert loaded.get_params() == model.get_params()
    np.testing.assert_array_equal(loaded.simulate(data).y, model.simulate(data).y)
    assert neckid.registry.method_of(model).name == "pnlss"


def test_to_control_is_the_model_linearised_at_rest_as_a_state_space() -> None:
    """The pnlss entry's form is "ss": the exact Jacobian at the equilibrium with mid-range inputs
    reproduces the model's response to small deviations (to second order in their size)."""
    import control

    from neckid.export.control import to_control
    from neckid.models.pnlss.linearise import linearise

    model = PolynomialStateSpace(order=2, degree=2, max_iter=20).fit(_known_pnlss(600, 0))
    system = to_control(model)
    assert isinstance(system, control.StateSpace) and system.state_labels == ["x1", "x2"]
    assert neckid.methods()["pnlss"].control_form == "ss"
    rest = linearise(model)
    x = rest.state.copy()
    np.testing.assert_allclose(model.run(rest.inputs[None, :], x)[0], rest.outputs, atol=1e-9)
    np.testing.assert_allclose(x, rest.state, atol=1e-9)  # a fixed point of the state equation
    rng = np.random.default_rng(3)
    for size in (1e-3, 1e-4):
        du = size * model.u_scale_ * rng.uniform(-1.0, 1.0, (200, 1))
        y = model.run(rest.inputs + du, rest.state.copy()) - rest.outputs
        linear = control.forced_response(system, U=du.T, X0=np.zeros(2)).outputs
        error = np.max(np.abs(y[:, 0] - linear))
        assert error < 1e-2 * np.max(np.abs(linear)) * (size / 1e-3) ** 2 + 1e-12
    with pytest.raises(ValueError, match="inclination applies"):
        to_control(model, inclination=10.0)
