"""What the benchmark tries: per-data-set lag grids and the hyper-parameter candidates of each method.

Everything here is a table. A candidate is a ``(settings, estimator)`` pair: a text that names
its hyper-parameters (it goes into the report) and an unfitted estimator made by the method
registry, ``neckid.methods()[name].make(lags, quick=..., **params)``. :data:`CANDIDATE_GRIDS`
maps a registry name to the small function that lists its candidates on one data set (from a
:class:`GridInput`); the benchmark runs the methods that have one (:data:`BENCHMARK_METHODS`).

The candidates are ranked on the training record only (:data:`SELECTION_FRACTION`, see
:mod:`neckid.experiments.benchmark.runner`). Two tables say what a run may share or skip:
:data:`BUILDS_ON` (a method whose lag grid is cut to the lags another method's selection chose)
and :func:`shared_fits` (fits several candidates share, done once per run).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from neckid.data.iodata import IOData, as_experiments
from neckid.experiments.benchmark.datasets import SOFTNECK_STAIR_EDGES
from neckid.experiments.benchmark.shared import SharedFits
from neckid.registry import methods
from neckid.regressors import Lags

__all__ = [
    "BENCHMARK_GROUPS",
    "BENCHMARK_METHODS",
    "BUILDS_ON",
    "CANDIDATE_GRIDS",
    "CROSS_RUN_BENCHMARKS",
    "DEFAULT_METHODS",
    "LAG_GRIDS",
    "LARGE_RECORDS",
    "LPV_DEGREES",
    "NEURAL_PARAMS",
    "ONLY_ON",
    "OPT_IN_METHODS",
    "PEER_METHODS",
    "PNLSS_MAX_WORK",
    "PNLSS_SAMPLES_PER_PARAMETER",
    "POLYNOMIAL_DEGREE",
    "PUBLIC_BENCHMARKS",
    "SCHEDULED_LAGS",
    "SCHEDULED_PARAMS",
    "SELECTION_FOLDS",
    "SELECTION_FRACTION",
    "SM_EPSILON_FACTORS",
    "SM_EPSILON_FACTORS_LARGE",
    "SM_INPUT_WEIGHTS",
    "SM_PARALLEL_EPSILON_FACTORS",
    "SM_PARALLEL_POLY_EPSILON_FACTORS",
    "SM_PARALLEL_POLY_ESTIMATES",
    "SM_PARALLEL_POLY_OPTIONS",
    "SM_PARALLEL_POLY_REGRESSORS",
    "SM_PARALLEL_REGRESSORS",
    "STATE_MODEL_LABELS",
    "STATE_MODEL_PARAMS",
    "Candidate",
    "GridInput",
    "arx_error_scale",
    "candidates",
    "lag_grid",
    "pnlss_order",
    "runs_on",
    "shared_fits",
]

#: A hyper-parameter setting of a method: its description and an unfitted estimator.
Candidate = tuple[str, Any]

#: The training data of a data set: one record, or several runs (the cross-run protocols).
Training = IOData | Sequence[IOData]

#: Share of the training record the candidates are fitted on; they are ranked by free-run RMSE on
#: the rest.
SELECTION_FRACTION = 0.75

#: When the training data are several experiments: the number of folds of experiments the
#: candidates are ranked on (:func:`neckid.selection.lags.score_candidates`); ``None`` holds out one
#: experiment at a time. :data:`SELECTION_FRACTION` is then not used.
SELECTION_FOLDS: int | None = None

#: Candidate regressors per data set (ranked on the training record). A quick run takes the
#: second (or only) one.
LAG_GRIDS: Mapping[str, tuple[Lags, ...]] = MappingProxyType(
    {
        "softneck": (
            Lags.arx(1, 1, 1),
            Lags.arx(2, 2, 1),
            Lags.arx(3, 3, 1),
            Lags.arx(1, 1, 0),
            Lags.arx(2, 2, 0),
        ),
        "cascaded_tanks": (Lags.arx(2, 2, 1), Lags.arx(3, 3, 1), Lags.arx(4, 4, 1)),
        # Duffing oscillator: second order in the output, the input at t..t-3 (lag 0 included).
        "silverbox": (Lags.arx(2, 3, 0), Lags.arx(2, 4, 0), Lags.arx(3, 4, 0)),
        "bouc_wen": (Lags.arx(5, 5, 0),),
        "robot_arm": (Lags.arx(2, 2, 1), Lags.arx(4, 4, 1)),
    }
)

#: The cross-run protocols of the soft-neck logs: the soft-neck grid with the payload [kg] as a
#: constant input (``Lags(..., conditions=["payload"])``; the scheduled model takes none).
CROSS_RUN_BENCHMARKS = frozenset({"softneck-payload", "softneck-controller"})


def _with_payload(lags: Lags) -> Lags:
    return Lags(lags.outputs, lags.inputs, conditions=["payload"])


#: Data sets whose training records are large (Silverbox, Bouc-Wen: 65,000 and 41,000 samples):
#: Set Membership leaves the knee rule out there (γ*(ε) on a 48-point grid over all pairs takes
#: minutes, at one given ε seconds).
LARGE_RECORDS = frozenset({"silverbox", "bouc_wen"})

#: Candidate noise bounds of Set Membership, as multiples of the one-step residual RMS of a linear
#: ARX on the same regressor (training record); ``None`` is SetMembership's own knee rule.
SM_EPSILON_FACTORS: tuple[float | None, ...] = (None, 1.0, 3.0)

#: The same on :data:`LARGE_RECORDS` (no knee rule).
SM_EPSILON_FACTORS_LARGE: tuple[float | None, ...] = (0.5, 1.0)

#: Candidate ``input_weight`` of SM with a linear part: the linear part carries the input
#: dynamics, and a light input weight lets the SM residual depend mostly on the past outputs.
SM_INPUT_WEIGHTS: tuple[float, ...] = (1.0, 0.1, 0.03)

#: Candidate SM regressors of the parallel model: ``(linear_lags, input_lags)``, lags of the
#: linear model's simulated output and of the inputs.
SM_PARALLEL_REGRESSORS: tuple[tuple[tuple[int, ...], tuple[int, ...]], ...] = (
    ((0,), ()),
    ((0, 1), ()),
    ((0, 1, 2), ()),
    ((0, 1), (1,)),
)

#: Candidate noise bounds of the parallel model, as multiples of the RMS free-run error of the
#: linear ARX on the training record; ``None`` is the knee rule (left out on
#: :data:`LARGE_RECORDS`).
SM_PARALLEL_EPSILON_FACTORS: tuple[float | None, ...] = (None, 0.25, 1.0)

#: Degree of the polynomial NARX (and of SM's parallel polynomial): a cubic, as the FROLS
#: polynomial NARX the Silverbox literature compares against.
POLYNOMIAL_DEGREE = 3

#: SM regressors on the parallel polynomial: its simulated output at t and t-1, without and with
#: the input at t-1. (A state-like one, output at t..t-2 and input at t..t-3, was tried on
#: Silverbox: the selection on the training record did not pick it, and it costs 50 % more time.)
SM_PARALLEL_POLY_REGRESSORS: tuple[tuple[tuple[int, ...], tuple[int, ...]], ...] = (
    ((0, 1), ()),
    ((0, 1), (1,)),
)

#: Noise bounds of SM on the parallel polynomial, as multiples of the polynomial's RMS free-run
#: error on the training record (a polynomial fitted for simulation leaves an error a fraction of
#: the ARX's, so the ARX's scale would make the SM map flat).
SM_PARALLEL_POLY_EPSILON_FACTORS: tuple[float | None, ...] = (1.0, 3.0)

#: The SM map on the parallel polynomial: a distance learnt from the data and one Lipschitz
#: constant per training point. On Silverbox's selection split (``Lags.arx(3, 4, 0)``, ε = 1× the
#: polynomial's error, regressor ``([0, 1], [1])``) the std distance with one γ gives 1.30 mV, the
#: learnt one 0.29 mV, with local constants 0.23 mV (the polynomial alone: 0.20 mV).
SM_PARALLEL_POLY_OPTIONS: Mapping[str, Any] = MappingProxyType(
    {"scaling": "gradient", "lipschitz": "local"}
)

#: The estimates tried for SM on the parallel polynomial: the central one, and the polynomial's
#: output projected into the SM bounds (corrected only where the data and the prior say it is
#: wrong; ``ParallelSetMembership(estimate=...)``).
SM_PARALLEL_POLY_ESTIMATES: tuple[str, ...] = ("central", "projection")

#: The neural network of a full run (a quick run takes the registry's ``quick`` settings): 10
#: networks trained, the 5 with the best free run on the held-out ends of the training records
#: averaged. On the soft-neck logs one network's free-run fit moves by about 20 points with its
#: seed, a plain mean of 5 by about 8, this by about 3 (see ``NeuralNARX``'s ``n_networks``).
NEURAL_PARAMS: Mapping[str, Any] = MappingProxyType(
    {"hidden_layer_sizes": (25, 25), "max_iter": 300, "n_networks": 5, "simulation_tuning": 5}
)

#: The scheduled model on the soft-neck training log: every stair is an operating point, the
#: first 40 samples (1 s) of each left out; CFF-RLS with the seed paper's λ; the lines go through
#: every point. ``window`` is 100 samples (50 in a quick run). The position form (motor
#: displacement to inclination): the paper's rate form integrates, and drifts far off in free run
#: on these logs.
SCHEDULED_PARAMS: Mapping[str, Any] = MappingProxyType(
    {
        "form": "position",
        "forgetting_factor": 0.98,
        "segments": SOFTNECK_STAIR_EDGES,
        "skip": 40,
        "window": 100,
        "converged_only": False,
    }
)

#: The regressor of the scheduled model: motor displacement [rad] at ``t − 1`` and the inclination.
SCHEDULED_LAGS = Lags(outputs=[1], inputs={"motor_displacement": [1]})

#: The public benchmarks (one training record each).
PUBLIC_BENCHMARKS = frozenset({"cascaded_tanks", "silverbox", "bouc_wen", "robot_arm"})

#: The soft-neck protocols: the single log and the two cross-run splits.
SOFTNECK_BENCHMARKS = frozenset({"softneck"}) | CROSS_RUN_BENCHMARKS

#: The data-set groups a registry entry's :attr:`~neckid.registry.Method.only_on` names.
BENCHMARK_GROUPS: Mapping[str, frozenset[str]] = MappingProxyType(
    {"public": PUBLIC_BENCHMARKS, "softneck": SOFTNECK_BENCHMARKS}
)

#: Methods that run on some data sets only: each registry entry's
#: :attr:`~neckid.registry.Method.only_on` group, and the peer's. The polynomial NARX's
#: simulation fit costs 1-3 min on a large record; on the soft-neck protocols, whose selection
#: refits every candidate per run left out (30 fits of 15,000 rows on the payload split), that is
#: most of an hour, so it runs on the public benchmarks only. The grey-box neck (tendon slack and
#: hysteresis) is a model of the soft neck. A user-defined grey box of another plant (e.g. a
#: cascaded-tanks ODE) names its group in its registry entry and adds one line to
#: :data:`CANDIDATE_GRIDS` (``_state_model_grid("<its registry name>")``).
ONLY_ON: Mapping[str, frozenset[str]] = MappingProxyType(
    {
        **{m.name: BENCHMARK_GROUPS[m.only_on] for m in methods().values() if m.only_on},
        "sysidentpy-frols": PUBLIC_BENCHMARKS,
        "pysindy-stlsq": PUBLIC_BENCHMARKS,
        "pykoopman-edmdc": PUBLIC_BENCHMARKS,
    }
)

#: Methods whose lag grid is cut to the lags another method's selection chose on the same
#: training data (when the grid holds more than one): each registry entry's
#: :attr:`~neckid.registry.Method.builds_on`. SM on the parallel polynomial sits on the
#: polynomial that ``poly``'s own selection picked. Measured on 2026-11-27 with the full grid
#: (``docs/benchmarks/methods.md``): the full grid chose those lags on all four public data sets.
BUILDS_ON: Mapping[str, str] = MappingProxyType(
    {m.name: m.builds_on for m in methods().values() if m.builds_on}
)

#: Hyper-parameters of the state models beside the registry's defaults: one candidate each, the
#: order from the training data (the singular values of the subspace step), not from a lag grid.
#: Each lag-free registry entry's :attr:`~neckid.registry.Method.benchmark_params`.
STATE_MODEL_PARAMS: Mapping[str, Mapping[str, Any]] = MappingProxyType(
    {m.name: MappingProxyType(dict(m.benchmark_params)) for m in methods().values() if m.lag_free}
)

#: Largest ``samples × outputs × parameters²`` of the polynomial state-space model (the work of
#: one least-squares step on its free-run Jacobian, which is what its fit time grows with): its
#: order is the ``ss`` model's, lowered until the model fits under it (:func:`pnlss_order`).
#: Measured on 2026-11-27 (2-core machine, load 8-10): Bouc-Wen order 3 (0.7e9) 104 s, Silverbox
#: order 3 (1.2e9) 186 s, the robot arm's ``ss`` order 8 on 512 samples (2.0e9) over 5 min.
PNLSS_MAX_WORK = 1.0e9

#: Fewest training samples (times outputs) per parameter of the polynomial state-space model: an
#: order whose model has more parameters than that is lowered too (:func:`pnlss_order`).
PNLSS_SAMPLES_PER_PARAMETER = 10


def lag_grid(benchmark: str, quick: bool = False) -> list[Lags]:
    """The candidate regressors on data set ``benchmark`` (:data:`LAG_GRIDS`)."""
    if benchmark in CROSS_RUN_BENCHMARKS:
        grid = [_with_payload(lags) for lags in LAG_GRIDS["softneck"]]
    else:
        grid = list(LAG_GRIDS[benchmark])
    return (grid[1:2] or grid[:1]) if quick else grid


def runs_on(method: str, benchmark: str) -> bool:
    """Whether the benchmark runs registry method ``method`` on data set ``benchmark``."""
    return method not in ONLY_ON or benchmark in ONLY_ON[method]


def arx_error_scale(
    lags: Lags,
    train: IOData | Sequence[IOData],
    free_run: bool = False,
    *,
    shared: SharedFits | None = None,
) -> float:
    """RMS error of a linear ARX with these lags on the training record (or records, pooled).

    The one-step residual by default; with ``free_run``, the free-run error. ``shared`` keeps it
    for the other grids of a run (:meth:`SharedFits.arx_scale`).

    Raises
    ------
    ValueError
        With ``free_run``, when the ARX's free run diverges on the training record.
    """
    return (shared or SharedFits()).arx_scale(lags, train, free_run)


def pnlss_order(ss_order: int, n_samples: int, n_inputs: int, n_outputs: int) -> int:
    """The order of the polynomial state-space model on a training set of this size.

    The ``ss`` model's order (the largest gap of its singular values on the training data),
    lowered until ``n_samples × n_outputs × n_parameters²`` (the work of one least-squares step
    on its free-run Jacobian) is at most :data:`PNLSS_MAX_WORK` and the training data give
    :data:`PNLSS_SAMPLES_PER_PARAMETER` samples per parameter; at least 1.

    Examples
    --------
    >>> pnlss_order(6, 40_960, 1, 1), pnlss_order(6, 65_062, 1, 1), pnlss_order(8, 512, 1, 1)
    (3, 2, 1)
    """
    from neckid.models.pnlss.fitting import Layout

    for order in range(max(int(ss_order), 1), 1, -1):
        layout = Layout(order, n_inputs, n_outputs, POLYNOMIAL_DEGREE, False)
        size = sum(rows * columns for rows, columns in layout.shapes())
        rows = n_samples * n_outputs
        if rows * size**2 <= PNLSS_MAX_WORK and rows >= PNLSS_SAMPLES_PER_PARAMETER * size:
            return order
    return 1


# ---------------------------------------------------------------------------- candidate grids
@dataclass(frozen=True)
class GridInput:
    """What a candidate grid reads: the data set, its training data and the run's settings.

    Attributes
    ----------
    benchmark : str
        A key of :data:`LAG_GRIDS` or :data:`CROSS_RUN_BENCHMARKS`.
    train : IOData or sequence of IOData
        The training record or runs (the Set Membership noise bounds scale with an ARX's error
        on them).
    quick : bool
        One candidate and the registry's smoke-run settings.
    seed : int
        ``random_state`` of the neural networks.
    lags : tuple of Lags, optional
        The lag sets to try; ``None`` is :func:`lag_grid` (a :data:`BUILDS_ON` method gets the
        lags its base method chose).
    shared : SharedFits
        The run's shared fits (ARX error scales, fitted polynomials and ``ss`` models).
    """

    benchmark: str
    train: Training
    quick: bool = False
    seed: int = 0
    lags: tuple[Lags, ...] | None = None
    shared: SharedFits = field(default_factory=SharedFits)

    def lag_sets(self, quick: bool | None = None) -> list[Lags]:
        """:attr:`lags`, or :func:`lag_grid` (of a quick run when ``quick``)."""
        if self.lags is not None:
            return list(self.lags)
        return lag_grid(self.benchmark, self.quick if quick is None else quick)

    def state_lags(self) -> Lags | None:
        """The lags a state model reads (their conditions only): the payload across runs."""
        return lag_grid(self.benchmark)[0] if self.benchmark in CROSS_RUN_BENCHMARKS else None

    def n_train(self) -> int:
        """Training samples, over every run."""
        return sum(r.n_samples for r in as_experiments(self.train, "train"))


def _epsilon(factor: float | None, scale: float) -> tuple[float | None, str]:
    """The noise bound ``factor × scale`` and its label (``None`` and ``"knee"`` for the rule)."""
    if factor is None:
        return None, "knee"
    return factor * scale, f"{factor:g} x {scale:.3g}"


def _arx_grid(g: GridInput) -> list[Candidate]:
    make = methods()["arx"].make
    return [(f"lags={lags!r}", make(lags, quick=g.quick)) for lags in g.lag_sets()]


def _set_membership_grid(
    name: str, input_weights: tuple[float, ...]
) -> Callable[[GridInput], list[Candidate]]:
    """The grid of ``"sm"`` or ``"sm-linear"``: lags × ε × ``input_weights`` (1 when quick)."""
    method = methods()[name]

    def grid(g: GridInput) -> list[Candidate]:
        full = SM_EPSILON_FACTORS_LARGE if g.benchmark in LARGE_RECORDS else SM_EPSILON_FACTORS
        factors: tuple[float | None, ...] = (None,) if g.quick else full
        weights = (1.0,) if g.quick else input_weights
        out: list[Candidate] = []
        for lags in g.lag_sets():
            noise = g.shared.arx_scale(lags, g.train)
            for factor, weight in itertools.product(factors, weights):
                epsilon, label = _epsilon(factor, noise)
                out.append(
                    (
                        f"lags={lags!r}, epsilon={label}, input_weight={weight:g}",
                        method.make(
                            lags,
                            quick=g.quick,
                            epsilon=epsilon,
                            input_weight=weight,
                            progress=False,
                        ),
                    )
                )
        return out

    return grid


def _parallel_candidates(
    make: Callable[..., Any],
    lags: Lags,
    quick: bool,
    regressors: Sequence[tuple[tuple[int, ...], tuple[int, ...]]],
    factors: Sequence[float | None],
    scale: float,
    extra: str,
    options: Mapping[str, Any] = MappingProxyType({}),
) -> list[Candidate]:
    """SM parallel candidates on ``lags``: SM regressor × ε (``factor × scale``)."""
    out: list[Candidate] = []
    shown = "".join(f", {k}={v}" for k, v in options.items())
    for (linear_lags, input_lags), factor in itertools.product(regressors, factors):
        epsilon, label = _epsilon(factor, scale)
        settings = make(
            lags,
            quick=quick,
            linear_lags=linear_lags,
            input_lags=input_lags,
            epsilon=epsilon,
            progress=False,
            **options,
        )
        out.append(
            (
                f"lags={lags!r}{extra}, linear_lags={list(linear_lags)},"
                f" input_lags={list(input_lags)}, epsilon={label}{shown}",
                settings,
            )
        )
    return out


def _parallel_grid(g: GridInput) -> list[Candidate]:
    make = methods()["sm-parallel"].make
    regressors = SM_PARALLEL_REGRESSORS[1:2] if g.quick else SM_PARALLEL_REGRESSORS
    factors: tuple[float | None, ...] = (
        (None,)
        if g.quick
        else SM_PARALLEL_EPSILON_FACTORS[1:]
        if g.benchmark in LARGE_RECORDS
        else SM_PARALLEL_EPSILON_FACTORS
    )
    out: list[Candidate] = []
    for lags in g.lag_sets():
        try:
            scale = g.shared.arx_scale(lags, g.train, free_run=True)
        except ValueError:
            continue  # an unstable linear model cannot run in parallel
        out += _parallel_candidates(make, lags, g.quick, regressors, factors, scale, "")
    return out


def _polynomial(lags: Lags) -> Any:
    """The polynomial NARX that ``poly`` ranks and ``sm-parallel-poly`` runs in parallel."""
    return methods()["poly"].make(lags, degree=POLYNOMIAL_DEGREE)


def _polynomial_grid(g: GridInput) -> list[Candidate]:
    make = methods()["poly"].make
    params = {} if g.quick else {"degree": POLYNOMIAL_DEGREE}
    out: list[Candidate] = []
    for lags in g.lag_sets():
        model = make(lags, quick=g.quick, **params)
        out.append((f"lags={lags!r}, degree={model.degree}, fit_for={model.fit_for}", model))
    return out


#: Degrees of the LPV-ARX's schedule the benchmark ranks (0 is the ARX; with the payload as the
#: scheduling condition a degree above (training payloads − 1) is that degree).
LPV_DEGREES = (0, 1, 2)


def _lpv_grid(g: GridInput) -> list[Candidate]:
    """The LPV-ARX: lags × :data:`LPV_DEGREES` (the registry's degree alone when quick)."""
    make = methods()["lpv"].make
    degrees: tuple[int | None, ...] = (None,) if g.quick else LPV_DEGREES
    out: list[Candidate] = []
    for lags, degree in itertools.product(g.lag_sets(), degrees):
        params = {} if degree is None else {"degree": degree}
        model = make(lags, quick=g.quick, **params)
        out.append((f"lags={lags!r}, degree={model.degree}, fit_for={model.fit_for}", model))
    return out


def _parallel_polynomial_grid(g: GridInput) -> list[Candidate]:
    """SM on a parallel polynomial NARX: lags × SM regressor × ε (× the polynomial's own error)."""
    method = methods()["sm-parallel-poly"]
    regressors = SM_PARALLEL_POLY_REGRESSORS[:1] if g.quick else SM_PARALLEL_POLY_REGRESSORS
    out: list[Candidate] = []
    factors: tuple[float | None, ...] = (None,)
    for lags in g.lag_sets():
        if g.quick:
            scale = 0.0
        else:
            try:
                polynomial = g.shared.fitted(_polynomial(lags), g.train)
            except ValueError:
                continue  # too few rows for the monomials of this regressor
            scale = float(np.sqrt(np.mean(np.square(polynomial.fit_report_["rmse"]))))
            factors = SM_PARALLEL_POLY_EPSILON_FACTORS
        degree = method.make(lags, quick=g.quick).parallel_degree  # the registry's (2 when quick)
        for estimate in SM_PARALLEL_POLY_ESTIMATES[:1] if g.quick else SM_PARALLEL_POLY_ESTIMATES:
            out += _parallel_candidates(
                method.make,
                lags,
                g.quick,
                regressors,
                factors,
                scale,
                f", degree={degree}",
                {**SM_PARALLEL_POLY_OPTIONS, "estimate": estimate},
            )
    return out


def _sindy_grid(g: GridInput) -> list[Candidate]:
    """The sparse NARX: one candidate per lag set (its threshold chosen inside, on the same data)."""
    make = methods()["sindy"].make
    out: list[Candidate] = []
    for lags in g.lag_sets():
        model = make(lags, quick=g.quick)
        label = (
            f"lags={lags!r}, degree={model.degree}, threshold by the rule, fit_for={model.fit_for}"
        )
        out.append((label, model))
    return out


def _free_run_rms(model: Any, train: Training) -> float:
    """RMS free-run error of a fitted model over the training records (pooled)."""
    errors = [(model.simulate(r).y - r.y)[model.max_lag_ :] for r in as_experiments(train, "train")]
    return float(np.sqrt(np.mean(np.square(np.vstack(errors)))))


def _parallel_sindy_grid(g: GridInput) -> list[Candidate]:
    """SM on a parallel sparse NARX: as on the parallel polynomial, ε × the sparse model's error."""
    method = methods()["sm-parallel-sindy"]
    regressors = SM_PARALLEL_POLY_REGRESSORS[:1] if g.quick else SM_PARALLEL_POLY_REGRESSORS
    factors: tuple[float | None, ...] = (None,) if g.quick else SM_PARALLEL_POLY_EPSILON_FACTORS
    out: list[Candidate] = []
    for lags in g.lag_sets():
        scale = 0.0
        if not g.quick:
            sparse = g.shared.fitted(methods()["sindy"].make(lags), g.train)
            scale = _free_run_rms(sparse, g.train)
            if not np.isfinite(scale):
                continue  # a sparse model that runs away cannot run in parallel
        for estimate in SM_PARALLEL_POLY_ESTIMATES[:1] if g.quick else SM_PARALLEL_POLY_ESTIMATES:
            out += _parallel_candidates(
                method.make,
                lags,
                g.quick,
                regressors,
                factors,
                scale,
                ", base=sindy",
                {**SM_PARALLEL_POLY_OPTIONS, "estimate": estimate},
            )
    return out


def _koopman_grid(g: GridInput) -> list[Candidate]:
    """The Koopman model: one candidate per lag set (dictionary size and ridge chosen inside)."""
    make = methods()["koopman"].make
    out: list[Candidate] = []
    for lags in g.lag_sets():
        model = make(lags, quick=g.quick)
        size = "by the rule" if model.n_observables is None else model.n_observables
        out.append((f"lags={lags!r}, {model.dictionary} RBFs: {size}", model))
    return out


def _parallel_koopman_grid(g: GridInput) -> list[Candidate]:
    """SM on a parallel Koopman model: ε × its free-run error (one SM regressor, two estimates).

    Each candidate fits its own Koopman model (``base="koopman"``, its dictionary size and ridge
    by the rule on the candidate's training part), so one SM regressor only: a candidate costs a
    Koopman selection.
    """
    method = methods()["sm-parallel-koopman"]
    regressors = SM_PARALLEL_POLY_REGRESSORS[:1]
    factors: tuple[float | None, ...] = (None,) if g.quick else SM_PARALLEL_POLY_EPSILON_FACTORS
    out: list[Candidate] = []
    for lags in g.lag_sets():
        scale = 0.0
        if not g.quick:
            try:
                koopman = g.shared.fitted(methods()["koopman"].make(lags), g.train)
                scale = _free_run_rms(koopman, g.train)
            except ValueError:
                continue  # a Koopman model that runs away cannot run in parallel
            if not np.isfinite(scale):
                continue
        for estimate in SM_PARALLEL_POLY_ESTIMATES[:1] if g.quick else SM_PARALLEL_POLY_ESTIMATES:
            options = {**SM_PARALLEL_POLY_OPTIONS, "estimate": estimate}
            out += _parallel_candidates(
                method.make, lags, g.quick, regressors, factors, scale, ", base=koopman", options
            )
    return out


def _neural_grid(g: GridInput) -> list[Candidate]:
    make = methods()["nn"].make
    params = {} if g.quick else dict(NEURAL_PARAMS)
    out: list[Candidate] = []
    # Across runs, leave-one-run-out over 6-8 runs would train an ensemble per lags and run left
    # out (most of an hour): one regressor there, fixed in advance (the grid's second, that of
    # docs/nn_seed_spread.py).
    for lags in g.lag_sets(g.quick or g.benchmark in CROSS_RUN_BENCHMARKS):
        model = make(lags, quick=g.quick, random_state=g.seed, **params)
        out.append((f"lags={lags!r}, hidden={tuple(model.hidden_layer_sizes)}", model))
    return out


def _scheduled_grid(g: GridInput) -> list[Candidate]:
    params = {**SCHEDULED_PARAMS, "window": 50 if g.quick else SCHEDULED_PARAMS["window"]}
    label = (
        f"form={params['form']}, forgetting_factor={params['forgetting_factor']:g},"
        f" skip={params['skip']}, window={params['window']}"
    )
    return [(label, methods()["scheduled"].make(SCHEDULED_LAGS, quick=g.quick, **params))]


def _state_label(g: GridInput, text: str) -> str:
    lags = g.state_lags()
    return f"{text}, conditions={list(lags.conditions)}" if lags is not None else text


#: How the settings column names a state model's one candidate (beside its own parameters).
STATE_MODEL_LABELS: Mapping[str, str] = MappingProxyType(
    {"ss": "order from the singular values", "greybox-neck": "tendon slack and hysteresis"}
)


def _state_model_grid(name: str) -> Callable[[GridInput], list[Candidate]]:
    """One candidate of state model ``name`` (registry settings and :data:`STATE_MODEL_PARAMS`)."""

    def grid(g: GridInput) -> list[Candidate]:
        params = dict(STATE_MODEL_PARAMS.get(name, {}))
        model = methods()[name].make(g.state_lags(), quick=g.quick, **params)
        shown = [STATE_MODEL_LABELS.get(name, name), "registry settings"]
        shown += [f"{k}={v}" for k, v in sorted(params.items())]
        return [(_state_label(g, ", ".join(shown)), model)]

    return grid


def _ss_for_pnlss(g: GridInput) -> Any:
    """The ``ss`` model whose order the polynomial state-space model starts from."""
    return methods()["ss"].make(g.state_lags(), quick=g.quick)


def _pnlss_grid(g: GridInput) -> list[Candidate]:
    """The polynomial state space: one candidate, its order by :func:`pnlss_order`."""
    method = methods()["pnlss"]
    ss = g.shared.fitted(_ss_for_pnlss(g), g.train)
    n_outputs = int(ss.n_outputs_)
    order = pnlss_order(int(ss.order_), g.n_train(), int(ss.n_inputs_), n_outputs)
    model = method.make(g.state_lags(), quick=g.quick, order=order)
    label = (
        f"order={order} (ss order {ss.order_}), degree={model.degree}, max_iter={model.max_iter}"
    )
    return [(_state_label(g, label), model)]


#: Registry name -> ``grid(GridInput)`` listing its candidates.
CANDIDATE_GRIDS: Mapping[str, Callable[[GridInput], list[Candidate]]] = MappingProxyType(
    {
        "arx": _arx_grid,
        "ss": _state_model_grid("ss"),
        "pnlss": _pnlss_grid,
        "sm": _set_membership_grid("sm", (1.0,)),
        "sm-linear": _set_membership_grid("sm-linear", SM_INPUT_WEIGHTS),
        "sm-parallel": _parallel_grid,
        "sm-parallel-poly": _parallel_polynomial_grid,
        "poly": _polynomial_grid,
        "lpv": _lpv_grid,
        "sindy": _sindy_grid,
        "sm-parallel-sindy": _parallel_sindy_grid,
        "koopman": _koopman_grid,
        "sm-parallel-koopman": _parallel_koopman_grid,
        "nn": _neural_grid,
        "scheduled": _scheduled_grid,
        "greybox-neck": _state_model_grid("greybox-neck"),
    }
)

#: The registry methods the benchmark can run, in the registry's order.
BENCHMARK_METHODS: tuple[str, ...] = tuple(m for m in methods() if m in CANDIDATE_GRIDS)

#: Methods run only when asked for by name: the LPV-ARX (``--methods lpv``; its grid multiplies
#: the lag sets by :data:`LPV_DEGREES`). SM on a parallel polynomial was one until its candidates
#: shared one polynomial fit and the projection estimate (``docs/benchmarks/``).
OPT_IN_METHODS: frozenset[str] = frozenset({"lpv"})

#: Other toolkits' models, run beside neckid's on the public data sets with the same lag grid and
#: selection rule (:mod:`neckid.experiments.benchmark.peers`; ``pip install "neckid[peers]"``).
PEER_METHODS: tuple[str, ...] = ("sysidentpy-frols", "pysindy-stlsq", "pykoopman-edmdc")

#: What a benchmark runs when no methods are named: neckid's own. A peer runs when named
#: (``--methods ...,sysidentpy-frols``; one that is not installed gives a row that says so).
DEFAULT_METHODS: tuple[str, ...] = tuple(m for m in BENCHMARK_METHODS if m not in OPT_IN_METHODS)


#: The base model SM runs in parallel with, of the methods whose candidates share its fits.
_PARALLEL_BASES = {"sm-parallel-sindy": "sindy", "sm-parallel-koopman": "koopman"}


def shared_fits(method: str, g: GridInput) -> list[tuple[Any, bool]]:
    """Fits the grid or the candidates of ``method`` share, to be done once per run before them.

    Returns
    -------
    list of (estimator, bool)
        An unfitted estimator, and whether it is also fitted on every selection fit part (the
        candidates refit it there) besides the whole training data (which the grid reads):
        for ``sm-parallel-poly`` the polynomial of every lag set, for ``sm-parallel-sindy`` and
        ``sm-parallel-koopman`` their base model of every lag set (its own selection inside),
        for ``pnlss`` the ``ss`` model whose order it starts from.
    """
    if method == "sm-parallel-poly" and not g.quick:
        return [(_polynomial(lags), True) for lags in g.lag_sets()]
    if method in _PARALLEL_BASES and not g.quick:
        make = methods()[_PARALLEL_BASES[method]].make
        return [(make(lags), True) for lags in g.lag_sets()]
    if method == "pnlss":
        return [(_ss_for_pnlss(g), False)]
    return []


def candidates(
    method: str,
    benchmark: str,
    train: IOData | Sequence[IOData],
    *,
    quick: bool = False,
    seed: int = 0,
    lags: Sequence[Lags] | None = None,
    shared: SharedFits | None = None,
) -> list[Candidate]:
    """The hyper-parameter candidates of registry method ``method`` on data set ``benchmark``.

    Parameters
    ----------
    method : str
        A name of :data:`BENCHMARK_METHODS`.
    benchmark : str
        A key of :data:`LAG_GRIDS`.
    train : IOData or sequence of IOData
        The training record or runs (the Set Membership noise bounds scale with an ARX's error
        on them).
    quick : bool, default False
        One candidate and the registry's smoke-run settings.
    seed : int, default 0
        ``random_state`` of the neural networks.
    lags : sequence of Lags, optional
        The lag sets to try instead of :func:`lag_grid` (lag-free methods ignore it).
    shared : SharedFits, optional
        Fits shared with the other grids of a run; a new store by default.

    Returns
    -------
    list of (str, estimator)
        The settings text and an unfitted estimator, per candidate.

    Raises
    ------
    ValueError
        If ``method`` has no candidate grid.
    """
    if method not in CANDIDATE_GRIDS:
        raise ValueError(f"method must be one of {list(BENCHMARK_METHODS)}; got {method!r}")
    grid_input = GridInput(
        benchmark,
        train,
        quick=quick,
        seed=seed,
        lags=None if lags is None else tuple(lags),
        shared=shared or SharedFits(),
    )
    return CANDIDATE_GRIDS[method](grid_input)
