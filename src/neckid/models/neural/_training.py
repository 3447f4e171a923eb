"""The ensemble trainer of :class:`~neckid.models.neural.narx.NeuralNARX`: scikit-learn's Adam, compiled.

:func:`train_ensemble` trains every network of an ensemble as ``MLPRegressor(solver="adam")``
(scikit-learn 1.9) trains one, draw for draw: from its seed, through
:func:`sklearn.utils.check_random_state`, it draws the Glorot-uniform initial weights (Glorot &
Bengio 2010; bound ``sqrt(6 / (n_in + n_out))``, ``sqrt(2 / …)`` for the logistic activation),
layer by layer, weights then biases; with early stopping, the held-out rows as ``train_test_split``
draws them (one permutation; the first ``ceil(validation_fraction n)`` rows are held out); then
per epoch one shuffle of the training rows. Batches of ``min(200, n_train)`` rows, the same loss,
gradients, Adam steps, validation R², tolerance rule and ``n_iter_no_change``, and the best
weights restored at the end. The sums run in another order than scikit-learn's BLAS products, so
weights agree to rounding, not bit for bit.

What it does differently is where the time goes: one compiled call per epoch
(:func:`neckid.models.neural._adam.adam_epoch`) runs every batch of every still-training network,
the networks in parallel, where scikit-learn makes a few dozen NumPy calls per batch of 200 rows
and trains the networks one after another. Between epochs, in Python, it checks for a stop
signal (:func:`neckid.utils.interrupt.check`): Ctrl-C ends the fit within an epoch, and no
half-trained ensemble is returned.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils import check_random_state

from neckid.models.neural._adam import adam_epoch, layout, validation_r2
from neckid.models.neural._kernels import ACTIVATION_CODES
from neckid.utils.interrupt import check as check_interrupted
from neckid.utils.types import FloatArray, IntArray

__all__ = ["AdamState", "Trained", "TrainingSettings", "more_epochs", "train_ensemble"]

#: MLPRegressor's ``batch_size="auto"``: at most this many rows per batch.
_BATCH = 200


@dataclass(frozen=True)
class TrainingSettings:
    """What MLPRegressor calls its hyper-parameters, as :class:`NeuralNARX` passes them."""

    activation: str
    alpha: float
    learning_rate_init: float
    max_iter: int
    tol: float
    n_iter_no_change: int
    early_stopping: bool
    validation_fraction: float


@dataclass
class AdamState:
    """What more epochs need besides the weights: every network's seed and Adam moments.

    As MLPRegressor keeps its optimiser after ``fit``: the moments and step counts are those of
    the last epoch run, even when early stopping restored earlier weights.
    """

    seeds: list[Any]
    first: FloatArray
    second: FloatArray
    steps: IntArray

    def take(self, keep: IntArray) -> AdamState:
        """The state of the networks ``keep`` only, in that order."""
        return AdamState(
            [self.seeds[int(m)] for m in keep],
            self.first[keep],
            self.second[keep],
            self.steps[keep],
        )


@dataclass(frozen=True)
class Trained:
    """The trained networks, stacked as :class:`NeuralNARX` keeps them, and their trainer."""

    coefs: list[FloatArray]
    intercepts: list[FloatArray]
    n_iter: IntArray
    #: Whether each network stopped by its own rule (False: ``max_iter`` ran out first).
    converged: np.ndarray
    state: AdamState


def _initial(
    rng: np.random.RandomState, sizes: IntArray, offsets: IntArray, activation: str
) -> FloatArray:
    """Glorot-uniform weights and biases drawn as MLPRegressor's ``_init_coef`` draws them."""
    factor = 2.0 if activation == "logistic" else 6.0
    row = np.empty(offsets[-1, 0])
    for k, (n_in, n_out) in enumerate(itertools.pairwise(sizes)):
        bound = np.sqrt(factor / (n_in + n_out))
        row[offsets[k, 0] : offsets[k, 1]] = rng.uniform(-bound, bound, (n_in, n_out)).ravel()
        row[offsets[k, 1] : offsets[k, 1] + n_out] = rng.uniform(-bound, bound, n_out)
    return row


def _stack(
    coefs: Sequence[FloatArray], intercepts: Sequence[FloatArray], offsets: IntArray
) -> FloatArray:
    """Per-layer stacked weights back to one parameter row per network (:func:`_unstack`)."""
    params = np.empty((coefs[0].shape[0], offsets[-1, 0]))
    for k, (w, b) in enumerate(zip(coefs, intercepts, strict=True)):
        params[:, offsets[k, 0] : offsets[k, 1]] = w.reshape(w.shape[0], -1)
        params[:, offsets[k, 1] : offsets[k, 1] + b.shape[1]] = b
    return params


