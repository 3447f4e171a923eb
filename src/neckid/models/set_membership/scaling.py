"""The distance of the Set Membership family: per-component weights of the regressor.

The SM bounds measure how far a regressor is from the training ones by a weighted Euclidean
distance ``‖(w − w_k) · weights‖``; ``scaling`` chooses the weights (``"std"``: one over each
component's standard deviation, ``"none"``, ``"gradient"``: the std weights that
:func:`~neckid.models.set_membership.metric.learnt_weights` multiplies, or the user's own), and
``input_weight`` multiplies those of the input terms.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from neckid.regressors import ResolvedLags
from neckid.utils.types import FloatArray

__all__ = ["distance_weights", "term_weights"]


def distance_weights(scaling: Any, x: FloatArray, names: Sequence[str]) -> FloatArray:
    """The per-component weights of the distance (scaled regressor = regressor * weights)."""
    n_terms = x.shape[1]
    if isinstance(scaling, str):
        if scaling == "none":
            return np.ones(n_terms)
        if scaling in ("std", "gradient"):  # "gradient": sm_metric.learnt_weights multiplies these
            # column by column: a temporary of one column, not of the whole matrix
            std = np.array([x[:, k].std() for k in range(n_terms)])
            constant = std == 0
            if constant.any():
                warnings.warn(
                    f"regressor terms {[names[int(i)] for i in np.flatnonzero(constant)]} are constant"
                    " in the training data; they get weight 1 in the distance (drop those lags if"
                    " they carry nothing)",
                    stacklevel=3,
                )
            return np.where(constant, 1.0, 1.0 / np.where(constant, 1.0, std))
        raise ValueError(
            f"scaling must be 'std', 'gradient', 'none' or an array of weights; got {scaling!r}"
        )
    try:
        weights = np.asarray(scaling, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"scaling must be 'std', 'none' or an array of weights; got {scaling!r}"
        ) from exc
    if weights.shape != (n_terms,):
        raise ValueError(
            f"scaling weights must have one value per regressor term ({n_terms}: {list(names)});"
            f" got shape {weights.shape}"
        )
    if not np.all(np.isfinite(weights)) or np.any(weights <= 0):
        raise ValueError(f"scaling weights must be finite and > 0; got {weights.tolist()}")
    return weights.copy()


def term_weights(scaling: Any, input_weight: Any, x: FloatArray, lags: ResolvedLags) -> FloatArray:
    """The weights of :func:`distance_weights`, with the input terms' multiplied by ``input_weight``."""
    weights = distance_weights(scaling, x, lags.names)
    return np.where(lags.source == 1, float(input_weight) * weights, weights)
