"""The grey-box neck (``greybox-neck``, :class:`~neckid.models.greybox.GreyBoxNeck`).

Analytic behaviour of the play operator, the stable parametrisation of the dynamics, recovery
of the slack width and the dynamics on data made by the model itself, files, and the refusal
of a candidate whose free run diverges.
"""

from __future__ import annotations

import numpy as np
import pytest

import neckid
from neckid import IOData
from neckid.models.greybox import GreyBoxNeck
from neckid.models.greybox.fitting import Problem, free_run_error
from neckid.models.greybox.hysteresis import denominator, play, reflection

TS = 0.025


def test_play_follows_after_the_gap_and_holds_inside_it() -> None:
    # Up from 0 to 2, back to 0: a play of radius 0.5 lags by 0.5 on the way up, holds for a
    # reversal of 1 (the width), then lags by 0.5 on the way down.
    x = np.concatenate([np.linspace(0, 2, 21), np.linspace(2, 0, 21)[1:]])
    z = play(x, [0.5])[:, 0]
    np.testing.assert_allclose(z[5:21], x[5:21] - 0.5, atol=1e-12)
    down = x[21:]
    held = down >= 1.0 - 1e-12
    np.testing.assert_allclose(z[21:][held], 1.5, atol=1e-12)
    np.testing.assert_allclose(z[21:][~held], down[~held] + 0.5, atol=1e-12)
    assert np.all(np.abs(z - x) <= 0.5 + 1e-12)


def test_a_periodic_input_draws_a_closed_loop_of_the_play_width() -> None:
    t = np.arange(400) * TS
    x = np.sin(2 * np.pi * t)
    for radius in (0.1, 0.3):
        z = play(x, [radius])[:, 0]
        last, before = z[-40:], z[-80:-40]  # one period is 40 samples: the loop closes
        np.testing.assert_allclose(last, before, atol=1e-12)
        at_zero = np.isclose(x[-40:], 0.0, atol=1e-9)
        # Crossing x = 0 upwards and downwards: z = -r and z = +r, a loop of width 2 r.
        assert np.ptp(last[at_zero]) == pytest.approx(2 * radius, abs=1e-9)


def test_plays_compose_as_a_semigroup() -> None:
    x = np.random.default_rng(0).normal(size=300).cumsum()
    np.testing.assert_allclose(
        play(play(x, [0.4])[:, 0], [0.7]), play(x, [1.1]), rtol=0, atol=1e-12
    )


def test_play_refuses_a_negative_radius() -> None:
    with pytest.raises(ValueError, match="radii must be finite and >= 0"):
        play([0.0, 1.0], [-0.1])


@pytest.mark.parametrize("coefficients", [[0.3], [-0.99], [-0.9, 0.8], [0.999, -0.999]])
def test_reflection_coefficients_give_stable_poles_and_round_trip(coefficients) -> None:
    a = denominator(coefficients)
    assert np.all(np.abs(np.roots(a)) < 1.0)
    np.testing.assert_allclose(reflection(a, bound=1.0), coefficients, atol=1e-12)


