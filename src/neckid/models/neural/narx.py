"""NeuralNARX: a multilayer-perceptron NARX model, the seed paper's comparison network.

The network maps the standardised regressor ``w(t)`` (see :class:`~neckid.Lags`) to the
standardised output ``y(t)``. It is trained on one-step-ahead targets as scikit-learn's
:class:`~sklearn.neural_network.MLPRegressor` trains it (see below); prediction and model files use a plain NumPy forward pass over the
learned weight matrices, so a loaded model needs no scikit-learn object, and the free run is one
compiled loop over those matrices (:mod:`neckid.models.neural._kernels`, about 3 µs per sample
for five 2x25 networks, against about 16 µs for the NumPy loop kept beside it as reference).

A fitted model is an ensemble of ``n_networks`` such networks, trained alike from different seeds,
whose outputs are averaged: one network's result depends on its seed by several points of
free-run fit on the soft-neck logs; the average of a few depends on it much less. Their weights are
stacked along a first axis, so one batched product per layer serves every network.

The networks are trained as scikit-learn's ``MLPRegressor(solver="adam")`` trains them, draw for
draw and formula by formula (:mod:`neckid.models.neural._training`), by a compiled loop that
runs one epoch of every network per call, the networks in parallel: about four times faster
than ``MLPRegressor.fit`` on the soft-neck logs, with the same epochs and weights equal to
rounding (the tests train both). Between epochs it checks for a stop signal
(:func:`neckid.utils.interrupt.check`), so Ctrl-C or SIGTERM stops the whole fit within one
epoch and no half-trained ensemble is ever made.
"""

from __future__ import annotations

import itertools
import logging
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.utils import check_random_state

from neckid.data.iodata import IOData, as_experiments
from neckid.metrics import fit_percent
from neckid.models.base import ModelResult, NarxModel, check_is_fitted
from neckid.models.neural._training import (
    AdamState,
    TrainingSettings,
    more_epochs,
    train_ensemble,
)
from neckid.regressors import Lags, ResolvedLags
from neckid.utils.checks import Interval, Options
from neckid.utils.memory import check_allocation
from neckid.utils.progress import task
from neckid.utils.types import FloatArray

__all__ = ["NeuralNARX", "forward_pass", "member_seeds"]

Activation = Literal["tanh", "relu", "logistic", "identity"]

logger = logging.getLogger(__name__)

_ACTIVATIONS = ("tanh", "relu", "logistic", "identity")

#: Fewest samples of a held-out tail beyond its initial conditions for free-run selection.
_MIN_TAIL_SAMPLES = 20


def _activate(z: FloatArray, activation: str) -> FloatArray:
    """Apply a hidden-layer activation in place and return ``z``."""
    if activation == "tanh":
        np.tanh(z, out=z)
    elif activation == "relu":
        np.maximum(z, 0.0, out=z)
    elif activation == "logistic":
        # 1 / (1 + exp(-z)) written as 0.5 (1 + tanh(z / 2)): no overflow for large |z|.
        np.multiply(z, 0.5, out=z)
        np.tanh(z, out=z)
        np.add(z, 1.0, out=z)
        np.multiply(z, 0.5, out=z)
    # "identity": nothing to do
    return z


def forward_pass(
    x: FloatArray,
    coefs: Sequence[FloatArray],
    intercepts: Sequence[FloatArray],
    activation: str,
) -> FloatArray:
    """Forward pass of a multilayer perceptron with an identity output layer.

    ``h_0 = x``, ``h_k = g(h_{k-1} W_k + b_k)`` for the hidden layers, ``out = h_{L-1} W_L + b_L``,
    with ``g`` the activation, as :class:`~sklearn.neural_network.MLPRegressor` computes it.

    Parameters
    ----------
    x : ndarray, shape (n_rows, n_features)
        Inputs of the network (already standardised).
    coefs, intercepts : sequence of ndarray
        Weight matrices ``W_k`` of shape ``(n_in, n_out)`` and bias vectors ``b_k`` of shape
        ``(n_out,)``, one per layer (``MLPRegressor.coefs_`` / ``intercepts_``).
    activation : {"tanh", "relu", "logistic", "identity"}
        Hidden-layer activation.

    Returns
    -------
    ndarray, shape (n_rows, n_outputs)

    Examples
    --------
    >>> import numpy as np
    >>> w = [np.array([[1.0, -1.0]]), np.array([[2.0], [3.0]])]
    >>> b = [np.zeros(2), np.array([0.5])]
    >>> forward_pass(np.array([[0.0], [1.0]]), w, b, "relu")
    array([[0.5],
           [2.5]])
    """
    h = np.asarray(x, dtype=np.float64)
    last = len(coefs) - 1
    for k, (weights, bias) in enumerate(zip(coefs, intercepts, strict=True)):
        h = h @ weights
        h += bias
        if k < last:
            h = _activate(h, activation)
    return h


