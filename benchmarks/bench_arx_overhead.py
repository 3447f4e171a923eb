"""LinearARX.simulate against scipy.signal.lfilter: the overhead around the filter (issue 33).

Run:  .venv/bin/python benchmarks/bench_arx_overhead.py [--repeat 30]

On a SISO ARX (``Lags.arx(2, 2, 1)``, ``bench_arx_free_run.siso_data``) three timings side by
side in one process, best of ``--repeat`` runs each:

- ``lfilter``: ``scipy.signal.lfilter(b, a, u)`` with the model's own transfer function (the
  arithmetic alone: no initial state, no checks);
- ``before``: ``LinearARX.simulate`` as it was before issue 33 (two ``lfilter`` calls and
  ``lfiltic``; the extrapolation warning's regressor-domain check builds the regressor matrix);
- ``now``: ``LinearARX.simulate`` (the FIR by ``np.convolve``, the all-pole filter in a compiled
  loop with lfilter's arithmetic, the training-box shares counted in one compiled pass).

``before`` and ``now`` must give the same floats, bit for bit (checked). Targets: ``now`` within
2x of ``lfilter`` at 20,000 samples and 1.2x at 1,000,000. On a shared 2-core machine the times
move from run to run: read the ratios, measured side by side.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable

import numpy as np
from bench_arx_free_run import siso_data
from scipy import signal

from neckid import IOData, Lags, LinearARX
from neckid.models.domain import regressor_domain
from neckid.models.linear.arx import _linear_free_run
from neckid.models.results import ModelResult


def previous_free_run(resolved, coef, intercept, u, y_initial):  # type: ignore[no-untyped-def]
    """The single-output free run before issue 33 (two lfilter calls and lfiltic)."""
    u_arr = np.asarray(u, dtype=np.float64)
    y = np.array(y_initial, dtype=np.float64, order="C", ndmin=2)
    coef_arr = np.asarray(coef, dtype=np.float64).reshape(resolved.n_terms, -1)
    n, m = y.shape[0], resolved.max_lag
    outputs = np.flatnonzero(resolved.source == 0)
    forcing = np.full(n - m, float(np.asarray(intercept, dtype=np.float64).reshape(())))
    for channel in np.unique(resolved.channel[resolved.source == 1]):
        terms = np.flatnonzero((resolved.source == 1) & (resolved.channel == channel))
        numerator = np.zeros(int(resolved.lag[terms].max()) + 1)
        np.add.at(numerator, resolved.lag[terms], coef_arr[terms, 0])
        forcing += signal.lfilter(numerator, [1.0], u_arr[:, channel])[m:]
    order = int(resolved.lag[outputs].max())
    denominator = np.zeros(order + 1)
    denominator[0] = 1.0
    np.subtract.at(denominator, resolved.lag[outputs], coef_arr[outputs, 0])
    state = signal.lfiltic([1.0], denominator, y[m - order : m, 0][::-1])
    y[m:, 0] = signal.lfilter([1.0], denominator, forcing, zi=state)[0]
    return y


class PreviousARX(LinearARX):
    """``LinearARX.simulate`` as before issue 33."""

    def _domain_shares(self, data: IOData) -> tuple[float, dict[str, float]]:
        """The box shares from the regressor matrix, built per call."""
        found = regressor_domain(self, data, nearest=False)
        return found.share, found.by_term

    def simulate(self, data: IOData, initial=None) -> ModelResult:  # type: ignore[no-untyped-def]
        data = self._with_conditions(data)
        y0 = np.array(self._initial_outputs(data, initial))
        with np.errstate(over="ignore", invalid="ignore"):
            y = previous_free_run(self.lags_, self.coef_, self.intercept_, data.u, y0)
        return self._result("simulation", data, y)


def best(function: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=30)
    args = parser.parse_args()
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} (best of {args.repeat})")
    print(
        f"\n  {'samples':>9} {'lfilter':>10} {'before':>10} {'now':>10}"
        f" {'before/lfilter':>14} {'now/lfilter':>11} {'target':>6} {'before/now':>10}"
    )
    for n, target in ((20_000, 2.0), (1_000_000, 1.2)):
        data = siso_data(n)
        model = LinearARX(Lags.arx(2, 2, 1)).fit(data)
        old = PreviousARX(Lags.arx(2, 2, 1)).fit(data)
        b = np.r_[0.0, model.coef_[2:, 0]]
        a = np.r_[1.0, -model.coef_[:2, 0]]
        u = np.ascontiguousarray(data.u[:, 0])
        np.testing.assert_array_equal(model.simulate(data).y, old.simulate(data).y)
        t_filter = best(lambda: signal.lfilter(b, a, u), args.repeat)  # noqa: B023
        t_old = best(lambda: old.simulate(data), args.repeat)  # noqa: B023
        t_new = best(lambda: model.simulate(data), args.repeat)  # noqa: B023
        print(
            f"  {n:>9,} {t_filter * 1e3:8.3f}ms {t_old * 1e3:8.3f}ms {t_new * 1e3:8.3f}ms"
            f" {t_old / t_filter:13.2f}x {t_new / t_filter:10.2f}x {target:5.1f}x"
            f" {t_old / t_new:9.2f}x"
        )
    _ = _linear_free_run  # the in-place free run the model calls
    print(f"\nload average at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
