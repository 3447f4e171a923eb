r"""The settings of a multi-step Set Membership model, chosen per horizon by cross-validation over runs.

:class:`~neckid.models.set_membership.multistep.MultiStepSetMembership` needs, per horizon ``k``,
an ε factor (ε_k = factor · 1.4826 · MAD of the k-step least-squares residual), a weight of the
input terms in the distance and the form of the Lipschitz prior (one constant, or one per
training point). :func:`select_settings` chooses them on the training logs only:

1. **Folds over runs.** With two or more training experiments each fold holds one out
   (leave-one-experiment-out); with one, the record is cut into ``MIN_BLOCKS = 3`` contiguous
   time blocks (:func:`neckid.data.folds.fold_records`: of one period of the period average when
   the input repeats exactly) and each fold holds one block out.
   Regressors never straddle two experiments or blocks.
2. **Every setting of the grid** (:class:`SettingGrid`; by default :data:`EPSILON_FACTORS` ×
   :data:`INPUT_WEIGHTS` × :data:`LIPSCHITZ_FORMS`, 28 settings) is fitted on each fold's
   training part by the estimator's own rules and scored on the held-out part: the share of the
   held-out k-step samples inside the guaranteed band ``[f_l − ε_k, f_u + ε_k]`` (coverage) and
   the band's mean width, per output.
3. **The rule.** Among the settings whose mean held-out coverage reaches ``target_coverage``
   (95 % by default) for every output, the one with the narrowest mean band (per output, in
   units of the residual's robust scale, summed over outputs; the width itself for one output);
   ties go to the first in the grid's order. If none reaches it, the setting with the highest
   mean coverage is taken, with a warning. A setting that fails in a fold (no Lipschitz
   constant can be learned at its ε) is out, with the reason kept.

Per horizon the regressor of each experiment (or block) is built once and shared by every fold
and setting, and every fold's least squares is computed before any compiled kernel runs; per
fold and input weight (the distance changes with it) one kd-tree is built, one walk per training
point gives its steepest slope at every ε of the grid (the local constants, and γ*(ε) as their
maximum; :func:`~neckid.models.set_membership._kernels.priors.point_gamma_grid`), and one walk
per held-out sample the bounds of all the settings of that tree
(:func:`~neckid.models.set_membership._kernels.priors.prior_bounds`). Each setting's band is, bit
for bit, the one a fit with that setting on the fold's training part gives
(:func:`~neckid.models.set_membership.horizon_fit.fit_horizon`).

The grid is the one of the hand-run study of ``docs/bounds.md``
(``docs/examples/bounds_experiment.py``), not pruned: once the tree and the distances are shared,
14 settings cost about 2.5 times one (``benchmarks/bench_multistep_selection.py``: the whole
choice 14.6 times less than fitting every setting on its own).
"""

from __future__ import annotations

import itertools
import logging
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from neckid.data.folds import MIN_BLOCKS, fold_records, rank_candidates
from neckid.data.iodata import IOData
from neckid.models.linear.arx import linear_sum
from neckid.models.set_membership._kernels.priors import prior_bounds
from neckid.models.set_membership.core import SMSettings
from neckid.models.set_membership.horizon_fit import (
    HorizonSetting,
    LinearPart,
    epsilon_floor,
    horizon_lags,
    linear_part,
    local_constants,
    prior_grid,
    rule_epsilon,
    stack_rows,
)
from neckid.models.set_membership.prior import ProgressOption, _progress_callback
from neckid.models.set_membership.scaling import term_weights
from neckid.models.set_membership.training import training_tree
from neckid.regressors import Lags, ResolvedLags
from neckid.utils.types import FloatArray

__all__ = [
    "EPSILON_FACTORS",
    "FALLBACK_SETTING",
    "INPUT_WEIGHTS",
    "LIPSCHITZ_FORMS",
    "MIN_BLOCKS",
    "MultiStepSelection",
    "SelectionRow",
    "SettingGrid",
    "candidate_grid",
    "fold_experiments",
    "json_candidates",
    "select_settings",
]

logger = logging.getLogger(__name__)

