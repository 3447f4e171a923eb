"""Speed of ``closed_loop``: the compiled loop for the built-in neck and PI vs stepping them (issue 18).

Run:  .venv/bin/python benchmarks/bench_closed_loop.py [--samples 5000] [--repeat 5]

Both paths run in the same process on the same reference: ``closed_loop(SoftNeck(),
InclinationController(), ...)`` (one compiled kernel for the whole loop) and the same call with
trivial subclasses of both, which ``closed_loop`` steps from Python like any plant and
controller (the path of an identified model's ``simulator()``). The script checks that the two
logs are identical before it prints microseconds per step and the ratio. Each path is timed as
the best of ``--repeat`` runs, CPU time of this thread (``time.thread_time``), so that other
processes on a shared machine weigh less; the compiled one after a warm-up run that loads (or
compiles) the kernel.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from neckid.data.iodata import IOData
from neckid.plant import InclinationController, SoftNeck, closed_loop


class SteppedNeck(SoftNeck):
    """The simulated neck, stepped from Python by ``closed_loop`` (not the exact class)."""


class SteppedController(InclinationController):
    """The PI controller, stepped from Python by ``closed_loop``."""


def best_time(run: Callable[[], IOData], repeat: int) -> tuple[float, IOData]:
    best, log = np.inf, None
    for _ in range(repeat):
        start = time.thread_time()
        log = run()
        best = min(best, time.thread_time() - start)
    assert log is not None
    return best, log


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=5_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    n = args.samples
    t = np.arange(n) * 0.02
    references = {
        "planar": np.where(t % 10.0 < 5.0, 25.0, 10.0) + 3.0 * np.sin(2.0 * t),
        "three_tendon": np.column_stack([15.0 + 5.0 * np.sin(0.5 * t), (30.0 * t) % 360.0]),
    }
    print(f"closed_loop, {n:,} samples at ts = 0.02 s (CPU time, best of {args.repeat})")
    for configuration, reference in references.items():

        def compiled(
            reference: np.ndarray = reference, configuration: str = configuration
        ) -> IOData:
            neck = SoftNeck(configuration=configuration)  # type: ignore[arg-type]
            pi = InclinationController(configuration=configuration)  # type: ignore[arg-type]
            return closed_loop(neck, pi, reference, 0.02)

        def stepped(
            reference: np.ndarray = reference, configuration: str = configuration
        ) -> IOData:
            neck = SteppedNeck(configuration=configuration)  # type: ignore[arg-type]
            pi = SteppedController(configuration=configuration)  # type: ignore[arg-type]
            return closed_loop(neck, pi, reference, 0.02)

        compiled()  # load or compile the kernel
        fast, fast_log = best_time(compiled, args.repeat)
        slow, slow_log = best_time(stepped, max(1, args.repeat // 2))
        if not (np.array_equal(fast_log.u, slow_log.u) and np.array_equal(fast_log.y, slow_log.y)):
            raise SystemExit(f"{configuration}: the compiled and stepped loops disagree")
        print(
            f"{configuration:13s} stepped {slow / n * 1e6:7.1f} us/step  compiled"
            f" {fast / n * 1e6:6.2f} us/step  ratio {slow / fast:5.1f}x  (logs identical)"
        )


if __name__ == "__main__":
    main()
