"""Do numba's threads, spinning after a parallel kernel, slow the BLAS call right after it? (issue 42)

Run:  .venv/bin/python benchmarks/bench_numba_wait.py [--rounds 30]

Each configuration runs in a fresh process (the variables must be set before numba and
OpenBLAS start their threads): numba's threading layer ``NUMBA_THREADING_LAYER`` (``omp``, the
one numba picks here, and ``workqueue``; ``tbb`` when installed), with and without
``OMP_WAIT_POLICY=PASSIVE`` (GNU OpenMP's threads then sleep at once when a parallel region
ends instead of spinning for a while), and with OpenBLAS held to one thread
(``OPENBLAS_NUM_THREADS=1``: its own threads spin too). In every round the process times, best of ``--rounds``
and the median, a BLAS product of the shapes neckid's fits use (``Jᵀ J`` of a 18,000 × 90
Jacobian, as the ``ss`` refinement forms; a 400 × 400 product) in two situations:

- ``alone``: after 50 ms of sleep, no parallel kernel before it;
- ``after``: right after a ``prange`` kernel of about 20 ms returned (as when a Set Membership
  kernel is followed by NumPy's linear algebra).

``after / alone`` above 1 is what the spinning threads cost the BLAS call. The load average is
printed: on a busy machine every spinning thread also takes a core from another process.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

#: (label, environment) of every configuration.
CONFIGURATIONS = (
    ("omp (default)", {"NUMBA_THREADING_LAYER": "omp"}),
    (
        "omp, OMP_WAIT_POLICY=PASSIVE",
        {"NUMBA_THREADING_LAYER": "omp", "OMP_WAIT_POLICY": "PASSIVE"},
    ),
    ("workqueue", {"NUMBA_THREADING_LAYER": "workqueue"}),
    ("tbb", {"NUMBA_THREADING_LAYER": "tbb"}),
    ("omp, one BLAS thread", {"NUMBA_THREADING_LAYER": "omp", "OPENBLAS_NUM_THREADS": "1"}),
    (
        "omp, PASSIVE, one BLAS thread",
        {"NUMBA_THREADING_LAYER": "omp", "OMP_WAIT_POLICY": "PASSIVE", "OPENBLAS_NUM_THREADS": "1"},
    ),
)


def child(rounds: int) -> dict[str, float]:
    """The timings of this process's configuration (run in the child)."""
    import numba

    @numba.njit(parallel=True, cache=False)
    def kernel(x: np.ndarray) -> float:
        total = 0.0
        for i in numba.prange(x.shape[0]):
            total += np.sqrt(x[i]) * np.sin(x[i])
        return total

    rng = np.random.default_rng(0)
    x = rng.uniform(size=2_000_000)
    jac, square = rng.normal(size=(18_000, 90)), rng.normal(size=(400, 400))
    kernel(x)  # compile and start the threads
    layer = numba.threading_layer()
    products = {"JtJ": lambda: jac.T @ jac, "400x400": lambda: square @ square}
    times: dict[str, list[float]] = {f"{k} {w}": [] for k in products for w in ("alone", "after")}
    kernel_times = []
    for _ in range(rounds):
        for name, product in products.items():
            time.sleep(0.05)
            start = time.perf_counter()
            product()
            times[f"{name} alone"].append(time.perf_counter() - start)
            start = time.perf_counter()
            kernel(x)
            middle = time.perf_counter()
            product()
            times[f"{name} after"].append(time.perf_counter() - middle)
            kernel_times.append(middle - start)
    out = {"layer": layer, "kernel_ms": 1e3 * float(np.median(kernel_times))}
    for key, values in times.items():
        out[f"{key} best ms"] = 1e3 * float(np.min(values))
        out[f"{key} median ms"] = 1e3 * float(np.median(values))
    return out


def main() -> None:
    """Run every configuration in a child process; print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=30)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(child(args.rounds)))
        return
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}; median (best) ms")
    header = f"{'configuration':32s} {'layer':10s} {'kernel':>7s}"
    for name in ("JtJ", "400x400"):
        header += f" {name + ' alone':>17s} {name + ' after':>17s} {'after/alone':>11s}"
    print(header)
    for label, extra in CONFIGURATIONS:
        unset = ("OMP_WAIT_POLICY", "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")
        env = {k: v for k, v in os.environ.items() if k not in unset}
        env.update(extra)
        done = subprocess.run(
            [sys.executable, __file__, "--child", "--rounds", str(args.rounds)],
            env=env, capture_output=True, text=True, check=False,
        )  # fmt: skip
        if done.returncode != 0:
            reason = (done.stderr.strip().splitlines() or ["failed"])[-1]
            print(f"{label:32s} not available: {reason[:90]}")
            continue
        row = json.loads(done.stdout.strip().splitlines()[-1])
        line = f"{label:32s} {row['layer']:10s} {row['kernel_ms']:7.1f}"
        for name in ("JtJ", "400x400"):
            alone, after = row[f"{name} alone median ms"], row[f"{name} after median ms"]
            line += f" {alone:9.2f} ({row[f'{name} alone best ms']:5.2f})"
            line += f" {after:9.2f} ({row[f'{name} after best ms']:5.2f}) {after / alone:10.2f}x"
        print(line)
    print(f"load average at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
