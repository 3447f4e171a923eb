"""C export of the neural NARX ensemble (``nn``): the compiled free run's layers, sum by sum.

The standardisation of the regressor is folded into every network's first layer, as the free
run folds it (:meth:`neckid.models.neural.narx.NeuralNARX.simulate`); the packed weights are
that run's. A step runs every network (``h_k = g(h_{k-1} W_k + b_k)``, the
output layer linear), averages them and de-standardises; ``tanh`` is the free run's formula
``sign(z) (1 - 2 / (exp(2|z|) + 1))``, the logistic ``(tanh(z/2) + 1) / 2``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from neckid.export.c.literals import c_array, c_int_array
from neckid.export.c.narx import narx_model
from neckid.export.c.program import CModel

__all__ = ["c_neural"]

_ACTIVATIONS = {
    "identity": "",
    "tanh": "                        z = NAME_tanh(z);\n",
    "relu": "                        z = z > 0.0 ? z : 0.0;\n",
    "logistic": "                        z = 0.5 * (NAME_tanh(0.5 * z) + 1.0);\n",
}

_TANH = r"""
static double NAME_tanh(double z)
{
    return copysign(1.0 - 2.0 / (exp(2.0 * fabs(z)) + 1.0), z);
}
"""

_MAP = (
    "    {\n"
    "        double h[NAME_WIDTH], g[NAME_WIDTH], total[NAME_N_OUTPUTS];\n"
    "        long net, k, i, j, o, w_start, b_start;\n"
    "        for (o = 0; o < NAME_N_OUTPUTS; ++o) total[o] = 0.0;\n"
    "        for (net = 0; net < NAME_N_NETWORKS; ++net) {\n"
    "            for (j = 0; j < NAME_N_TERMS; ++j) h[j] = w[j];\n"
    "            w_start = 0;\n"
    "            b_start = 0;\n"
    "            for (k = 0; k < NAME_N_LAYERS; ++k) {\n"
    "                long n_in = NAME_sizes[k], n_out = NAME_sizes[k + 1];\n"
    "                const double *layer = NAME_weights + w_start + net * n_in * n_out;\n"
    "                const double *bias = NAME_biases + b_start + net * n_out;\n"
    "                for (j = 0; j < n_out; ++j) g[j] = 0.0;\n"
    "                for (i = 0; i < n_in; ++i)\n"
    "                    for (j = 0; j < n_out; ++j) g[j] += h[i] * layer[i * n_out + j];\n"
    "                for (j = 0; j < n_out; ++j) {\n"
    "                    double z = g[j] + bias[j];\n"
    "                    if (k < NAME_N_LAYERS - 1) {\n"
    "@ACTIVATION@"
    "                    }\n"
    "                    h[j] = z;\n"
    "                }\n"
    "                w_start += NAME_N_NETWORKS * n_in * n_out;\n"
    "                b_start += NAME_N_NETWORKS * n_out;\n"
    "            }\n"
    "            for (o = 0; o < NAME_N_OUTPUTS; ++o) total[o] += h[o];\n"
    "        }\n"
    "        for (o = 0; o < NAME_N_OUTPUTS; ++o)\n"
    "            out[o] = total[o] / NAME_N_NETWORKS * NAME_y_scale[o] + NAME_y_mean[o];\n"
    "    }\n"
)


def c_neural(model: Any) -> CModel:
    """The C export of a fitted :class:`~neckid.NeuralNARX` (its registry entry's ``c_export``)."""
    activation = str(model.activation)
    if activation not in _ACTIVATIONS:
        raise ValueError(f"activation {activation!r} has no C export")
    coefs, intercepts = model.coefs_, model.intercepts_
    w1 = coefs[0] / model.x_scale_[None, :, None]
    b1 = intercepts[0] - (model.x_mean_ / model.x_scale_) @ coefs[0]
    layers, offsets = [w1, *coefs[1:]], [b1, *intercepts[1:]]
    # packed as the free run packs them: every network's layer k, row-major, layer after layer
    weights = np.concatenate([np.ascontiguousarray(w, dtype=np.float64).ravel() for w in layers])
    biases = np.concatenate([np.ascontiguousarray(b, dtype=np.float64).ravel() for b in offsets])
    sizes = np.array([np.shape(w1)[1], *(np.shape(w)[2] for w in layers)], dtype=np.int64)
    constants = "\n".join(
        [
            f"#define NAME_N_TERMS {int(model.lags_.n_terms)}",
            f"#define NAME_N_NETWORKS {int(w1.shape[0])}",
            f"#define NAME_N_LAYERS {int(sizes.shape[0]) - 1}",
            f"#define NAME_WIDTH {int(np.max(sizes))}",
            c_array("NAME_weights", weights),
            c_array("NAME_biases", biases),
            c_int_array("NAME_sizes", sizes),
            c_array("NAME_y_scale", model.y_scale_),
            c_array("NAME_y_mean", model.y_mean_),
            _TANH if activation in ("tanh", "logistic") else "",
        ]
    )
    notes = [
        f"y(t) = mean over {int(w1.shape[0])} networks of h_L(w(t)) .* y_scale + y_mean,",
        f"h_k = g(h_(k-1) W_k + b_k), g = {activation} (the output layer linear), the regressor's",
        "standardisation folded into W_1 and b_1; layer widths: "
        + ", ".join(str(int(s)) for s in sizes),
    ]
    step = _MAP.replace("@ACTIVATION@", _ACTIVATIONS[activation] or "                        ;\n")
    return narx_model(model, "Neural NARX ensemble (neckid NeuralNARX)", notes, constants, step)
