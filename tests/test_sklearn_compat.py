"""scikit-learn estimator contract of the neckid models, through scikit-learn's own checks.

``parametrize_with_checks`` runs every check of ``check_estimator`` on LinearARX, NeuralNARX,
RecursiveARX and SetMembership. The checks that apply to a time-series estimator pass:

- ``check_estimator_cloneable``, ``check_estimator_repr``, ``check_estimator_tags_renamed``,
  ``check_valid_tag_types``, ``check_mixin_order``;
- ``check_no_attributes_set_in_init``, ``check_parameters_default_constructible``,
  ``check_do_not_raise_errors_in_init_or_set_params`` (``__init__`` stores its arguments
  unchanged and does nothing else);
- ``check_get_params_invariance``, ``check_set_params`` (get/set round trip);
- ``check_estimators_unfitted`` (``predict`` before ``fit`` raises a ``NotFittedError``).

The others cannot apply (``NOT_APPLICABLE`` gives the reason of each); they are run and must still
fail, so that one that starts passing fails this module and the list stays true. They all call ``fit(X, y)`` with an anonymous
``(n_samples, n_features)`` array and a target vector of independent rows, then probe dtypes,
sparse matrices, sample-order invariance, subsets of rows, pickling, ``n_features_in_`` and so on.
A NARX estimator learns from an *ordered time series* with *named input and output channels*
(an :class:`~neckid.IOData`, or a list of them, with its sampling period): ``fit(data)`` has no
``y`` argument, regressors are built from past samples so rows are neither independent nor
reorderable, and sparse or complex data have no meaning for a sensor log. Models are saved as
``.npz`` + JSON, never pickled, so the pickle check does not apply either. What those checks
protect (finite data refused at the door, fit returns self, fit does not change parameters) is
tested with IOData in the models' own test modules and below.
"""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.utils.estimator_checks import parametrize_with_checks

from neckid import IOData, Lags, LinearARX
from neckid.models.neural import NeuralNARX
from neckid.models.rls import RecursiveARX
from neckid.models.set_membership import SetMembership

ESTIMATORS: list = [LinearARX(), NeuralNARX(), RecursiveARX(), SetMembership()]

_XY = (
    "calls fit(X, y) with an (n_samples, n_features) array; a NARX model fits an IOData time series"
)

NOT_APPLICABLE = {
    "check_fit_score_takes_y": _XY + " and has no y argument",
    "check_estimators_overwrite_params": _XY + " (tested with IOData below)",
    "check_dont_overwrite_parameters": _XY + " (tested with IOData below)",
    "check_estimators_fit_returns_self": _XY + " (tested with IOData below)",
    "check_readonly_memmap_input": _XY + "; IOData holds its own read-only copy anyway",
    "check_n_features_in_after_fitting": _XY + "; channels are named, see n_inputs_/lags_",
    "check_n_features_in": _XY + "; channels are named, see n_inputs_/lags_",
    "check_positive_only_tag_during_fit": _XY,
    "check_estimators_dtypes": _XY,
    "check_complex_data": _XY + "; complex sensor logs have no meaning",
    "check_dtype_object": _XY,
    "check_estimators_empty_data_messages": _XY + "; IOData refuses an empty log itself",
    "check_pipeline_consistency": _XY + "; a NARX model is not a Pipeline step",
    "check_estimators_nan_inf": _XY + "; IOData refuses NaN/inf naming channel and row",
    "check_estimator_sparse_tag": _XY + "; sparse matrices have no meaning for a log",
    "check_estimator_sparse_array": _XY + "; sparse matrices have no meaning for a log",
    "check_estimator_sparse_matrix": _XY + "; sparse matrices have no meaning for a log",
    "check_estimators_pickle": _XY + "; models are saved as .npz + JSON, never pickled",
    "check_f_contiguous_array_estimator": _XY,
    "check_methods_sample_order_invariance": _XY + "; time-series rows cannot be reordered",
    "check_methods_subset_invariance": _XY + "; regressors span several consecutive rows",
    "check_fit2d_1sample": _XY,
    "check_fit2d_1feature": _XY,
    "check_dict_unchanged": _XY,
    "check_fit_idempotent": _XY,
    "check_fit_check_is_fitted": _XY,
    "check_fit1d": _XY,
    "check_fit2d_predict1d": _XY,
}


def _check_name(check: object) -> str:
    func = getattr(check, "func", check)  # parametrize_with_checks yields functools.partial
    return str(getattr(func, "__name__", func))


@parametrize_with_checks(ESTIMATORS)
def test_sklearn_estimator_checks(estimator, check) -> None:
    name = _check_name(check)
    if name not in NOT_APPLICABLE:
        check(estimator)
        return
    # Not applicable: it must still fail (a check that starts passing belongs in the list above),
    # but without a pytest xfail, whose traceback formatting of sklearn's long module costs ~0.4 s
    # per check.
    try:
        check(estimator)
    except Exception:
        return
    pytest.fail(f"{name} now passes on {type(estimator).__name__}; remove it from NOT_APPLICABLE")


# ---------------------------------------------------------------------- the same, with IOData
def _data() -> IOData:
    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, size=300)
    y = np.zeros(300)
    for t in range(1, 300):
        y[t] = 0.8 * y[t - 1] + 0.5 * u[t - 1]
    return IOData(u, y + 0.01 * rng.normal(size=300), ts=0.02)


def _configured(estimator):
    params = estimator.get_params()
    if "lags" in params:
        estimator = clone(estimator).set_params(lags=Lags.arx(1, 1))
    if "hidden_layer_sizes" in params:
        estimator.set_params(hidden_layer_sizes=(4,), max_iter=20)
    return estimator


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
@pytest.mark.parametrize("estimator", ESTIMATORS, ids=lambda e: type(e).__name__)
def test_fit_returns_self_and_keeps_parameters(estimator) -> None:
    model = _configured(estimator)
    before = {k: repr(v) for k, v in model.get_params().items()}
    assert model.fit(_data()) is model
    assert {k: repr(v) for k, v in model.get_params().items()} == before
    # A clone of a fitted model carries the parameters but nothing learned.
    copy = clone(model)
    assert repr(copy.get_params()) == repr(model.get_params())
    assert not [k for k in vars(copy) if k.endswith("_") and not k.startswith("_")]


@pytest.mark.parametrize("estimator", ESTIMATORS, ids=lambda e: type(e).__name__)
def test_clone_copies_lags_and_set_params_round_trip(estimator) -> None:
    if "lags" not in estimator.get_params():
        pytest.skip(f"{type(estimator).__name__} has no lags parameter (orders na, nb, delay)")
    lags = Lags(outputs=[1, 2], inputs={"u": [0, 3]})
    model = clone(estimator).set_params(lags=lags)
    assert model.get_params()["lags"] is lags
    copy = clone(model)
    assert copy.lags == lags
    assert copy.lags is not lags
