"""Tests of Lags: regressor rows equal the hand-built ones, experiments never mix, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from neckid.data.iodata import IOData
from neckid.regressors import Lags, ResolvedLags


def make_data(n: int = 30, n_inputs: int = 2, offset: float = 0.0) -> IOData:
    k = np.arange(n, dtype=float)
    u = np.column_stack([offset + 1000.0 * (i + 1) + k for i in range(n_inputs)])
    return IOData(u=u, y=offset + k, ts=0.1)


def test_paper_regressor() -> None:
    data = IOData(u=np.random.default_rng(0).normal(size=(60, 3)), y=np.arange(60.0), ts=0.02)
    lags = Lags(outputs=3, inputs=[8, 9, 10])
    x, y = lags.build(data)
    assert lags.max_lag == 10 and x.shape == (50, 12) and y.shape == (50, 1)
    t = 25
    row = t - 10
    expected = [data.y[t - 1, 0], data.y[t - 2, 0], data.y[t - 3, 0]]
    for c in range(3):
        expected += [data.u[t - 8, c], data.u[t - 9, c], data.u[t - 10, c]]
    np.testing.assert_array_equal(x[row], expected)
    assert y[row, 0] == data.y[t, 0]


def test_lag_zero_and_per_channel_mapping() -> None:
    data = make_data(10)
    lags = Lags(outputs={"y": [2]}, inputs={"u2": [0, 1]})
    resolved = lags.resolve(data)
    assert resolved.names == ("y(t-2)", "u2(t)", "u2(t-1)")
    x, _ = lags.build(data)
    np.testing.assert_array_equal(x[0], [data.y[0, 0], data.u[2, 1], data.u[1, 1]])
    only_now = Lags(inputs=[0])
    assert only_now.max_lag == 0
    x0, y0 = only_now.build(data)
    assert x0.shape == (10, 2) and y0.shape == (10, 1)


@settings(max_examples=40, deadline=None)
@given(
    output_lags=st.lists(st.integers(1, 6), unique=True, max_size=4),
    input_lags=st.lists(st.integers(0, 6), unique=True, min_size=1, max_size=4),
    n=st.integers(8, 25),
)
def test_build_rows_equal_hand_built_regressor(
    output_lags: list[int], input_lags: list[int], n: int
) -> None:
    data = make_data(n)
    lags = Lags(outputs=output_lags, inputs=input_lags)
    x, y = lags.build(data)
    m = max(output_lags + input_lags)
    assert lags.max_lag == m and x.shape[0] == n - m
    for t in range(m, n):
        hand = [data.y[t - lag, 0] for lag in sorted(output_lags)]
        for c in range(2):
            hand += [data.u[t - lag, c] for lag in sorted(input_lags)]
        np.testing.assert_array_equal(x[t - m], hand)
        resolved = lags.resolve(data)
        np.testing.assert_array_equal(resolved.regressor_from_history(data.y, data.u, t), hand)
        assert y[t - m, 0] == data.y[t, 0]


def test_build_never_mixes_two_experiments() -> None:
    # Experiment b is offset by 1e6: any row that mixed a and b would hold values of both sizes.
    a, b = make_data(12), make_data(9, offset=1e6)
    lags = Lags(outputs=2, inputs=[0, 3])
    x, y = lags.build([a, b])
    assert x.shape[0] == (12 - 3) + (9 - 3)
    big = np.abs(x) > 5e5
    assert np.all(big.all(axis=1) | (~big).all(axis=1))
    np.testing.assert_array_equal(x[:9], lags.build(a)[0])
    np.testing.assert_array_equal(x[9:], lags.build(b)[0])
    np.testing.assert_array_equal(y[9:], lags.build(b)[1])


def test_round_trips_and_arx() -> None:
    data = make_data(10)
    lags = Lags(outputs={"y": [1, 3]}, inputs={"u1": [0], "u2": [2]})
    resolved = lags.resolve(data)
    again = ResolvedLags.from_dict(resolved.to_dict())
    assert again.names == resolved.names and again.max_lag == 3
    np.testing.assert_array_equal(again.lag, resolved.lag)
    assert resolved.to_lags().resolve(data).names == resolved.names
    assert Lags.arx(2, 3, delay=0) == Lags(outputs=[1, 2], inputs=[0, 1, 2])
    assert repr(Lags.arx(1, 1)) == "Lags(outputs=[1], inputs=[1])"


BAD = [
    (lambda: Lags(outputs=[0]), ValueError, r"outputs must hold lags >= 1; got 0 in \[0\]"),
    (lambda: Lags(inputs=[-1]), ValueError, r"inputs must hold lags >= 0; got -1"),
    (lambda: Lags(outputs=[1, 1]), ValueError, r"outputs repeats a lag: \[1, 1\]"),
    (lambda: Lags(outputs=[1.5]), TypeError, r"outputs must hold whole numbers; got 1.5"),
    (lambda: Lags(outputs=True), TypeError, r"outputs must be an int or a list of ints; got True"),
    (lambda: Lags(outputs=-2), ValueError, r"outputs must be >= 0 when given as an order; got -2"),
    (lambda: Lags(), ValueError, r"Lags has no term at all"),
    (lambda: Lags.arx(na=-1, nb=1), ValueError, r"na must be >= 0; got -1"),
    (
        lambda: Lags(inputs={"motor": [1]}).build(make_data()),
        KeyError,
        r"Lags inputs names 'motor', which is not an input of the data; its inputs are \['u1', 'u2'\]",
    ),
    (
        lambda: Lags(outputs=5).build(make_data(5)),
        ValueError,
        r"has 5 samples, too few for lags up to 5: it needs at least 6",
    ),
    (
        lambda: Lags(outputs=1).build([make_data(5), make_data(5, n_inputs=1)]),
        ValueError,
        r"data\[1\] has channels \['u'\]",
    ),
    (
        lambda: Lags(inputs=[1]).build(IOData(u=np.zeros((5, 0)), y=np.zeros(5))),
        ValueError,
        r"gives no regressor term",
    ),
]


@pytest.mark.parametrize(("call", "error", "message"), BAD)
def test_bad_lags_are_refused(call, error, message) -> None:
    with pytest.raises(error, match=message):
        call()
