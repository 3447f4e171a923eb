"""The default ε rule at scale (issue 33): the knee search against the walk over the whole curve.

``SetMembership().fit`` with ε and γ not given takes ε at the knee of γ*(ε) and γ = 1.1 γ*(ε).
:func:`~neckid.models.set_membership.prior.knee_search` computes γ*(ε) exactly only on the grid's
first values, as far as the knee needs (``KNEE_METHOD = "search"``, the default); the walk
computes it on the whole grid (``"walk"``, the rule before). Both must give the same ε and γ, bit
for bit: here on synthetic logs (above ``KNEE_SEARCH_MIN_ROWS``, the production settings) and on
the soft-neck logs and public benchmarks (small: the search is forced with a small subsample).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import neckid.models.set_membership.prior as prior
from neckid import IOData, Lags
from neckid.models.set_membership._kernels.gamma import gamma_star
from neckid.models.set_membership.narx import SetMembership
from neckid.models.set_membership.prior import GammaCurve, choose_epsilon, knee_search

#: The shared data folder, beside the repository (``../shared/data`` from its root).
SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def held_input(n: int, seed: int = 0, hold: int = 20) -> IOData:
    """A first-order saturating plant whose input is held for ``hold`` samples at a time."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n // hold + 1).repeat(hold)[:n]
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.9 * y[t - 1] + 0.1 * np.tanh(2 * u[t - 1]) + 0.02 * u[t - 1] * abs(y[t - 1])
    return IOData(u[:, None], y + rng.uniform(-1e-3, 1e-3, n), ts=0.02)


