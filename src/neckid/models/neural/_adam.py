"""Compiled kernels of the ensemble trainer: one epoch of mini-batch Adam, the validation R².

:mod:`neckid.models.neural._training` drives them one epoch at a time. Every network of an
ensemble keeps its parameters in one row of a ``(n_networks, n_params)`` array, layer after
layer, each as its weight matrix ``W_k`` (row-major ``(n_in, n_out)``) then its bias ``b_k``
(:func:`layout`). The networks of one call run in parallel (``prange``), each on its own rows:
nothing is shared between them, so a network's result does not depend on the threads.

The arithmetic is scikit-learn's ``MLPRegressor`` with ``solver="adam"`` (version 1.9), formula
by formula: loss ``½ mean (out − y)² + ½ α Σ‖W‖² / n_batch``, back-propagation through the
hidden activations, gradients ``(aᵀ δ + α W) / n_batch`` and ``Σ δ / n_batch``, and Adam
(Kingma & Ba 2015, Algorithm 1 with the bias correction folded into the step) with
``β₁ = 0.9, β₂ = 0.999, ε = 1e-8``. Only the order of the sums differs (loops here, BLAS
there), so the weights agree to rounding (the tests run both on the same draws).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numba import njit, prange

from neckid.utils.types import FloatArray, IntArray

__all__ = ["adam_epoch", "layout", "validation_r2"]

#: Adam's constants, as scikit-learn's MLPRegressor sets them.
BETA_1 = 0.9
BETA_2 = 0.999
EPSILON = 1e-8


def layout(sizes: IntArray) -> IntArray:
    """Offsets of every layer's weights and biases in a network's parameter row.

    Returns ``(n_layers + 1, 2)``: row ``k`` holds where ``W_k`` and ``b_k`` start; the last row
    holds the row's length twice.

    Examples
    --------
    >>> layout(np.array([3, 4, 1])).tolist()
    [[0, 12], [16, 20], [21, 21]]
    """
    rows = []
    start = 0
    for n_in, n_out in itertools.pairwise(sizes):
        rows.append([start, start + n_in * n_out])
        start += n_in * n_out + n_out
    rows.append([start, start])
    return np.array(rows, dtype=np.int64)


#: ln 2 split in a part exact in a few bits and the rest (fdlibm's constants), and log2(e).
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_LOG2_E = 1.4426950408889634


@njit(cache=True, error_model="numpy", inline="always")
def _tanh(z: float) -> float:  # pragma: no cover - compiled; tests compare it with numpy.tanh
    """tanh(z) = sign(z) (1 − 2 / (e^{2|z|} + 1)), with an exponential loops can vectorise.

    ``e^x`` for ``x = min(2|z|, 40)`` (beyond 40 the result is ±1 exactly): ``x = k ln 2 + r``
    with ``|r| ≤ ln 2 / 2``, ``e^r`` by its Taylor polynomial of degree 13 (truncation below
    5e-18), ``2^k`` as a product of the powers ``2^(2^b)`` of the bits of ``k`` (exact). No call
    and no branch, so the hidden layers' loops run it in SIMD lanes: about 3 ns per value
    against 14 ns for ``math.tanh``. Its absolute error is that of ``math.tanh`` (2.2e-16 on a
    million normal draws of scale 3, against ``numpy.tanh``); NaN stays NaN.
    """
    x = min(2.0 * abs(z), 40.0)
    kf = math.floor(x * _LOG2_E + 0.5)
    r = (x - kf * _LN2_HI) - kf * _LN2_LO
    p = 1.0 / 6227020800.0
    p = 1.0 / 479001600.0 + r * p
    p = 1.0 / 39916800.0 + r * p
    p = 1.0 / 3628800.0 + r * p
    p = 1.0 / 362880.0 + r * p
    p = 1.0 / 40320.0 + r * p
    p = 1.0 / 5040.0 + r * p
    p = 1.0 / 720.0 + r * p
    p = 1.0 / 120.0 + r * p
    p = 1.0 / 24.0 + r * p
    p = 1.0 / 6.0 + r * p
    p = 0.5 + r * p
    p = 1.0 + r * p
    p = 1.0 + r * p
    k = int(kf)
    scale = 2.0 if k & 1 else 1.0
    scale *= 4.0 if k & 2 else 1.0
    scale *= 16.0 if k & 4 else 1.0
    scale *= 256.0 if k & 8 else 1.0
    scale *= 65536.0 if k & 16 else 1.0
    scale *= 4294967296.0 if k & 32 else 1.0
    return math.copysign(1.0 - 2.0 / (p * scale + 1.0), z)


@njit(cache=True, error_model="numpy", fastmath={"reassoc", "nsz"})
def _dot(a: FloatArray, b: FloatArray, n: int) -> float:  # pragma: no cover - compiled
    """``sum(a[:n] * b[:n])`` in any order (so in SIMD lanes), as BLAS would sum it."""
    total = 0.0
    for r in range(n):
        total += a[r] * b[r]
    return total


@njit(cache=True, error_model="numpy", fastmath={"reassoc", "nsz"})
def _sum(a: FloatArray, n: int) -> float:  # pragma: no cover - compiled
    """``sum(a[:n])`` in any order."""
    total = 0.0
    for r in range(n):
        total += a[r]
    return total


@njit(cache=True, error_model="numpy", inline="always")
def _weighted_rows(
    out: FloatArray, rows: FloatArray, weights: FloatArray, n: int
) -> None:  # pragma: no cover - compiled
    """``out[:n] = Σ_c weights[c] rows[c, :n]``, one row at a time (the loop over ``n`` vectorises)."""
    for r in range(n):
        out[r] = 0.0
    for c in range(weights.shape[0]):
        weight = weights[c]
        row = rows[c]
        for r in range(n):
            out[r] += row[r] * weight


@njit(cache=True, error_model="numpy")
def _forward(
    x: FloatArray,
    rows: IntArray,
    params: FloatArray,
    sizes: IntArray,
    offsets: IntArray,
    activation: int,
    values: FloatArray,
) -> None:  # pragma: no cover - compiled
    """Every layer's output for the rows ``rows`` of ``x``: ``values[k, j, r]``, unit ``j``.

    ``values`` is ``(n_layers + 1, width, ≥ n_rows)``, a unit's values over the rows contiguous
    (the loops over rows vectorise); ``values[0]`` gets the inputs.
    """
    n_layers = sizes.shape[0] - 1
    n = rows.shape[0]
    for r in range(n):
        for i in range(sizes[0]):
            values[0, i, r] = x[rows[r], i]
    for k in range(n_layers):
        n_in = sizes[k]
        n_out = sizes[k + 1]
        w = params[offsets[k, 0] : offsets[k, 0] + n_in * n_out].reshape((n_in, n_out))
        b = params[offsets[k, 1] : offsets[k, 1] + n_out]
        hidden = k < n_layers - 1
        for j in range(n_out):
            out = values[k + 1, j]
            _weighted_rows(out, values[k, :n_in], w[:, j], n)
            bias = b[j]
            # one loop per activation: each runs in SIMD lanes
            if hidden and activation == 1:
                for r in range(n):
                    out[r] = _tanh(out[r] + bias)
            elif hidden and activation == 2:
                for r in range(n):
                    out[r] = max(out[r] + bias, 0.0)
            elif hidden and activation == 3:  # the logistic function, 0.5 (1 + tanh(z / 2))
                for r in range(n):
                    out[r] = 0.5 * (1.0 + _tanh(0.5 * (out[r] + bias)))
            else:
                for r in range(n):
                    out[r] += bias


@njit(cache=True, error_model="numpy")
def _batch_gradient(
    x: FloatArray,
    y: FloatArray,
    rows: IntArray,
    params: FloatArray,
    sizes: IntArray,
    offsets: IntArray,
    activation: int,
    alpha: float,
    values: FloatArray,
    deltas: FloatArray,
    grad: FloatArray,
) -> float:  # pragma: no cover - compiled
    """Loss of one mini-batch and its gradient (into ``grad``), as MLPRegressor's ``_backprop``.

    ``deltas[k, j, r]`` is the loss's derivative by unit ``j``'s input in layer ``k``.
    """
    n_layers = sizes.shape[0] - 1
    n = rows.shape[0]
    n_outputs = sizes[n_layers]
    _forward(x, rows, params, sizes, offsets, activation, values)
    last = n_layers - 1
    squares = 0.0
    for o in range(n_outputs):
        for r in range(n):
            d = values[n_layers, o, r] - y[rows[r], o]
            deltas[last, o, r] = d
            squares += d * d
    penalty = 0.0
    for k in range(n_layers):
        for p in range(offsets[k, 0], offsets[k, 1]):
            penalty += params[p] * params[p]
    loss = 0.5 * (squares / n / n_outputs) + 0.5 * alpha * penalty / n
    for k in range(last, -1, -1):
        n_in = sizes[k]
        n_out = sizes[k + 1]
        w = params[offsets[k, 0] : offsets[k, 0] + n_in * n_out].reshape((n_in, n_out))
        gw = grad[offsets[k, 0] : offsets[k, 0] + n_in * n_out].reshape((n_in, n_out))
        gb = grad[offsets[k, 1] : offsets[k, 1] + n_out]
        # gradient of W_k: (a_kᵀ δ_k + α W_k) / n; of b_k: Σ δ_k / n
        for i in range(n_in):
            for j in range(n_out):
                gw[i, j] = (_dot(values[k, i], deltas[k, j], n) + alpha * w[i, j]) / n
        for j in range(n_out):
            gb[j] = _sum(deltas[k, j], n) / n
        if k == 0:
            break
        # δ_{k-1} = (δ_k W_kᵀ) · g'(a_k), with g' written in the layer's output a_k
        for i in range(n_in):
            back = deltas[k - 1, i]
            _weighted_rows(back, deltas[k, :n_out], w[i], n)
            a = values[k, i]
            if activation == 1:
                for r in range(n):
                    back[r] *= 1.0 - a[r] * a[r]
            elif activation == 2:
                for r in range(n):
                    if a[r] == 0.0:
                        back[r] = 0.0
            elif activation == 3:
                for r in range(n):
                    back[r] = back[r] * a[r] * (1.0 - a[r])
    return loss


@njit(cache=True, error_model="numpy", parallel=True)
def adam_epoch(
    x: FloatArray,
    y: FloatArray,
    order: IntArray,
    active: IntArray,
    params: FloatArray,
    first: FloatArray,
    second: FloatArray,
    steps: IntArray,
    sizes: IntArray,
    offsets: IntArray,
    activation: int,
    alpha: float,
    learning_rate: float,
    batch_size: int,
    losses: FloatArray,
) -> None:  # pragma: no cover - compiled; the tests compare it with MLPRegressor
    """One epoch of mini-batch Adam for the networks ``active``, in parallel, in place.

    Network ``m`` visits the rows ``order[m]`` of ``x`` and ``y`` in that order, in batches of
    ``batch_size`` (the last one shorter), and after each batch updates ``params[m]`` with its
    moments ``first[m]``, ``second[m]`` and step count ``steps[m]``. ``losses[m]`` gets the
    epoch's mean batch loss, weighted by the batch sizes (MLPRegressor's ``loss_``).
    """
    n_layers = sizes.shape[0] - 1
    width = 0
    for k in range(n_layers + 1):
        width = max(width, sizes[k])
    n_train = order.shape[1]
    n_params = params.shape[1]
    for a in prange(active.shape[0]):
        m = active[a]
        values = np.empty((n_layers + 1, width, batch_size))
        deltas = np.empty((n_layers, width, batch_size))
        grad = np.empty(n_params)
        row = params[m]
        m1 = first[m]
        m2 = second[m]
        total = 0.0
        for start in range(0, n_train, batch_size):
            stop = min(start + batch_size, n_train)
            rows = order[m, start:stop]
            loss = _batch_gradient(
                x, y, rows, row, sizes, offsets, activation, alpha, values, deltas, grad
            )
            total += loss * (stop - start)
            steps[m] += 1
            t = steps[m]
            step = learning_rate * math.sqrt(1.0 - BETA_2**t) / (1.0 - BETA_1**t)
            for p in range(n_params):
                g = grad[p]
                m1[p] = BETA_1 * m1[p] + (1.0 - BETA_1) * g
                m2[p] = BETA_2 * m2[p] + (1.0 - BETA_2) * (g * g)
                row[p] += -step * m1[p] / (math.sqrt(m2[p]) + EPSILON)
        losses[m] = total / n_train


@njit(cache=True, error_model="numpy", parallel=True)
def validation_r2(
    x: FloatArray,
    y: FloatArray,
    rows: IntArray,
    active: IntArray,
    params: FloatArray,
    sizes: IntArray,
    offsets: IntArray,
    activation: int,
    scores: FloatArray,
) -> None:  # pragma: no cover - compiled; the tests compare it with MLPRegressor
    """``scores[m]``: R² of network ``m`` on the rows ``rows[m]``, averaged over the outputs.

    As scikit-learn's ``r2_score`` (uniform average, finite): an output whose targets are
    constant scores 1 when predicted exactly and 0 otherwise; a prediction that is not finite
    scores NaN.
    """
    n_layers = sizes.shape[0] - 1
    n_outputs = sizes[n_layers]
    width = 0
    for k in range(n_layers + 1):
        width = max(width, sizes[k])
    n_rows = rows.shape[1]
    for a in prange(active.shape[0]):
        m = active[a]
        values = np.empty((n_layers + 1, width, n_rows))
        _forward(x, rows[m], params[m], sizes, offsets, activation, values)
        finite = True
        score = 0.0
        for o in range(n_outputs):
            mean = 0.0
            for r in range(n_rows):
                mean += y[rows[m, r], o]
            mean /= n_rows
            residual = 0.0
            spread = 0.0
            for r in range(n_rows):
                target = y[rows[m, r], o]
                out = values[n_layers, o, r]
                if not math.isfinite(out):
                    finite = False
                residual += (target - out) ** 2
                spread += (target - mean) ** 2
            if spread != 0.0:
                score += 1.0 - residual / spread
            elif residual == 0.0:
                score += 1.0
        scores[m] = score / n_outputs if finite else np.nan
