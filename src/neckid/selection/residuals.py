"""Is the model good enough? Ljung's residual tests of a model on a log (MATLAB's ``resid``).

A model that has caught all there is to catch in the data leaves one-step prediction residuals
that are white (nothing left to predict from their own past) and independent of the past inputs
(no input dynamics missed). :func:`residual_tests` runs both tests of Ljung, *System
Identification: Theory for the User*, 2nd ed., 1999, section 16.6, per output and per
input-output pair: the whiteness test (the residual's autocorrelation at lags 1..M and the
statistic ``N sum r_e(k)^2``, chi-square with M degrees of freedom) and the independence test
(the residual-input cross-correlation at lags -M..M and ``N r^T R_u^{-1} r``, chi-square with
2M + 1). The correlations and their statistics are :func:`neckid.metrics.residual_autocorrelation`
and :func:`neckid.metrics.residual_input_correlation`; this module picks the residual a model
offers and says which one it is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from neckid.data.iodata import IOData
from neckid.metrics import CorrelationTest, residual_autocorrelation, residual_input_correlation
from neckid.utils.checks import check_number
from neckid.utils.types import FloatArray

__all__ = ["ONE_STEP", "OUTPUT_ERROR", "ResidualTests", "residual_tests"]

#: The residual of a model with a one-step predictor: ``y(t) - ŷ(t | t-1)``.
ONE_STEP = "one-step prediction"
#: The residual of an output-error model, whose one-step predictor is its free run.
OUTPUT_ERROR = "free run (output-error model: its one-step predictor is its simulation)"


@dataclass(frozen=True)
class ResidualTests:
    """The residual tests of one model on one log.

    Attributes
    ----------
    residual : str
        Which residual was tested: :data:`ONE_STEP` (``predict``, the measured past outputs in
        the regressor) or :data:`OUTPUT_ERROR` (an output-error model's free run).
    residuals : ndarray, shape (n_samples - n_initial, n_outputs)
        ``y - ŷ`` after the initial samples, in the outputs' units.
    n_initial : int
        Samples at the start left out (the model's initial conditions).
    ts : float
        Sampling period [s] (a lag of k samples is ``k ts`` seconds).
    output_names, output_units, input_names : tuple of str
    whiteness : tuple of CorrelationTest
        One per output: the residual's autocorrelation at lags 0..M.
    independence : tuple of tuple of (CorrelationTest or None)
        ``independence[j][i]``: output j's residual against input i at lags -M..M; ``None``
        when input i is constant over the log (its correlation is undefined).
    """

    residual: str
    residuals: FloatArray
    n_initial: int
    ts: float
    output_names: tuple[str, ...]
    output_units: tuple[str, ...]
    input_names: tuple[str, ...]
    whiteness: tuple[CorrelationTest, ...]
    independence: tuple[tuple[CorrelationTest | None, ...], ...]

    @property
    def max_lag(self) -> int:
        """M, the largest lag tested [samples]."""
        return int(self.whiteness[0].lags[-1])

    @property
    def confidence(self) -> float:
        """The tests' confidence level."""
        return self.whiteness[0].confidence

    @property
    def passed(self) -> bool:
        """True when no test rejects the model: every whiteness and independence test passed."""
        tests = [*self.whiteness, *(t for row in self.independence for t in row if t is not None)]
        return all(t.passed for t in tests)

    def lines(self) -> list[str]:
        """One line per test in words, then the verdict (what the CLI prints).

        Examples
        --------
        >>> import numpy as np
        >>> from neckid import IOData
        >>> from neckid.models.linear import LinearARX
        >>> from neckid.regressors import Lags
        >>> rng = np.random.default_rng(0)
        >>> u, e = rng.normal(size=3000), 0.1 * rng.normal(size=3000)
        >>> y = np.zeros(3000)
        >>> for t in range(1, 3000):
        ...     y[t] = 0.8 * y[t - 1] + 0.5 * u[t - 1] + e[t]
        >>> data = IOData(u, y, ts=0.02, input_names=["cmd"], output_names=["incl"])
        >>> model = LinearARX(Lags(outputs=[1], inputs=[1])).fit(data)
        >>> print(residual_tests(model, data, max_lag=10).lines()[-1])
        verdict: passed (no test rejects the model at 99 % confidence)
        """
        out = []
        percent = f"{100 * self.confidence:g} %"
        for j, name in enumerate(self.output_names):
            out.append(f"whiteness of e({name}): {_test_text(self.whiteness[j], percent)}")
            for i, input_name in enumerate(self.input_names):
                test = self.independence[j][i]
                text = (
                    "not tested: the input is constant"
                    if test is None
                    else _test_text(test, percent)
                )
                out.append(f"independence of e({name}) and {input_name}: {text}")
        verdict = (
            f"passed (no test rejects the model at {percent} confidence)"
            if self.passed
            else f"failed (a test rejects the model at {percent} confidence)"
        )
        return [*out, f"verdict: {verdict}"]

    def to_dict(self) -> dict[str, Any]:
        """The tests as plain values (JSON): per output and per input-output pair."""
        outputs = []
        for j, name in enumerate(self.output_names):
            pairs = {
                input_name: None if test is None else _test_dict(test, self.ts)
                for input_name, test in zip(self.input_names, self.independence[j], strict=True)
            }
            outputs.append(
                {
                    "output": name,
                    "unit": self.output_units[j],
                    "residual_std": float(np.std(self.residuals[:, j])),
                    "whiteness": _test_dict(self.whiteness[j], self.ts),
                    "independence": pairs,
                }
            )
        return {
            "residual": self.residual,
            "n_samples": int(self.residuals.shape[0]),
            "n_initial": self.n_initial,
            "ts": self.ts,
            "max_lag": self.max_lag,
            "confidence": self.confidence,
            "passed": self.passed,
            "outputs": outputs,
        }


def _test_text(test: CorrelationTest, percent: str) -> str:
    """``passed (N Σr² = 18.2 <= 44.3, χ²(25) at 99 %); 0 of 25 lags outside the 99 % band``."""
    word = "passed" if test.passed else "FAILED"
    relation = "<=" if test.passed else ">"
    tested = test.lags.size - 1 if test.lags[0] == 0 else test.lags.size
    return (
        f"{word} (statistic {test.statistic:.4g} {relation} {test.threshold:.4g},"
        f" chi2({test.degrees_of_freedom}) at {percent}); {test.outside} of {tested} lags outside"
        f" the {percent} band ±{test.bound:.3g}"
    )


def _test_dict(test: CorrelationTest, ts: float) -> dict[str, Any]:
    return {
        "passed": bool(test.passed),
        "statistic": test.statistic,
        "threshold": test.threshold,
        "degrees_of_freedom": test.degrees_of_freedom,
        "band": test.bound,
        "lags_outside_band": test.outside,
        "lags": test.lags.tolist(),
        "lag_seconds": (test.lags * ts).tolist(),
        "correlation": test.correlation.tolist(),
    }


def residual_tests(
    model: Any, data: IOData, max_lag: int = 25, confidence: float = 0.99
) -> ResidualTests:
    """Ljung's whiteness and independence tests of ``model``'s residuals on ``data``.

    Parameters
    ----------
    model : fitted estimator
        Any model of :func:`neckid.methods`. Its ``predict`` gives the one-step prediction; for
        an output-error model (``predicts_by_simulation``: the parallel SM model, the
        polynomial state-space model and the grey-box ODE, whose ``predict`` is their free run) the free-run error is tested instead, and
        :attr:`ResidualTests.residual` says so: its whiteness test then fails whenever the
        noise is coloured, so judge it by the independence test (Ljung 16.6).
    data : IOData
        The log, as the model reads it (channels and preprocessing; the CLI's
        ``read_for_model``), with measured outputs.
    max_lag : int, default 25
        M, the largest lag [samples] (MATLAB ``resid``'s default); ``2M`` must be below the
        number of samples after the model's initial ones.
    confidence : float, default 0.99
        Of the bands and of the chi-square tests.

    Returns
    -------
    ResidualTests

    Raises
    ------
    ValueError
        If ``data`` has no measured output, ``max_lag`` is too large for it, a residual is
        constant, or the run diverges (:class:`~neckid.models.results.DivergenceError`).

    Notes
    -----
    The first ``n_initial`` samples (the model's initial conditions, where the result repeats
    the measured outputs) are left out. The bands and the chi-square distributions are
    asymptotic (N large) and assume the residuals white and, for the independence test,
    independent of the input; in a closed loop the input depends on past residuals, so the
    cross-correlation at negative lags is expected outside its band and only the positive lags
    speak about the model.
    """
    if data.n_outputs == 0:
        raise ValueError("data holds inputs only; the residual tests need the measured outputs")
    confidence = check_number(confidence, "confidence", low=0, high=1, closed="neither")
    result = model.predict(data)
    skip = int(result.n_initial)
    n = data.n_samples - skip
    max_lag = check_number(max_lag, "max_lag", low=1, integer=True)
    if 2 * max_lag >= n:
        raise ValueError(
            f"max_lag={max_lag} is too large for {data.name or 'the log'}: the tests need more"
            f" than 2 x max_lag residual samples, and it has {n} after the model's {skip}"
            f" initial samples; give max_lag <= {max(1, (n - 1) // 2)}"
        )
    residuals = np.asarray(data.y[skip:] - result.y[skip:], dtype=np.float64)
    u = np.asarray(data.u[skip:], dtype=np.float64)
    whiteness = []
    for j, name in enumerate(data.output_names):
        if np.ptp(residuals[:, j]) == 0:
            raise ValueError(
                f"the residual of output {name!r} is constant ({residuals[0, j]!r}) over the"
                f" {n} samples after the initial ones; its correlation is undefined"
            )
        whiteness.append(residual_autocorrelation(residuals[:, j], max_lag, confidence))
    independence = tuple(
        tuple(
            None
            if np.ptp(u[:, i]) == 0
            else residual_input_correlation(residuals[:, j], u[:, i], max_lag, confidence)
            for i in range(data.n_inputs)
        )
        for j in range(data.n_outputs)
    )
    return ResidualTests(
        residual=OUTPUT_ERROR if result.kind == "simulation" else ONE_STEP,
        residuals=residuals,
        n_initial=skip,
        ts=float(data.ts),
        output_names=tuple(data.output_names),
        output_units=tuple(data.output_units),
        input_names=tuple(data.input_names),
        whiteness=tuple(whiteness),
        independence=independence,
    )