#: ε factors tried (ε_k = factor × the robust scale of the k-step least-squares residual).
EPSILON_FACTORS = (1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0)
#: Weights of the input terms in the distance tried.
INPUT_WEIGHTS = (1.0, 0.3)
#: Forms of the Lipschitz prior tried.
LIPSCHITZ_FORMS = ("global", "local")
#: Leaf size of the cross-validation's trees (split in the principal frame). Their walks are
#: screened, so smaller leaves skip more points for a few more boxes: one fold's bounds of the
#: 14 priors at horizon 3 of the soft-neck payload split took 2.43 CPU s with leaves of 16,
#: 1.95 with 8 and 1.84 with 4 (horizon 40: 1.61, 1.60, 1.43); 8 for half the nodes of 4.
SELECTION_LEAF_SIZE = 8
#: The setting of a horizon whose folds are too short to score any setting (the defaults
#: before the selection existed).
FALLBACK_SETTING = HorizonSetting(3.0, 1.0, "global")


@dataclass(frozen=True)
class SettingGrid:
    """The candidate settings: every ε factor × input weight × Lipschitz form.

    Attributes
    ----------
    epsilon_factors : tuple of float
        Ascending, distinct, > 0.
    input_weights : tuple of float
        Distinct, > 0.
    lipschitz : tuple of str
        Of ``"global"``, ``"local"``.
    """

    epsilon_factors: tuple[float, ...] = EPSILON_FACTORS
    input_weights: tuple[float, ...] = INPUT_WEIGHTS
    lipschitz: tuple[str, ...] = LIPSCHITZ_FORMS

    def settings(self) -> list[HorizonSetting]:
        """Every setting, input weight outermost, then the form, then the ε factor."""
        return [
            HorizonSetting(f, w, form)
            for w, form, f in itertools.product(
                self.input_weights, self.lipschitz, self.epsilon_factors
            )
        ]


@dataclass(frozen=True)
class SelectionRow:
    """One setting of one horizon, scored over the folds.

    Attributes
    ----------
    horizon : int
    setting : HorizonSetting
    coverage, worst_coverage, width : tuple of float
        Per output: mean held-out coverage over the folds, the lowest fold's, and the mean
        band width (output units). NaN for a failed setting.
    fold_coverage, fold_width : tuple of tuple of float
        Per fold, per output.
    status : str
        ``"chosen"``, ``"meets target"``, ``"below target"`` or ``"failed"``.
    reason : str
        Why a setting failed (empty otherwise).
    """

    horizon: int
    setting: HorizonSetting
    coverage: tuple[float, ...]
    worst_coverage: tuple[float, ...]
    width: tuple[float, ...]
    fold_coverage: tuple[tuple[float, ...], ...]
    fold_width: tuple[tuple[float, ...], ...]
    status: str
    reason: str = ""

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict."""
        return {
            "horizon": self.horizon,
            "setting": self.setting.to_json(),
            "coverage": list(self.coverage),
            "worst_coverage": list(self.worst_coverage),
            "width": list(self.width),
            "fold_coverage": [list(v) for v in self.fold_coverage],
            "fold_width": [list(v) for v in self.fold_width],
            "status": self.status,
            "reason": self.reason,
        }

    @classmethod
    def from_json(cls, value: Any) -> SelectionRow:
        """The row :meth:`to_json` wrote."""
        return cls(
            int(value["horizon"]),
            HorizonSetting.from_json(value["setting"]),
            tuple(float(v) for v in value["coverage"]),
            tuple(float(v) for v in value["worst_coverage"]),
            tuple(float(v) for v in value["width"]),
            tuple(tuple(float(v) for v in f) for f in value["fold_coverage"]),
            tuple(tuple(float(v) for v in f) for f in value["fold_width"]),
            str(value["status"]),
            str(value["reason"]),
        )


@dataclass(frozen=True)
class MultiStepSelection:
    """What :func:`select_settings` found: the chosen setting per horizon and the fold table.

    Attributes
    ----------
    folds : {"experiments", "time blocks", "time blocks of one period"}
        Leave-one-experiment-out, or contiguous blocks of the one training record.
    fold_names : tuple of str
        The held-out experiment (or block) of each fold.
    target_coverage : float
    horizons : tuple of int
    chosen : tuple of HorizonSetting
        One per horizon, in the order of ``horizons``.
    rows : tuple of SelectionRow
        Every setting of every horizon.
    seconds : float
        Wall time of the selection.
    """

    folds: str
    fold_names: tuple[str, ...]
    target_coverage: float
    horizons: tuple[int, ...]
    chosen: tuple[HorizonSetting, ...]
    rows: tuple[SelectionRow, ...]
    seconds: float

    def table(self) -> pd.DataFrame:
        """One row per horizon and setting: the settings, coverage, worst fold, width, status.

        With several outputs, ``coverage`` is the lowest output's and ``width`` the first
        output's (the per-output values are in :attr:`rows`).
        """
        return pd.DataFrame(
            [
                {
                    "horizon": r.horizon,
                    **r.setting.to_json(),
                    "coverage": min(r.coverage),
                    "worst_coverage": min(r.worst_coverage),
                    "width": r.width[0],
                    "status": r.status,
                    "reason": r.reason,
                }
                for r in self.rows
            ]
        )

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (the model file stores it)."""
        return {
            "folds": self.folds,
            "fold_names": list(self.fold_names),
            "target_coverage": self.target_coverage,
            "horizons": list(self.horizons),
            "chosen": [s.to_json() for s in self.chosen],
            "rows": [r.to_json() for r in self.rows],
            "seconds": self.seconds,
        }

    @classmethod
    def from_json(cls, value: Any) -> MultiStepSelection:
        """The selection :meth:`to_json` wrote."""
        return cls(
            str(value["folds"]),
            tuple(str(n) for n in value["fold_names"]),
            float(value["target_coverage"]),
            tuple(int(k) for k in value["horizons"]),
            tuple(HorizonSetting.from_json(s) for s in value["chosen"]),
            tuple(SelectionRow.from_json(r) for r in value["rows"]),
            float(value["seconds"]),
        )