def _unstack(
    params: FloatArray, sizes: IntArray, offsets: IntArray
) -> tuple[list[FloatArray], list[FloatArray]]:
    """Parameter rows to per-layer ``(n_networks, n_in, n_out)`` and ``(n_networks, n_out)``."""
    coefs, intercepts = [], []
    for k, (n_in, n_out) in enumerate(itertools.pairwise(sizes)):
        w = params[:, offsets[k, 0] : offsets[k, 1]]
        coefs.append(np.ascontiguousarray(w.reshape(-1, int(n_in), int(n_out))))
        intercepts.append(np.ascontiguousarray(params[:, offsets[k, 1] : offsets[k, 1] + n_out]))
    return coefs, intercepts


def _nothing() -> None:
    """No progress to show."""


def _held_out(
    rngs: Sequence[np.random.RandomState], n_rows: int, settings: TrainingSettings
) -> tuple[IntArray, IntArray]:
    """Every network's held-out and training rows, drawn as ``train_test_split`` draws them."""
    n_networks = len(rngs)
    if not settings.early_stopping:
        everything = np.broadcast_to(np.arange(n_rows), (n_networks, n_rows)).copy()
        return np.empty((n_networks, 0), dtype=np.int64), everything
    n_val = math.ceil(settings.validation_fraction * n_rows)
    if n_val < 2:
        raise ValueError(
            f"validation_fraction={settings.validation_fraction!r} of {n_rows} regressor rows"
            f" holds out {n_val} for early stopping; it needs at least 2"
        )
    drawn = [rng.permutation(n_rows) for rng in rngs]
    return np.stack([p[:n_val] for p in drawn]), np.stack([p[n_val:] for p in drawn])


class _Stopping:
    """MLPRegressor's stopping rule, per network, and the best weights it keeps.

    With early stopping, an epoch makes progress when the validation R² beats the best one by
    ``tol``, and the weights of the best R² are kept; without, when the training loss falls
    ``tol`` below its best. A network stops after more than ``n_iter_no_change`` epochs without.
    """

    def __init__(self, params: FloatArray, settings: TrainingSettings) -> None:
        n_networks = params.shape[0]
        self.settings = settings
        self.best = params.copy()
        self.best_score = np.full(n_networks, -np.inf)
        self.best_loss = np.full(n_networks, np.inf)
        self.stale = np.zeros(n_networks, dtype=np.int64)

    def stops(self, m: int, params: FloatArray, score: float, loss: float) -> bool:
        """Record network ``m``'s epoch; whether it stops training now."""
        tol = self.settings.tol
        if self.settings.early_stopping:
            self.stale[m] = self.stale[m] + 1 if score < self.best_score[m] + tol else 0
            if score > self.best_score[m]:
                self.best_score[m] = score
                self.best[m] = params[m]
        else:
            self.stale[m] = self.stale[m] + 1 if loss > self.best_loss[m] - tol else 0
            self.best_loss[m] = min(self.best_loss[m], loss)
        return bool(self.stale[m] > self.settings.n_iter_no_change)


def _epoch(
    x: FloatArray,
    y: FloatArray,
    order: IntArray,
    active: IntArray,
    params: FloatArray,
    state: AdamState,
    sizes: IntArray,
    offsets: IntArray,
    settings: TrainingSettings,
    losses: FloatArray,
) -> None:
    """One epoch of the networks ``active`` (:func:`~neckid.models.neural._adam.adam_epoch`)."""
    adam_epoch(
        x,
        y,
        order,
        active,
        params,
        state.first,
        state.second,
        state.steps,
        sizes,
        offsets,
        ACTIVATION_CODES[settings.activation],
        float(settings.alpha),
        float(settings.learning_rate_init),
        min(_BATCH, order.shape[1]),
        losses,
    )


