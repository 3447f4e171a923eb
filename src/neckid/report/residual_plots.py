"""Figures of the residual tests: autocorrelations and cross-correlations with their bands."""

from __future__ import annotations

from typing import Any

from neckid.metrics import CorrelationTest
from neckid.selection.residuals import ResidualTests

__all__ = ["plot_residual_tests"]


def plot_residual_tests(tests: ResidualTests) -> Any:
    """Draw every residual test of ``tests``: one row per output, one column per test.

    Column 0 holds the residual's autocorrelation at lags 0..M, the next columns its
    cross-correlation with each input at lags -M..M; the shaded band is the per-lag band
    (``±z/sqrt(N)`` at the tests' confidence) that white residuals independent of the input stay
    inside, and each title gives the chi-square verdict. The lag axis is in samples (below) and
    in seconds (above).

    Parameters
    ----------
    tests : ResidualTests
        What :func:`neckid.selection.residuals.residual_tests` returned.

    Returns
    -------
    matplotlib.figure.Figure
        Never shown; call ``savefig`` or ``plt.show`` yourself.

    Raises
    ------
    TypeError
        If ``tests`` is not a :class:`~neckid.selection.residuals.ResidualTests`.

    Examples
    --------
    >>> import numpy as np
    >>> from neckid import IOData
    >>> from neckid.models.linear import LinearARX
    >>> from neckid.regressors import Lags
    >>> from neckid.selection.residuals import residual_tests
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=1000)
    >>> y = np.convolve(u, [0.0, 1.0, 0.5])[:1000] + 0.1 * rng.normal(size=1000)
    >>> data = IOData(u, y, ts=0.02, input_names=["cmd"], output_names=["incl"])
    >>> fig = plot_residual_tests(residual_tests(LinearARX(Lags(1, [1, 2])).fit(data), data))
    >>> fig.axes[0].get_xlabel(), fig.axes[0].get_ylabel()
    ('lag [samples]', 'correlation [-]')
    >>> import matplotlib.pyplot as plt
    >>> plt.close(fig)
    """
    if not isinstance(tests, ResidualTests):
        raise TypeError(f"tests must be a ResidualTests; got {type(tests).__name__}")
    import matplotlib.pyplot as plt

    rows, columns = len(tests.output_names), 1 + len(tests.input_names)
    fig, axes = plt.subplots(
        rows,
        columns,
        figsize=(4.6 * columns, 3.2 * rows),
        layout="constrained",
        squeeze=False,
    )
    for j, output in enumerate(tests.output_names):
        _draw(axes[j, 0], tests.whiteness[j], tests.ts, f"autocorrelation of e({output})")
        for i, name in enumerate(tests.input_names):
            test = tests.independence[j][i]
            title = f"e({output}) vs {name}"
            if test is None:
                axes[j, i + 1].set_title(f"{title}: not tested (constant input)", fontsize=9)
                axes[j, i + 1].set_axis_off()
            else:
                _draw(axes[j, i + 1], test, tests.ts, title)
    percent = f"{100 * tests.confidence:g} %"
    fig.suptitle(
        f"residual tests ({tests.residual} residual), {percent} band and chi-square verdicts:"
        f" {'passed' if tests.passed else 'failed'}",
        fontsize=10,
    )
    return fig


def _draw(ax: Any, test: CorrelationTest, ts: float, title: str) -> None:
    """One test: stems of the correlation, the band shaded, the verdict in the title."""
    lags = test.lags
    ax.axhspan(-test.bound, test.bound, color="tab:blue", alpha=0.15, lw=0)
    ax.axhline(0.0, color="0.4", lw=0.6)
    outside = abs(test.correlation) > test.bound
    if lags[0] == 0:
        outside[0] = False  # r(0) = 1 by definition, not tested
    ax.vlines(lags, 0.0, test.correlation, color="tab:blue", lw=1.2)
    ax.plot(lags[~outside], test.correlation[~outside], "o", ms=3, color="tab:blue")
    ax.plot(lags[outside], test.correlation[outside], "o", ms=4, color="tab:red")
    ax.set_xlabel("lag [samples]")
    ax.set_ylabel("correlation [-]")
    seconds = ax.secondary_xaxis("top", functions=(lambda k: k * ts, lambda s: s / ts))
    seconds.set_xlabel("lag [s]", fontsize=8)
    seconds.tick_params(labelsize=7)
    verdict = "passed" if test.passed else "FAILED"
    ax.set_title(
        f"{title}\n{verdict}: {test.statistic:.3g} vs chi2({test.degrees_of_freedom}) "
        f"{test.threshold:.3g}; {test.outside} outside ±{test.bound:.3f}",
        fontsize=9,
        color="black" if test.passed else "tab:red",
    )
