"""The default ε rule at scale (issue 33): the knee search against the walk over the whole curve.

``SetMembership().fit`` with ε and γ not given takes ε at the knee of γ*(ε) and γ = 1.1 γ*(ε).
From ``KNEE_SEARCH_MIN_ROWS`` rows on it runs
:func:`~neckid.models.set_membership.prior.knee_search`, which computes γ*(ε) exactly only on the
grid's first values, as far as the knee needs; the walk computes it on the whole grid (the rule
before, and still the fit's when the default grid is given as ``epsilons``). Both must give the
same ε and γ, bit for bit: here on synthetic logs (above ``KNEE_SEARCH_MIN_ROWS``, the production
settings) and on the soft-neck logs and public benchmarks (the estimator's own choice, and the
search run on its tree with a small subsample, against the whole curve on the same tree).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import neckid.models.set_membership.prior as prior
from neckid import IOData, Lags
from neckid.models.set_membership._kernels import SMTree
from neckid.models.set_membership._kernels.gamma import gamma_star
from neckid.models.set_membership.narx import SetMembership, gamma_curve
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


def whole_curve(model: SetMembership) -> GammaCurve:
    """γ*(ε) over the whole default grid, on the fitted model's own tree (the walk).

    Through the active cache of γ*(ε) values: the fit's exact values are taken from it (each
    exact, whatever else was in its grid), the rest of the grid is computed.
    """
    tree = model._tree
    grid = prior._default_epsilons(tree.targets)
    values = prior._gamma_star(tree.points, tree.targets, grid, False, tree)
    return GammaCurve(grid, values, model.output_names_, tree.points.shape[0])


def assert_prefix_of(part: GammaCurve, full: GammaCurve) -> None:
    """``part`` is ``full``'s first rows, bit for bit, and has the same knee."""
    rows = part.epsilons.shape[0]
    np.testing.assert_array_equal(part.epsilons, full.epsilons[:rows])
    np.testing.assert_array_equal(part.gamma, full.gamma[:rows])
    np.testing.assert_array_equal(part.knee(), full.knee())
    assert part.n_samples == full.n_samples


def assert_same_choice(walk: SetMembership, search: SetMembership) -> None:
    np.testing.assert_array_equal(search.epsilon_, walk.epsilon_)
    np.testing.assert_array_equal(search.gamma_, walk.gamma_)
    assert_prefix_of(search.gamma_curve_, walk.gamma_curve_)


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
    data: IOData, lags: Lags, partial: bool
) -> None:
    # production settings: above KNEE_SEARCH_MIN_ROWS the default fit searches
    assert data.n_samples > prior.KNEE_SEARCH_MIN_ROWS
    search = SetMembership(lags, progress=False).fit(data)
    # the walk: the same fit with the default grid given, whose curve is computed whole
    grid = prior._default_epsilons(search._tree.targets)
    walk = SetMembership(lags, epsilons=grid, progress=False).fit(data)
    assert walk.gamma_curve_.epsilons.shape[0] == prior.DEFAULT_GRID_POINTS
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
    name: str, lags: Lags, linear_part: bool
) -> None:
    train = _shared(name)
    weight = 0.1 if linear_part else 1.0
    model = SetMembership(lags, linear_part=linear_part, input_weight=weight, progress=False)
    try:
        model.fit(train)
    except ValueError as error:  # the knee rule fails on this one: it must fail the walk too
        assert "infinite over the whole" in str(error)
        curve = gamma_curve(train, lags, linear_part=linear_part, input_weight=weight)
        with pytest.raises(ValueError, match="infinite over the whole"):
            curve.knee()
        return
    full = whole_curve(model)
    # the estimator's choice (the search above KNEE_SEARCH_MIN_ROWS rows, the walk below)
    assert_prefix_of(model.gamma_curve_, full)
    np.testing.assert_array_equal(model.epsilon_, full.knee())
    at_knee = [
        full.gamma[np.flatnonzero(full.epsilons[:, c] == model.epsilon_[c])[0], c]
        for c in range(model.n_outputs_)
    ]
    np.testing.assert_array_equal(model.gamma_, 1.1 * np.array(at_knee))
    # the search on these small records, forced with a subsample of 500 rows
    searched = knee_search(
        model._tree, full.epsilons, progress=False, subsample=500, output_names=full.output_names
    )
    assert_prefix_of(searched, full)


def test_knee_search_returns_a_prefix_whose_knee_is_the_walks() -> None:
    data = held_input(25_001, seed=3)
    x, y = Lags(outputs=[1], inputs=[1]).build(data)
    points = x / x.std(axis=0)
    tree = SMTree(points, y, 8)
    grid = prior._default_epsilons(tree.targets)
    curve = knee_search(tree, grid, progress=False, output_names=("y",))
    whole = gamma_star(tree.points, tree.targets, grid, tree=tree)
    rows = curve.epsilons.shape[0]
    assert rows < grid.shape[0]
    assert_prefix_of(curve, GammaCurve(grid, whole, ("y",), tree.points.shape[0]))
    assert choose_epsilon(grid[:, 0], whole[:, 0]) + prior.SLOPE_WINDOW + prior.KNEE_MARGIN < rows


def test_small_data_and_given_grids_walk_the_whole_curve() -> None:
    data = held_input(3_001)
    model = SetMembership(Lags(outputs=[1], inputs=[1]), progress=False).fit(data)
    assert model.gamma_curve_.epsilons.shape[0] == prior.DEFAULT_GRID_POINTS
    grid = np.linspace(0.0, 0.05, 12)
    model = SetMembership(Lags(outputs=[1], inputs=[1]), epsilons=grid, progress=False)
    assert model.fit(data).gamma_curve_.epsilons.shape[0] == grid.size


def test_the_subsample_rows_are_every_kth_in_time() -> None:
    rng = np.random.default_rng(5)
    tree = SMTree(rng.normal(size=(70_001, 2)), rng.normal(size=(70_001, 1)), 8)
    rows = prior._subsample_rows(tree, 5_000)
    stride = -(-70_001 // 5_000)
    np.testing.assert_array_equal(tree.perm[rows], np.arange(0, 70_001, stride))


def test_the_default_fit_peaks_below_100_bytes_per_sample_at_six_terms() -> None:
    import tracemalloc

    from neckid.models.cache import use_caches

    lags = Lags(outputs=2, inputs=[1, 2])  # six terms: the raw regressor is 48 B/sample
    data = smooth(60_004, seed=2)
    with use_caches(gamma_curves=None):
        SetMembership(lags, progress=False).fit(data[:25_000])  # load the compiled kernels
        tracemalloc.start()
        try:
            start = tracemalloc.get_traced_memory()[0]
            model = SetMembership(lags, progress=False).fit(data)
            kept, peak = (v - start for v in tracemalloc.get_traced_memory())
        finally:
            tracemalloc.stop()
    rows = model.n_samples_
    assert model.gamma_curve_.n_samples == rows > prior.KNEE_SEARCH_MIN_ROWS  # the search ran
    # the points (48), targets (8), permutation (8) and nodes (about 19) are kept; the outputs
    # are not copied, the duplicate check takes 4 B/sample, the search about 1 MB in all
    assert kept / rows < 92, kept / rows
    assert peak / rows < 100, peak / rows
