"""Where a model was identified: is each regressor of a new log inside what training saw.

A model identified on one payload, range or controller says little about regressors far from
its training regressors. Two measures, per sample of a new log (its one-step regressors, built
from the *measured* outputs):

- **the training box**: every regressor term (``inclination(t-1)``, ``motor_position(t-2)``,
  ...) within the range it took in training (``regressor_ranges_``, recorded by every NARX
  model at ``fit`` and saved in its file). Reported by term and by channel;
- **the nearest training regressor** (Set Membership models): the distance, in the model's own
  scaled regressor space (its ``weights_``), to the closest training regressor, against a
  radius: the 99th percentile of the training regressors' own nearest-neighbour distances. A
  regressor inside the box can still be far from every training regressor (a combination the
  experiment never produced); the SM bounds widen there, the other models just extrapolate.

:func:`regressor_domain` computes both; ``Estimator.domain(data)`` is the method form, and a
free run's :class:`~neckid.models.base.ExtrapolationWarning` counts the box
(:func:`box_shares`). :func:`regressor_terms` and :func:`channel_terms` give the training box
and the channels' training ranges as the compiled passes read them
(:mod:`neckid.models._domain_kernels`), for a free run that counts them itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from neckid.data.iodata import IOData
from neckid.utils.types import BoolArray, FloatArray, IntArray

__all__ = [
    "NEAREST_QUANTILE",
    "Domain",
    "box_shares",
    "channel_terms",
    "regressor_box",
    "regressor_domain",
    "regressor_terms",
]

#: The radius of the nearest-regressor domain: this quantile of the training regressors'
#: distances to their own nearest neighbour.
NEAREST_QUANTILE = 0.99
#: Training regressors the radius is estimated on (a seeded subsample beyond that).
RADIUS_SAMPLE = 20_000


@dataclass(frozen=True)
class Domain:
    """Which samples of a log lie outside a model's domain, and why.

    Attributes
    ----------
    outside : ndarray of bool, shape (n_samples,)
        Per sample: a regressor term outside its training range, or (SM) farther than
        ``radius`` from every training regressor. False for the initial samples.
    by_term : dict of str to float
        Regressor term -> share of the samples (after the initial ones) where it is outside its
        training range.
    by_channel : dict of str to float
        Channel -> share of the samples where one of its terms is outside.
    distance : ndarray, shape (n_samples,), or None
        SM models: the distance to the nearest training regressor (scaled space; NaN for the
        initial samples).
    radius : float or None
        SM models: the radius the distance is compared with.
    n_initial : int
        The initial samples (no regressor).
    """

    outside: BoolArray
    by_term: dict[str, float]
    by_channel: dict[str, float]
    distance: FloatArray | None
    radius: float | None
    n_initial: int

    @property
    def share(self) -> float:
        """Share of the samples (after the initial ones) outside the domain."""
        rows = self.outside[self.n_initial :]
        return float(rows.mean()) if rows.size else 0.0


def regressor_box(x: FloatArray, names: tuple[str, ...]) -> dict[str, tuple[float, float]]:
    """Each regressor term's training range: name -> (lowest, highest)."""
    low, high = x.min(axis=0), x.max(axis=0)
    return {name: (float(low[j]), float(high[j])) for j, name in enumerate(names)}


def regressor_terms(model: Any) -> tuple[list[str], IntArray, FloatArray]:
    """The regressor terms of a fitted NARX model with a training range, as compiled passes read them.

    Returns
    -------
    names : list of str
        The terms' names, in the order of ``model.lags_.names`` (terms without a range left out).
    terms : ndarray of int64, shape (n_terms, 3)
        ``(source, channel, lag)`` of each: source 0 for an output, 1 for an input.
    bounds : ndarray, shape (n_terms, 2)
        ``(low, high)`` of each, from ``model.regressor_ranges_``.
    """
    lags = model.lags_
    box: dict[str, tuple[float, float]] = getattr(model, "regressor_ranges_", {})
    columns = (lags.source.tolist(), lags.channel.tolist(), lags.lag.tolist())
    kept = [(name, term) for name, *term in zip(lags.names, *columns, strict=True) if name in box]
    terms = np.array([term for _, term in kept], dtype=np.int64).reshape(-1, 3)
    bounds = np.array([box[name] for name, _ in kept], dtype=np.float64).reshape(-1, 2)
    return [name for name, _ in kept], terms, bounds