def _ensemble_mean(
    x: FloatArray,
    coefs: Sequence[FloatArray],
    intercepts: Sequence[FloatArray],
    activation: str,
) -> FloatArray:
    """Mean over the networks of :func:`forward_pass`, for weights stacked on a first axis.

    ``coefs[k]`` has shape ``(n_networks, n_in, n_out)`` and ``intercepts[k]``
    ``(n_networks, n_out)``; one batched product per layer serves every network.
    """
    h = np.asarray(x, dtype=np.float64)
    last = len(coefs) - 1
    for k, (weights, bias) in enumerate(zip(coefs, intercepts, strict=True)):
        h = np.matmul(h, weights)  # (n_networks, n_rows, n_out)
        h += bias[:, None, :]
        if k < last:
            h = _activate(h, activation)
    return np.asarray(h.mean(axis=0), dtype=np.float64)


def member_seeds(
    random_state: int | np.random.RandomState | None, n_networks: int
) -> list[int | np.random.RandomState | None]:
    """The seed of every network of an ensemble of ``n_networks``.

    The first network takes ``random_state`` as it is, so an ensemble of one is the single
    network that ``random_state`` gives. The others take seeds derived from it: for an int, the
    first word of ``numpy.random.SeedSequence(random_state).spawn(n_networks - 1)``'s children
    (so the first ``k`` networks of a larger ensemble are those of an ensemble of ``k``); for a
    ``RandomState``, ``n_networks - 1`` draws from it; for ``None``, ``None`` (scikit-learn then
    draws from NumPy's global generator, and the networks differ from run to run).

    Parameters
    ----------
    random_state : int, numpy.random.RandomState or None
        The ensemble's seed (``NeuralNARX.random_state``).
    n_networks : int
        Networks in the ensemble, >= 1.

    Returns
    -------
    list
        ``n_networks`` seeds, one per network (``random_state`` of its trainer).

    Examples
    --------
    >>> seeds = member_seeds(7, 3)
    >>> seeds[0], len(set(seeds)), member_seeds(7, 2) == seeds[:2]
    (7, 3, True)
    """
    if n_networks == 1 or random_state is None:
        return [random_state] * n_networks
    if isinstance(random_state, np.random.RandomState):
        drawn = random_state.randint(0, np.iinfo(np.int32).max, size=n_networks - 1)
        return [random_state, *(int(s) for s in drawn)]
    children = np.random.SeedSequence(int(random_state)).spawn(n_networks - 1)
    return [random_state, *(int(c.generate_state(1)[0]) for c in children)]