def _candidates(name: str, value: Any, default: tuple[float, ...]) -> tuple[float, ...]:
    """The values of ``epsilon_factor`` or ``input_weight`` to try (one when it is fixed)."""
    if value is None:
        return default
    values = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if values.ndim != 1 or values.size == 0 or np.any(values <= 0):
        raise ValueError(f"{name} must be a number > 0 or a non-empty list of them; got {value!r}")
    return tuple(float(v) for v in dict.fromkeys(values.tolist()))


def candidate_grid(
    epsilon_factor: Any, input_weight: Any, lipschitz: str | None, *, given: bool
) -> SettingGrid:
    """The settings a multi-step estimator tries, from its parameters.

    None means the default candidates, a number fixes a setting, a list lists the candidates.
    With ``given`` (ε given: nothing is cross-validated) there is one setting: ``input_weight``
    None means 1 and ``lipschitz`` None ``"global"`` (:data:`FALLBACK_SETTING`).

    Raises
    ------
    ValueError
        A candidate <= 0, an empty list, or several input weights with ``given``.
    """
    default = SettingGrid()
    forms = default.lipschitz if lipschitz is None else (str(lipschitz),)
    factors = tuple(sorted(_candidates("epsilon_factor", epsilon_factor, default.epsilon_factors)))
    weights = _candidates("input_weight", input_weight, default.input_weights)
    if not given:
        return SettingGrid(factors, weights, forms)
    if input_weight is not None and len(weights) > 1:
        raise ValueError(
            f"input_weight lists candidates ({list(weights)}) for the cross-validation, which"
            " does not run when epsilon is given (a known bound); give one input_weight"
        )
    weight = weights[0] if input_weight is not None else FALLBACK_SETTING.input_weight
    form = forms[0] if lipschitz is not None else FALLBACK_SETTING.lipschitz
    return SettingGrid((factors[0],), (weight,), (form,))


def json_candidates(value: Any) -> float | list[float] | None:
    """A number, a list of candidates or None, as a model file's JSON holds it."""
    if value is None:
        return None
    array = np.asarray(value, dtype=np.float64)
    return float(array) if array.ndim == 0 else array.tolist()


def fold_experiments(experiments: Sequence[IOData]) -> tuple[list[IOData], str]:
    """The parts the folds hold out: the experiments (two or more), else time blocks of the one.

    One record is cut as :func:`neckid.data.folds.fold_records` cuts it: within one period of its
    period average when its input repeats exactly.

    Returns
    -------
    parts : list of IOData
    kind : {"experiments", "time blocks", "time blocks of one period"}
    """
    if len(experiments) >= 2:
        return list(experiments), "experiments"
    parts, scheme = fold_records(list(experiments), MIN_BLOCKS)
    return parts, "time blocks of one period" if scheme.endswith("period") else "time blocks"


# ---------------------------------------------------------------------------------- one fold
@dataclass(frozen=True)
class _FoldScore:
    coverage: FloatArray  # (n_settings, n_outputs)
    width: FloatArray  # (n_settings, n_outputs)
    scale: FloatArray  # (n_outputs,)
    failed: dict[int, str]


