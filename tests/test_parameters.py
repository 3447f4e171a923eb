"""Each hyper-parameter is declared in ``_parameter_constraints`` and taken by ``__init__`` alike.

The constraints are what ``fit`` checks (:func:`neckid.utils.checks.validate_parameters`) and what
``get_params`` / ``set_params`` and the CLI's ``--param`` read; a parameter in one and not the
other would be accepted without a check, or checked without being settable.
"""

from __future__ import annotations

import inspect

import pytest

import neckid


@pytest.mark.parametrize("name", sorted(neckid.methods()))
def test_constraints_and_init_name_the_same_parameters(name: str) -> None:
    cls = neckid.methods()[name].estimator_class()
    init = set(inspect.signature(cls.__init__).parameters) - {"self"}
    assert set(cls._parameter_constraints) == init