def train_ensemble(
    xs: FloatArray,
    ys: FloatArray,
    layers: tuple[int, ...],
    seeds: Sequence[Any],
    settings: TrainingSettings,
    advance: Callable[[], None] | None = None,
) -> Trained:
    """Train one network per seed on standardised rows ``xs`` → ``ys`` (2-D), as MLPRegressor.

    ``advance`` is called once per network when it stops training. Raises the stop signal's
    exception (:func:`neckid.utils.interrupt.check`, or ``KeyboardInterrupt``) between epochs.
    """
    x = np.ascontiguousarray(xs, dtype=np.float64)
    y = np.ascontiguousarray(ys, dtype=np.float64)
    sizes = np.array([x.shape[1], *layers, y.shape[1]], dtype=np.int64)
    offsets = layout(sizes)
    n_networks = len(seeds)
    tick = advance if advance is not None else _nothing
    rngs = [check_random_state(seed) for seed in seeds]
    params = np.stack([_initial(rng, sizes, offsets, settings.activation) for rng in rngs])
    held, train = _held_out(rngs, x.shape[0], settings)
    n_train = train.shape[1]
    sample = np.broadcast_to(np.arange(n_train), (n_networks, n_train)).copy()
    order = np.empty_like(train)
    moments = np.zeros_like(params), np.zeros_like(params)
    state = AdamState(list(seeds), *moments, np.zeros(n_networks, dtype=np.int64))
    losses = np.zeros(n_networks)
    scores = np.zeros(n_networks)
    rule = _Stopping(params, settings)
    n_iter = np.zeros(n_networks, dtype=np.int64)
    converged = np.zeros(n_networks, dtype=bool)
    training = list(range(n_networks))
    for _ in range(int(settings.max_iter)):
        for m in training:  # MLPRegressor's shuffle of the sample indices, every epoch
            shuffled = np.arange(n_train)
            rngs[m].shuffle(shuffled)
            sample[m] = sample[m][shuffled]
            order[m] = train[m][sample[m]]
        active = np.array(training, dtype=np.int64)
        _epoch(x, y, order, active, params, state, sizes, offsets, settings, losses)
        if settings.early_stopping:
            code = ACTIVATION_CODES[settings.activation]
            validation_r2(x, y, held, active, params, sizes, offsets, code, scores)
        check_interrupted()
        n_iter[active] += 1
        stopped = [m for m in training if rule.stops(m, params, scores[m], losses[m])]
        converged[stopped] = True
        for _ in stopped:
            tick()
        training = [m for m in training if m not in stopped]
        if not training:
            break
    if training:
        warnings.warn(
            f"{len(training)} of {n_networks} networks ran all max_iter={settings.max_iter}"
            " epochs without meeting the stopping rule (tol, n_iter_no_change): raise max_iter"
            " or learning_rate_init",
            ConvergenceWarning,
            stacklevel=3,
        )
        for _ in training:
            tick()
    final = rule.best if settings.early_stopping else params
    coefs, intercepts = _unstack(final, sizes, offsets)
    return Trained(coefs, intercepts, n_iter, converged, state)


def more_epochs(
    coefs: Sequence[FloatArray],
    intercepts: Sequence[FloatArray],
    state: AdamState,
    xs: FloatArray,
    ys: FloatArray,
    epochs: int,
    settings: TrainingSettings,
) -> tuple[list[FloatArray], list[FloatArray]]:
    """``epochs`` more epochs of every network on new rows, as MLPRegressor's ``partial_fit``.

    Each epoch is one ``partial_fit`` call of scikit-learn 1.9: no rows held out, the Adam
    moments carried on (``state`` is updated in place), and the rows in the order of a first
    shuffle from the network's seed (``partial_fit`` draws its random stream from
    ``random_state`` again at every call, so with an integer seed every such epoch visits the
    rows in the same order). Returns the new stacked weights.
    """
    x = np.ascontiguousarray(xs, dtype=np.float64)
    y = np.ascontiguousarray(ys, dtype=np.float64)
    n_rows = x.shape[0]
    sizes = np.array([x.shape[1], *(w.shape[2] for w in coefs)], dtype=np.int64)
    offsets = layout(sizes)
    params = _stack(coefs, intercepts, offsets)
    n_networks = params.shape[0]
    active = np.arange(n_networks, dtype=np.int64)
    order = np.empty((n_networks, n_rows), dtype=np.int64)
    losses = np.zeros(n_networks)
    for _ in range(int(epochs)):
        for m in range(n_networks):
            shuffled = np.arange(n_rows)
            check_random_state(state.seeds[m]).shuffle(shuffled)
            order[m] = shuffled
        _epoch(x, y, order, active, params, state, sizes, offsets, settings, losses)
        check_interrupted()
    return _unstack(params, sizes, offsets)
