"""Online identification: ``partial_fit`` on every model, offset adaptation, the adaptive protocols.

Equivalences of two code paths (an update against the refit it must equal, an incremental γ*
against the full pass, a streaming run against a batch fit), the prior rules of Set Membership,
and the contract that every registered method can be updated.
"""

from __future__ import annotations

import copy
import warnings

import numpy as np
import pytest

import neckid
from neckid import IOData, Lags, LinearARX, NotFittedError, SetMembership, load_model
from neckid.loops.adaptive import adaptive_free_run, streaming_ahead
from neckid.models.io import read_model_file, write_model_file
from neckid.models.linear.ls_statistics import LeastSquaresStatistics
from neckid.models.online import estimate_offset, simulate_with_offset
from neckid.models.set_membership._kernels.gamma import gamma_star
from neckid.models.set_membership.update import cross_gamma_star

METHODS = sorted(neckid.methods())


def _log(seed: int, n: int = 800, offset: float = 0.0, gain: float = 0.3) -> IOData:
    """A slow first-order system with a saturating input (as the contract test's), plus an offset."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1.0, 1.0, n // 20), 20) + 0.05 * rng.normal(size=n)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.8 * y[t - 1] + gain * np.tanh(2.0 * u[t - 1])
    return IOData(
        u,
        y + offset + 0.01 * rng.normal(size=n),
        ts=0.02,
        input_names=["command"],
        output_names=["inclination"],
        name=f"synthetic-{seed}",
    )


def _linear_log(seed: int, n: int = 400, offset: float = 0.3) -> IOData:
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 2))
    y = np.zeros(n)
    for t in range(2, n):
        y[t] = 1.2 * y[t - 1] - 0.5 * y[t - 2] + 0.4 * u[t - 1, 0] - 0.2 * u[t - 2, 1] + offset
    return IOData(u, y + 0.01 * rng.normal(size=n), ts=0.02)


# ---------------------------------------------------------------------- least squares
@pytest.mark.parametrize(
    "params",
    [{}, {"fit_intercept": False}, {"ridge": 0.5}, {"ridge": 1e-3, "fit_intercept": False}],
)
def test_arx_update_equals_the_refit_on_old_and_new_data(params: dict) -> None:
    a, b, c = _linear_log(1), _linear_log(2, 300), _linear_log(3, 5)  # c: fewer rows than terms
    updated = LinearARX(Lags.arx(2, 2), **params).fit(a).partial_fit(b).partial_fit([c, a])
    refit = LinearARX(Lags.arx(2, 2), **params).fit([a, b, c, a])
    np.testing.assert_allclose(updated.coef_, refit.coef_, rtol=0, atol=1e-8)
    np.testing.assert_allclose(updated.intercept_, refit.intercept_, rtol=0, atol=1e-8)
    assert updated.n_samples_ == refit.n_samples_


def test_merged_statistics_equal_those_of_all_rows(rng: np.random.Generator) -> None:
    x, y = rng.normal(size=(60, 3)) + 5.0, rng.normal(size=(60, 2))
    whole = LeastSquaresStatistics.from_rows(x, y)
    merged = LeastSquaresStatistics.from_rows(x[:7], y[:7]).merge(
        LeastSquaresStatistics.from_rows(x[7:], y[7:])
    )
    z = np.hstack([x, y]) - np.hstack([x, y]).mean(axis=0)
    np.testing.assert_allclose(merged.factor.T @ merged.factor, z.T @ z, rtol=1e-10)
    np.testing.assert_allclose(merged.x_mean, whole.x_mean, rtol=1e-12)
    with pytest.raises(ValueError, match="cannot merge"):
        whole.merge(LeastSquaresStatistics.from_rows(x, y, centred=False))


def test_arx_statistics_survive_the_model_file(tmp_path) -> None:
    a, b = _linear_log(1), _linear_log(2)
    model = LinearARX(Lags.arx(2, 2)).fit(a)
    loaded = load_model(model.save(tmp_path / "arx"))
    loaded.partial_fit(b)
    np.testing.assert_allclose(loaded.coef_, LinearARX(Lags.arx(2, 2)).fit([a, b]).coef_, atol=1e-8)


def test_arx_from_an_older_file_loads_but_refuses_to_update(tmp_path) -> None:
    a = _linear_log(1)
    path = LinearARX(Lags.arx(2, 2)).fit(a).save(tmp_path / "arx")
    name, arrays, meta = read_model_file(path)
    older = {k: v for k, v in arrays.items() if not k.startswith("statistics_")}
    write_model_file(path, name, older, meta)
    model = load_model(path)
    assert model.statistics_ is None
    model.simulate(a)
    with pytest.raises(ValueError, match="refit"):
        model.partial_fit(a)


def test_arx_file_with_damaged_statistics_is_refused(tmp_path) -> None:
    path = LinearARX(Lags.arx(2, 2)).fit(_linear_log(1)).save(tmp_path / "arx")
    name, arrays, meta = read_model_file(path)
    arrays["statistics_factor"] = np.ones_like(arrays["statistics_factor"])
    write_model_file(path, name, arrays, meta)
    with pytest.raises(ValueError, match="upper triangular"):
        load_model(path)


# ---------------------------------------------------------------------- Set Membership
@pytest.mark.parametrize("linear_part", [False, True])
def test_sm_update_equals_a_fit_on_all_points_with_the_same_prior(linear_part: bool) -> None:
    a, b = _log(0), _log(1, 400)
    model = SetMembership(Lags.arx(1, 1), linear_part=linear_part, progress=False).fit(a)
    n_old = model.n_samples_
    model.partial_fit(b, prior="adapt")
    assert model.n_samples_ == n_old + b.n_samples - 1
    batch = SetMembership(
        Lags.arx(1, 1),
        epsilon=model.epsilon_,
        gamma=model.gamma_,
        scaling=model.weights_.tolist(),  # an ndarray trips Options.accepts (see report)
        linear_part=linear_part,
    ).fit([a, b])
    np.testing.assert_allclose(model.coef_, batch.coef_, atol=1e-10)
    test = _log(2, 300)
    np.testing.assert_allclose(model.predict(test).upper, batch.predict(test).upper, atol=1e-9)
    np.testing.assert_allclose(model.simulate(test).y, batch.simulate(test).y, atol=1e-9)


def test_sm_update_round_trips_through_the_model_file(tmp_path) -> None:
    model = SetMembership(Lags.arx(1, 1), progress=False).fit(_log(0))
    model.partial_fit(_log(1, 300))
    loaded = load_model(model.save(tmp_path / "sm"))
    assert loaded.n_samples_ == model.n_samples_
    np.testing.assert_array_equal(loaded.gamma_, model.gamma_)
    test = _log(2, 300)
    np.testing.assert_array_equal(loaded.simulate(test).y, model.simulate(test).y)
    loaded.partial_fit(_log(3, 200))  # a loaded model updates too
    assert loaded.n_samples_ > model.n_samples_


def test_an_inconsistent_datum_raises_gamma_or_is_reported() -> None:
    a = _log(0)
    fitted = SetMembership(Lags.arx(1, 1), progress=False).fit(a)
    gamma = fitted.gamma_.copy()
    shifted = _log(0, 300, offset=1.0)  # the same regressors' inputs, outputs far off

    adapted = copy.deepcopy(fitted).partial_fit(shifted, prior="adapt")
    assert adapted.last_invalidation_[0].falsified
    assert adapted.last_invalidation_[0].fraction[0] > 0.5
    assert np.all(adapted.gamma_ > gamma) and adapted.prior_valid_.all()
    # the new γ is gamma_margin · γ*(ε) of all the data, computed exactly
    points = np.ascontiguousarray(adapted._x_train * adapted.weights_)
    star = gamma_star(points, adapted._y_train, adapted.epsilon_[None, :])[0]
    np.testing.assert_allclose(adapted.gamma_, adapted.gamma_margin * star, rtol=1e-12)
    np.testing.assert_allclose(adapted.gamma_star_, star, rtol=1e-12)

    kept = copy.deepcopy(fitted)
    with pytest.warns(UserWarning, match="falsify"):
        kept.partial_fit(shifted, prior="keep")
    np.testing.assert_array_equal(kept.gamma_, gamma)
    assert not kept.prior_valid_.any() and kept.last_invalidation_[0].falsified

    refused = copy.deepcopy(fitted)
    with pytest.raises(ValueError, match="falsify the prior"):
        refused.partial_fit(shifted, prior="raise")
    assert refused.n_samples_ == fitted.n_samples_
    with pytest.raises(ValueError, match="prior must be one of"):
        copy.deepcopy(fitted).partial_fit(shifted, prior="forget")  # type: ignore[arg-type]


def test_consistent_new_data_keep_gamma() -> None:
    fitted = SetMembership(Lags.arx(1, 1), gamma=50.0, epsilon=0.05).fit(_log(0))
    fitted.partial_fit(_log(1, 300))
    assert not fitted.last_invalidation_[0].falsified
    np.testing.assert_array_equal(fitted.gamma_, [50.0])


def test_cross_gamma_star_equals_the_full_pass_over_all_pairs(rng: np.random.Generator) -> None:
    points = rng.normal(size=(300, 3))
    targets = np.sin(points @ [1.0, 2.0, -1.0])[:, None] + 0.05 * rng.normal(size=(300, 1))
    epsilon = np.array([0.02])
    old = gamma_star(points[:200], targets[:200], epsilon[None, :])[0]
    incremental = np.maximum(old, cross_gamma_star(points, targets, np.arange(200, 300), epsilon))
    np.testing.assert_allclose(incremental, gamma_star(points, targets, epsilon[None, :])[0])


# ---------------------------------------------------------------------- every method
@pytest.fixture(scope="module", params=METHODS)
def fitted(request: pytest.FixtureRequest):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the quick network stops before converging
        model = neckid.methods()[request.param].make(Lags.arx(1, 1, 1), quick=True).fit(_log(0))
    return request.param, model


def test_every_method_updates_and_the_free_run_changes(fitted) -> None:
    name, model = fitted
    model = copy.deepcopy(model)
    new, test = _log(1, 400, offset=0.2, gain=0.4), _log(2, 400, offset=0.2, gain=0.4)
    before = model.simulate(test).y
    if name.startswith("scheduled"):  # the new record is not held at one level: never settles
        model.set_params(converged_only=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert model.partial_fit(new) is model
    after = model.simulate(test).y
    assert np.max(np.abs(after - before)) > 1e-6, name


def test_every_method_checks_the_data_of_an_update(fitted) -> None:
    _, model = fitted
    model = copy.deepcopy(model)
    other = IOData(np.zeros((50, 1)), np.zeros(50), ts=0.02, input_names=["other"])
    with pytest.raises(ValueError, match="inputs"):
        model.partial_fit(other)
    slower = IOData(np.zeros(50), np.zeros(50), ts=0.1, input_names=["command"],
                    output_names=["inclination"])  # fmt: skip
    with pytest.raises(ValueError, match="sampled every"):
        model.partial_fit(slower)


@pytest.mark.parametrize("name", [m for m in METHODS if m != "rls"])
def test_updating_an_unfitted_model_raises(name: str) -> None:
    with pytest.raises(NotFittedError):
        neckid.methods()[name].make(Lags.arx(1, 1, 1), quick=True).partial_fit(_log(0))


def test_rls_partial_fit_keeps_its_meaning_of_starting_from_scratch() -> None:
    # RecursiveARX.partial_fit predates the others: on an unfitted model it is fit (CFF-RLS
    # from the initial state), and update(y, u) stays the per-sample step.
    data = _log(0)
    fresh = neckid.methods()["rls"].make(Lags.arx(1, 1, 1)).partial_fit(data)
    np.testing.assert_array_equal(
        fresh.theta_, neckid.methods()["rls"].make(Lags.arx(1, 1, 1)).fit(data).theta_
    )


def test_a_loaded_network_refuses_to_update(tmp_path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the quick network stops before converging
        model = neckid.methods()["nn"].make(Lags.arx(1, 1, 1), quick=True).fit(_log(0))
    loaded = load_model(model.save(tmp_path / "nn"))
    with pytest.raises(ValueError, match="refit"):
        loaded.partial_fit(_log(1, 300))


# ---------------------------------------------------------------------- offset
def test_the_offset_of_a_shifted_run_is_recovered_exactly() -> None:
    rng = np.random.default_rng(0)
    u = rng.normal(size=600)
    y = np.zeros(600)
    for t in range(1, 600):
        y[t] = 0.7 * y[t - 1] + 0.5 * u[t - 1]
    model = LinearARX(Lags.arx(1, 1), fit_intercept=False).fit(IOData(u[:300], y[:300], ts=0.1))
    shifted = IOData(u[300:], y[300:] - 0.8, ts=0.1)
    offset = estimate_offset(model, shifted[:100], initial=y[300:301])
    np.testing.assert_allclose(offset, [-0.8], atol=1e-9)
    result = simulate_with_offset(model, shifted, offset)
    np.testing.assert_allclose(result.y, shifted.y, atol=1e-9)
    assert result.extras["offset"][0] == pytest.approx(-0.8)
    with pytest.raises(ValueError, match="offset must be 1 finite"):
        simulate_with_offset(model, shifted, [np.nan])


# ---------------------------------------------------------------------- protocols
@pytest.fixture(scope="module")
def drifted():
    """A model identified on runs at one offset, and a test run at another (the slack changed)."""
    train = [_log(0), _log(1)]
    test = _log(2, 1200, offset=0.5)
    return train, test


@pytest.mark.parametrize("method", ["arx", "sm", "sm-parallel"])
def test_adapting_to_a_changed_offset_lifts_the_fit(drifted, method: str) -> None:
    train, test = drifted
    options = {} if method == "arx" else {"progress": False}
    model = neckid.methods()[method].make(Lags.arx(1, 1, 1), **options).fit(train)
    runs = {a: adaptive_free_run(model, test, 5.0, adapt=a) for a in ("none", "offset", "both")}
    assert runs["offset"].fit[0] > runs["none"].fit[0] + 10
    assert runs["both"].fit[0] > runs["none"].fit[0] + 10
    assert runs["none"].warmup_samples == 250
    # every mode is scored on the same samples: after the warm-up, from its last outputs
    assert runs["none"].scored == runs["both"].scored == test[250 - model.max_lag_ :]


def test_set_membership_update_alone_follows_the_new_run(drifted) -> None:
    train, test = drifted
    model = SetMembership(Lags.arx(1, 1, 1), progress=False).fit(train)
    none = adaptive_free_run(model, test, 5.0, adapt="none")
    updated = adaptive_free_run(model, test, 5.0, adapt="update")
    assert updated.fit[0] > none.fit[0] + 3  # local: only near the warm-up's regressors
    assert updated.model.n_samples_ == model.n_samples_ + 249


@pytest.mark.parametrize("adapt", ["update", "both", "offset", "none"])
def test_the_protocols_never_change_the_given_model(drifted, adapt: str) -> None:
    train, test = drifted
    model = SetMembership(Lags.arx(1, 1, 1), linear_part=True, progress=False).fit(train)
    arrays, meta = model._get_state()
    adaptive_free_run(model, test, 5.0, adapt=adapt)
    streaming_ahead(model, test[:300], steps=2, update_every=50)
    after, meta_after = model._get_state()
    assert meta_after == meta and not hasattr(model, "last_invalidation_")
    for key, value in arrays.items():
        np.testing.assert_array_equal(after[key], value, err_msg=key)


def test_adaptive_free_run_refuses_bad_settings(drifted) -> None:
    train, test = drifted
    model = LinearARX(Lags.arx(1, 1)).fit(train)
    with pytest.raises(ValueError, match="adapt must be one of"):
        adaptive_free_run(model, test, 5.0, adapt="retrain")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="warm-up samples"):
        adaptive_free_run(model, test, 0.01)
    with pytest.raises(ValueError, match="warm-up samples"):
        adaptive_free_run(model, test, 1000.0)
    with pytest.raises(NotFittedError):
        adaptive_free_run(LinearARX(Lags.arx(1, 1)), test, 5.0)


def test_streaming_arx_ends_as_the_refit_on_everything_seen(drifted) -> None:
    train, test = drifted
    model = LinearARX(Lags.arx(1, 1)).fit(train)
    run = streaming_ahead(model, test, steps=3, update_every=37)
    refit = LinearARX(Lags.arx(1, 1)).fit([*train, test[: run.n_updates * 37]])
    np.testing.assert_allclose(run.model.coef_, refit.coef_, atol=1e-10)
    assert run.result.n_initial == model.max_lag_ + 2
    assert run.result.extras == {"steps": 3, "update_every": 37}
    assert streaming_ahead(model, test, steps=1).result.extras["update_every"] == 50  # 1 s
    assert run.fit[0] > streaming_ahead(model, test, steps=3, update_every=10_000).fit[0]


@pytest.mark.parametrize("method", ["arx", "sm-linear"])
def test_streaming_predictions_use_only_the_past(drifted, method: str) -> None:
    train, test = drifted
    options = {} if method == "arx" else {"progress": False}
    model = neckid.methods()[method].make(Lags.arx(1, 1), **options).fit(train)
    steps, cut = 4, 333
    y = np.array(test.y)
    y[cut:] += 5.0  # what happens from `cut` on
    changed = IOData(test.u, y, ts=test.ts, input_names=test.input_names,
                     output_names=test.output_names)  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = streaming_ahead(model, test, steps=steps, update_every=40).result.y
        b = streaming_ahead(model, changed, steps=steps, update_every=40).result.y
    # a prediction of y(s) is made at s - steps: untouched up to s = cut + steps - 1
    np.testing.assert_array_equal(a[: cut + steps], b[: cut + steps])
    assert not np.array_equal(a[cut + steps :], b[cut + steps :])


def test_streaming_ahead_gives_bands_of_set_membership_models(drifted) -> None:
    train, test = drifted
    model = neckid.methods()["sm-multistep"].make(Lags.arx(1, 1), quick=True).fit(train)
    run = streaming_ahead(model, test[:400], steps=3, update_every=100)
    assert run.n_updates == 3
    start = run.result.n_initial
    assert np.all(run.result.lower[start:] <= run.result.y[start:])
    assert np.all(run.result.y[start:] <= run.result.upper[start:])