def smooth(n: int, seed: int = 1) -> IOData:
    """Two smoothed random-step inputs into a second-order output (a neck-like log)."""
    rng = np.random.default_rng(seed)
    steps = rng.uniform(-1, 1, size=(n // 25 + 1, 2)).repeat(25, axis=0)[:n]
    u = np.empty_like(steps)
    u[0] = steps[0]
    for t in range(1, n):
        u[t] = 0.9 * u[t - 1] + 0.1 * steps[t]
    y = np.zeros(n)
    for t in range(3, n):
        y[t] = (
            1.6 * y[t - 1]
            - 0.7 * y[t - 2]
            + 0.08 * np.tanh(2.0 * (u[t - 2, 0] - 0.5 * u[t - 2, 1]))
            + rng.uniform(-1e-3, 1e-3)
        )
    return IOData(u, y, ts=0.02)


def both_ways(monkeypatch: pytest.MonkeyPatch, make, data) -> tuple[SetMembership, SetMembership]:
    """The default fit with the walk, then with the search (same settings otherwise)."""
    fits = []
    for method in ("walk", "search"):
        monkeypatch.setattr(prior, "KNEE_METHOD", method)
        fits.append(make().fit(data))
    return fits[0], fits[1]


def assert_same_choice(walk: SetMembership, search: SetMembership) -> None:
    np.testing.assert_array_equal(search.epsilon_, walk.epsilon_)
    np.testing.assert_array_equal(search.gamma_, walk.gamma_)
    # the partial curve is the whole one's first rows, bit for bit, and its knee the same
    full, part = walk.gamma_curve_, search.gamma_curve_
    rows = part.epsilons.shape[0]
    np.testing.assert_array_equal(part.epsilons, full.epsilons[:rows])
    np.testing.assert_array_equal(part.gamma, full.gamma[:rows])
    np.testing.assert_array_equal(part.knee(), full.knee())
    assert part.n_samples == full.n_samples


@pytest.mark.parametrize(
    ("data", "lags", "partial"),
    [
        (held_input(30_001), Lags(outputs=[1], inputs=[1]), True),
        (smooth(30_003), Lags(outputs=3, inputs=[2]), True),
        (smooth(25_004, seed=4), Lags(outputs=2, inputs=[1, 2]), False),
    ],
    ids=["held-input", "smooth-5-terms", "smooth-6-terms"],
)
def test_the_search_chooses_as_the_walk_on_synthetic_logs(
    monkeypatch: pytest.MonkeyPatch, data: IOData, lags: Lags, partial: bool
) -> None:
    # production settings: above KNEE_SEARCH_MIN_ROWS the default fit searches
    assert data.n_samples > prior.KNEE_SEARCH_MIN_ROWS
    walk, search = both_ways(monkeypatch, lambda: SetMembership(lags, progress=False), data)
    assert_same_choice(walk, search)
    # (a knee high on the grid, or one the subsample cannot vouch for, takes the whole curve)
    assert (search.gamma_curve_.epsilons.shape[0] < prior.DEFAULT_GRID_POINTS) == partial


def _shared(name: str):
    from neckid.experiments.benchmark.datasets import load_benchmark

    bench = load_benchmark(name, SHARED_DATA)
    if bench is None:
        pytest.skip(f"data set {name} is not under {SHARED_DATA}")
    return bench.train


@pytest.mark.parametrize(
    ("name", "lags"),
    [
        ("softneck", Lags.arx(2, 2, 1)),
        ("softneck", Lags.arx(1, 1, 0)),
        ("softneck-payload", Lags(outputs=[1, 2], inputs=[1, 2], conditions=["payload"])),
        ("softneck-controller", Lags(outputs=[1], inputs=[1], conditions=["payload"])),
        ("cascaded_tanks", Lags.arx(3, 3, 1)),
        ("robot_arm", Lags.arx(2, 2, 1)),
        ("bouc_wen", Lags.arx(5, 5, 0)),
        ("silverbox", Lags.arx(2, 3, 0)),
    ],
)
@pytest.mark.parametrize("linear_part", [False, True], ids=["sm", "sm-linear"])
def test_the_search_chooses_as_the_walk_on_the_shared_data(
    monkeypatch: pytest.MonkeyPatch, name: str, lags: Lags, linear_part: bool
) -> None:
    train = _shared(name)
    # the records are small: force the search, with a subsample of 500 rows
    monkeypatch.setattr(prior, "KNEE_SEARCH_MIN_ROWS", 0)
    monkeypatch.setattr(prior, "KNEE_SUBSAMPLE", 500)
    weight = 0.1 if linear_part else 1.0

    def make() -> SetMembership:
        return SetMembership(lags, linear_part=linear_part, input_weight=weight, progress=False)

    try:
        walk, search = both_ways(monkeypatch, make, train)
    except ValueError as error:  # the knee rule fails on this one: it must fail both ways
        monkeypatch.setattr(prior, "KNEE_METHOD", "search")
        with pytest.raises(ValueError, match="infinite over the whole"):
            make().fit(train)
        assert "infinite over the whole" in str(error)
        return
    assert_same_choice(walk, search)


def test_knee_search_returns_a_prefix_whose_knee_is_the_walks() -> None:
    data = held_input(40_001, seed=3)
    x, y = Lags(outputs=[1], inputs=[1]).build(data)
    points = x / x.std(axis=0)
    from neckid.models.set_membership._kernels import SMTree

    tree = SMTree(points, y, 8)
    grid = prior._default_epsilons(tree.targets)
    curve = knee_search(tree, grid, progress=False, output_names=("y",))
    whole = gamma_star(tree.points, tree.targets, grid, tree=tree)
    rows = curve.epsilons.shape[0]
    assert rows < grid.shape[0]
    np.testing.assert_array_equal(curve.gamma, whole[:rows])
    full = GammaCurve(grid, whole, ("y",), tree.points.shape[0])
    np.testing.assert_array_equal(curve.knee(), full.knee())
    assert choose_epsilon(grid[:, 0], whole[:, 0]) + prior.SLOPE_WINDOW + prior.KNEE_MARGIN < rows


def test_small_data_and_given_grids_walk_the_whole_curve() -> None:
    data = held_input(3_001)
    model = SetMembership(Lags(outputs=[1], inputs=[1]), progress=False).fit(data)
    assert model.gamma_curve_.epsilons.shape[0] == prior.DEFAULT_GRID_POINTS
    grid = np.linspace(0.0, 0.05, 12)
    model = SetMembership(Lags(outputs=[1], inputs=[1]), epsilons=grid, progress=False)
    assert model.fit(data).gamma_curve_.epsilons.shape[0] == grid.size
