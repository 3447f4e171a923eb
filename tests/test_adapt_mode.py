"""Models adapted on a new run's first seconds, in compare's folds and test logs (issue 40)."""

from __future__ import annotations

import numpy as np
import pytest

from neckid import IOData, Lags, LinearARX
from neckid.models.adapted import adaptation_label, adapted_run, check_adaptation
from neckid.selection.comparison import compare, select_safely
from neckid.selection.lags import free_run, select_lags

pytestmark = pytest.mark.filterwarnings("ignore::neckid.models.results.ExtrapolationWarning")


def _run(seed: int, offset: float, payload: float = 0.0) -> IOData:
    """A first-order neck whose sensor zero differs per run by ``offset``."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, 80), 10)
    y = np.zeros(u.size)
    for t in range(1, u.size):
        y[t] = 0.8 * y[t - 1] + 0.4 * u[t - 1] + 0.1 * payload
    noisy = y + offset + 0.01 * rng.normal(size=u.size)
    return IOData(u, noisy, ts=0.02, name=f"run {seed}").with_conditions(payload=payload)


def test_adapted_run_is_causal_and_labelled() -> None:
    model = LinearARX(Lags.arx(1, 1)).fit([_run(1, 0.0), _run(2, 0.1)])
    test = _run(3, 1.5)
    run = adapted_run(model, test, 2.0)
    assert (
        run.label == adaptation_label(2.0, "offset") == "free run after 2 s of adaptation (offset)"
    )
    assert run.adapted.fit[0] > run.unadapted.fit[0] + 30
    assert run.adapted.offset[0] == pytest.approx(1.45, abs=0.15)  # 1.5 less the training mean
    # what follows the warm-up is never read before it is predicted: change it, nothing moves
    n = run.adapted.warmup_samples
    later = test.replace(y=np.concatenate([test.y[:n], test.y[n:] + 100.0]))
    again = adapted_run(model, later, 2.0)
    np.testing.assert_array_equal(again.adapted.offset, run.adapted.offset)
    np.testing.assert_array_equal(again.adapted.result.y[1:], run.adapted.result.y[1:])
    assert 0.9 < run.band_coverage[0] <= 1.0


def test_check_adaptation_refuses_bad_values() -> None:
    with pytest.raises(ValueError, match="adapt seconds"):
        check_adaptation(0.0, "offset")
    with pytest.raises(ValueError, match="adapt mode"):
        check_adaptation(5.0, "none")


def test_free_run_with_adaptation_scores_after_the_warm_up() -> None:
    model = LinearARX(Lags.arx(1, 1)).fit([_run(1, 0.0), _run(2, 0.1)])
    test = _run(3, 1.5)
    y, skip = free_run(model, test, adapt=(2.0, "offset"))
    assert skip == 100  # 2 s at 0.02 s: the warm-up, measured
    np.testing.assert_array_equal(y[:skip], test.y[:skip])
    plain, _ = free_run(model, test)
    assert np.abs(y[skip:] - test.y[skip:]).mean() < np.abs(plain[skip:] - test.y[skip:]).mean()


def test_select_safely_scores_the_adapted_folds() -> None:
    runs = [_run(s, o) for s, o in ((1, 0.0), (2, 1.0), (3, -1.0))]
    options = [("arx", LinearARX(Lags.arx(1, 1)))]
    plain = select_safely(options, runs)
    adapted = select_safely(options, runs, adapt=(2.0, "offset"))
    assert adapted.table.loc[0, "fit_mean"] > plain.table.loc[0, "fit_mean"] + 20


def test_compare_with_adaptation_reports_both_fits_and_the_band() -> None:
    train = [_run(1, 0.0), _run(2, 0.5)]
    tests = [_run(3, 1.5), _run(4, -1.0)]
    found = compare(train, tests, methods=["arx"], lags=Lags.arx(1, 1), adapt=(2.0, "offset"))
    assert found.kind == "free run after 2 s of adaptation (offset)"
    rows = found.results
    assert (rows["fit_percent"] > rows["fit_percent_unadapted"] + 10).all()
    assert rows["band"].eq("adaptive conformal 95 %").all()
    assert rows["band_coverage"].between(0.85, 1.0).all()
    assert found.to_json()["kind"] == found.kind
    with pytest.raises(ValueError, match="adapt mode"):
        compare(train, tests, methods=["arx"], adapt=(2.0, "retrain"))


def test_conditions_go_straight_into_compare_and_select_lags() -> None:
    train = [_run(1, 0.0, 0.0), _run(2, 0.0, 0.6), _run(5, 0.0, 0.3)]
    tests = [_run(3, 0.0, 0.2)]
    lags = Lags(1, 1, conditions=["payload"])
    found = compare(train, tests, methods=["arx"], lags=lags)
    assert "payload" in found.models["arx"].input_names_
    assert found.results["fit_percent"].min() > 95
    chosen = select_lags(train, candidates=[lags, Lags(1, 1)], estimator="arx", progress=False)
    assert not chosen.table["error"].astype(bool).any()
    assert Lags(1, 1, conditions=None) == Lags(1, 1)


def test_offset_model_runs_its_state_map_as_its_free_run() -> None:
    from neckid.models.adapted import OffsetModel, adapted_model

    model = LinearARX(Lags.arx(2, 2)).fit([_run(1, 0.0), _run(2, 0.1)])
    test = _run(3, 1.5)
    wrapped = adapted_model(model, test, 2.0, "offset")
    assert isinstance(wrapped, OffsetModel) and wrapped.n_outputs_ == 1
    free = wrapped.simulate(test).y[:, 0]
    states = wrapped.state_map()
    m = model.max_lag_
    x = states.initial_state(test.y[:m], test.u[:m])
    stepped = list(test.y[:m, 0])
    for k in range(m, test.n_samples):
        stepped.append(float(states.output(x, test.u[k])[0]))
        x = states.update(x, test.u[k])
    np.testing.assert_allclose(stepped, free, atol=1e-9)
    updated = adapted_model(model, test, 2.0, "update")
    assert updated is not model and not isinstance(updated, OffsetModel)
