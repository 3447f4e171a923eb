"""State and grey-box models say when the training logs cannot identify them (issue 39).

Set Membership and the recursive ARX warn when the system is not excited persistently; ``ss``
and the grey-box models were saved without a word on a constant input, and the tanks' 10
parameters were fitted on 8 samples.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from neckid import IOData, methods
from neckid.cli import app


def _constant_input(n: int = 400) -> IOData:
    rng = np.random.default_rng(0)
    y = np.cumsum(rng.normal(size=n)) * 0.01 + np.linspace(0.0, 1.0, n)
    return IOData(np.ones(n), y, ts=0.02, input_names=["command"], output_names=["inclination"])


@pytest.mark.parametrize("method", ["ss", "greybox-neck"])
def test_a_constant_input_is_warned_about(method: str) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        methods()[method].make(quick=True).fit(_constant_input())
    said = [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
    assert any(
        "input 'command' is constant (1) over the training logs" in text
        and "Excite the system persistently" in text
        for text in said
    ), said


def test_more_parameters_than_output_values_are_refused() -> None:
    with pytest.raises(
        ValueError, match=r"has 10 parameters to fit, and the training logs give only 8"
    ):
        methods()["greybox-tanks"].make(quick=True).fit(_constant_input()[:8])


def test_the_grey_box_neck_on_as_many_samples_as_parameters_is_refused() -> None:
    model = methods()["greybox-neck"].make(quick=True)
    with pytest.raises(
        ValueError, match=r"GreyBoxNeck has 6 parameters to fit, and the training logs give only 6"
    ):
        model.fit(_constant_input()[:8])  # 8 samples, 2 of them the initial ones
    assert not hasattr(model, "weights_")  # refused before anything is set
    assert methods()["greybox-neck"].make(quick=True).fit(_constant_input()[:40]).weights_.size == 3


def test_a_moving_input_is_not_warned_about() -> None:
    data = _constant_input()
    moving = data.replace(u=np.sin(np.arange(data.n_samples) * 0.1)[:, None])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        methods()["ss"].make(quick=True).fit(moving)
    assert not [w for w in caught if "persistently" in str(w.message)]


def test_identify_prints_the_warning_and_saves(tmp_path: Path) -> None:
    log = tmp_path / "run.csv"
    _constant_input().to_csv(log)
    save = tmp_path / "ss.npz"
    args = [
        "identify",
        str(log),
        "--inputs",
        "command",
        "--outputs",
        "inclination",
        "--method",
        "ss",
    ]
    result = CliRunner().invoke(app, [*args, "--save", str(save)])
    assert result.exit_code == 0 and save.exists(), result.output
    assert "input 'command' is constant (1) over the training logs" in " ".join(
        result.output.split()
    )
