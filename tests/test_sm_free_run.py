"""The compiled Set Membership free run: the screened walk gives the exact-box walk's floats.

The free run evaluates both optimal bounds at every step by the screened walk of
``priors.walk_priors`` (one global prior). The reference here steps ``tree.query_one``, the
exact-box branch and bound, from Python on the same tree: every simulated output and every
bound must be the same float, on data full of ties (quantised signals), on two outputs, on
the model's own tree and on the same points split in their principal frame.
"""

from __future__ import annotations

import numpy as np
import pytest

from neckid import IOData, Lags
from neckid.models.set_membership._kernels import SMTree
from neckid.models.set_membership._kernels.free_run import free_run
from neckid.models.set_membership._kernels.tree import STACK_DEPTH, query_one
from neckid.models.set_membership.narx import SetMembership


def _quantised_system(n: int, seed: int) -> IOData:
    """Two coupled outputs of a quantised input: many equal regressors and targets."""
    rng = np.random.default_rng(seed)
    u = np.round(rng.uniform(-1, 1, size=(n, 2)) * 4) / 4
    y = np.zeros((n, 2))
    for t in range(2, n):
        y[t, 0] = 0.5 * y[t - 1, 0] - 0.2 * y[t - 2, 1] + np.tanh(2 * u[t - 1, 0])
        y[t, 1] = 0.4 * y[t - 1, 1] + 0.3 * u[t - 1, 1] ** 2 - 0.1 * y[t - 1, 0]
    y = np.round(y * 64) / 64
    return IOData(u, y, ts=0.01)


def _reference_run(
    tree: SMTree, model: SetMembership, data: IOData
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The free run stepped in Python with ``query_one`` (the exact-box walk)."""
    lags, core = model.lags_, model.core_
    m = int(lags.max_lag)
    y = np.array(data.y, dtype=np.float64)
    lower = np.full(y.shape, np.nan)
    upper = np.full(y.shape, np.nan)
    node_stack = np.empty(STACK_DEPTH, np.int64)
    dist_stack = np.empty(STACK_DEPTH)
    no_points = np.empty((0, y.shape[1]))
    arrays = tree.kernel_arrays()
    for t in range(m, data.n_samples):
        w = np.array(
            [
                y[t - k, c] if s == 0 else data.u[t - k, c]
                for s, c, k in zip(lags.source, lags.channel, lags.lag, strict=True)
            ]
        )
        ws = w * core.weights
        for c in range(y.shape[1]):
            linear = float(core.intercept[c])
            for k in range(w.shape[0]):
                linear += float(w[k] * core.coef[k, c])
            low, high = query_one(
                ws, arrays[0], arrays[1], c, float(core.gamma[c]), *arrays[2:], node_stack,
                dist_stack, no_points,
            )  # fmt: skip
            f_lower, f_upper = low - core.epsilon[c], high + core.epsilon[c]
            lower[t, c] = linear + f_lower
            upper[t, c] = linear + f_upper
            y[t, c] = linear + 0.5 * (f_lower + f_upper)
    return y, lower, upper


@pytest.mark.parametrize("seed", [0, 1])
def test_free_run_is_the_exact_walk_bit_for_bit(seed: int) -> None:
    data = _quantised_system(900, seed)
    lags = Lags(outputs=[1, 2, 3], inputs=[0, 1, 2, 3])  # 2·3 + 2·4 = 14 terms
    model = SetMembership(lags, epsilon=0.02).fit(data[:700])
    test = data[700:]
    core = model.core_
    framed = SMTree(core.tree.points.copy(), core.tree.targets.copy(), frame=True)
    assert framed.framed and not core.tree.framed
    expected = _reference_run(core.tree, model, test)
    resolved = model.lags_
    for tree in (core.tree, framed):
        got = free_run(
            tree,
            test.u,
            test.y,
            resolved.source,
            resolved.channel,
            resolved.lag,
            resolved.max_lag,
            core.weights,
            core.coef,
            core.intercept,
            core.epsilon,
            core.gamma,
        )
        for a, b in zip(got, expected, strict=True):
            np.testing.assert_array_equal(a, b)
    # and the estimator's own simulate is that run
    sim = model.simulate(test)
    np.testing.assert_array_equal(sim.y, expected[0])
    np.testing.assert_array_equal(sim.lower, expected[1])
    np.testing.assert_array_equal(sim.upper, expected[2])


def test_free_run_of_a_one_point_tree() -> None:
    """A tree of one leaf (every query prunes nothing): the same floats as the reference."""
    data = _quantised_system(40, 3)
    model = SetMembership(Lags(outputs=[1], inputs=[0]), epsilon=0.05).fit(data[:12])
    test = data[12:]
    expected = _reference_run(model.core_.tree, model, test)
    sim = model.simulate(test)
    np.testing.assert_array_equal(sim.y, expected[0])
    np.testing.assert_array_equal(sim.upper, expected[2])
