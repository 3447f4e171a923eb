"""The old module paths (before the family subpackages) still import, warn, and give the same objects."""

from __future__ import annotations

import importlib
import sys
import warnings

import pytest

#: old path -> (a public name there, its new home)
ALIASES = {
    "neckid.models.arx": ("LinearARX", "neckid.models.linear"),
    "neckid.models.rls": ("RecursiveARX", "neckid.models.linear"),
    "neckid.models.rls_kernels": ("ParameterHistory", "neckid.models.linear.rls_kernels"),
    "neckid.models.ls_statistics": ("LeastSquaresStatistics", "neckid.models.linear"),
    "neckid.models.sm_multistep": ("MultiStepSetMembership", "neckid.models.set_membership"),
    "neckid.models.sm_parallel": ("ParallelSetMembership", "neckid.models.set_membership"),
    "neckid.models.sm_prior": ("GammaCurve", "neckid.models.set_membership"),
    "neckid.models.sm_metric": ("learnt_weights", "neckid.models.set_membership.metric"),
    "neckid.models.sm_training": ("linear_sum", "neckid.models.linear"),
    "neckid.models.sm_update": ("revise_prior", "neckid.models.set_membership.update"),
    "neckid.models.scheduled_points": ("identify_point", "neckid.models.scheduled"),
    "neckid.models.scheduled_simulator": ("GainScheduledSimulator", "neckid.models.scheduled"),
    "neckid.data_files": ("file_fields", "neckid.data.readers"),
    "neckid.data_rosbag": ("rosbag_fields", "neckid.data.rosbag"),
    "neckid.conditions": ("parse_condition", "neckid.data.conditions"),
    "neckid.experiments.model_in_loop": ("model_in_the_loop", "neckid.loops.model_in_loop"),
    "neckid.experiments.adaptive": ("adaptive_free_run", "neckid.loops.adaptive"),
    "neckid.experiments.operating_points": (
        "identify_operating_points",
        "neckid.loops.operating_points",
    ),
}


@pytest.mark.parametrize("old", sorted(ALIASES))
def test_old_path_warns_and_gives_the_same_object(old: str) -> None:
    name, new = ALIASES[old]
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match="next release"):
        module = importlib.import_module(old)
    assert getattr(module, name) is getattr(importlib.import_module(new), name)
    assert name in module.__all__


@pytest.mark.parametrize(
    ("old", "name"),
    [
        ("neckid.models.set_membership", "SetMembership"),
        ("neckid.models.polynomial", "PolynomialNARX"),
        ("neckid.models.neural", "NeuralNARX"),
        ("neckid.models.scheduled", "GainScheduledModel"),
        ("neckid.data", "IOData"),
    ],
)
def test_modules_that_became_packages_keep_their_names_without_warning(old: str, name: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        module = importlib.import_module(old)
    import neckid

    assert getattr(module, name) is getattr(neckid, name)


def test_the_old_condition_function_is_the_method() -> None:
    from neckid import IOData

    with pytest.warns(DeprecationWarning):
        sys.modules.pop("neckid.conditions", None)
        conditions = importlib.import_module("neckid.conditions")
    log = IOData(u=[1.0, 2.0], ts=0.1, conditions={"payload": 0.2})
    assert conditions.conditions_as_inputs(log, ["payload"]) == log.conditions_as_inputs(
        ["payload"]
    )


def test_neckid_models_re_exports_every_estimator_of_the_registry() -> None:
    import neckid
    import neckid.models

    classes = {entry.estimator_class() for entry in neckid.methods().values()}
    assert classes <= {getattr(neckid.models, name) for name in neckid.models.__all__}