def _fold_bands(
    train: Sequence[tuple[FloatArray, FloatArray]],
    held: tuple[FloatArray, FloatArray],
    lags: ResolvedLags,
    linear: LinearPart,
    grid: SettingGrid,
    options: SMSettings,
) -> tuple[FloatArray, FloatArray, FloatArray, dict[int, str]]:
    """Every setting's guaranteed band on the held-out rows, fitted on the training rows.

    Returns ``(lower, upper, scale, failed)``: bands of shape ``(n_rows, n_settings,
    n_outputs)`` (NaN for a failed setting), the residual scale, and why settings failed.
    """
    settings = grid.settings()
    x, y = stack_rows(train)
    target = np.ascontiguousarray(linear.residual if options.linear_part else y)
    x_held = held[0]
    centre = linear_sum(x_held, linear.coef, linear.intercept)
    n_out = y.shape[1]
    lower = np.full((x_held.shape[0], len(settings), n_out), np.nan)
    upper = np.full_like(lower, np.nan)
    failed: dict[int, str] = {}
    margin = float(options.gamma_margin)
    for weight in grid.input_weights:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # the final fit reports them
            weights = term_weights(options.scaling, weight, x, lags)
        floor = epsilon_floor(np.ascontiguousarray(x * weights), target)
        epsilon = np.vstack([rule_epsilon(f, linear.scale, floor) for f in grid.epsilon_factors])
        tree, _ = training_tree(
            x.copy(),
            y,
            weights,
            linear.coef,
            linear.intercept,
            bool(options.linear_part),
            frame=True,
            leaf_size=SELECTION_LEAF_SIZE,
        )
        priors = prior_grid(tree, epsilon, margin)
        gamma, steepest = priors.gamma, priors.steepest
        constants = np.empty((0, tree.points.shape[0], n_out))
        if "local" in grid.lipschitz:
            constants = np.stack(
                [
                    local_constants(steepest[e], np.nan_to_num(gamma[e]), margin)
                    for e in range(len(epsilon))
                ]
            )
        columns, factor_of, local = [], [], []
        for s, setting in enumerate(settings):
            if setting.input_weight != weight:
                continue
            e = grid.epsilon_factors.index(float(setting.epsilon_factor))  # type: ignore[arg-type]
            if np.any(np.isnan(gamma[e])):
                failed[s] = "γ*(ε) = 0 and no fraction of ε gives a positive γ*: no constant"
            elif not np.all(np.isfinite(steepest[e])):
                failed[s] = "identical regressors with outputs more than 2ε apart"
            else:
                columns.append(s)
                factor_of.append(e)
                local.append(e if setting.lipschitz == "local" else -1)
        if not columns:
            continue
        eps_s, gamma_s = epsilon[factor_of], gamma[factor_of]
        low, high = prior_bounds(
            tree,
            x_held * weights,
            eps_s,
            gamma_s,
            constants,
            np.asarray(local, dtype=np.int64),
            int(options.local_neighbours),
        )
        # As MultiStepSetMembership.predict_ahead: (linear + (f_l − ε)) − ε, likewise above.
        lower[:, columns] = (centre[:, None, :] + low) - eps_s[None]
        upper[:, columns] = (centre[:, None, :] + high) + eps_s[None]
    return lower, upper, linear.scale, failed


def _score_fold(
    train: Sequence[tuple[FloatArray, FloatArray]],
    held: tuple[FloatArray, FloatArray],
    lags: ResolvedLags,
    linear: LinearPart,
    grid: SettingGrid,
    options: SMSettings,
) -> _FoldScore:
    """Held-out coverage and mean width of every setting's band (NaN where it failed)."""
    lower, upper, scale, failed = _fold_bands(train, held, lags, linear, grid, options)
    y = held[1][:, None, :]
    inside = (lower <= y) & (y <= upper)
    coverage = inside.mean(axis=0)
    width = (upper - lower).mean(axis=0)
    for s in failed:
        coverage[s], width[s] = np.nan, np.nan
    return _FoldScore(coverage, width, scale, failed)


