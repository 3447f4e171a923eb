"""The free run of a NARX ensemble of multilayer perceptrons: the compiled loop and its packing.

:meth:`neckid.models.neural.narx.NeuralNARX.simulate` calls :func:`mlp_free_run` (numba) on weights
packed once per call by :func:`pack_layers`; the plain NumPy loop it replaced stays in
:mod:`neckid.models.neural.narx` (``compiled=False``) as the reference the tests compare it with.

Per sample the loop builds the regressor ``w(t)`` from the lagged outputs and inputs, runs every
network's layers (``h_k = g(h_{k-1} W_k + b_k)``, identity output layer) and writes the mean of
the networks, de-standardised, as ``y(t)``, which later regressors read back. Nothing is
allocated per sample.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit

from neckid.utils.types import FloatArray, IntArray

__all__ = ["ACTIVATION_CODES", "mlp_free_run", "pack_layers"]


#: The kernel's code of every hidden-layer activation.
ACTIVATION_CODES = {"identity": 0, "tanh": 1, "relu": 2, "logistic": 3}


def pack_layers(
    coefs: Sequence[FloatArray], intercepts: Sequence[FloatArray]
) -> tuple[FloatArray, FloatArray, IntArray]:
    """Flatten stacked layer weights into the kernel's arrays.

    Parameters
    ----------
    coefs, intercepts : sequence of ndarray
        ``coefs[k]`` of shape ``(n_networks, n_in_k, n_out_k)`` and ``intercepts[k]`` of shape
        ``(n_networks, n_out_k)``, one per layer.

    Returns
    -------
    weights : ndarray, shape (sum_k n_networks n_in_k n_out_k,)
        Layer ``k`` of network ``m`` at ``weights[offset + m n_in n_out :]``, row-major
        ``(n_in, n_out)``, the layers one after another.
    biases : ndarray, shape (sum_k n_networks n_out_k,)
        Likewise for the bias vectors.
    sizes : ndarray of int, shape (n_layers + 1,)
        ``n_in_0, n_out_0, n_out_1, ...``: the width of every layer's input and of the output.

    Examples
    --------
    >>> import numpy as np
    >>> w, b, sizes = pack_layers([np.ones((2, 3, 4)), np.ones((2, 4, 1))],
    ...                           [np.zeros((2, 4)), np.zeros((2, 1))])
    >>> w.shape, b.shape, sizes.tolist()
    ((32,), (10,), [3, 4, 1])
    """
    weights = np.concatenate([np.ascontiguousarray(w, dtype=np.float64).ravel() for w in coefs])
    biases = np.concatenate([np.ascontiguousarray(b, dtype=np.float64).ravel() for b in intercepts])
    sizes = np.array([np.shape(coefs[0])[1], *(np.shape(w)[2] for w in coefs)], dtype=np.int64)
    return weights, biases, sizes


@njit(cache=True, error_model="numpy")
def _tanh(z: float) -> float:  # pragma: no cover - compiled; tests compare it with numpy.tanh
    """tanh(z) = sign(z) (1 - 2 / (exp(2 |z|) + 1)): within 2.3e-16 of it, three times faster.

    glibc's ``exp`` is much faster than its ``tanh``; the formula loses relative accuracy only
    where tanh(z) is tiny, and the hidden layers only ever add it up with weights, so what
    counts is the absolute error (rounding). Large ``|z|`` give exactly +-1 (``exp`` overflows
    to inf), NaN stays NaN.
    """
    return math.copysign(1.0 - 2.0 / (math.exp(2.0 * abs(z)) + 1.0), z)


@njit(cache=True, error_model="numpy")
def mlp_free_run(
    u: FloatArray,
    y: FloatArray,
    source: IntArray,
    channel: IntArray,
    lag: IntArray,
    weights: FloatArray,
    biases: FloatArray,
    sizes: IntArray,
    n_networks: int,
    activation: int,
    y_scale: FloatArray,
    y_mean: FloatArray,
    start: int,
) -> None:  # pragma: no cover - compiled; checked against NeuralNARX's NumPy loop
    """Free run: fill ``y[start:]`` in place from ``u`` and the first ``start`` rows of ``y``.

    ``source``, ``channel`` and ``lag`` describe the regressor (``ResolvedLags``: source 0 reads
    ``y``, 1 reads ``u``; ``start`` is at least the largest lag); the first layer's weights
    already act on the raw (unstandardised) regressor. ``activation`` is a code of
    :data:`ACTIVATION_CODES`.
    """
    n = u.shape[0]
    n_terms = lag.shape[0]
    n_outputs = y.shape[1]
    n_layers = sizes.shape[0] - 1
    width = 0
    for k in range(n_layers + 1):
        width = max(width, sizes[k])
    regressor = np.empty(n_terms)
    h = np.empty(width)
    g = np.empty(width)
    total = np.empty(n_outputs)
    for t in range(start, n):
        for j in range(n_terms):
            signal = y if source[j] == 0 else u
            regressor[j] = signal[t - lag[j], channel[j]]
        for o in range(n_outputs):
            total[o] = 0.0
        for net in range(n_networks):
            for j in range(n_terms):
                h[j] = regressor[j]
            w_start = 0
            b_start = 0
            for k in range(n_layers):
                n_in = sizes[k]
                n_out = sizes[k + 1]
                offset = w_start + net * n_in * n_out
                layer = weights[offset : offset + n_in * n_out].reshape((n_in, n_out))
                # g = h W (row by row: the inner loop is contiguous and vectorises), then + b
                for j in range(n_out):
                    g[j] = 0.0
                for i in range(n_in):
                    hi = h[i]
                    for j in range(n_out):
                        g[j] += hi * layer[i, j]
                bias = b_start + net * n_out
                hidden = k < n_layers - 1
                for j in range(n_out):
                    z = g[j] + biases[bias + j]
                    if hidden:
                        if activation == 1:
                            z = _tanh(z)
                        elif activation == 2:
                            z = max(z, 0.0)
                        elif activation == 3:  # logistic, as 0.5 (1 + tanh(z / 2))
                            z = 0.5 * (_tanh(0.5 * z) + 1.0)
                    h[j] = z
                w_start += n_networks * n_in * n_out
                b_start += n_networks * n_out
            for o in range(n_outputs):
                total[o] += h[o]
        for o in range(n_outputs):
            y[t, o] = total[o] / n_networks * y_scale[o] + y_mean[o]
