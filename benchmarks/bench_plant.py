"""Speed of the simulated neck: compiled (numba) kernel vs the plain NumPy reference, one core.

Run: ``.venv/bin/python benchmarks/bench_plant.py``. Prints samples per second of each path and
their ratio. Timings on a shared machine are noisy; the best of several repeats is reported.
"""

import time

import numpy as np

from neckid.plant import SoftNeck


def best_rate(neck: SoftNeck, commands: np.ndarray, compiled: bool, repeats: int) -> float:
    noise = np.random.default_rng(0).standard_normal((commands.shape[0], neck._n_dof))
    best = np.inf
    for _ in range(repeats):
        neck.reset()
        start = time.perf_counter()
        neck._advance(commands, noise, compiled=compiled)
        best = min(best, time.perf_counter() - start)
    return commands.shape[0] / best


def main() -> None:
    for configuration, n_motors in (("planar", 1), ("three_tendon", 3)):
        neck = SoftNeck(configuration=configuration)
        rng = np.random.default_rng(1)
        commands = np.repeat(rng.uniform(-2.0, 3.0, size=(2_000, n_motors)), 100, axis=0)
        neck._advance(commands[:10], np.zeros((10, neck._n_dof)))  # compile (or load the cache)
        fast = best_rate(neck, commands, compiled=True, repeats=5)
        slow = best_rate(neck, commands[:2_000], compiled=False, repeats=2)
        print(
            f"{configuration:13s} sub-steps/sample={neck._n_sub:2d}  compiled {fast:12,.0f} samples/s"
            f"  NumPy reference {slow:9,.0f} samples/s  ratio {fast / slow:7.0f}x"
        )
        start = time.perf_counter()
        neck.run(commands)
        elapsed = time.perf_counter() - start
        print(f"{'':13s} SoftNeck.run on {commands.shape[0]:,} samples: {elapsed:.3f} s")


if __name__ == "__main__":
    main()
