r"""KoopmanEDMD: a lifted linear model fitted by extended DMD with control (``koopman``).

.. math::

    z(t+1) = A z(t) + B u(t), \qquad y(t) = C z(t) + D u(t), \qquad
    z(t) = [\,p(t);\; \varphi(r(t));\; 1\,],

``p`` the output and input delays, ``φ`` radial basis functions or monomials of the model's lag
terms (:mod:`~neckid.models.koopman.dictionary`), the matrices by ridge least squares
(:mod:`~neckid.models.koopman.lift`). A free run lifts the state once, from the first
``max_lag_`` samples, and then runs the linear system: the observables are never recomputed
from the simulated outputs, so the model is the linear predictor of Korda & Mezić (2018) that
linear MPC and python-control take as it is (:meth:`KoopmanEDMD.lifted_system`).

References
----------
M. Korda, I. Mezić, "Linear predictors for nonlinear dynamical systems: Koopman operator meets
model predictive control", Automatica 93, 149–160, 2018.
D. Bruder, B. Gillespie, C. D. Remy, R. Vasudevan, "Modeling and control of soft robots using
the Koopman operator and model predictive control", RSS 2019 (arXiv 1902.02827).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import Estimator, ModelResult, check_is_fitted
from neckid.models.cache import remembered_fit
from neckid.models.domain import regressor_box
from neckid.models.koopman.dictionary import (
    DICTIONARIES,
    Observables,
    fit_observables_with_values,
)
from neckid.models.koopman.lift import (
    Gram,
    Layout,
    LiftedSystem,
    clip_spectrum,
    free_run,
    gram,
    lift_rows,
    solve,
)
from neckid.models.koopman.selection import RIDGES, SIZES, Choice, choose
from neckid.models.online import extend_training_ranges, update_experiments
from neckid.regressors import Lags, ResolvedLags
from neckid.systems import history_rows, input_row
from neckid.utils.checks import Interval, Options
from neckid.utils.types import FloatArray

__all__ = ["KoopmanEDMD", "KoopmanSimulator"]

_ARRAYS = ("A", "B", "C", "D", "y_mean", "y_std", "u_mean", "u_std")
_OBSERVABLE_ARRAYS = ("centres", "powers", "observable_mean", "observable_std")
_GRAM_ARRAYS = ("gram_xx", "gram_xy", "gram_ww", "gram_wz", "gram_rows")

Blocks = list[tuple[FloatArray, FloatArray]]


def _to_log_units(
    a: FloatArray, b: FloatArray, c: FloatArray, d: FloatArray, scales: tuple[FloatArray, ...]
) -> LiftedSystem:
    """The standardised system with the logs' inputs and outputs (the state stays standardised).

    ``ũ = (u − μ_u) / σ_u`` and ``y = μ_y + σ_y ỹ``: the offsets go into the constant state's
    column, which is why the system stays linear in ``u``.
    """
    y_mean, y_std, u_mean, u_std = scales
    shift = u_mean / u_std
    a_raw = a.copy()
    a_raw[:, -1] -= b @ shift
    c_raw = y_std[:, None] * c
    c_raw[:, -1] += y_mean - y_std * (d @ shift)
    return LiftedSystem(a_raw, b / u_std[None, :], c_raw, y_std[:, None] * d / u_std[None, :])


class KoopmanEDMD(Estimator):
    r"""Koopman model with control by extended DMD (Korda & Mezić 2018): a lifted linear system.

    Parameters
    ----------
    lags : Lags
        The delays (every channel's from 1 to its largest lag are the state's linear part) and
        the terms the observables read (the lags of lag ``>= 1``); inputs of lag 0 and
        conditions enter the output through ``D`` and the state through ``B``.
    dictionary : {"thin-plate", "gaussian", "monomials"}, default "thin-plate"
        The observables (:mod:`neckid.models.koopman.dictionary`).
    n_observables : int, optional
        How many; ``None`` chooses among :data:`~neckid.models.koopman.selection.SIZES` on the
        training logs (:mod:`~neckid.models.koopman.selection`). 0 is the delays alone (an ARX
        in state-space form).
    ridge : float, optional
        Ridge penalty per training row on the standardised regressors; ``None`` chooses among
        :data:`~neckid.models.koopman.selection.RIDGES` with the size.
    max_spectral_radius : float, optional
        Pull every eigenvalue of ``A`` (its constant state aside) of larger modulus onto this
        circle and refit ``B`` by least squares (:func:`~neckid.models.koopman.lift.clip_spectrum`);
        the delays are then no longer exact shifts. ``None``: no constraint.
    random_state : int, default 0
        Seed of k-means (the RBF centres).

    Attributes
    ----------
    A_, B_, C_, D_ : ndarray
        The lifted system in the logs' input and output units (:meth:`lifted_system`).
    n_observables_, ridge_ : int, float
        The dictionary size and penalty used.
    selection_ : dict or None
        The choice on the training logs (candidates, mean fold fits, the rule's sentence).
    spectral_radius_ : float
        Largest eigenvalue modulus of ``A_`` without the constant state.
    order_ : int
        Dimension of the lifted state.
    max_lag_, n_inputs_, n_outputs_, n_samples_ : int
    ts_ : float

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags
    >>> from neckid.models.koopman import KoopmanEDMD
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, 1500)
    >>> y = np.zeros(1500)
    >>> for t in range(1, 1500):
    ...     y[t] = 0.6 * y[t - 1] + 0.4 * u[t - 1] - 0.1 * y[t - 1] ** 3
    >>> data = IOData(u, y, ts=0.01)
    >>> model = KoopmanEDMD(Lags.arx(1, 1), dictionary="monomials", n_observables=5,
    ...                     ridge=1e-8).fit(data)
    >>> bool(model.fit_percent(data)[0] > 95.0), model.order_
    (True, 8)
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "dictionary": [Options(set(DICTIONARIES))],
        "n_observables": [None, Interval("int", 0, 2000)],
        "ridge": [None, Interval("real", 0, None)],
        "max_spectral_radius": [None, Interval("real", 0, 1, closed="right")],
        "random_state": [Interval("int", 0, None)],
    }

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        dictionary: str = "thin-plate",
        n_observables: int | None = None,
        ridge: float | None = None,
        max_spectral_radius: float | None = None,
        random_state: int = 0,
    ) -> None:
        self.lags = lags
        self.dictionary = dictionary
        self.n_observables = n_observables
        self.ridge = ridge
        self.max_spectral_radius = max_spectral_radius
        self.random_state = random_state

    # ------------------------------------------------------------------ fit
    def fit(self, data: IOData | Sequence[IOData]) -> KoopmanEDMD:
        """Fit on one experiment or a list of them (the state never straddles two).

        The least squares are small dense problems: they run on one BLAS thread (a thread pool
        costs more than it saves on them, many times more on a busy machine). The fitted state
        is remembered per parameters and training data in the active ``polynomial_fits`` cache
        (:func:`neckid.models.cache.remembered_fit`): the candidates of
        ``ParallelSetMembership(base="koopman")`` refit the same model, its selection included.
        """
        from threadpoolctl import threadpool_limits

        def fit() -> None:
            with threadpool_limits(limits=1):
                self._fit(data)

        return remembered_fit(self, data, fit)

    def _fit(self, data: IOData | Sequence[IOData]) -> KoopmanEDMD:
        self._validate_params()
        if self.lags is None:
            raise ValueError("KoopmanEDMD needs lags=Lags(...); got None")
        experiments = as_experiments(self._with_conditions(data, fitting=True))
        resolved = self.lags.resolve(experiments)
        self._check_training(experiments)
        layout = Layout.of(resolved)
        for d in experiments:
            if d.n_samples < layout.max_lag + 2:
                raise ValueError(
                    f"{d.name or 'a training log'} has {d.n_samples} samples; the Koopman model"
                    f" with lags up to {layout.max_lag} needs at least {layout.max_lag + 2}"
                )
        y_all = np.vstack([d.y for d in experiments])
        u_all = np.vstack([d.u for d in experiments])
        spread = u_all.std(axis=0) if u_all.shape[1] else np.zeros(0)
        scales = (
            y_all.mean(axis=0),
            y_all.std(axis=0),
            u_all.mean(axis=0) if u_all.shape[1] else np.zeros(0),
            np.where(spread > 0, spread, 1.0),
        )
        self.lags_ = resolved
        self.y_mean_, self.y_std_, self.u_mean_, self.u_std_ = scales
        choice = self._choose(experiments, layout)
        size = choice.n_observables if choice else int(self.n_observables or 0)
        ridge = choice.ridge if choice else float(self.ridge or 0.0)
        observables, normal = self._prepare(self._standardised(experiments), layout, size)
        self._set_system(self._system(layout, observables, normal, ridge), observables, normal)
        self.n_observables_, self.ridge_ = int(observables.size), float(ridge)
        self.selection_ = None if choice is None else choice.to_dict()
        self._set_channels(experiments[0])
        self.n_samples_ = int(sum(d.n_samples - layout.max_lag for d in experiments))
        rows = [resolved.build_one(d)[0] for d in experiments]
        self.regressor_ranges_ = regressor_box(np.vstack(rows), resolved.names)
        self.max_lag_ = layout.max_lag
        return self

    def partial_fit(self, data: IOData | Sequence[IOData]) -> KoopmanEDMD:
        """Add ``data`` to the least squares: the same model as a refit on old and new data.

        The dictionary (centres, standardisation), the ridge penalty and the channels' scales
        stay those of :meth:`fit`; the Gram sums of the new experiments are added to the stored
        ones and both least squares solved again, so the result is exactly ``fit`` on all the
        data with that dictionary. The training ranges (and the divergence envelope) widen.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            For data on other channels or another sampling period, or too short.
        """
        from threadpoolctl import threadpool_limits

        experiments = update_experiments(self, data)
        extend_training_ranges(self, experiments)
        layout, observables = Layout.of(self.lags_), self._observables()
        stored = Gram(self.gram_xx_, self.gram_xy_, self.gram_ww_, self.gram_wz_, self.gram_rows_)
        with threadpool_limits(limits=1):
            normal = stored.plus(gram(layout, observables, self._standardised(experiments)))
            system = self._system(layout, observables, normal, self.ridge_)
        self._set_system(system, observables, normal)
        self.n_samples_ += int(sum(d.n_samples - layout.max_lag for d in experiments))
        return self

    def _standardised(self, experiments: Sequence[IOData]) -> Blocks:
        return [
            ((d.y - self.y_mean_) / self.y_std_, (d.u - self.u_mean_) / self.u_std_)
            for d in experiments
        ]

    def _sizes(self, layout: Layout) -> list[int]:
        if self.n_observables is not None:
            return [int(self.n_observables)]
        if self.dictionary != "monomials":
            return list(SIZES)
        n = layout.terms.size
        total = n * (n + 1) // 2 + n * (n + 1) * (n + 2) // 6
        return sorted({min(s, total) for s in (0, 5, 10, 20, 40)})

    def _choose(self, experiments: Sequence[IOData], layout: Layout) -> Choice | None:
        """The paired rule's size and ridge on the training logs, or None when both are given."""
        if self.n_observables is not None and self.ridge is not None:
            return None
        ridges = list(RIDGES) if self.ridge is None else [float(self.ridge)]

        def fit_fold(records: Sequence[IOData], sizes: Sequence[int]) -> Any:
            blocks = self._standardised(records)
            prepared = {s: self._prepare(blocks, layout, s) for s in sizes}

            def run(size: int, ridge: float, held: IOData) -> tuple[FloatArray, int]:
                observables, normal = prepared[size]
                system = self._system(layout, observables, normal, ridge)
                return self._run_log(system, observables, layout, held), layout.max_lag

            return run

        return choose(experiments, self._sizes(layout), ridges, fit_fold)

    def _prepare(self, blocks: Blocks, layout: Layout, size: int) -> tuple[Observables, Gram]:
        """Observables of this size fitted on ``blocks``, and the Gram sums of ``blocks``."""
        r = np.vstack([layout.delays(y, u, layout.max_lag)[:, layout.terms] for y, u in blocks])
        observables, values = fit_observables_with_values(
            r, self.dictionary, size, self.random_state
        )
        return observables, gram(layout, observables, blocks, values)

    def _system(
        self, layout: Layout, observables: Observables, normal: Gram, ridge: float
    ) -> LiftedSystem:
        a, b, c, d = solve(layout, observables, normal, ridge, self.u_mean_.shape[0])
        if self.max_spectral_radius is not None:
            a, b = clip_spectrum(a, b, float(self.max_spectral_radius), normal)
        return _to_log_units(a, b, c, d, (self.y_mean_, self.y_std_, self.u_mean_, self.u_std_))

    def _set_system(self, system: LiftedSystem, observables: Observables, normal: Gram) -> None:
        self.gram_xx_, self.gram_xy_, self.gram_ww_ = normal.xx, normal.xy, normal.ww
        self.gram_wz_, self.gram_rows_ = normal.wz, normal.rows
        self.A_, self.B_, self.C_, self.D_ = system.A, system.B, system.C, system.D
        self.centres_, self.powers_ = observables.centres, observables.powers
        self.width_ = float(observables.width)
        self.observable_mean_, self.observable_std_ = observables.mean, observables.std
        self.order_ = system.order
        core = system.A[:-1, :-1]
        self.spectral_radius_ = float(np.max(np.abs(np.linalg.eigvals(core)))) if core.size else 0.0

    def _run_log(
        self, system: LiftedSystem, observables: Observables, layout: Layout, data: IOData
    ) -> FloatArray:
        """Free run of ``system`` on a standardised-by-the-model log ``data`` (its outputs measured)."""
        m = layout.max_lag
        z = self._lift(observables, layout, data.y[:m], data.u[:m])
        y = np.array(data.y, dtype=np.float64)
        y[m:] = free_run(system, z, np.asarray(data.u[m:], dtype=np.float64))
        return y

    # ------------------------------------------------------------------ use
    def _observables(self) -> Observables:
        return Observables(
            self.dictionary,
            self.centres_,
            self.powers_,
            self.width_,
            self.observable_mean_,
            self.observable_std_,
        )

    def _lift(
        self, observables: Observables, layout: Layout, y_rows: FloatArray, u_rows: FloatArray
    ) -> FloatArray:
        m = layout.max_lag
        y = np.vstack([(y_rows - self.y_mean_) / self.y_std_, np.zeros((1, y_rows.shape[1]))])
        u = np.vstack([(u_rows - self.u_mean_) / self.u_std_, np.zeros((1, u_rows.shape[1]))])
        return lift_rows(layout, observables, layout.delays(y, u, m))[0]

    def lifted_system(self) -> LiftedSystem:
        """``z⁺ = A z + B u``, ``y = C z + D u`` with the logs' input and output units.

        The state ``z`` is standardised (:meth:`state_names`); its last entry is the constant 1
        (eigenvalue 1, the offsets); start it with :meth:`initial_state`.
        """
        check_is_fitted(self)
        return LiftedSystem(self.A_, self.B_, self.C_, self.D_)

    def state_names(self) -> list[str]:
        """Names of the lifted state: the delays, ``phi1 … phiK`` and ``one``."""
        check_is_fitted(self)
        delays = list(Layout.of(self.lags_).names)
        return [*delays, *(f"phi{k + 1}" for k in range(self.n_observables_)), "one"]

    def initial_state(self, y_rows: ArrayLike, u_rows: ArrayLike) -> FloatArray:
        """The lifted state at ``t = max_lag_`` from the first ``max_lag_`` outputs and inputs.

        Parameters
        ----------
        y_rows : array_like, shape (max_lag_, n_outputs)
        u_rows : array_like, shape (max_lag_, n_inputs)

        Returns
        -------
        ndarray, shape (order_,)
        """
        check_is_fitted(self)
        m = self.max_lag_
        y = history_rows(y_rows, m, self.n_outputs_, "y_rows")
        u = history_rows(u_rows, m, self.n_inputs_, "u_rows")
        return self._lift(self._observables(), Layout.of(self.lags_), y, u)

    def run(self, u: FloatArray, z: FloatArray) -> FloatArray:
        """Outputs of inputs ``u`` (rows: time, the logs' units) from state ``z`` (moved on in place)."""
        return free_run(
            self.lifted_system(), z, np.asarray(u, dtype=np.float64).reshape(-1, self.n_inputs_)
        )

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """Free run: the state lifted from the first ``max_lag_`` samples, then the linear system.

        Parameters
        ----------
        data : IOData
            The inputs; its first ``max_lag_`` measured outputs give the initial state unless
            ``initial`` is given (then ``data`` may hold inputs only).
        initial : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
            The first outputs (oldest first; one row is repeated).
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        y = self._initial_outputs(data, initial)
        m = self.max_lag_
        z = self.initial_state(y[:m], data.u[:m])
        y[m:] = self.run(np.asarray(data.u[m:], dtype=np.float64), z)
        return self._result("simulation", data, y)

    def predict(self, data: IOData) -> ModelResult:
        """One step ahead: the state lifted from the measured past at every sample, ``C z + D u``."""
        check_is_fitted(self)
        data = self._with_conditions(data)
        y = self._initial_outputs(data, None)
        layout, m = Layout.of(self.lags_), self.max_lag_
        standard = (data.y - self.y_mean_) / self.y_std_, (data.u - self.u_mean_) / self.u_std_
        z = lift_rows(layout, self._observables(), layout.delays(*standard, m))
        y[m:] = z @ self.C_.T + data.u[m:] @ self.D_.T
        return self._result("prediction", data, y)

    def simulator(self) -> KoopmanSimulator:
        """A stateful simulator: ``reset(y0, u0)`` then ``step(u) -> y`` (the floats of simulate)."""
        check_is_fitted(self)
        return KoopmanSimulator(self)

    def state_map(self, bounds: bool = False) -> Any:
        """The lifted system's state functions, for python-control (``bounds`` is ignored).

        Returns
        -------
        KoopmanStateMap
            State: the lifted state ``z`` (:meth:`state_names`).
        """
        from neckid.models.koopman.state_map import KoopmanStateMap

        check_is_fitted(self)
        return KoopmanStateMap(self)

    def _impulse_norms(self) -> FloatArray | None:
        return None

    # ------------------------------------------------------------------ files
    def _check_state(self) -> None:
        super()._check_state()
        layout = Layout.of(self.lags_)
        if self.max_lag_ != layout.max_lag:
            raise ValueError(
                f"max_lag {self.max_lag_} does not fit the lags {self.lags_.to_lags()!r}"
            )
        k, p, m = int(self.n_observables_), self.n_outputs_, self.n_inputs_
        n = layout.n_delays + k + 1
        if self.order_ != n:
            raise ValueError(f"order {self.order_} must be {n} (delays + observables + 1)")
        for name, shape in (("A", (n, n)), ("B", (n, m)), ("C", (p, n)), ("D", (p, m))):
            self._check_shape(name, getattr(self, f"{name}_"), shape)
        for name, size in (("y_mean", p), ("y_std", p), ("u_mean", m), ("u_std", m)):
            self._check_shape(name, getattr(self, f"{name}_"), (size,))
        terms = layout.terms.size
        rbf = self.dictionary != "monomials"
        self._check_shape("centres", self.centres_, (k if rbf else 0, terms))
        self._check_shape("powers", self.powers_, (0 if rbf else k, terms))
        for name in ("observable_mean", "observable_std"):
            self._check_shape(name, getattr(self, f"{name}_"), (k,))
        if not (
            np.all(self.y_std_ > 0) and np.all(self.u_std_ > 0) and np.all(self.observable_std_ > 0)
        ):
            raise ValueError("y_std, u_std and observable_std must be > 0")
        if not rbf and (np.any(self.powers_ < 0) or np.any(self.powers_.sum(axis=1) > 3)):
            raise ValueError("powers must be monomials of degree 2 or 3 (non-negative exponents)")
        n_x = terms + k + 1 + Layout.of(self.lags_).direct.size
        gram_shapes: list[tuple[str, tuple[int, ...]]] = [
            ("gram_xx", (n_x, n_x)),
            ("gram_xy", (n_x, p)),
            ("gram_ww", (n + m, n + m)),
            ("gram_wz", (n + m, n)),
            ("gram_rows", (2,)),
        ]
        for name, sums in gram_shapes:
            self._check_shape(name, getattr(self, f"{name}_"), sums)
        if not (np.isfinite(self.width_) and self.width_ > 0):
            raise ValueError(f"width must be a positive number; got {self.width_!r}")

    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        names = (*_ARRAYS, *_OBSERVABLE_ARRAYS, *_GRAM_ARRAYS)
        arrays = {name: getattr(self, f"{name}_") for name in names}
        params = self.get_params(deep=False)
        params.pop("lags")
        meta = {
            "params": params,
            "lags": self.lags_.to_dict(),
            "ts": self.ts_,
            "n_samples": self.n_samples_,
            "order": self.order_,
            "n_observables": self.n_observables_,
            "ridge": self.ridge_,
            "width": self.width_,
            "spectral_radius": self.spectral_radius_,
            "selection": self.selection_,
            **self._channels_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls, arrays: Mapping[str, NDArray[Any]], meta: Mapping[str, Any]
    ) -> KoopmanEDMD:
        resolved = ResolvedLags.from_dict(meta["lags"])
        model = cls(resolved.to_lags(), **meta["params"])
        model.lags_ = resolved
        model._restore_channels(meta, resolved)
        model.ts_ = float(meta["ts"])
        model.n_samples_ = int(meta["n_samples"])
        model.order_ = int(meta["order"])
        model.n_observables_ = int(meta["n_observables"])
        model.ridge_ = float(meta["ridge"])
        model.width_ = float(meta["width"])
        model.spectral_radius_ = float(meta["spectral_radius"])
        model.selection_ = meta.get("selection")
        for name in (*_ARRAYS, *_OBSERVABLE_ARRAYS, *_GRAM_ARRAYS):
            dtype = np.int64 if name == "powers" else np.float64
            setattr(model, f"{name}_", np.ascontiguousarray(arrays[name], dtype=dtype))
        model.max_lag_ = resolved.max_lag
        return model


class KoopmanSimulator:
    """Step-by-step free run of a :class:`KoopmanEDMD`, for closed loops.

    ``reset(y0, u0)`` lifts the state from ``max_lag_`` past outputs and inputs (zeros when not
    given: ``reset()`` starts from the lift of a zero history, the zero state of
    :meth:`KoopmanEDMD.state_map`). ``step(u)`` returns ``y(t) = C z + D u`` and moves the state
    on, with the arithmetic of ``simulate``.
    """

    def __init__(self, model: KoopmanEDMD) -> None:
        self._model = model
        self.n_inputs, self.n_outputs = model.n_inputs_, model.n_outputs_
        self.reset()

    def reset(self, y0: ArrayLike | None = None, u0: ArrayLike | None = None) -> None:
        """Start again from past outputs ``y0`` and inputs ``u0`` (one row repeated; default 0).

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (max_lag_, n_outputs), optional
            Past outputs (oldest first).
        u0 : array_like, shape (n_inputs,) or (max_lag_, n_inputs), optional
            Past inputs.
        """
        m = max(self._model.max_lag_, 1)
        y_rows = history_rows(y0, m, self.n_outputs, "y0")
        u_rows = history_rows(u0, m, self.n_inputs, "u0")
        self.x = self._model.initial_state(y_rows, u_rows)

    def step(self, u: ArrayLike) -> FloatArray:
        """Advance one sample with input ``u`` (``(n_inputs,)``); return ``y(t)`` (``(n_outputs,)``)."""
        row = input_row(u, self.n_inputs)
        return np.asarray(self._model.run(row, self.x)[0], dtype=np.float64)
