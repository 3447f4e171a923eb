"""Levenberg–Marquardt on LAPACK's QR against MINPACK's lmder (scipy's method="lm")."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from scipy.optimize import least_squares

from neckid.models.levenberg import levenberg_marquardt

Problem = tuple[Callable[[np.ndarray], np.ndarray], Callable[[np.ndarray], np.ndarray], np.ndarray]

#: MINPACK's info for scipy's common status (scipy maps info 4 -> 1, 1 -> 2, 2 -> 3, 3 -> 4).
SCIPY_STATUS = {0: 5, 1: 4, 2: 1, 3: 2, 4: 3}


def _two_exponentials() -> Problem:
    rng = np.random.default_rng(1)
    t = np.linspace(0, 4, 200)
    y = 2 * np.exp(-1.3 * t) + 0.5 * np.exp(-0.2 * t) + 0.01 * rng.standard_normal(t.size)

    def fun(p: np.ndarray) -> np.ndarray:
        return p[0] * np.exp(-p[1] * t) + p[2] * np.exp(-p[3] * t) - y

    def jac(p: np.ndarray) -> np.ndarray:
        e1, e3 = np.exp(-p[1] * t), np.exp(-p[3] * t)
        return np.column_stack([e1, -p[0] * t * e1, e3, -p[2] * t * e3])

    return fun, jac, np.array([1.0, 1.0, 1.0, 0.1])


def _rosenbrock() -> Problem:
    def fun(p: np.ndarray) -> np.ndarray:
        return np.array([10 * (p[1] - p[0] ** 2), 1 - p[0]])

    def jac(p: np.ndarray) -> np.ndarray:
        return np.array([[-20 * p[0], 10.0], [-1.0, 0.0]])

    return fun, jac, np.array([-1.2, 1.0])


def _network() -> Problem:
    """A 3-5-1 tanh network fitted to another one: badly scaled, many iterations."""
    rng = np.random.default_rng(2)
    x = rng.standard_normal((400, 3))
    y = np.tanh(x @ rng.standard_normal((3, 5))) @ rng.standard_normal(5)

    def fun(p: np.ndarray) -> np.ndarray:
        return np.tanh(x @ p[:15].reshape(3, 5)) @ p[15:] - y

    def jac(p: np.ndarray) -> np.ndarray:
        hidden = np.tanh(x @ p[:15].reshape(3, 5))
        slope = (1 - hidden**2) * p[15:]
        return np.column_stack([(x[:, :, None] * slope[:, None, :]).reshape(len(x), 15), hidden])

    return fun, jac, 0.5 * rng.standard_normal(20)


def _with_a_dead_column() -> Problem:
    """A parameter the residuals do not depend on: the Jacobian is rank deficient."""
    fun0, jac0, x0 = _two_exponentials()
    return (
        lambda p: fun0(p[:4]),
        lambda p: np.column_stack([jac0(p[:4]), np.zeros(200)]),
        np.append(x0, 3.0),
    )


PROBLEMS = {
    "two exponentials": _two_exponentials,
    "rosenbrock": _rosenbrock,
    "network": _network,
    "dead column": _with_a_dead_column,
}


@pytest.mark.parametrize("name", sorted(PROBLEMS))
@pytest.mark.parametrize("budget", [3, 12, 200])
def test_it_takes_minpacks_steps(name: str, budget: int) -> None:
    fun, jac, x0 = PROBLEMS[name]()
    reference = least_squares(fun, x0, jac=jac, method="lm", x_scale="jac", max_nfev=budget)
    result = levenberg_marquardt(fun, x0, jac, max_nfev=budget)
    assert result.nfev == reference.nfev
    assert result.status == SCIPY_STATUS[reference.status]
    scale = max(1.0, float(np.max(np.abs(reference.x))))
    # the network's 200 evaluations let rounding differences grow; the others stay at rounding
    tolerance = 1e-6 if (name == "network" and budget == 200) else 1e-10
    np.testing.assert_allclose(result.x, reference.x, rtol=0, atol=tolerance * scale)
    start_cost = 0.5 * float(fun(x0) @ fun(x0))
    assert result.cost == pytest.approx(reference.cost, rel=1e-8, abs=1e-20 * start_cost)
    np.testing.assert_array_equal(result.fun, fun(result.x))


def test_the_start_it_is_given_is_not_evaluated_again() -> None:
    fun, jac, x0 = _two_exponentials()
    calls: list[np.ndarray] = []

    def counted(p: np.ndarray) -> np.ndarray:
        calls.append(p.copy())
        return fun(p)

    given = levenberg_marquardt(counted, x0, jac, max_nfev=50, f0=fun(x0))
    assert len(calls) == given.nfev - 1
    assert not any(np.array_equal(c, x0) for c in calls)
    np.testing.assert_array_equal(given.x, levenberg_marquardt(fun, x0, jac, max_nfev=50).x)


def test_it_stops_at_the_budget_and_never_ends_worse_than_the_start() -> None:
    fun, jac, x0 = _network()
    start_cost = 0.5 * float(fun(x0) @ fun(x0))
    for budget in (1, 2, 7):
        result = levenberg_marquardt(fun, x0, jac, max_nfev=budget)
        assert result.nfev <= max(budget, 2)  # as MINPACK, one trial step is always taken
        assert result.cost <= start_cost
    assert levenberg_marquardt(fun, x0, jac, max_nfev=7).status == 5


def test_an_exact_fit_stops_on_the_gradient_test() -> None:
    a = np.random.default_rng(3).standard_normal((30, 4))
    b = a @ np.array([1.0, -2.0, 0.5, 3.0])
    result = levenberg_marquardt(lambda p: a @ p - b, np.zeros(4), lambda p: a, max_nfev=100)
    np.testing.assert_allclose(result.x, [1.0, -2.0, 0.5, 3.0], atol=1e-12)
    assert result.status in (2, 4)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"max_nfev": 0}, "max_nfev must be at least 1; got 0"),
        ({"max_nfev": 5, "f0": np.zeros(1)}, "at least as many residuals as variables; got 1 < 2"),
    ],
)
def test_bad_arguments_are_refused(kwargs: dict[str, object], match: str) -> None:
    fun, jac, x0 = _two_exponentials()
    with pytest.raises(ValueError, match=match):
        levenberg_marquardt(fun, x0[:2], jac, **kwargs)  # type: ignore[arg-type]


def test_a_jacobian_of_the_wrong_shape_is_refused() -> None:
    fun, jac, x0 = _two_exponentials()
    with pytest.raises(ValueError, match=r"the Jacobian has shape \(200, 3\); expected \(200, 4\)"):
        levenberg_marquardt(fun, x0, lambda p: jac(p)[:, :3], max_nfev=5)


def test_fewer_residuals_than_variables_go_to_the_trust_region_with_the_start_given() -> None:
    from neckid.models.levenberg import fit_least_squares

    a = np.random.default_rng(5).standard_normal((3, 6))
    b = np.array([1.0, -1.0, 2.0])
    calls: list[np.ndarray] = []

    def fun(p: np.ndarray) -> np.ndarray:
        calls.append(p.copy())
        return a @ p - b

    x0 = np.zeros(6)
    result = fit_least_squares(fun, x0, lambda p: a, max_nfev=50, f0=a @ x0 - b)
    reference = least_squares(
        lambda p: a @ p - b, x0, jac=lambda p: a, method="trf", x_scale="jac", max_nfev=50
    )
    np.testing.assert_allclose(result.x, reference.x, atol=1e-12)
    assert result.nfev == reference.nfev == len(calls) + 1
    assert result.status == SCIPY_STATUS[reference.status]
    assert result.cost == pytest.approx(reference.cost, rel=1e-6, abs=1e-15) and result.cost < 1e-15


def test_enough_residuals_go_to_levenberg_marquardt() -> None:
    from neckid.models.levenberg import fit_least_squares

    fun, jac, x0 = _two_exponentials()
    given = fit_least_squares(fun, x0, jac, max_nfev=30, f0=fun(x0))
    np.testing.assert_array_equal(given.x, levenberg_marquardt(fun, x0, jac, max_nfev=30).x)
