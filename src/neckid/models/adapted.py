r"""A model adapted on a new run's first seconds, with the un-adapted run and an adaptive band.

What ``neckid validate --adapt`` and ``neckid compare --adapt`` report for one test log: the
free run after ``seconds`` of adaptation (:func:`~neckid.models.online.adaptive_free_run`: the
offset, ``partial_fit`` or both, on the warm-up only), the un-adapted model on exactly the same
samples, and an adaptive conformal band (:func:`~neckid.models.adaptive_conformal.band_around`,
Gibbs & Candès 2021) around the adapted run, whose window starts with the warm-up's residuals.
Nothing after the warm-up is read before it is predicted: the adaptation sees the warm-up only,
and the band at a sample uses the scores of the samples before it.
"""

from __future__ import annotations

import copy
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from neckid.data.iodata import IOData
from neckid.models.adaptive_conformal import band_around
from neckid.models.online import (
    ADAPT_MODES,
    AdaptiveRun,
    adaptive_free_run,
    estimate_offset,
    simulate_with_offset,
)
from neckid.models.results import DivergenceError, ExtrapolationWarning, ModelResult
from neckid.systems import StateMap
from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = [
    "AdaptedRun",
    "OffsetModel",
    "adaptation_label",
    "adapted_model",
    "adapted_outputs",
    "adapted_run",
    "check_adaptation",
    "diverged_rows",
]


def check_adaptation(seconds: float, mode: str) -> tuple[float, str]:
    """``(seconds, mode)`` checked: seconds > 0 and finite, mode ``offset``, ``update`` or ``both``."""
    value = check_number(seconds, "adapt seconds", low=0, closed="neither")
    if mode not in ADAPT_MODES or mode == "none":
        raise ValueError(f"adapt mode must be 'offset', 'update' or 'both'; got {mode!r}")
    return float(value), str(mode)


def adaptation_label(seconds: float, mode: str) -> str:
    """``"free run after 5 s of adaptation (offset)"``: what every output of the mode says."""
    return f"free run after {seconds:g} s of adaptation ({mode})"


@dataclass(frozen=True)
class AdaptedRun:
    """One log run by a model adapted on its first seconds (:func:`adapted_run`).

    Attributes
    ----------
    adapted : AdaptiveRun
        The free run after the warm-up, by the adapted copy.
    unadapted : AdaptiveRun
        The model as given, on the same samples (``adapt="none"``); None if it diverged.
    band : ModelResult or None
        ``adapted.result`` with the adaptive conformal band (``extras["running_coverage"]``);
        None when no band could be formed.
    label : str
        :func:`adaptation_label`.
    """

    adapted: AdaptiveRun
    unadapted: AdaptiveRun | None
    band: ModelResult | None
    label: str

    def rows(self) -> list[dict[str, Any]]:
        """One row per output: fits (adapted, un-adapted), RMSE and the band, as compare lists them."""
        scored, result = self.adapted.scored, self.adapted.result
        errors = result.rmse(scored)
        plain = self.unadapted.fit if self.unadapted is not None else np.full(errors.shape, -np.inf)
        band = "adaptive conformal 95 %" if self.band is not None else ""
        held, widths = self.band_coverage, self.band_width
        return [
            {"output": name, "unit": unit, "fit_percent": float(self.adapted.fit[j])}
            | {"fit_percent_unadapted": float(plain[j]), "rmse": float(errors[j]), "band": band}
            | {"band_width": float(widths[j]), "band_coverage": float(held[j])}
            for j, (name, unit) in enumerate(
                zip(scored.output_names, scored.output_units, strict=True)
            )
        ]

    @property
    def band_coverage(self) -> FloatArray:
        """Per output, the band's running coverage at the log's end (share inside; NaN: none)."""
        if self.band is None:
            return np.full(self.adapted.fit.shape, np.nan)
        return np.asarray(self.band.extras["running_coverage"][-1], dtype=np.float64)

    @property
    def band_width(self) -> FloatArray:
        """Per output, the band's mean width over the samples where it is finite (output units)."""
        if self.band is None or self.band.lower is None or self.band.upper is None:
            return np.full(self.adapted.fit.shape, np.nan)
        width = self.band.upper - self.band.lower
        width = np.where(np.isfinite(width), width, np.nan)[self.band.n_initial :]
        return np.asarray(np.nanmean(width, axis=0), dtype=np.float64)


