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

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from neckid.data.iodata import IOData
from neckid.models.adaptive_conformal import band_around
from neckid.models.online import ADAPT_MODES, AdaptiveRun, adaptive_free_run, simulate_with_offset
from neckid.models.results import DivergenceError, ExtrapolationWarning, ModelResult
from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = [
    "AdaptedRun",
    "adaptation_label",
    "adapted_outputs",
    "adapted_run",
    "check_adaptation",
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
