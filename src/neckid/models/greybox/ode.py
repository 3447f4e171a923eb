r"""GreyBoxODE: a user-written state-space model with physical parameters, fitted on its free run.

MATLAB's ``idnlgrey`` / ``nlgreyest`` for neckid: a :class:`~.structure.GreyBoxStructure`
holds the equations (continuous or discrete time), the parameters with units, initial guesses
and bounds, and the initial state's rule; :class:`GreyBoxODE` fits the parameters on the
simulation error of every training experiment (:mod:`.ode_fitting`) and simulates with a
fixed-step Runge–Kutta integrator (:mod:`.ode_kernels`).

.. math::

    \dot x = f(x, u, \theta), \qquad y(t) = g(x(t), u(t), \theta), \qquad
    x(0) = x_0(y(0), u(0), \theta)\ \text{or estimated}.

The documentation page ``docs/greybox_ode.md`` gives the contract, the shipped structure
(``cascaded-tanks``, :mod:`.tanks`) and measured results.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from neckid.data.iodata import IOData, as_experiments
from neckid.models.base import Estimator, ModelResult, check_is_fitted
from neckid.models.excitation import check_excitation
from neckid.models.greybox.catalog import resolve_structure, shipped_structures
from neckid.models.greybox.ode_fitting import OdeProblem, fit_structure
from neckid.models.greybox.ode_kernels import advance, check_functions, evaluate, free_run
from neckid.models.greybox.structure import GreyBoxStructure
from neckid.models.online import update_experiments
from neckid.models.results import DIVERGENCE_SPANS
from neckid.regressors import Lags
from neckid.systems import history_rows
from neckid.utils.checks import Interval, Options, check_finite
from neckid.utils.types import FloatArray

__all__ = ["GreyBoxODE", "GreyBoxODESimulator"]

#: Runge–Kutta steps per sampling period of a continuous-time structure when ``substeps=None``.
DEFAULT_SUBSTEPS = 4

#: Relative slack allowed on a loaded parameter's bounds (rounding in a hand-made file).
_BOUND_TOLERANCE = 1e-9


class GreyBoxODE(Estimator):
    r"""A grey-box state-space model: the user's equations, physical parameters fitted on the free run.

    Parameters
    ----------
    lags : Lags, optional
        Only its ``conditions`` are used: they are appended to the log's inputs (the structure's
        ``n_inputs`` counts them). The state takes the place of the lags.
    structure : str or GreyBoxStructure, default "cascaded-tanks"
        The equations: a shipped structure's name (:func:`.catalog.shipped_structures`) or a
        user's :class:`~.structure.GreyBoxStructure`.
    fixed : sequence of str, default ()
        Parameters held at their initial guess (MATLAB's ``Fixed``), besides those the
        structure fixes itself: e.g. ``("pump_threshold",)`` when the data cannot tell two
        parameters apart.
    initial_state : {"output", "estimated"}, default "output"
        ``"output"``: every free run starts from the structure's rule ``x0(y(0), u(0), θ)``.
        ``"estimated"``: the fit also estimates the initial state of every training experiment
        (``initial_states_``); a free run on other data still starts from the rule unless
        :meth:`simulate` is given ``state=``.
    substeps : int, optional
        Runge–Kutta steps per sampling period (continuous time); default
        :data:`DEFAULT_SUBSTEPS` (4). A discrete-time structure takes 1.
    n_starts : int, default 8
        Starting points of the fit: the structure's initial guesses and ``n_starts - 1``
        Halton points of the parameters' box (see :mod:`.ode_fitting`).
    max_iter : int, default 200
        Cost evaluations of each refined ``least_squares`` run.
    random_state : int, numpy Generator or None, default 0
        Seeds the Halton points.

    Attributes
    ----------
    structure_ : GreyBoxStructure
        The structure fitted.
    parameters_ : ndarray, shape (n_parameters,)
        The fitted parameters, in the structure's order and units (:meth:`parameter_values`).
    initial_states_ : ndarray, shape (n_experiments, n_states)
        The initial state of each training experiment (the rule's, or the estimated one).
    train_rmse_ : ndarray, shape (n_outputs,)
        Free-run RMSE over the training experiments (from sample 1 on), in the outputs' units.
    start_costs_ : ndarray, shape (n_starts,)
        Mean square free-run error of every start after its screening.
    n_evaluations_ : int
        Free runs of one experiment the fit took.
    substeps_ : int
    max_lag_ : int
        1: the first sample's output sets the initial state (and is returned as measured).

    Notes
    -----
    Sample ``t`` holds the state ``x(t)``; the input is held over ``[t, t + 1)`` (zero-order
    hold), so ``x(t+1)`` is ``x(t)`` integrated over one period with ``u(t)``, and the output is
    ``y(t) = g(x(t), u(t), θ)``. The model is of output-error type: :meth:`predict` is its free
    run and says so (``kind="simulation"``).

    Examples
    --------
    The cascaded tanks at known parameters, and the fit of their free run:

    >>> import numpy as np
    >>> from neckid import IOData
    >>> from neckid.models.greybox import GreyBoxODE, shipped_structures, simulate_structure
    >>> tanks = shipped_structures()["cascaded-tanks"]
    >>> u = np.repeat([3.0, 5.0, 2.0, 4.0, 1.0, 3.5] * 6, 25)
    >>> truth = [0.05, 0.5, 0.06, 0.5, 0.06, 0.3, 0.0, 12.0, 0.5, 10.0]
    >>> _, y = simulate_structure(tanks, u, truth, ts=4.0, x0=[4.0, 3.0])
    >>> data = IOData(u, y, ts=4.0)
    >>> model = GreyBoxODE(structure="cascaded-tanks", n_starts=1, max_iter=40).fit(data)
    >>> bool(model.fit_percent(data)[0] > 95.0)
    True
    """

    _parameter_constraints: ClassVar[dict[str, list[Any]]] = {
        "lags": [None, Lags],
        "structure": [str, GreyBoxStructure],
        "fixed": [tuple, list],
        "initial_state": [Options({"output", "estimated"})],
        "substeps": [None, Interval("int", 1, None)],
        "n_starts": [Interval("int", 1, None)],
        "max_iter": [Interval("int", 1, None)],
        "random_state": ["random_state"],
    }
    predicts_by_simulation = True

    def __init__(
        self,
        lags: Lags | None = None,
        *,
        structure: str | GreyBoxStructure = "cascaded-tanks",
        fixed: Sequence[str] = (),
        initial_state: str = "output",
        substeps: int | None = None,
        n_starts: int = 8,
        max_iter: int = 200,
        random_state: int | np.random.Generator | None = 0,
    ) -> None:
        self.lags = lags
        self.structure = structure
        self.fixed = fixed
        self.initial_state = initial_state
        self.substeps = substeps
        self.n_starts = n_starts
        self.max_iter = max_iter
        self.random_state = random_state

    # ------------------------------------------------------------------ settings
    def _structure(self) -> GreyBoxStructure:
        structure = resolve_structure(self.structure)
        structure.check()
        return structure

    def _fitted_structure(self, structure: GreyBoxStructure) -> GreyBoxStructure:
        """``structure`` with the parameters of ``fixed`` held (the one the fit moves)."""
        names = list(self.fixed)
        unknown = [n for n in names if n not in structure.parameter_names]
        if unknown or not all(isinstance(n, str) for n in names):
            raise ValueError(
                f"fixed must name parameters of structure {structure.name!r}"
                f" {list(structure.parameter_names)}; got {names!r}"
            )
        if not names:
            return structure
        held = tuple(replace(p, fixed=p.fixed or p.name in names) for p in structure.parameters)
        return replace(structure, parameters=held)

    def _substeps(self, structure: GreyBoxStructure) -> int:
        if structure.time == "discrete":
            if self.substeps not in (None, 1):
                raise ValueError(
                    f"substeps must be None or 1 for the discrete-time structure"
                    f" {structure.name!r}; got {self.substeps!r}"
                )
            return 1
        return DEFAULT_SUBSTEPS if self.substeps is None else int(self.substeps)

    # ------------------------------------------------------------------ fit
    def fit(self, data: IOData | Sequence[IOData]) -> GreyBoxODE:
        """Fit the parameters on the free-run error of one experiment or a list of them.

        Raises
        ------
        ValueError
            For a bad hyper-parameter or structure, data whose channels are not the structure's,
            a run shorter than 2 samples, or a best fit that still runs away.
        TypeError
            For a structure whose functions do not return arrays of the declared shapes.
        """
        self._validate_params()
        experiments = as_experiments(self._with_conditions(data, fitting=True))
        self._check_training(experiments)
        self._fit_experiments(experiments)
        return self

    def _check_channels(self, structure: GreyBoxStructure, data: IOData) -> None:
        if (data.n_inputs, data.n_outputs) != (structure.n_inputs, structure.n_outputs):
            raise ValueError(
                f"structure {structure.name!r} takes {structure.n_inputs} input(s) and gives"
                f" {structure.n_outputs} output(s); the data have {data.n_inputs} input(s)"
                f" {list(data.input_names)} and {data.n_outputs} output(s)"
                f" {list(data.output_names)}: select the channels its equations use"
                " (data.select(inputs=..., outputs=...)) or write a structure for these"
            )

    def _fit_experiments(self, experiments: Sequence[IOData]) -> None:
        structure = self._structure()
        self._check_channels(structure, experiments[0])
        check_excitation(
            f"GreyBoxODE ({structure.name})",
            experiments,
            n_parameters=len(structure.parameter_names),
            skip=self._condition_names(True),
            stacklevel=4,  # the caller of fit / partial_fit
        )
        for i, run in enumerate(experiments):
            if run.n_samples < 2:
                raise ValueError(f"data[{i}] has {run.n_samples} sample(s); it needs at least 2")
        substeps = self._substeps(structure)
        first = experiments[0]
        check_functions(structure, first.y[0], first.u[0], structure.initial_values())
        searched = self._fitted_structure(structure)
        y = np.vstack([d.y for d in experiments])
        width = np.ptp(y, axis=0)
        envelope = np.vstack(
            [y.min(axis=0) - DIVERGENCE_SPANS * width, y.max(axis=0) + DIVERGENCE_SPANS * width]
        )
        runs = [
            (np.ascontiguousarray(d.u, dtype=np.float64), np.ascontiguousarray(d.y, dtype=float))
            for d in experiments
        ]
        problem = OdeProblem(
            searched,
            runs,
            float(first.ts),
            substeps,
            self.initial_state == "estimated",
            envelope,
        )
        solution = fit_structure(problem, int(self.n_starts), int(self.max_iter), self._seed())
        self.structure_ = structure
        self.substeps_ = substeps
        self.parameters_ = solution.parameters
        self.initial_states_ = solution.initial_states
        self.train_rmse_ = solution.rmse
        self.start_costs_ = solution.start_costs
        self.n_evaluations_ = solution.evaluations
        self.n_samples_ = int(y.shape[0])
        self._set_channels(first)
        self.max_lag_ = 1

    def _seed(self) -> Any:
        state = self.random_state
        return state if isinstance(state, np.random.Generator) or state is None else int(state)

    def partial_fit(self, data: IOData | Sequence[IOData]) -> GreyBoxODE:
        """Refit on ``data`` alone with the same settings (not an update).

        The free-run fit keeps no statistics that add up over records, so this is a new fit on
        the new experiments; to fit old and new data together call ``fit([old, new])``.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        ValueError
            For data on other channels or another sampling period, or too short.
        """
        experiments = update_experiments(self, data)
        self._validate_params()
        self._check_training(experiments)
        self._fit_experiments(experiments)
        return self

    # ------------------------------------------------------------------ use
    def parameter_values(self) -> dict[str, float]:
        """The fitted parameters by name, in the structure's units.

        Raises
        ------
        NotFittedError
            Before ``fit``.
        """
        check_is_fitted(self)
        return dict(zip(self.structure_.parameter_names, map(float, self.parameters_), strict=True))

    def start_state(self, y0: ArrayLike, u0: ArrayLike) -> FloatArray:
        """The structure's initial state from a first output ``y0`` and input ``u0``.

        Returns
        -------
        ndarray, shape (n_states,)
            Held in the structure's state bounds.
        """
        check_is_fitted(self)
        structure = self.structure_
        y_row = history_rows(y0, 1, self.n_outputs_, "y0")[-1]
        u_row = history_rows(u0, 1, self.n_inputs_, "u0")[-1]
        low, high = structure.state_bounds()
        return np.clip(evaluate(structure.initial_state, y_row, u_row, self.parameters_), low, high)

    def _state_argument(self, state: ArrayLike) -> FloatArray:
        x0 = np.asarray(state, dtype=np.float64).reshape(-1)
        n = self.structure_.n_states
        if x0.shape != (n,):
            raise ValueError(
                f"state must have {n} values {list(self.structure_.state_names)}; got {x0.size}"
            )
        check_finite(x0[None, :], "state")
        return x0

    def simulate(
        self, data: IOData, initial: ArrayLike | None = None, *, state: ArrayLike | None = None
    ) -> ModelResult:
        """Free run from the first sample's state over the inputs of ``data``.

        Parameters
        ----------
        data : IOData
            The inputs; its first measured output sets the initial state unless ``initial`` or
            ``state`` is given (then ``data`` may hold inputs only).
        initial : array_like, shape (n_outputs,) or (1, n_outputs), optional
            The first output, in place of the measured one.
        state : array_like, shape (n_states,), optional
            The state at the first sample, in the states' units (e.g. ``initial_states_[0]``
            to rerun a training experiment from its estimated start); the first output of the
            result is then ``g(state, u(0))``.

        Returns
        -------
        ModelResult
            Of kind ``"simulation"``; ``extras["states"]`` holds the states
            ``(n_samples, n_states)`` and ``extras["state_names"]`` their names.
        """
        check_is_fitted(self)
        data = self._with_conditions(data)
        if state is not None and initial is None and data.n_outputs == 0:
            self._check_inputs(data)
            y = np.zeros((data.n_samples, self.n_outputs_))
        else:
            y = self._initial_outputs(data, initial)
        u = np.ascontiguousarray(data.u, dtype=np.float64)
        x0 = self.start_state(y[0], u[0]) if state is None else self._state_argument(state)
        states, simulated = free_run(
            self.structure_, x0, u, self.parameters_, self.ts_, self.substeps_
        )
        if state is None:
            y[1:] = simulated[1:]
        else:
            y[:] = simulated
        extras = {"states": states, "state_names": self.structure_.state_names}
        return self._result("simulation", data, y, extras=extras)

    def predict(self, data: IOData) -> ModelResult:
        """The free run of :meth:`simulate`, with ``kind="simulation"`` (an output-error model)."""
        return self.simulate(data)

    def simulator(self) -> GreyBoxODESimulator:
        """A stateful simulator: ``reset(y0, u0)`` then ``step(u) -> y`` (the values of simulate)."""
        check_is_fitted(self)
        return GreyBoxODESimulator(self)

    def state_map(self, bounds: bool = False) -> Any:
        """The model's state functions, for python-control (:func:`neckid.export.control.to_iosystem`).

        Parameters
        ----------
        bounds : bool, default False
            Ignored (the model has no band).

        Returns
        -------
        GreyBoxODEStateMap
            State: the structure's states at the current sample (the simulator's).
        """
        from neckid.models.greybox.ode_state_map import GreyBoxODEStateMap

        check_is_fitted(self)
        return GreyBoxODEStateMap(self)

    # ------------------------------------------------------------------ files
    def _check_state(self) -> None:
        super()._check_state()
        structure = self.structure_
        # One initial state per training experiment: as many rows as there were experiments.
        n_runs = (
            max(int(np.shape(self.initial_states_)[0]), 1) if np.ndim(self.initial_states_) else 1
        )
        for name, array, shape in (
            ("parameters", self.parameters_, (len(structure.parameters),)),
            ("initial_states", self.initial_states_, (n_runs, structure.n_states)),
            ("train_rmse", self.train_rmse_, (self.n_outputs_,)),
        ):
            self._check_shape(name, array, shape)
        for value, parameter in zip(self.parameters_, structure.parameters, strict=True):
            span = _BOUND_TOLERANCE * max(1.0, abs(float(value)))
            if not parameter.lower - span <= value <= parameter.upper + span:
                raise ValueError(
                    f"parameter {parameter.name!r} = {value!r} lies outside its bounds"
                    f" [{parameter.lower}, {parameter.upper}] in structure {structure.name!r}"
                )
        self._check_channels(structure, self._zeros(2))
        if self.max_lag_ != 1 or self.substeps_ != self._substeps(structure):
            raise ValueError(
                f"max_lag must be 1 and substeps {self._substeps(structure)} for this model; got"
                f" {self.max_lag_!r} and {self.substeps_!r}"
            )

    def _zeros(self, n: int) -> IOData:
        return IOData(
            np.zeros((n, len(self.input_names_))),
            np.zeros((n, len(self.output_names_))),
            ts=1.0,
            input_names=self.input_names_,
            output_names=self.output_names_,
        )

    def _get_state(self) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        check_is_fitted(self)
        arrays = {
            "parameters": np.asarray(self.parameters_, dtype=np.float64),
            "initial_states": np.asarray(self.initial_states_, dtype=np.float64),
            "train_rmse": np.asarray(self.train_rmse_, dtype=np.float64),
            "start_costs": np.asarray(self.start_costs_, dtype=np.float64),
        }
        params = self.get_params(deep=False)
        lags = params.pop("lags")
        params["structure"] = self.structure_.name
        params["fixed"] = list(params["fixed"])
        if isinstance(params["random_state"], np.random.Generator):
            params["random_state"] = None
        meta = {
            "params": params,
            "structure": self.structure_.fingerprint(),
            "parameter_names": list(self.structure_.parameter_names),
            "conditions": None if lags is None else list(lags.conditions),
            "ts": self.ts_,
            "n_samples": self.n_samples_,
            "substeps": self.substeps_,
            "n_evaluations": self.n_evaluations_,
            **self._channels_meta(),
        }
        return arrays, meta

    @classmethod
    def _from_state(
        cls,
        arrays: Mapping[str, NDArray[Any]],
        meta: Mapping[str, Any],
        structures: Iterable[GreyBoxStructure] = (),
    ) -> GreyBoxODE:
        recorded = meta["structure"]
        if not isinstance(recorded, Mapping) or not isinstance(recorded.get("name"), str):
            raise ValueError("the file's 'structure' entry must name the grey-box structure")
        structure = resolve_structure(recorded["name"], structures)
        structure.check()
        structure.check_fingerprint(recorded)
        conditions = meta["conditions"]
        lags = None if conditions is None else Lags(1, 1, conditions=conditions)
        params = dict(meta["params"])
        shipped = shipped_structures().get(structure.name) is structure
        params["structure"] = structure.name if shipped else structure
        model = cls(lags, **params)
        model._restore_channels(meta)
        model.structure_ = structure
        model.ts_ = float(meta["ts"])
        model.n_samples_ = int(meta["n_samples"])
        model.substeps_ = int(meta["substeps"])
        model.n_evaluations_ = int(meta["n_evaluations"])
        for key in ("parameters", "initial_states", "train_rmse", "start_costs"):
            setattr(model, f"{key}_", np.ascontiguousarray(arrays[key], dtype=np.float64))
        model.max_lag_ = 1
        return model

    @classmethod
    def load(cls, path: str | Path, structures: Iterable[GreyBoxStructure] | None = None) -> Any:
        """Load a model saved by :meth:`save`; a user's structure is passed in ``structures``.

        Parameters
        ----------
        path : str or Path
        structures : iterable of GreyBoxStructure, optional
            Structures to find the file's structure among (by name) before the shipped ones;
            needed for a model of a user's structure.

        Raises
        ------
        ValueError
            If the file is not a valid GreyBoxODE file, or names a structure that is neither
            given nor shipped (the message names it and says how to provide it), or the given
            structure of that name has other parameters, states or channels.
        TypeError
            If the file holds another model class.
        """
        if structures is None:
            return super().load(path)
        from neckid.models.greybox.ode_files import load_with_structures

        return load_with_structures(cls, path, tuple(structures))


class GreyBoxODESimulator:
    """Step-by-step free run of a :class:`GreyBoxODE`, for closed loops.

    The state is the structure's state at the current sample. ``reset(y0, u0)`` takes the
    structure's initial state from the last row of ``y0`` and ``u0`` (or ``state=``) and
    integrates it over that sample's period; ``step(u)`` returns ``y(t) = g(x(t), u)`` and moves
    the state to ``t + 1`` with ``u`` held. After ``reset(y0=y[:1], u0=u[:1])``, stepping
    ``u[1:]`` gives what ``simulate`` gives.
    """

    def __init__(self, model: GreyBoxODE) -> None:
        self._model = model
        self.n_inputs, self.n_outputs = model.n_inputs_, model.n_outputs_
        self.n_states = model.structure_.n_states
        self.reset()

    def reset(
        self,
        y0: ArrayLike | None = None,
        u0: ArrayLike | None = None,
        *,
        state: ArrayLike | None = None,
    ) -> None:
        """Start again from a first output and input (default zeros), or from ``state``.

        Parameters
        ----------
        y0 : array_like, shape (n_outputs,) or (rows, n_outputs), optional
            The last row is the first output.
        u0 : array_like, shape (n_inputs,) or (rows, n_inputs), optional
            The last row is held over the first period.
        state : array_like, shape (n_states,), optional
            The state at that first sample, in place of the structure's rule.
        """
        model = self._model
        y_row = history_rows(y0, 1, self.n_outputs, "y0")[-1]
        u_row = history_rows(u0, 1, self.n_inputs, "u0")[-1]
        x = model.start_state(y_row, u_row) if state is None else model._state_argument(state)
        low, high = model.structure_.state_bounds()
        self.state = self._next(np.clip(x, low, high), u_row)

    def _next(self, x: FloatArray, u: FloatArray) -> FloatArray:
        model = self._model
        return advance(model.structure_, x, u, model.parameters_, model.ts_, model.substeps_)

    def step(self, u: ArrayLike) -> FloatArray:
        """Advance one sample with input ``u`` (``(n_inputs,)``); return ``y(t)`` (``(n_outputs,)``)."""
        row = np.asarray(u, dtype=np.float64).reshape(-1)
        if row.shape[0] != self.n_inputs:
            raise ValueError(
                f"u must have {self.n_inputs} values (one per input); got {row.shape[0]}"
            )
        check_finite(row[None, :], "u")
        model = self._model
        y = evaluate(model.structure_.output_equation, self.state, row, model.parameters_)
        self.state = self._next(self.state, row)
        return y
