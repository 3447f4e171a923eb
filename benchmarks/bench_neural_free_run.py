"""Speed of NeuralNARX's free run: the compiled loop vs the NumPy loop it replaced (issue 18).

Run:  .venv/bin/python benchmarks/bench_neural_free_run.py [--samples 5000] [--repeat 5]

One model of the demo's shape (five networks of 2x25 tanh neurons on the paper's regressor
``[y(t-1..3), u(t-8..10)]``, briefly trained on a known nonlinear system) runs three free runs in
the same process: the generic per-sample loop of ``neckid.models.base`` (``_predict_rows`` on one
row per step), the NumPy loop specialised for one row per step (``compiled=False``, the
reference) and the compiled loop (``NeuralNARX.simulate``). The script checks that they agree
(1e-10) before it prints microseconds per step and the ratios. Times are CPU time of this thread
(``time.thread_time``), best of ``--repeat`` runs, after a warm-up run that loads (or compiles)
the kernel.
"""

from __future__ import annotations

import argparse
import time
import warnings
from collections.abc import Callable

import numpy as np

from neckid import IOData, Lags
from neckid.models.base import _free_run
from neckid.models.neural.narx import NeuralNARX


def narx_system(n: int, seed: int = 0) -> IOData:
    """y(t) = 0.6 y(t-1) + 0.2 y(t-2) + tanh(u(t-8)) + 0.1 u(t-9), u uniform in [-2, 2]."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-2.0, 2.0, size=n)
    y = np.zeros(n)
    for t in range(9, n):
        y[t] = 0.6 * y[t - 1] + 0.2 * y[t - 2] + np.tanh(u[t - 8]) + 0.1 * u[t - 9]
    return IOData(u, y, ts=0.02)


def best_time(run: Callable[[], np.ndarray], repeat: int) -> tuple[float, np.ndarray]:
    best, result = np.inf, np.empty(0)
    for _ in range(repeat):
        start = time.thread_time()
        result = run()
        best = min(best, time.thread_time() - start)
    return best, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=5_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    data = narx_system(3_000 + args.samples)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ConvergenceWarning: a short training is enough here
        model = NeuralNARX(Lags(outputs=3, inputs=[8, 9, 10]), max_iter=40, random_state=0)
        model.fit(data[:3_000])
    test = data[3_000:]
    u, y0 = test.u, test.y
    steps = test.n_samples - model.lags_.max_lag

    model._simulate_array(u, y0)  # load or compile the kernel
    fast, fast_y = best_time(lambda: model._simulate_array(u, y0), args.repeat)
    numpy_loop, numpy_y = best_time(
        lambda: model._simulate_array(u, y0, compiled=False), args.repeat
    )
    generic, generic_y = best_time(
        lambda: _free_run(model.lags_, model._predict_rows, u, y0), max(1, args.repeat // 2)
    )
    for name, other in (("NumPy loop", numpy_y), ("generic loop", generic_y)):
        if not np.allclose(fast_y, other, rtol=1e-10, atol=1e-10):
            raise SystemExit(f"the compiled free run disagrees with the {name}")
    print(
        f"NeuralNARX free run, {model.n_networks} networks of {model.hidden_layer_sizes}"
        f" ({model.activation}), {steps:,} steps (CPU time, best of {args.repeat})"
    )
    print(f"  generic NARX loop   {generic / steps * 1e6:7.2f} us/step")
    print(f"  NumPy loop (old)    {numpy_loop / steps * 1e6:7.2f} us/step")
    print(
        f"  compiled (new)      {fast / steps * 1e6:7.2f} us/step  ratio {numpy_loop / fast:5.1f}x"
        f" vs the NumPy loop, {generic / fast:5.1f}x vs the generic one"
        f"  (max difference {np.max(np.abs(fast_y - numpy_y)):.1e})"
    )


if __name__ == "__main__":
    main()