# ---------------------------------------------------------------------------------- one horizon
def _choose(
    coverage: FloatArray, width: FloatArray, scale: FloatArray, target: float
) -> tuple[int | None, bool]:
    """Index of the chosen setting (None if all failed) and whether it meets the target.

    ``coverage`` and ``width`` are means over folds, ``(n_settings, n_outputs)``, NaN where a
    setting failed in some fold. The choice is the one ranking of every selection
    (:func:`neckid.data.folds.rank_candidates`, ``"best"`` rule): among the settings that meet
    the target, the narrowest band (width over the residual scale, summed over outputs; ties:
    the first); when none does, the highest worst-output coverage, the narrower band on a tie.
    """
    ok = ~np.isnan(coverage).any(axis=1)
    if not ok.any():
        return None, False
    score = np.where(ok, np.sum(width / np.where(scale > 0, scale, 1.0), axis=1), np.inf)
    meets = ok & np.all(coverage >= target, axis=1)
    if meets.any():
        narrow = rank_candidates(
            -score[:, None], accepted=np.asarray(meets, dtype=bool).tolist(), rule="best"
        )
        return narrow.chosen, True
    worst = np.where(ok, coverage.min(axis=1), -np.inf)
    covered = rank_candidates(
        worst[:, None], score.tolist(), accepted=np.asarray(ok, dtype=bool).tolist(), rule="best"
    )
    return covered.chosen, False


@dataclass(frozen=True)
class _HorizonFolds:
    """One horizon's k-step regressor and each fold's linear part (or why it has none)."""

    steps: int
    lags: ResolvedLags
    linear: list[LinearPart | str]
    short: str


def _horizon_folds(parts: Sequence[IOData], lags: ResolvedLags, steps: int) -> _HorizonFolds:
    """The least squares of every fold, before any compiled kernel runs (see horizon_rows)."""
    lags_k = horizon_lags(lags, steps).resolve(list(parts))
    short = [p.name for p in parts if p.n_samples <= lags_k.max_lag + 1]
    if short:
        reason = f"{short[0]!r} is too short for the regressor of horizon {steps}"
        return _HorizonFolds(steps, lags_k, [], reason)
    rows = [lags_k.build_one(p) for p in parts]
    linear: list[LinearPart | str] = []
    for f in range(len(parts)):
        try:
            linear.append(linear_part(*stack_rows(rows[:f] + rows[f + 1 :])))
        except ValueError as error:  # fewer rows than regressor terms
            linear.append(str(error))
    return _HorizonFolds(steps, lags_k, linear, "")


def _fold_scores(
    parts: Sequence[IOData],
    folds: _HorizonFolds,
    grid: SettingGrid,
    options: SMSettings,
    tick: Callable[[], None],
) -> tuple[FloatArray, FloatArray, FloatArray, dict[int, str]]:
    """Coverage and width ``(n_folds, n_settings, n_outputs)``, residual scales, failures."""
    n_settings, n_folds = len(grid.settings()), len(parts)
    lags, steps = folds.lags, folds.steps
    coverage = np.full((n_folds, n_settings, len(lags.output_names)), np.nan)
    width = np.full_like(coverage, np.nan)
    scales = np.ones((n_folds, coverage.shape[2]))
    if folds.short:
        for _ in range(n_folds):
            tick()
        return coverage, width, scales, dict.fromkeys(range(n_settings), folds.short)
    rows = [lags.build_one(p) for p in parts]  # once per horizon, shared by every fold
    reasons: dict[int, str] = {}
    for f in range(n_folds):
        started = time.perf_counter()
        linear = folds.linear[f]
        try:
            if isinstance(linear, str):
                raise ValueError(linear)
            score = _score_fold(rows[:f] + rows[f + 1 :], rows[f], lags, linear, grid, options)
        except ValueError as error:  # too few rows for the linear part, a constant output...
            score = _FoldScore(
                coverage[f], width[f], scales[f], dict.fromkeys(range(n_settings), str(error))
            )
        coverage[f], width[f], scales[f] = score.coverage, score.width, score.scale
        for s, reason in score.failed.items():
            reasons.setdefault(s, f"fold {parts[f].name!r}: {reason}")
        logger.info(
            "horizon %d, fold %d/%d (%s held out): %d settings in %.2f s",
            steps,
            f + 1,
            n_folds,
            parts[f].name,
            n_settings,
            time.perf_counter() - started,
        )
        tick()
    return coverage, width, scales, reasons


def _warn_choice(
    steps: int, chosen: HorizonSetting, coverage: float | None, target: float, reason: str
) -> None:
    if coverage is None:
        warnings.warn(
            f"horizon {steps}: no setting could be scored in cross-validation ({reason}); the"
            f" fallback setting {chosen.to_json()} is used. Give longer or more experiments, or"
            " fix epsilon_factor, input_weight and lipschitz",
            UserWarning,
            stacklevel=5,
        )
    else:
        warnings.warn(
            f"horizon {steps}: no setting reached the target coverage {target:g} on the"
            f" held-out folds; the one with the highest ({coverage:.3f}) is used:"
            f" {chosen.to_json()}. Its band may hold fewer samples of a new run than that",
            UserWarning,
            stacklevel=5,
        )