def _made_by_the_model(slack: float, seed: int, n: int = 1200) -> tuple[IOData, GreyBoxNeck]:
    """A record of a known grey box: slack ``slack``, poles 0.9 ± 0.2j, one play, gain 10."""
    rng = np.random.default_rng(seed)
    x = np.repeat(rng.uniform(0.0, 2.0, n // 40), 40)
    truth = GreyBoxNeck(order=2, delay=1, n_play=1)
    truth.slack_ = np.array([slack])
    truth.radii_ = np.zeros((1, 1))
    truth.reflection_ = reflection(np.poly([0.9 + 0.2j, 0.9 - 0.2j]).real)[None, :]
    truth.mode_radius_ = 1.0
    truth.weights_ = np.array([[10.0, 1.0]])
    truth.n_conditions_, truth.train_mse_, truth.n_samples_ = 0, 0.0, n
    truth._set_channels(IOData(x, np.zeros(n), ts=TS))
    truth.max_lag_ = 2
    y = truth.simulate(IOData(x, np.ones(n), ts=TS)).y[:, 0]
    return IOData(x, y + 0.01 * rng.normal(size=n), ts=TS), truth


def test_recovers_the_slack_width_and_the_dynamics() -> None:
    data, truth = _made_by_the_model(slack=0.3, seed=1)
    model = GreyBoxNeck(order=2, n_play=1, max_iter=40).fit(data)
    assert model.slack_[0] == pytest.approx(0.3, abs=0.02)
    np.testing.assert_allclose(
        np.sort_complex(np.roots(model.denominators_[0])),
        np.sort_complex(np.roots(truth.denominators_[0])),
        atol=0.02,
    )
    np.testing.assert_allclose(model.weights_[0], truth.weights_[0], rtol=0.05, atol=0.05)
    test, _ = _made_by_the_model(slack=0.3, seed=2)
    assert model.fit_percent(test)[0] > 98.0


def test_a_linear_model_cannot_fit_the_slack_the_grey_box_can() -> None:
    data, _ = _made_by_the_model(slack=0.6, seed=3)
    test, _ = _made_by_the_model(slack=0.6, seed=4)
    arx = neckid.LinearARX(neckid.Lags.arx(2, 2, 1)).fit(data)
    grey = GreyBoxNeck(order=2, n_play=1, max_iter=40).fit(data)
    assert grey.fit_percent(test)[0] > arx.fit_percent(test)[0] + 5.0


def test_every_pole_settles_within_the_records() -> None:
    # By default no pole is slower than a fifth of the longest record: with unit static gain a
    # slower one would integrate the operators' output, and its weights would grow to match.
    data, _ = _made_by_the_model(slack=0.2, seed=8, n=600)
    model = GreyBoxNeck(n_play=1, max_iter=10).fit(data)
    assert model.mode_radius_ == pytest.approx(np.exp(-5.0 / 600))
    assert np.max(np.abs(np.roots(model.denominators_[0]))) <= model.mode_radius_ + 1e-12
    given = GreyBoxNeck(n_play=1, max_iter=10, max_time_constant=0.1).fit(data)
    assert given.mode_radius_ == pytest.approx(np.exp(-TS / 0.1))
    assert np.max(np.abs(np.roots(given.denominators_[0]))) <= given.mode_radius_ + 1e-12


def test_save_load_gives_the_same_free_run(tmp_path) -> None:
    data, _ = _made_by_the_model(slack=0.2, seed=5, n=400)
    model = GreyBoxNeck(n_play=3, max_iter=10).fit(data)
    loaded = neckid.load_model(model.save(tmp_path / "grey"))
    np.testing.assert_array_equal(loaded.simulate(data).y, model.simulate(data).y)
    np.testing.assert_array_equal(loaded.slack_, model.slack_)


def test_a_loaded_file_with_an_unstable_pole_is_refused(tmp_path) -> None:
    data, _ = _made_by_the_model(slack=0.2, seed=6, n=400)
    model = GreyBoxNeck(n_play=1, max_iter=5).fit(data)
    model.reflection_ = np.array([[1.2, 0.0]])
    with pytest.raises(ValueError, match="reflection coefficients must lie"):
        neckid.load_model(model.save(tmp_path / "bad"))


def test_a_diverging_candidate_is_refused() -> None:
    data, _ = _made_by_the_model(slack=0.2, seed=7, n=400)
    x, y = data.u, data.y
    envelope = np.array([[y.min() - 1.0], [y.max() + 1.0]])  # a narrow envelope
    problem = Problem([(x, np.zeros((x.shape[0], 0)), y)], np.zeros((1, 1)), 2, 1, 2,
                      envelope, np.ptp(x, axis=0))  # fmt: skip
    _, _, diverged = free_run_error(problem, np.array([0.2]), np.array([[-0.9, 0.1]]))
    assert not diverged  # a well-damped candidate stays inside
    # A pole pair a hair inside the unit circle from the measured initial outputs far off:
    far = Problem([(x, np.zeros((x.shape[0], 0)), np.vstack([y[:2] + 1e4, y[2:]]))],
                  np.zeros((1, 1)), 2, 1, 2, envelope, np.ptp(x, axis=0))  # fmt: skip
    _, _, diverged = free_run_error(far, np.array([0.2]), np.array([[-0.9995, 0.9995]]))
    assert diverged
