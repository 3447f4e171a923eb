"""LinearARX.simulate against scipy.signal.lfilter: the overhead around the filter (issue 33).

Run:  .venv/bin/python benchmarks/bench_arx_overhead.py [--repeat 30] [--compile]

On a SISO ARX (``Lags.arx(2, 2, 1)``, ``bench_arx_free_run.siso_data``) four timings side by
side in one process, best of ``--repeat`` runs each, the four taking turns in every round:

- ``lfilter``: ``scipy.signal.lfilter(b, a, u)`` with the model's own transfer function (the
  arithmetic alone: no initial state, no checks);
- ``before``: ``LinearARX.simulate`` as it was before issue 33 (two ``lfilter`` calls and
  ``lfiltic``; the result's checks each a pass of their own, the extrapolation warning's
  regressor-domain check building the regressor matrix);
- ``now``: ``LinearARX.simulate``: one compiled pass, block by block, for the FIR
  (``np.convolve``'s arithmetic), the all-pole filter (``lfilter``'s) and every check of the
  result (time stamps, channel ranges, training box, finiteness, divergence envelope);
- ``pass``: ``linear_free_run`` on the same log: that compiled pass without the checks and
  without the result (what the checks and the Python around them cost is ``now − pass``).

What ``now`` reads of the fitted model (the filters, the terms and bounds the checks count,
the plain divergence envelope) is built once per fitted model (issue 42:
``neckid.models.linear._arx_plan``), and the run screens each block channel by channel before
counting term by term.

``before`` and ``now`` must give the same floats, bit for bit (checked), with the same extras.
Targets: ``now`` within 1.5x of ``lfilter`` at 20,000 samples (issue 42; 2x in issue 33) and
1.2x at 1,000,000. On a shared
2-core machine the times move from run to run: read the ratios, measured side by side, and the
load average printed beside them.

``--compile`` adds what the one pass costs once, with an empty numba cache: the first
``LinearARX.simulate`` compiles it. Side by side, each in a fresh process with a cache folder of
its own (numba itself warmed up first in both): the compilation of the kernels the first round
of issue 33 used (:data:`FIRST_ROUND_KERNELS`, verbatim) and the first ``simulate`` now.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from bench_arx_free_run import siso_data
from scipy import signal

from neckid import IOData, Lags, LinearARX
from neckid.models.domain import regressor_domain
from neckid.models.linear.arx import linear_free_run
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


#: The compiled kernels of issue 33's first round, verbatim (the all-pole filter with its state
#: in an array; the training box counted term by term), compiled by ``--compile``.
FIRST_ROUND_KERNELS = """
@numba.njit(cache=True, nogil=True)
def _all_pole_filter(denominator, x, state, out):
    order = denominator.shape[0] - 1
    z = state.copy()
    for k in range(x.shape[0]):
        xn = x[k]
        yn = z[0] + 1.0 * xn
        for i in range(order - 1):
            z[i] = z[i + 1] + xn * 0.0 - yn * denominator[i + 1]
        z[order - 1] = xn * 0.0 - yn * denominator[order]
        out[k] = yn


@numba.njit(cache=True, nogil=True)
def box_counts(y, u, source, channel, lag, low, high, start):
    n_rows = y.shape[0] - start
    counts = np.zeros(lag.shape[0], np.int64)
    for j in range(lag.shape[0]):
        column = (y if source[j] == 0 else u)[start - lag[j] : y.shape[0] - lag[j], channel[j]]
        lo, hi = low[j], high[j]
        count = 0
        for t in range(n_rows):
            count += (column[t] < lo) | (column[t] > hi)
        counts[j] = count
    if np.count_nonzero(counts) < 2:
        return counts, int(counts.sum())
    rows = 0
    for t in range(n_rows):
        for j in range(lag.shape[0]):
            v = (
                y[start + t - lag[j], channel[j]]
                if source[j] == 0
                else u[t + start - lag[j], channel[j]]
            )
            if v < low[j] or v > high[j]:
                rows += 1
                break
    return counts, rows
"""

#: What each fresh process runs before the timed part: numba warmed up, neckid imported, a
#: model fitted (nothing of it compiles the free run's kernels).
PRELUDE = """
import sys
import time
sys.path.insert(0, {benchmarks!r})
import numba
import numpy as np
numba.njit(lambda x: x + 1)(1)
from bench_arx_free_run import siso_data
from neckid import Lags, LinearARX
data = siso_data(500)
model = LinearARX(Lags.arx(2, 2, 1)).fit(data)
y, u = np.asarray(data.y), np.asarray(data.u)
start = time.perf_counter()
"""

#: The timed part of each process.
TIMED = {
    "first round's kernels": FIRST_ROUND_KERNELS
    + """