def diverged_rows(data: IOData) -> list[dict[str, Any]]:
    """:meth:`AdaptedRun.rows` of a run that diverged: fit ``-inf``, nothing else known."""
    return [
        {"output": name, "unit": unit, "fit_percent": -np.inf, "fit_percent_unadapted": np.nan}
        | {"rmse": np.inf, "band": "", "band_width": np.nan, "band_coverage": np.nan}
        for name, unit in zip(data.output_names, data.output_units, strict=True)
    ]


def adapted_outputs(
    model: Any, record: IOData, seconds: float, mode: str, *, diverged: str = "raise"
) -> tuple[FloatArray, int]:
    """The measured outputs through the warm-up, then the adapted free run; and the warm-up's length.

    What a selection fold scores with adaptation (``neckid.selection.lags.free_run``): the
    first ``skip`` samples are measured (the warm-up), the rest the free run after it.
    ``diverged="keep"`` returns a diverged run as it is instead of raising.
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ExtrapolationWarning)
            run = adaptive_free_run(model, record, seconds, adapt=mode)  # type: ignore[arg-type]
        simulated = run.result.y
    except DivergenceError as exc:
        if diverged == "raise":
            raise
        simulated = exc.result.y
    y = np.array(record.y, dtype=np.float64)
    start = record.n_samples - simulated.shape[0]
    y[start:] = simulated
    return y, start + int(model.max_lag_)


def _warmup_scores(model: Any, run: AdaptiveRun, data: IOData) -> FloatArray | None:
    """The adapted model's absolute free-run residuals over the warm-up (None if it diverged)."""
    warmup = data[: run.warmup_samples]
    try:
        if np.any(run.offset):
            result = simulate_with_offset(run.model, warmup, run.offset)
        else:
            result = run.model.simulate(warmup)
    except (DivergenceError, ValueError):
        return None
    return np.abs(warmup.y - result.y)[result.n_initial :]


def adapted_run(
    model: Any, data: IOData, seconds: float, mode: str = "offset", *, coverage: float = 0.95
) -> AdaptedRun:
    """Adapt a copy of ``model`` on ``data``'s first ``seconds``, run the rest, band it.

    Parameters
    ----------
    model : fitted estimator
        Any registered model (not changed).
    data : IOData
        The test log.
    seconds : float
        Warm-up length [s].
    mode : {"offset", "update", "both"}, default "offset"
        The adaptation (:func:`~neckid.models.online.adaptive_free_run`).
    coverage : float, default 0.95
        Nominal level of the adaptive conformal band.

    Returns
    -------
    AdaptedRun

    Raises
    ------
    ValueError
        For a bad ``seconds`` or ``mode``, or a warm-up that leaves nothing to score.
    DivergenceError
        If the adapted free run diverges.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData, Lags, LinearARX
    >>> rng = np.random.default_rng(0)
    >>> u = np.repeat(rng.uniform(-1, 1, 100), 20)
    >>> y = np.zeros(2000)
    >>> for t in range(1, 2000):
    ...     y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 1]
    >>> model = LinearARX(Lags.arx(1, 1)).fit(IOData(u[:1000], y[:1000], ts=0.1))
    >>> test = IOData(u[1000:], y[1000:] + 1.0 + 0.01 * rng.normal(size=1000), ts=0.1)
    >>> run = adapted_run(model, test, 10.0)
    >>> bool(run.adapted.fit[0] > run.unadapted.fit[0] + 20), run.label
    (True, 'free run after 10 s of adaptation (offset)')
    """
    seconds, mode = check_adaptation(seconds, mode)
    adapted = adaptive_free_run(model, data, seconds, adapt=mode)  # type: ignore[arg-type]
    try:
        unadapted: AdaptiveRun | None = adaptive_free_run(model, data, seconds, adapt="none")
    except DivergenceError:
        unadapted = None
    band = None
    if np.all(np.isfinite(adapted.result.y[adapted.result.n_initial :])):
        scores = _warmup_scores(model, adapted, data)
        band = band_around(adapted.result, adapted.scored, coverage=coverage, scores=scores)
    return AdaptedRun(adapted, unadapted, band, adaptation_label(seconds, mode))