class NeuralNARX(NarxModel):
    """Neural-network NARX model: ``y(t) = f(w(t))`` with ``f`` a multilayer perceptron.

    The seed paper's comparison network has two hidden layers of 25 neurons. Regressors and outputs
    are standardised with means and standard deviations learned in ``fit``; the network is trained
    on one-step-ahead targets by mini-batch Adam, as scikit-learn's
    :class:`~sklearn.neural_network.MLPRegressor` trains it (same draws from ``random_state``, same
    epochs, weights equal to rounding; a compiled loop, the networks in parallel), with early
    stopping on a random validation split of the regressor rows.

    Parameters
    ----------
    lags : Lags
        The regressor, e.g. ``Lags(outputs=3, inputs=[8, 9, 10])`` (the seed paper's).
    hidden_layer_sizes : tuple of int, default (25, 25)
        Neurons per hidden layer.
    activation : {"tanh", "relu", "logistic", "identity"}, default "tanh"
        Hidden-layer activation.
    alpha : float, default 1e-4
        L2 penalty on the weights (MLPRegressor's ``alpha``).
    learning_rate_init : float, default 1e-3
        Adam step size.
    max_iter : int, default 1000
        Most training epochs.
    tol : float, default 1e-5
        Improvement of the validation score (R², early stopping) or of the loss below which an
        epoch counts as no progress.
    n_iter_no_change : int, default 20
        Epochs without progress before training stops.
    early_stopping : bool, default True
        Hold out ``validation_fraction`` of the regressor rows (at random) and keep the weights
        with the best validation score.
    validation_fraction : float, default 0.15
        Share of the rows held out for early stopping, in (0, 1). With ``simulation_tuning > 0``
        the same share of every experiment's *end* is also held out, contiguous, to rank the
        candidate networks by free-run fit.
    simulation_tuning : int, default 0
        Extra networks, ranked by free-run simulation fit. 0 trains ``n_networks`` networks and
        selects them by one-step error only. ``k > 0`` trains ``n_networks + k`` networks (seeds
        drawn from ``random_state``) on all but the last ``validation_fraction`` of every
        experiment, scores each alone by its free run on those held-out ends (mean NRMSE fit),
        and keeps the ``n_networks`` best; with ``n_networks=1``, the best of ``k + 1``.
    n_networks : int, default 5
        Networks in the ensemble, each trained on the same data from its own seed; the model's
        output is their mean. 1 is a single network (the same one as before this option
        existed, for the same ``random_state``). Training time grows linearly with it. On the
        soft-neck logs (free run on logs with other payloads) the fit of one network moves by
        about 20 points from seed to seed, the mean of 5 by about 8, and the mean of the 5 best
        of 10 (``simulation_tuning=5``) by about 3, with a mean fit some 8 points higher than
        one network's.
    random_state : int, numpy.random.RandomState or None, default None
        Seed of the weight initialisation, the mini-batch order and the validation split. The
        first network uses it as it is; the others use seeds derived from it
        (:func:`member_seeds`).

    Attributes
    ----------
    coefs_ : list of ndarray
        Weight matrices of every network, stacked: ``coefs_[k]`` of shape
        ``(n_networks, n_in_k, n_out_k)``, acting on standardised values.
    intercepts_ : list of ndarray
        Bias vectors, ``intercepts_[k]`` of shape ``(n_networks, n_out_k)``.
    x_mean_, x_scale_ : ndarray, shape (n_terms,)
        Regressor standardisation: ``(w - x_mean_) / x_scale_``.
    y_mean_, y_scale_ : ndarray, shape (n_outputs,)
        Output standardisation: ``y = y_mean_ + y_scale_ * network output``.
    n_iter_ : ndarray of int, shape (n_networks,)
        Epochs run by every network of the chosen ensemble.
    simulation_fits_ : ndarray, shape (n_networks + simulation_tuning,)
        Free-run fit (%) of every candidate network alone on the held-out ends, in training order
        (only when ``simulation_tuning > 0``).
    lags_ : ResolvedLags
    n_inputs_, n_outputs_, n_samples_ : int
    ts_ : float

    Notes
    -----
    The ensemble's map is ``y = y_mean + y_scale (1/M) sum_m f_m((w - x_mean) / x_scale)`` over
    its ``M = n_networks`` networks ``f_m``; a free run feeds that mean back, so the ensemble is
    one NARX model (prediction, free run and simulator agree), not the mean of ``M`` free runs.

    Free-run simulation folds the regressor standardisation into the first layer,
    ``W_1' = W_1 / x_scale``, ``b_1' = b_1 - (x_mean / x_scale) W_1``, and runs a compiled loop
    (numba) that per sample builds the raw regressor, runs the ``M`` networks and writes their
    mean, de-standardised. It computes ``tanh`` as ``1 - 2 / (exp(2|z|) + 1)`` (within 2.3e-16 of
    it) and agrees with the NumPy loop (``_simulate_array(..., compiled=False)``, which computes the
    input part of the first layer for all samples in one product) to rounding, about 1e-15.

    References
    ----------
    .. [1] Model Identification of a Soft Robotic Neck, Robotics Lab, Universidad Carlos III de
       Madrid (humanoid TEO): NARX neural network with two hidden layers of 25 neurons, compared
       with Set Membership identification.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> from neckid.models.neural.narx import NeuralNARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-2, 2, size=600)
    >>> y = np.zeros(600)
    >>> for t in range(2, 600):
    ...     y[t] = 0.7 * y[t - 1] + np.tanh(u[t - 2])
    >>> data = IOData(u, y, ts=0.02)
    >>> model = NeuralNARX(Lags(outputs=[1], inputs=[2]), hidden_layer_sizes=(10,),
    ...                    learning_rate_init=3e-3, random_state=0).fit(data[:400])
    >>> bool(model.simulate(data[400:]).fit_percent(data[400:])[0] > 90)
    True
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "hidden_layer_sizes": ["layer-sizes", Interval("int", 1, None)],
        "activation": [Options(_ACTIVATIONS)],
        "alpha": [Interval("real", 0, None)],
        "learning_rate_init": [Interval("real", 0, None, closed="neither")],
        "max_iter": [Interval("int", 1, None)],
        "tol": [Interval("real", 0, None)],
        "n_iter_no_change": [Interval("int", 1, None)],
        "early_stopping": ["boolean"],
        "validation_fraction": [Interval("real", 0, 1, closed="neither")],
        "simulation_tuning": [Interval("int", 0, None)],
        "n_networks": [Interval("int", 1, None)],
        "random_state": [None, Interval("int", 0, None), np.random.RandomState],
    }

    coefs_: list[FloatArray]
    intercepts_: list[FloatArray]
    n_iter_: NDArray[np.int64]
    _adam: AdamState  # the trainer's state, for partial_fit (not in model files)

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        hidden_layer_sizes: tuple[int, ...] = (25, 25),
        activation: Activation = "tanh",
        alpha: float = 1e-4,
        learning_rate_init: float = 1e-3,
        max_iter: int = 1000,
        tol: float = 1e-5,
        n_iter_no_change: int = 20,
        early_stopping: bool = True,
        validation_fraction: float = 0.15,
        simulation_tuning: int = 0,
        n_networks: int = 5,
        random_state: int | np.random.RandomState | None = None,
    ) -> None:
        self.lags = lags
        self.hidden_layer_sizes = hidden_layer_sizes
        self.activation = activation
        self.alpha = alpha
        self.learning_rate_init = learning_rate_init
        self.max_iter = max_iter
        self.tol = tol
        self.n_iter_no_change = n_iter_no_change
        self.early_stopping = early_stopping
        self.validation_fraction = validation_fraction
        self.simulation_tuning = simulation_tuning
        self.n_networks = n_networks
        self.random_state = random_state

    # ------------------------------------------------------------------ validation
    def _check_params(self) -> tuple[tuple[int, ...], int]:
        self._validate_params()
        sizes = self.hidden_layer_sizes
        layers = (int(sizes),) if isinstance(sizes, int | np.integer) else tuple(sizes)
        return tuple(int(n) for n in layers), int(self.simulation_tuning)

    # ------------------------------------------------------------------ fitting
    def fit(self, data: IOData | Sequence[IOData]) -> NeuralNARX:
        """Train the network on one experiment or a list of them.

        Parameters
        ----------
        data : IOData or list of IOData
            Training records; regressors never straddle two of them.

        Returns
        -------
        NeuralNARX
            ``self``, fitted.

        Raises
        ------
        ValueError
            If a hyper-parameter is out of range (the message names it and its value), or a record
            is too short for the lags (or, with ``simulation_tuning``, for a held-out end).
        TypeError
            If ``lags`` is not a :class:`~neckid.Lags` or a hyper-parameter has the wrong type.
        """
        layers, tuning = self._check_params()
        experiments = as_experiments(self._with_conditions(data, fitting=True))
        n_networks = int(self.n_networks)
        if tuning == 0:
            x, y = self._prepare_fit(experiments)
            self._train_ensemble(x, y, layers, member_seeds(self.random_state, n_networks))
            self._mark_fitted()
            return self
        resolved = self._lags().resolve(experiments)
        heads: list[IOData] = []
        tails: list[IOData] = []
        for i, record in enumerate(experiments):
            n_tail = int(np.ceil(float(self.validation_fraction) * record.n_samples))
            if n_tail < resolved.max_lag + _MIN_TAIL_SAMPLES:
                raise ValueError(
                    f"simulation_tuning needs a held-out end of at least max_lag + {_MIN_TAIL_SAMPLES}"
                    f" = {resolved.max_lag + _MIN_TAIL_SAMPLES} samples per record, but"
                    f" validation_fraction={self.validation_fraction!r} of data[{i}]"
                    f" ({record.n_samples} samples) gives {n_tail}; use a longer record, a larger"
                    " validation_fraction or simulation_tuning=0"
                )
            heads.append(record[: record.n_samples - n_tail])
            # The tail keeps max_lag samples of overlap as its initial conditions.
            tails.append(record[record.n_samples - n_tail :])
        x, y = self._prepare_fit(heads)
        rng = check_random_state(self.random_state)
        seeds = rng.randint(0, np.iinfo(np.int32).max, size=n_networks + tuning)
        self._train_ensemble(x, y, layers, [int(s) for s in seeds])
        scores = np.array([self._free_run_score(tails, [m]) for m in range(seeds.size)])
        logger.debug("free-run fit of the candidate networks: %s %%", np.round(scores, 3))
        # The n_networks best (the first of equals), in the order they were trained.
        keep = np.sort(np.argsort(-scores, kind="stable")[:n_networks])
        self.coefs_ = [w[keep] for w in self.coefs_]
        self.intercepts_ = [b[keep] for b in self.intercepts_]
        self._adam = self._adam.take(keep)
        self.n_iter_ = self.n_iter_[keep]
        self.simulation_fits_ = scores
        self._mark_fitted()
        return self

    def _train_ensemble(
        self,
        x: FloatArray,
        y: FloatArray,
        layers: tuple[int, ...],
        seeds: Sequence[int | np.random.RandomState | None],
    ) -> None:
        """Standardise, train one network per seed, stack their weights."""
        n_rows = x.shape[0]
        min_rows = 10 if self.early_stopping else 2
        if n_rows < min_rows:
            raise ValueError(
                f"NeuralNARX needs at least {min_rows} regressor rows to train; got {n_rows}:"
                " use a longer record or fewer lags"
            )
        self.x_mean_ = x.mean(axis=0)
        x_scale = x.std(axis=0)
        x_scale[x_scale == 0] = 1.0
        self.x_scale_ = x_scale
        self.y_mean_ = y.mean(axis=0)
        y_scale = y.std(axis=0)
        y_scale[y_scale == 0] = 1.0
        self.y_scale_ = y_scale
        xs = (x - self.x_mean_) / self.x_scale_
        ys = (y - self.y_mean_) / self.y_scale_
        sizes = [x.shape[1], *layers, ys.shape[1]]
        weights = sum(a * b + b for a, b in itertools.pairwise(sizes))
        check_allocation(
            # weights, best weights and Adam's two moments; the rows' three orders
            8.0 * (4 * weights + 3 * n_rows) * len(seeds),
            f"{len(seeds)} networks of layers {list(layers)} on {x.shape[1]} regressor terms"
            f" ({weights:,} weights each) and {n_rows:,} rows",
            "use smaller hidden layers (hidden_layer_sizes) or fewer networks",
        )
        with task(f"training {len(seeds)} networks", total=len(seeds)) as advance:
            trained = train_ensemble(xs, ys, layers, seeds, self._settings(), advance)
        self.coefs_ = trained.coefs
        self.intercepts_ = trained.intercepts
        self.n_iter_ = trained.n_iter
        self._adam = trained.state

    def _settings(self) -> TrainingSettings:
        """The trainer's hyper-parameters."""
        return TrainingSettings(
            activation=str(self.activation),
            alpha=float(self.alpha),
            learning_rate_init=float(self.learning_rate_init),
            max_iter=int(self.max_iter),
            tol=float(self.tol),
            n_iter_no_change=int(self.n_iter_no_change),
            early_stopping=bool(self.early_stopping),
            validation_fraction=float(self.validation_fraction),
        )

    def _free_run_score(
        self, tails: Sequence[IOData], networks: Sequence[int] | None = None
    ) -> float:
        """Mean free-run fit (%) over held-out records; -inf when a run diverges.

        ``networks`` (positions in the ensemble) scores the ensemble of those alone.
        """
        fits = []
        for record in tails:
            with np.errstate(over="ignore", invalid="ignore"):
                y_sim = self._simulate_array(record.u, record.y, networks)
            if not np.all(np.isfinite(y_sim)):
                return -np.inf
            fits.append(fit_percent(record.y, y_sim, skip=self.lags_.max_lag).mean())
        return float(np.mean(fits))

    def _fit_regression(self, x: FloatArray, y: FloatArray) -> None:
        layers, _ = self._check_params()
        self._train_ensemble(x, y, layers, member_seeds(self.random_state, int(self.n_networks)))

    # ------------------------------------------------------------------ the map
    def _predict_rows(self, x: FloatArray) -> FloatArray:
        xs = (np.asarray(x, dtype=np.float64) - self.x_mean_) / self.x_scale_
        out = _ensemble_mean(xs, self.coefs_, self.intercepts_, self.activation)
        return np.asarray(out * self.y_scale_ + self.y_mean_, dtype=np.float64)

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free-run simulation: the regressor holds the model's own past outputs.

        The first ``max_lag`` outputs of ``data`` (or ``initial``) are the initial conditions;
        from then on only ``data.u`` is used. Same result as the generic loop of
        :class:`NarxModel` (to rounding), computed by a compiled loop (see Notes of the class).

        Parameters
        ----------
        data : IOData
            Inputs, and initial outputs in its first ``max_lag`` rows (or inputs only, with
            ``initial``).
        initial : array_like, shape (n_outputs,) or (max_lag, n_outputs), optional
            The first outputs, oldest first (one row is repeated).

        Returns
        -------
        ModelResult
            ``kind="simulation"``, ``n_initial=max_lag``.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y0 = self._initial_outputs(data, initial)
        with np.errstate(over="ignore", invalid="ignore"):  # divergence is reported below
            y = self._simulate_array(data.u, y0)
        return self._result("simulation", data, y)

    def _simulate_array(
        self,
        u: FloatArray,
        y_measured: FloatArray,
        networks: Sequence[int] | None = None,
        *,
        compiled: bool = True,
    ) -> FloatArray:
        """Free run over ``u`` from the first ``max_lag`` rows of ``y_measured``.

        ``networks`` (positions in the ensemble) runs the ensemble of those alone. ``compiled``
        runs the numba loop (:func:`~neckid.models.neural._kernels.mlp_free_run`); ``False``
        runs the NumPy loop kept beside it as its reference (the tests check they agree).
        """
        coefs, intercepts = self.coefs_, self.intercepts_
        if networks is not None:  # the ensemble of some of the networks only
            coefs = [w[list(networks)] for w in coefs]
            intercepts = [b[list(networks)] for b in intercepts]
        resolved: ResolvedLags = self.lags_
        n = u.shape[0]
        m = resolved.max_lag
        if n <= m:
            raise ValueError(
                f"data has {n} samples, too few for lags up to {m}: it needs at least {m + 1}"
            )
        # Fold the standardisation of the regressor into the first layer of every network:
        # w1 is (n_networks, n_terms, width), b1 and each row of pre (n_networks, width).
        w1 = coefs[0] / self.x_scale_[None, :, None]
        b1 = intercepts[0] - (self.x_mean_ / self.x_scale_) @ coefs[0]
        y = np.array(y_measured, dtype=np.float64)
        if compiled:
            from neckid.models.neural._kernels import ACTIVATION_CODES, mlp_free_run, pack_layers

            weights, biases, sizes = pack_layers([w1, *coefs[1:]], [b1, *intercepts[1:]])
            mlp_free_run(
                np.ascontiguousarray(u, dtype=np.float64),
                y,
                np.ascontiguousarray(resolved.source, dtype=np.int64),
                np.ascontiguousarray(resolved.channel, dtype=np.int64),
                np.ascontiguousarray(resolved.lag, dtype=np.int64),
                weights,
                biases,
                sizes,
                int(w1.shape[0]),
                ACTIVATION_CODES[str(self.activation)],
                np.ascontiguousarray(self.y_scale_, dtype=np.float64),
                np.ascontiguousarray(self.y_mean_, dtype=np.float64),
                int(m),
            )
            return y
        is_out = resolved.source == 0
        out_lag = resolved.lag[is_out]
        out_channel = resolved.channel[is_out]
        in_lag = resolved.lag[~is_out]
        in_channel = resolved.channel[~is_out]
        steps = np.arange(m, n)
        pre = np.broadcast_to(b1, (steps.size, *b1.shape)).copy()
        if in_lag.size:
            x_in = u[steps[:, None] - in_lag[None, :], in_channel[None, :]]
            pre += np.matmul(x_in, w1[:, ~is_out]).transpose(1, 0, 2)
        w1_out = np.ascontiguousarray(w1[:, is_out])
        rest_w = coefs[1:]
        rest_b = intercepts[1:]
        last = len(rest_w) - 1
        single_layer = not rest_w
        activation = self.activation
        y_scale = self.y_scale_
        y_mean = self.y_mean_
        has_out = bool(out_lag.size)
        for i, t in enumerate(steps):
            z = pre[i]
            if has_out:
                z = z + y[t - out_lag, out_channel] @ w1_out
            if single_layer:
                # A network without hidden layer is linear: identity output.
                h = z
            else:
                h = _activate(z.copy() if not has_out else z, activation)
                for k, (weights, bias) in enumerate(zip(rest_w, rest_b, strict=True)):
                    h = np.matmul(h[:, None, :], weights)[:, 0, :] + bias
                    if k < last:
                        h = _activate(h, activation)
            y[t] = h.mean(axis=0) * y_scale + y_mean
        return y

    def _check_state(self) -> None:
        super()._check_state()
        n_in, n_out = self.lags_.n_terms, self.n_outputs_
        for name, value, size in (
            ("x_mean", self.x_mean_, n_in),
            ("x_scale", self.x_scale_, n_in),
            ("y_mean", self.y_mean_, n_out),
            ("y_scale", self.y_scale_, n_out),
        ):
            self._check_shape(name, value, (size,))
        if np.any(self.x_scale_ <= 0) or np.any(self.y_scale_ <= 0):
            raise ValueError("x_scale and y_scale must be > 0")
        width, n_networks = n_in, int(self.n_networks)
        self._check_shape("n_iter", self.n_iter_, (n_networks,))
        for k, (weights, bias) in enumerate(zip(self.coefs_, self.intercepts_, strict=True)):
            self._check_shape(f"coef_{k}", weights, (n_networks, width, np.shape(weights)[-1]))
            width = int(np.shape(weights)[-1])
            self._check_shape(f"intercept_{k}", bias, (n_networks, width))
        if width != n_out:
            raise ValueError(f"the last layer has {width} outputs; the model has {n_out}")

    # ------------------------------------------------------------------ files
    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        arrays: dict[str, NDArray[Any]] = {
            "x_mean": self.x_mean_,
            "x_scale": self.x_scale_,
            "y_mean": self.y_mean_,
            "y_scale": self.y_scale_,
        }
        for k, (weights, bias) in enumerate(zip(self.coefs_, self.intercepts_, strict=True)):
            arrays[f"coef_{k}"] = weights
            arrays[f"intercept_{k}"] = bias
        meta = {
            "params": {
                "hidden_layer_sizes": [int(n) for n in self.hidden_layer_sizes],
                "activation": str(self.activation),
                "alpha": float(self.alpha),
                "learning_rate_init": float(self.learning_rate_init),
                "max_iter": int(self.max_iter),
                "tol": float(self.tol),
                "n_iter_no_change": int(self.n_iter_no_change),
                "early_stopping": bool(self.early_stopping),
                "validation_fraction": float(self.validation_fraction),
                "simulation_tuning": int(self.simulation_tuning),
                "n_networks": int(self.n_networks),
            },
            "n_layers": len(self.coefs_),
            "n_iter": [int(n) for n in self.n_iter_],
            **self._narx_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]) -> NeuralNARX:
        params = dict(meta["params"])
        params["hidden_layer_sizes"] = tuple(params["hidden_layer_sizes"])
        # Files written before n_networks hold one network, unstacked: give it the network axis.
        single = "n_networks" not in params
        params.setdefault("n_networks", 1)
        model = cls(lags=None, **params)
        model._restore_narx_meta(meta)
        n_layers = int(meta["n_layers"])
        model.coefs_, model.intercepts_ = [], []
        for k in range(n_layers):
            weights = np.asarray(arrays[f"coef_{k}"], dtype=np.float64)
            bias = np.asarray(arrays[f"intercept_{k}"], dtype=np.float64)
            model.coefs_.append(weights[None] if single else weights)
            model.intercepts_.append(bias[None] if single else bias)
        model.x_mean_ = np.asarray(arrays["x_mean"], dtype=np.float64)
        model.x_scale_ = np.asarray(arrays["x_scale"], dtype=np.float64)
        model.y_mean_ = np.asarray(arrays["y_mean"], dtype=np.float64)
        model.y_scale_ = np.asarray(arrays["y_scale"], dtype=np.float64)
        model.n_iter_ = np.atleast_1d(np.asarray(meta["n_iter"], dtype=np.int64))
        return model

    def partial_fit(self, data: IOData | Sequence[IOData], *, epochs: int = 10) -> NeuralNARX:
        """Train every network of the ensemble for a few more epochs on new experiments.

        Each network continues as scikit-learn's ``MLPRegressor.partial_fit`` would (Adam, its
        moments and random stream carried on from ``fit``) for ``epochs`` passes over the new
        regressor rows, standardised with the training means and scales (kept: the first layer
        is trained for them). Without early stopping: the new data are too few to hold some out.

        Parameters
        ----------
        data : IOData or list of IOData
            New measurements on the model's channels.
        epochs : int, default 10
            Passes over the new rows (each one mini-batch step per 200 rows).

        Returns
        -------
        NeuralNARX
            ``self``; ``n_iter_`` grows by ``epochs``.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            Data on other channels or too short; a model loaded from a file (it holds the
            weights, not the trainers with their optimiser state: refit it to update it).

        Notes
        -----
        Only the new rows are seen, so many epochs make the networks forget the old data
        (catastrophic forgetting); a few epochs nudge them towards the new run.
        """
        from neckid.models.online import extend_training_ranges, update_experiments, update_rows
        from neckid.utils.checks import check_number

        epochs = check_number(epochs, "epochs", low=1, integer=True)
        experiments = update_experiments(self, data)
        state = getattr(self, "_adam", None)
        if state is None:
            raise ValueError(
                "this NeuralNARX was loaded from a file, which holds the networks' weights but"
                " not their trainer's state (Adam's moments and random streams); refit it to"
                " update it"
            )
        x, y = update_rows(self, experiments)
        xs = (x - self.x_mean_) / self.x_scale_
        ys = (y - self.y_mean_) / self.y_scale_
        self.coefs_, self.intercepts_ = more_epochs(
            self.coefs_, self.intercepts_, state, xs, ys, int(epochs), self._settings()
        )
        self.n_iter_ = np.asarray(self.n_iter_, dtype=np.int64) + int(epochs)
        self.n_samples_ += int(x.shape[0])
        extend_training_ranges(self, experiments)
        return self