_all_pole_filter(np.array([1.0, -0.5, 0.1]), u[:, 0], np.zeros(2), np.empty(500))
box_counts(y, u, np.zeros(2, np.int64), np.zeros(2, np.int64), np.ones(2, np.int64),
           np.zeros(2), np.ones(2), 2)
""",
    "first simulate now": "model.simulate(data)\n",
}


def compile_seconds(code: str) -> float:
    """Seconds the timed ``code`` takes after :data:`PRELUDE`, in a fresh process and cache."""
    with tempfile.TemporaryDirectory() as folder:
        script = Path(folder) / "timed.py"  # a file: numba caches what it compiles there
        prelude = PRELUDE.format(benchmarks=str(Path(__file__).resolve().parent))
        script.write_text(prelude + code + "print(time.perf_counter() - start)\n")
        env = {**os.environ, "NUMBA_CACHE_DIR": str(Path(folder) / "cache")}
        done = subprocess.run(
            [sys.executable, str(script)], env=env, capture_output=True, text=True, check=True
        )
    return float(done.stdout.split()[-1])


def print_compile_times() -> None:
    """Compilation with an empty cache: the first round's kernels and the one pass now."""
    print(f"\ncompilation, empty numba cache (load average {os.getloadavg()[0]:.2f})")
    seconds = {label: compile_seconds(code) for label, code in TIMED.items()}
    for label, value in seconds.items():
        print(f"  {label:>22}: {value:6.2f} s")
    first, now = seconds.values()
    print(f"  {'ratio now/first round':>22}: {now / first:6.2f}x")


def best_of(functions: dict[str, Callable[[], object]], repeat: int) -> dict[str, float]:
    """Best wall time of each function over ``repeat`` rounds, the functions taking turns."""
    times: dict[str, list[float]] = {name: [] for name in functions}
    for _ in range(repeat):
        for name, function in functions.items():
            start = time.perf_counter()
            function()
            times[name].append(time.perf_counter() - start)
    return {name: min(values) for name, values in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=30)
    parser.add_argument("--compile", action="store_true", help="also time the compilation")
    args = parser.parse_args()
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} (best of {args.repeat})")
    print(
        f"\n  {'samples':>9} {'lfilter':>10} {'before':>10} {'now':>10} {'pass':>10}"
        f" {'before/lfilter':>14} {'now/lfilter':>11} {'target':>6} {'pass/lfilter':>12}"
        f" {'before/now':>10}"
    )
    for n, target in ((20_000, 1.5), (1_000_000, 1.2)):
        data = siso_data(n)
        model = LinearARX(Lags.arx(2, 2, 1)).fit(data)
        old = PreviousARX(Lags.arx(2, 2, 1)).fit(data)
        b = np.r_[0.0, model.coef_[2:, 0]]
        a = np.r_[1.0, -model.coef_[:2, 0]]
        u = np.ascontiguousarray(data.u[:, 0])
        new_result, old_result = model.simulate(data), old.simulate(data)
        np.testing.assert_array_equal(new_result.y, old_result.y)
        np.testing.assert_array_equal(new_result.time, old_result.time)
        assert new_result.extras == old_result.extras
        times = best_of(
            {
                "lfilter": lambda: signal.lfilter(b, a, u),  # noqa: B023
                "before": lambda: old.simulate(data),  # noqa: B023
                "now": lambda: model.simulate(data),  # noqa: B023
                "pass": lambda: linear_free_run(
                    model.lags_,  # noqa: B023
                    model.coef_,  # noqa: B023
                    model.intercept_,  # noqa: B023
                    data.u,  # noqa: B023
                    data.y,  # noqa: B023
                ),
            },
            args.repeat,
        )
        base = times["lfilter"]
        print(
            f"  {n:>9,} {base * 1e3:8.3f}ms {times['before'] * 1e3:8.3f}ms"
            f" {times['now'] * 1e3:8.3f}ms {times['pass'] * 1e3:8.3f}ms"
            f" {times['before'] / base:13.2f}x {times['now'] / base:10.2f}x {target:5.1f}x"
            f" {times['pass'] / base:11.2f}x {times['before'] / times['now']:9.2f}x"
        )
    if args.compile:
        print_compile_times()
    print(f"\nload average at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