def channel_terms(model: Any, data: IOData) -> tuple[list[str], IntArray, FloatArray]:
    """The channels of ``data`` that ``model`` has a training range for, as terms of lag 0.

    The channels ``Estimator.extrapolation`` counts, in its order (the inputs, then the
    outputs): their names, their ``(source, channel, 0)`` rows and their ``(low, high)`` rows
    from ``model.training_ranges_`` (see :func:`regressor_terms`).
    """
    ranges: dict[str, tuple[float, float]] = getattr(model, "training_ranges_", {})
    found = [
        (name, source, channel)
        for source, names in ((1, data.input_names), (0, data.output_names))
        for channel, name in enumerate(names)
        if name in ranges
    ]
    terms = np.array([(source, channel, 0) for _, source, channel in found], np.int64)
    bounds = np.array([ranges[name] for name, _, _ in found], dtype=np.float64)
    return [name for name, _, _ in found], terms.reshape(-1, 3), bounds.reshape(-1, 2)


def box_shares(model: Any, data: IOData) -> tuple[float, dict[str, float]]:
    """``Domain.share`` and ``Domain.by_term`` of the training box alone, in one compiled pass.

    The same numbers as :func:`regressor_domain` with ``nearest=False``, without building the
    regressor matrix (every free run's extrapolation warning counts them).
    """
    from neckid.models._domain_kernels import box_counts, channels_of

    lags = model.lags_
    data = model._with_conditions(data)
    lags.check_compatible(data)
    names, terms, bounds = regressor_terms(model)
    counts, rows = box_counts(
        channels_of(data.y),
        channels_of(data.u),
        terms,
        bounds,
        lags.max_lag,
    )
    n_rows = data.n_samples - lags.max_lag
    return rows / n_rows, {name: int(c) / n_rows for name, c in zip(names, counts, strict=True)}


def _nearest(model: Any, x: FloatArray) -> tuple[FloatArray, float] | None:
    """Distances of ``x`` to the nearest training regressor of an SM model, and the radius."""
    from scipy.spatial import cKDTree

    core = getattr(model, "core_", None)
    if core is None:
        return None
    points = core.tree.points
    tree = cKDTree(points)
    sample = points
    if points.shape[0] > RADIUS_SAMPLE:
        rows = np.random.default_rng(0).choice(points.shape[0], RADIUS_SAMPLE, replace=False)
        sample = points[rows]
    if points.shape[0] < 2:
        return None
    own, _ = tree.query(sample, k=2)
    radius = float(np.quantile(own[:, 1], NEAREST_QUANTILE))
    distance, _ = tree.query(x * core.weights, k=1)
    return np.asarray(distance, dtype=np.float64), radius


def regressor_domain(model: Any, data: IOData, *, nearest: bool = True) -> Domain:
    """Which samples of ``data`` are outside the domain of a fitted NARX model (see the module).

    Parameters
    ----------
    model : fitted NARX model
        With ``lags_`` and ``regressor_ranges_`` (models fitted or saved before the ranges were
        recorded have none: then only the nearest-regressor measure, for SM models).
    data : IOData
        A log with the model's channels and its measured outputs.
    nearest : bool, default True
        Also the nearest-training-regressor distance (SM models; builds a kd-tree).

    Returns
    -------
    Domain

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> u = np.sin(np.arange(300) / 10.0)
    >>> y = np.convolve(u, [0.0, 0.5])[:300]
    >>> model = LinearARX(Lags.arx(1, 1)).fit(IOData(u, y, ts=0.1))
    >>> wider = IOData(2 * u, 2 * y, ts=0.1)
    >>> found = regressor_domain(model, wider)
    >>> round(found.share, 2), sorted(found.by_channel)
    (0.7, ['u', 'y'])
    """
    lags = model.lags_
    data = model._with_conditions(data)
    x, _ = lags.build_one(data)
    m = lags.max_lag
    outside = np.zeros(data.n_samples, dtype=bool)
    box: dict[str, tuple[float, float]] = getattr(model, "regressor_ranges_", {})
    by_term: dict[str, float] = {}
    by_channel: dict[str, float] = {}
    channel_of = [
        (lags.output_names if source == 0 else lags.input_names)[channel]
        for source, channel in zip(lags.source, lags.channel, strict=True)
    ]
    per_channel: dict[str, BoolArray] = {}
    for j, name in enumerate(lags.names):
        if name not in box:
            continue
        low, high = box[name]
        out = (x[:, j] < low) | (x[:, j] > high)
        by_term[name] = float(out.mean()) if out.size else 0.0
        outside[m:] |= out
        per_channel[channel_of[j]] = per_channel.get(channel_of[j], np.zeros_like(out)) | out
    by_channel = {k: float(v.mean()) if v.size else 0.0 for k, v in per_channel.items()}
    distance, radius = None, None
    found = _nearest(model, x) if nearest else None
    if found is not None:
        distance = np.full(data.n_samples, np.nan)
        distance[m:], radius = found
        outside[m:] |= found[0] > found[1]
    return Domain(outside, by_term, by_channel, distance, radius, m)
