"""Experimental conditions on IOData: validation, kept through edits, made inputs, read from names."""

from __future__ import annotations

import numpy as np
import pytest

import neckid
from neckid import IOData, Lags, LinearARX
from neckid.data.conditions import parse_condition
from neckid.datasets.softneck import conditions_from_name


def _log(**conditions: float | str) -> IOData:
    return IOData(
        np.arange(6.0), np.arange(6.0) ** 2, ts=0.1, input_names=["cmd"], output_names=["incl"],
        conditions=conditions, condition_units={"payload": "kg"} if "payload" in conditions else {},
    )  # fmt: skip


def test_conditions_survive_slicing_selecting_and_equality() -> None:
    data = _log(payload=0.4, controller="ada")
    for edited in (data[1:4], data.select(inputs=["cmd"]), data.renamed("x"), data.time_slice(0.2)):
        assert dict(edited.conditions) == {"payload": 0.4, "controller": "ada"}
        assert edited.condition_units["payload"] == "kg"
    assert data != _log(payload=0.2, controller="ada")
    assert data == _log(payload=0.4, controller="ada")
    assert data.to_dict()["conditions"] == {"payload": 0.4, "controller": "ada"}
    assert "condition payload [kg]: 0.4" in data.describe()


def test_conditions_are_read_only() -> None:
    data = _log(payload=0.4)
    with pytest.raises(TypeError):
        data.conditions["payload"] = 1.0  # type: ignore[index]


@pytest.mark.parametrize(
    ("conditions", "units", "message"),
    [
        ({"payload": float("nan")}, None, r"conditions\['payload'\] must be finite"),
        ({"payload": True}, None, "must be a number or a label"),
        ({"payload": [1.0]}, None, "must be a number or a label"),
        ({"1bad": 1.0}, None, "condition named '1bad'"),
        ({"cmd": 1.0}, None, "'cmd', which is already a channel"),
        ({"payload": ""}, None, "empty label"),
        ({"payload": 0.1}, {"mass": "kg"}, "unit for 'mass', which is not a condition"),
    ],
)
def test_bad_conditions_are_refused_naming_them(conditions, units, message) -> None:
    with pytest.raises(ValueError, match=message):
        IOData(np.zeros(3), ts=0.1, input_names=["cmd"], conditions=conditions,
               condition_units=units)  # fmt: skip


def test_conditions_as_inputs_appends_constant_channels_once() -> None:
    data = _log(payload=0.4, controller="ada")
    made = data.conditions_as_inputs(["payload"])
    assert made.input_names == ("cmd", "payload")
    assert made.unit("payload") == "kg"
    np.testing.assert_array_equal(made.channel("payload"), np.full(6, 0.4))
    assert dict(made.conditions) == {"controller": "ada"}
    assert made.conditions_as_inputs(["payload"]) == made
    with pytest.raises(ValueError, match="is a label"):
        data.conditions_as_inputs(["controller"])
    with pytest.raises(KeyError, match="does not have"):
        data.conditions_as_inputs(["speed"])


def test_lags_give_conditions_lag_zero_only_and_keep_them_in_files() -> None:
    data = _log(payload=0.4).conditions_as_inputs(["payload"])
    resolved = Lags(2, 3, conditions=["payload"]).resolve(data)
    assert resolved.names == (
        "incl(t-1)",
        "incl(t-2)",
        "cmd(t-1)",
        "cmd(t-2)",
        "cmd(t-3)",
        "payload(t)",
    )
    assert resolved.to_lags() == Lags({"incl": [1, 2]}, {"cmd": [1, 2, 3], "payload": [0]},
                                      conditions=["payload"])  # fmt: skip
    assert type(resolved).from_dict(resolved.to_dict()).to_dict() == resolved.to_dict()
    assert resolved.to_dict()["conditions"] == ["payload"]
    with pytest.raises(KeyError, match="conditions_as_inputs"):
        Lags(1, 1, conditions=["payload"]).resolve(_log(payload=0.4))
    with pytest.raises(TypeError, match="list of names"):
        Lags(1, 1, conditions="payload")


def test_a_condition_lets_a_linear_model_interpolate_between_payloads() -> None:
    rng = np.random.default_rng(1)

    def run(payload: float) -> IOData:
        u = rng.normal(size=500)
        y = np.zeros(500)
        for t in range(1, 500):
            y[t] = 0.6 * y[t - 1] + u[t - 1] + 4.0 * payload
        return IOData(u, y, ts=0.02, conditions={"payload": payload})

    model = LinearARX(Lags(1, 1, conditions=["payload"])).fit([run(0.0), run(0.6)])
    test = run(0.3)
    assert model.fit_percent(test)[0] > 99.0
    assert LinearARX(Lags(1, 1)).fit([run(0.0), run(0.6)]).fit_percent(test)[0] < 90.0


def test_parse_condition() -> None:
    assert parse_condition("payload=0.4kg") == ("payload", 0.4, "kg")
    assert parse_condition(" controller = int ") == ("controller", "int", "")
    for bad in ("payload", "=3", "payload=", "9x=1"):
        with pytest.raises(ValueError, match="condition"):
            parse_condition(bad)


def test_softneck_file_names_give_payload_and_controller() -> None:
    assert conditions_from_name("ada200response.csv")["conditions"] == {
        "payload": 0.2, "controller": "ada"}  # fmt: skip
    assert conditions_from_name("fra600stepresponse.csv")["conditions"]["payload"] == 0.6
    assert conditions_from_name("id000response.csv") == {}


def test_a_label_condition_is_one_hot_encoded_and_an_unseen_label_refused(tmp_path) -> None:
    rng = np.random.default_rng(2)
    offsets = {"A": 0.0, "B": 3.0, "C": -2.0}

    def run(neck: str) -> IOData:
        u = rng.normal(size=400)
        y = np.zeros(400)
        for t in range(1, 400):
            y[t] = 0.5 * y[t - 1] + u[t - 1] + offsets[neck]
        return IOData(u, y, ts=0.02, conditions={"neck": neck}, name=f"neck {neck}")

    model = LinearARX(Lags(1, 1, conditions=["neck"])).fit([run("A"), run("B")])
    assert model.lags_.conditions == ("neck=A", "neck=B")
    assert model.input_names_ == ("u", "neck=A", "neck=B")
    assert model.fit_percent(run("B"))[0] > 99.0
    assert LinearARX(Lags(1, 1)).fit([run("A"), run("B")]).fit_percent(run("B"))[0] < 90.0
    loaded = neckid.load_model(model.save(tmp_path / "neck.npz"))
    assert loaded.fit_percent(run("A"))[0] > 99.0
    with pytest.raises(ValueError, match=r"neck='C', a label the model was not identified with"):
        loaded.simulate(run("C"))