class _OffsetStateMap(StateMap):
    """A state map seen through a constant output offset ``c``: ``y = ỹ + c``."""

    def __init__(self, inner: Any, offset: FloatArray) -> None:
        super().__init__()
        self.inner, self.offset = inner, offset
        self.inputs, self.outputs = list(inner.inputs), list(inner.outputs)
        self.states, self.ts = list(inner.states), float(inner.ts)
        self.feedthrough = bool(getattr(inner, "feedthrough", True))

    def _output(self, x: FloatArray, u: FloatArray) -> FloatArray:
        return np.asarray(self.inner.output(x, u), dtype=np.float64) + self.offset

    def _next(self, x: FloatArray, u: FloatArray, out: FloatArray) -> FloatArray:
        return np.asarray(self.inner.update(x, u), dtype=np.float64)

    def initial_state(self, y0: ArrayLike | None, u0: ArrayLike | None) -> FloatArray:
        shifted = None if y0 is None else np.asarray(y0, dtype=np.float64) - self.offset
        return np.asarray(self.inner.initial_state(shifted, u0), dtype=np.float64)


class OffsetModel:
    """A fitted model seen through a constant output offset (the output-offset model).

    Everything is the wrapped model's but the free run (``simulate_with_offset`` of
    :mod:`neckid.models.online`) and the state map (outputs plus ``offset``, the state started
    at the measured outputs minus it), so that a loop that runs ``state_map()`` runs it too.

    Parameters
    ----------
    model : fitted estimator
    offset : array_like, shape (n_outputs,)
    """

    def __init__(self, model: Any, offset: ArrayLike) -> None:
        self.model = model
        self.offset = np.asarray(offset, dtype=np.float64).reshape(-1)

    def __getattr__(self, name: str) -> Any:
        if name in ("model", "offset"):  # not set yet (a copy being made)
            raise AttributeError(name)
        return getattr(self.model, name)

    def simulate(self, data: IOData, initial: ArrayLike | None = None) -> ModelResult:
        """The free run of the output-offset model (``initial``: measured outputs, as usual)."""
        if initial is not None:
            m = max(int(self.model.max_lag_), 1)
            head = np.asarray(initial, dtype=np.float64).reshape(m, -1)
            data = data.replace(y=np.vstack([head, np.asarray(data.y)[m:]]))
        return simulate_with_offset(self.model, data, self.offset)

    def state_map(self) -> StateMap:
        """The wrapped model's state map with the offset on its outputs."""
        return _OffsetStateMap(self.model.state_map(), self.offset)


def adapted_model(model: Any, data: IOData, seconds: float, mode: str = "offset") -> Any:
    """A copy of ``model`` adapted on ``data``'s first ``seconds``, to run anywhere a model runs.

    ``"update"``: ``partial_fit`` on the warm-up; ``"offset"``: an :class:`OffsetModel` with the
    offset estimated on the warm-up; ``"both"``: the offset first, then the update on the
    warm-up with the offset taken off (as :func:`~neckid.models.online.adaptive_free_run`).
    What ``validate --in-loop --adapt`` runs in the loop.
    """
    seconds, mode = check_adaptation(seconds, mode)
    n = int(np.searchsorted(data.time, data.t0 + seconds - 1e-9 * data.ts, side="left"))
    if n <= int(model.max_lag_) or n >= data.n_samples:
        raise ValueError(
            f"--adapt {seconds:g} s gives {n} warm-up samples of {data.n_samples}: it must hold"
            f" more than max_lag = {model.max_lag_} samples and leave some to run"
        )
    warmup = data[:n]
    offset = np.zeros(int(model.n_outputs_))
    if mode in ("offset", "both"):
        offset = estimate_offset(model, warmup)
    adapted = model
    if mode in ("update", "both"):
        adapted = copy.deepcopy(model)
        adapted.partial_fit(warmup.replace(y=warmup.y - offset))
    return OffsetModel(adapted, offset) if mode in ("offset", "both") else adapted