def _status(chosen: bool, failed: bool, meets: bool) -> str:
    if chosen:
        return "chosen"
    if failed:
        return "failed"
    return "meets target" if meets else "below target"


def _select_horizon(
    parts: Sequence[IOData],
    folds: _HorizonFolds,
    grid: SettingGrid,
    options: SMSettings,
    target: float,
    tick: Callable[[], None],
) -> tuple[HorizonSetting, list[SelectionRow]]:
    """The chosen setting of one horizon and the rows of its table."""
    settings, steps = grid.settings(), folds.steps
    coverage, width, scales, reasons = _fold_scores(parts, folds, grid, options, tick)
    mean_cov, mean_width = np.mean(coverage, axis=0), np.mean(width, axis=0)
    mean_cov[list(reasons)], mean_width[list(reasons)] = np.nan, np.nan
    index, met = _choose(mean_cov, mean_width, np.mean(scales, axis=0), target)
    chosen = FALLBACK_SETTING if index is None else settings[index]
    if not met:
        held = None if index is None else float(mean_cov[index].min())
        _warn_choice(steps, chosen, held, target, next(iter(reasons.values()), ""))
    table = []
    for s, setting in enumerate(settings):
        status = _status(s == index, s in reasons, bool(np.all(mean_cov[s] >= target)))
        table.append(
            SelectionRow(
                steps,
                setting,
                tuple(mean_cov[s].tolist()),
                tuple(np.min(coverage[:, s], axis=0).tolist()),
                tuple(mean_width[s].tolist()),
                tuple(tuple(v) for v in coverage[:, s].tolist()),
                tuple(tuple(v) for v in width[:, s].tolist()),
                status,
                reasons.get(s, ""),
            )
        )
    return chosen, table


def select_settings(
    experiments: Sequence[IOData],
    lags: Lags | ResolvedLags,
    horizons: Sequence[int],
    grid: SettingGrid,
    options: SMSettings,
    *,
    target_coverage: float = 0.95,
    progress: ProgressOption = None,
) -> MultiStepSelection:
    """Choose each horizon's ε factor, input weight and Lipschitz form by cross-validation.

    Parameters
    ----------
    experiments : list of IOData
        The training experiments (one is cut into :data:`MIN_BLOCKS` time blocks).
    lags : Lags or ResolvedLags
        The one-step regressor; each horizon's follows from it (``horizon_lags``).
    horizons : sequence of int
        The horizons, in samples.
    grid : SettingGrid
        The candidate settings.
    options : SMSettings
        ``scaling``, ``linear_part``, ``gamma_margin`` and ``local_neighbours`` of the estimator.
    target_coverage : float, default 0.95
        The mean held-out coverage a setting must reach.
    progress : bool or callable, optional
        A bar (True; None: only above 20,000 training rows) or ``callback(done, total)`` over
        the horizons × folds.

    Returns
    -------
    MultiStepSelection
    """
    started = time.perf_counter()
    parts, kind = fold_experiments(experiments)
    resolved = lags.resolve(list(parts)) if isinstance(lags, Lags) else lags
    total = len(horizons) * len(parts)
    callback, close = _progress_callback(progress, sum(p.n_samples for p in parts))
    done = [0]

    def tick() -> None:
        done[0] += 1
        if callback is not None:
            callback(done[0], total)

    # Every least-squares fit first, then the compiled kernels (see horizon_rows).
    prepared = [_horizon_folds(parts, resolved, int(k)) for k in horizons]
    chosen, rows = [], []
    try:
        for k, folds in zip(horizons, prepared, strict=True):
            setting, table = _select_horizon(parts, folds, grid, options, target_coverage, tick)
            chosen.append(setting)
            rows.extend(table)
            best = next((r for r in table if r.status == "chosen"), None)
            logger.info(
                "horizon %d: chose %s (held-out coverage %s, width %s)",
                k,
                setting.to_json(),
                "n/a" if best is None else f"{min(best.coverage):.3f}",
                "n/a" if best is None else f"{best.width[0]:.4g}",
            )
    finally:
        close()
    return MultiStepSelection(
        kind,
        tuple(p.name or f"part {i + 1}" for i, p in enumerate(parts)),
        float(target_coverage),
        tuple(int(k) for k in horizons),
        tuple(chosen),
        tuple(rows),
        time.perf_counter() - started,
    )
