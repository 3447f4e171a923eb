"""The training rows every NARX model fits on (``NarxModel._prepare_fit``), and their memory.

One experiment gives its regressor rows as built and a read-only view of its outputs (no copy);
several experiments are built one after the other into one preallocated matrix, so that the
rows exist once plus one experiment's worth, not once per experiment and again stacked.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from _synthetic import arx_system
from neckid import Lags, LinearARX

LAGS = Lags.arx(2, 2, 3)


def test_one_experiment_gives_its_rows_and_a_view_of_its_outputs() -> None:
    data = arx_system(600, 0)
    x, y = LinearARX(LAGS)._prepare_fit(data)
    x_ref, y_ref = LAGS.build(data)
    np.testing.assert_array_equal(x, x_ref)
    np.testing.assert_array_equal(y, y_ref)
    assert x.flags.c_contiguous and x.flags.writeable  # a new array the model may take over
    assert not y.flags.writeable  # the data's own outputs: a fit cannot change them
    assert np.shares_memory(y, data.y)


def test_several_experiments_fill_one_matrix_in_their_order() -> None:
    runs = [arx_system(n, seed) for seed, n in enumerate([300, 451, 80])]
    x, y = LinearARX(LAGS)._prepare_fit(runs)
    x_ref, y_ref = LAGS.build(runs)
    np.testing.assert_array_equal(x, x_ref)
    np.testing.assert_array_equal(y, y_ref)
    assert x.shape[0] == sum(r.n_samples - LAGS.resolve(runs).max_lag for r in runs)


def test_several_experiments_are_stacked_without_a_second_copy_of_all_rows() -> None:
    lags = Lags.arx(20, 20, 1)  # 40 terms: the rows dwarf everything else
    runs = [arx_system(20_000, seed) for seed in range(4)]
    model = LinearARX(lags)
    model._prepare_fit(runs[:1])  # warm up
    tracemalloc.start()
    try:
        start = tracemalloc.get_traced_memory()[0]
        x, _ = model._prepare_fit(runs)
        peak = tracemalloc.get_traced_memory()[1] - start
    finally:
        tracemalloc.stop()
    # the stack (x and y) and one experiment's rows: 1.25x the rows, not 2x as with np.vstack
    assert peak < 1.4 * x.nbytes, peak / x.nbytes


def test_a_record_too_short_for_the_lags_is_refused_by_name() -> None:
    runs = [arx_system(300, 0), arx_system(3, 1).renamed("short run")]
    with pytest.raises(ValueError, match=r"short run has 3 samples, too few for lags up to 4"):
        LinearARX(LAGS)._prepare_fit(runs)
