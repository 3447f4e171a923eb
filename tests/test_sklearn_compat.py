"""scikit-learn estimator contract of the neckid models, through scikit-learn's own checks.

``parametrize_with_checks`` runs every check of ``check_estimator`` on one unfitted estimator per
registered method (:func:`neckid.methods`; ``sm`` and ``sm-linear`` share a class but differ in
their defaults, so both run). The checks that apply to a time-series estimator pass:

- ``check_estimator_cloneable``, ``check_estimator_repr``, ``check_estimator_tags_renamed``,
  ``check_valid_tag_types``, ``check_mixin_order``;
- ``check_no_attributes_set_in_init``, ``check_parameters_default_constructible``,
  ``check_do_not_raise_errors_in_init_or_set_params`` (``__init__`` stores its arguments
  unchanged and does nothing else);
- ``check_get_params_invariance``, ``check_set_params`` (get/set round trip);
- ``check_estimators_unfitted`` (``predict`` before ``fit`` raises a ``NotFittedError``).

The others cannot apply; :data:`NOT_APPLICABLE` gives the reason of each. They are marked
``xfail(strict=True)``: they run and must fail, and one that starts passing fails this module, so
the list stays true. They all call ``fit(X, y)`` with an anonymous ``(n_samples, n_features)``
array and a target vector of independent rows, then probe dtypes, sparse matrices, sample-order
invariance, subsets of rows, pickling, ``n_features_in_`` and so on. A NARX estimator learns from
an *ordered time series* with *named input and output channels* (an :class:`~neckid.IOData`, or a
list of them, with its sampling period): ``fit(data)`` has no ``y`` argument, regressors are built
from past samples so rows are neither independent nor reorderable, and sparse or complex data
have no meaning for a sensor log. Models are saved as ``.npz`` + JSON, never pickled, so the
pickle check does not apply either. What those checks protect (fit returns self, fit does not
change parameters, clone) is tested with IOData below, over the same registry; bad data refused
at the door is tested in the models' own modules.
"""

from __future__ import annotations

from unittest import SkipTest

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.utils.estimator_checks import estimator_checks_generator, parametrize_with_checks

import neckid
from neckid import IOData, Lags

METHODS = neckid.methods()

_XY = (
    "calls fit(X, y) with an (n_samples, n_features) array; a NARX model fits an IOData time series"
)

#: Checks that cannot apply to a NARX estimator, with the reason of each (the same for every
#: registered method). Each is an xfail(strict=True): it must still fail.
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
    "check_array_api_input": _XY + " (skipped by scikit-learn unless SCIPY_ARRAY_API=1)",
}


#: scikit-learn's sparse checks pass when the error of ``fit(X_sparse, y)`` mentions "sparse": the
#: class name ``SparseNARX`` in Python's "takes 2 positional arguments" error does, by accident.
_SPARSE_CHECKS = (
    "check_estimator_sparse_tag",
    "check_estimator_sparse_array",
    "check_estimator_sparse_matrix",
)


def _not_applicable(estimator: object) -> dict[str, str]:
    if "sparse" in type(estimator).__name__.lower():
        return {k: v for k, v in NOT_APPLICABLE.items() if k not in _SPARSE_CHECKS}
    return NOT_APPLICABLE


def _check_name(check: object) -> str:
    func = getattr(check, "func", check)  # parametrize_with_checks yields functools.partial
    return str(getattr(func, "__name__", func))


class ExpectedCheckFailure(AssertionError):
    """A not-applicable check failed, as it must; the message keeps the original exception."""


@parametrize_with_checks(
    [method.make() for method in METHODS.values()],
    expected_failed_checks=_not_applicable,
    xfail_strict=True,
)
def test_sklearn_estimator_checks(estimator, check) -> None:
    if _check_name(check) not in _not_applicable(estimator):
        check(estimator)
        return
    # Marked xfail(strict=True) by parametrize_with_checks: a failure is expected, a pass fails
    # the suite. The failure is re-raised without scikit-learn's traceback, which pytest would
    # otherwise format for every xfail by parsing estimator_checks.py (5,000 lines) once per
    # frame: about 0.3 s per check, a minute for the module. Skips pass through unchanged.
    try:
        check(estimator)
    except SkipTest:
        raise
    except Exception as exc:
        raise ExpectedCheckFailure(f"{type(exc).__name__}: {exc}") from None


def test_not_applicable_names_real_checks() -> None:
    # A misspelt entry would mark nothing and silently leave its check unlisted.
    generated = {_check_name(check) for _, check in estimator_checks_generator(neckid.LinearARX())}
    assert set(NOT_APPLICABLE) <= generated, sorted(set(NOT_APPLICABLE) - generated)


# ---------------------------------------------------------------------- the same, with IOData
def _data() -> IOData:
    """800 samples of a slow first-order system (the scheduled method cuts 8 segments of 100)."""
    rng = np.random.default_rng(0)
    n = 800
    u = rng.uniform(-1, 1, size=n)
    y = np.zeros(n)
    for t in range(1, n):
        y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    return IOData(u, y + 0.01 * rng.normal(size=n), ts=0.02)


def _quick(name: str):
    return METHODS[name].make(Lags.arx(1, 1), quick=True)


def _learned(model: object) -> list[str]:
    return [k for k in vars(model) if k.endswith("_") and not k.startswith("_")]


@pytest.mark.filterwarnings("ignore::sklearn.exceptions.ConvergenceWarning")
@pytest.mark.parametrize("name", list(METHODS))
def test_fit_returns_self_and_keeps_parameters(name: str) -> None:
    model = _quick(name)
    before = {k: repr(v) for k, v in model.get_params().items()}
    assert not _learned(model)
    assert model.fit(_data()) is model
    assert _learned(model)
    assert {k: repr(v) for k, v in model.get_params().items()} == before
    # A clone of a fitted model carries the parameters but nothing learned.
    copy = clone(model)
    assert repr(copy.get_params()) == repr(model.get_params())
    assert not _learned(copy)


@pytest.mark.parametrize("name", list(METHODS))
def test_clone_copies_lags_and_set_params_round_trip(name: str) -> None:
    lags = Lags(outputs=[1, 2], inputs={"u": [0, 3]})
    model = clone(METHODS[name].make(quick=True)).set_params(lags=lags)
    assert model.get_params()["lags"] is lags
    copy = clone(model)
    assert copy.lags == lags
    assert copy.lags is not lags
