"""Speed of the simulated neck: compiled (numba) kernel vs the plain NumPy reference, one core.

Run: ``.venv/bin/python benchmarks/bench_plant.py``. Prints samples per second of each path,
their ratio, and the issue's floor (issue 18: at least 300,000 samples/s). Times are CPU time of
this thread (``time.thread_time``), best of several repeats, so that other processes on a shared
machine weigh less; the compiled kernel is timed after a warm-up call that loads (or compiles) it.
Before timing, the script checks that both paths give the same log (outputs exactly, as the
sensor quantises them; state to 1e-9).
"""

import time

import numpy as np

from neckid.plant import SoftNeck

#: The issue's floor, samples per second.
FLOOR = 300_000


def best_rate(neck: SoftNeck, commands: np.ndarray, compiled: bool, repeats: int) -> float:
    noise = np.random.default_rng(0).standard_normal((commands.shape[0], neck._n_dof))
    best = np.inf
    for _ in range(repeats):
        neck.reset()
        start = time.thread_time()
        neck._advance(commands, noise, compiled=compiled)
        best = min(best, time.thread_time() - start)
    return commands.shape[0] / best


def check_agreement(neck: SoftNeck, commands: np.ndarray) -> None:
    noise = np.random.default_rng(2).standard_normal((commands.shape[0], neck._n_dof))
    runs = []
    for compiled in (True, False):
        neck.reset()
        outputs, position, _ = neck._advance(commands, noise, compiled=compiled)
        runs.append((outputs, position, neck._state.copy()))
    (out_a, pos_a, state_a), (out_b, pos_b, state_b) = runs
    if not (
        np.array_equal(out_a, out_b)
        and np.allclose(pos_a, pos_b, rtol=1e-9, atol=1e-12)
        and np.allclose(state_a, state_b, rtol=1e-9, atol=1e-12)
    ):
        raise SystemExit(f"{neck.configuration}: the compiled kernel disagrees with the reference")


def main() -> None:
    print(f"SoftNeck samples per second (CPU time; floor {FLOOR:,})")
    for configuration, n_motors in (("planar", 1), ("three_tendon", 3)):
        neck = SoftNeck(configuration=configuration)
        rng = np.random.default_rng(1)
        commands = np.repeat(rng.uniform(-2.0, 3.0, size=(2_000, n_motors)), 100, axis=0)
        neck._advance(commands[:10], np.zeros((10, neck._n_dof)))  # compile (or load the cache)
        check_agreement(neck, commands[:1_000])
        fast = best_rate(neck, commands, compiled=True, repeats=5)
        slow = best_rate(neck, commands[:2_000], compiled=False, repeats=2)
        verdict = "meets" if fast >= FLOOR else "BELOW"
        print(
            f"{configuration:13s} sub-steps/sample={neck._n_sub:2d}  compiled {fast:10,.0f}"
            f"  NumPy reference {slow:7,.0f}  ratio {fast / slow:5.0f}x  ({verdict} the floor)"
        )
        start = time.perf_counter()
        neck.run(commands)
        elapsed = time.perf_counter() - start
        print(f"{'':13s} SoftNeck.run on {commands.shape[0]:,} samples: {elapsed:.3f} s wall")


if __name__ == "__main__":
    main()
