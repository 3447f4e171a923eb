r"""How far a free run may go before it counts as a runaway: the divergence envelope's reach.

A free run that leaves its output's training range widened :data:`DIVERGENCE_SPANS` times its
width on each side raises :class:`~neckid.models.results.DivergenceError`. On a log whose inputs
stay in their training ranges that is a runaway. On a log whose inputs go further than the
training ones (steps of 20–50 after training on 0–3), a correct model *follows* its inputs
beyond that range: its output is an extrapolation, not a divergence. So the envelope widens by
what the inputs' reach can explain:

- **a linear model** (an impulse response ``h_{o,i}`` from input ``i`` to output ``o``): write
  the log's input as ``u = ū + d``, ``ū`` the input clipped to its training range and
  ``|d(t)| <= r_i``, the input's *reach* beyond that range. By superposition the output is the
  response to ``ū`` (inside the plain envelope for a model that is not running away) plus the
  response to ``d``, bounded by ``Σ_i ||h_{o,i}||_1 r_i`` (Young's inequality for the
  convolution; ``||h||_1`` is at least the DC gain ``|Σ_k h_k|``). The envelope widens on each
  side by that sum. An unstable model has ``||h||_1 = ∞``: its envelope is not widened, and its
  runaway is stopped as before;
- **any other model**: a conservative extension by the inputs' *relative* reach
  ``ρ = max_i r_i / w_i`` (``w_i`` the input's training width): each side widens by
  ``DIVERGENCE_SPANS · ρ`` output widths, as if the output could move ``DIVERGENCE_SPANS``
  output widths per training width the inputs go beyond.

With inputs inside their training ranges ``r = 0`` and the envelope is the plain one. A runaway
still leaves any finite envelope: it grows without bound, while the widened envelope is fixed by
the log's inputs before the run starts.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from neckid.data.iodata import IOData
from neckid.models.results import DIVERGENCE_SPANS
from neckid.utils.types import FloatArray

__all__ = ["MAX_IMPULSE_SAMPLES", "impulse_l1", "input_reach", "reach_widening"]

#: Longest impulse response :func:`impulse_l1` reads before calling a model not stable enough.
MAX_IMPULSE_SAMPLES = 1 << 17

_FIRST_IMPULSE_SAMPLES = 1024
_TAIL_TOLERANCE = 1e-9


def input_reach(
    ranges: Mapping[str, tuple[float, float]], data: IOData
) -> dict[str, tuple[float, float]]:
    """Per input of ``data`` with a training range: ``(reach r_i, training width w_i)``.

    ``r_i = max(0, max u_i − high_i, low_i − min u_i)`` over the log's finite samples (0 for an
    input inside its range); inputs without a training range are left out.
    """
    reach: dict[str, tuple[float, float]] = {}
    for j, name in enumerate(data.input_names):
        if name not in ranges:
            continue
        column = np.asarray(data.u[:, j], dtype=np.float64)
        if column.size == 0:
            continue
        smallest, largest = float(column.min()), float(column.max())
        if not (math.isfinite(smallest) and math.isfinite(largest)):  # NaN or inf: drop them
            column = column[np.isfinite(column)]
            if column.size == 0:
                continue
            smallest, largest = float(column.min()), float(column.max())
        low, high = ranges[name]
        r = max(0.0, largest - high, low - smallest)
        reach[name] = (r, float(high - low))
    return reach


def impulse_l1(
    run: Callable[[FloatArray], FloatArray], n_inputs: int, n_outputs: int
) -> FloatArray:
    """``||h_{o,i}||_1`` of a linear map from its impulse responses; ``inf`` where not decayed.

    Parameters
    ----------
    run : callable
        ``run(u)`` with ``u`` of shape ``(n, n_inputs)`` returns the zero-state, zero-offset
        response of shape ``(n, n_outputs)``.
    n_inputs, n_outputs : int
        The map's size.

    Returns
    -------
    ndarray, shape (n_outputs, n_inputs)
        The sum of ``|h|`` over the response; ``inf`` when the response has not decayed (its last
        eighth holds more than ``1e-9`` of the sum, or a value is not finite) by
        :data:`MAX_IMPULSE_SAMPLES` samples: an unstable or barely stable model.
    """
    norms = np.full((n_outputs, n_inputs), np.inf)
    for i in range(n_inputs):
        n = _FIRST_IMPULSE_SAMPLES
        while n <= MAX_IMPULSE_SAMPLES:
            u = np.zeros((n, n_inputs))
            u[0, i] = 1.0
            with np.errstate(over="ignore", invalid="ignore"):
                h = np.abs(np.asarray(run(u), dtype=np.float64))
            if not np.all(np.isfinite(h)):
                break
            total, tail = h.sum(axis=0), h[n - n // 8 :].sum(axis=0)
            if np.all(tail <= _TAIL_TOLERANCE * np.maximum(total, 1e-300)):
                norms[:, i] = total
                break
            n *= 4
    return norms


def reach_widening(
    reach: Mapping[str, tuple[float, float]],
    input_names: Sequence[str],
    output_widths: FloatArray,
    gains: FloatArray | None,
) -> FloatArray:
    """How much each side of each output's envelope widens for the inputs' ``reach``.

    ``gains``: ``||h_{o,i}||_1`` of a linear model (shape ``(n_outputs, n_inputs)`` over
    ``input_names``), or None for a model without an impulse response (the relative-reach rule
    of the module docstring). Zero where no input reaches beyond its range.
    """
    widths = np.asarray(output_widths, dtype=np.float64)
    r = np.array([reach.get(name, (0.0, 1.0))[0] for name in input_names], dtype=np.float64)
    if not np.any(r > 0):
        return np.zeros_like(widths)
    if gains is not None:
        g = np.asarray(gains, dtype=np.float64)
        with np.errstate(invalid="ignore"):
            extra = np.where(r > 0, g * r, 0.0).sum(axis=1)
        return np.where(np.isfinite(extra), extra, 0.0)  # unstable: no widening
    w = np.array([reach.get(name, (0.0, 1.0))[1] for name in input_names], dtype=np.float64)
    # an input constant in training has no width to scale by: its reach counts in its units
    relative = np.where(w > 0, r / np.where(w > 0, w, 1.0), r)
    rho = float(relative.max()) if relative.size else 0.0
    return DIVERGENCE_SPANS * rho * widths
