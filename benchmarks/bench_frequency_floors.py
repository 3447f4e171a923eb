"""The issue-43 figures of the frequency core over many seeds (tests/test_frequency.py runs one).

Run: ``.venv/bin/python benchmarks/bench_frequency_floors.py [n_seeds]``. Prints, per figure, the
minimum, median and maximum over the seeds and how many seeds meet the floor.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy import signal as sps

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import test_frequency as tf
from neckid.frequency import indirect_frf, smoothed_frf


def _wiener_hammerstein(seed: int) -> tuple[float, float, float]:
    plan = tf._plan(seed=seed)
    y = tf._wiener_hammerstein(plan.signal[:, 0])
    y = y + 0.01 * np.random.default_rng(seed + 100).standard_normal(y.shape)
    bla = tf._bla(plan, y)
    amplitude = tf._line_amplitude(plan)
    omega = bla.omega
    variance_x = np.sum(np.abs(tf._response(tf.FIRST, omega)) ** 2 * amplitude**2 / 2)
    analytic = (
        tf._response(tf.FIRST, omega)
        * tf._response(tf.SECOND, omega)
        * (1 + 3 * tf.CUBIC * variance_x)
    )
    inside = (np.abs(bla.frf[:, 0, 0] - analytic) <= bla.band_radius()[:, 0, 0]).mean()
    reference = tf._monte_carlo_distortion(plan, 200, seed=seed + 7)
    difference = 10 * np.log10(bla.distortion_variance[:, 0, 0] / reference)
    ratio = 10 * np.log10(bla.distortion_variance[:, 0, 0].mean() / reference.mean())
    return float(inside), float(difference.mean()), float(ratio)


def _linear(seed: int) -> float:
    plan = tf._plan(seed=seed)
    clean = sps.lfilter(*tf.FIRST, plan.signal[:, 0])
    rng = np.random.default_rng(seed + 1)
    bla = tf._bla(plan, clean + 0.01 * clean.std() * rng.standard_normal(clean.shape))
    return float(1 - bla.nonlinear_detected(0.99).mean())


def _kind(seed: int) -> bool:
    right = True
    for power, even, odd in ((2, True, False), (3, False, True)):
        plan = tf._plan(seed=seed)
        x = sps.lfilter(*tf.SECOND, plan.signal[:, 0])
        clean = sps.lfilter(*tf.SECOND, x + 0.2 * x**power)
        rng = np.random.default_rng(seed + 2)
        bla = tf._bla(plan, clean + 0.01 * clean.std() * rng.standard_normal(clean.shape))
        right &= bla.levels.kind_detected("even") is even
        right &= bla.levels.kind_detected("odd") is odd
    return bool(right)


def _closed_loop(seed: int) -> tuple[float, float]:
    from neckid.plant import InclinationController, closed_loop

    n, ts, segment = 2**15, 0.02, 2048
    rng = np.random.default_rng(seed)
    reference = 10 + 2 * sps.lfilter(*sps.butter(2, 0.1), rng.standard_normal(n))
    noise = sps.lfilter(*sps.butter(1, 0.3), rng.standard_normal(n))
    runs = {}
    for name, level in (("clean", 0.0), ("noisy", 1.0)):
        data = closed_loop(tf._NoisySensor(level * noise), InclinationController(), reference, ts)
        runs[name] = (data.channel("velocity_command"), data.y[:, 0])
    truth = smoothed_frf(*runs["clean"], ts, segment=segment).frf
    loop = smoothed_frf(reference, runs["clean"][1], ts, segment=segment)
    band = loop.omega <= loop.omega[np.argmax(np.abs(loop.frf) < 1 / math.sqrt(2))]
    u, y = runs["noisy"]
    indirect = indirect_frf(reference, u, y, ts, segment=segment).inside(truth)[band].mean()
    direct = smoothed_frf(u, y, ts, segment=segment).inside(truth)[band].mean()
    return float(indirect), float(direct)


def _row(name: str, values: list[float], floor: str, met: int) -> None:
    print(
        f"{name:48s} min {min(values):7.3f}  median {np.median(values):7.3f}"
        f"  max {max(values):7.3f}   floor {floor:>9s}: {met}/{len(values)} seeds"
    )


def main(n_seeds: int = 20) -> None:
    start = time.perf_counter()
    seeds = range(n_seeds)
    wh = [_wiener_hammerstein(s) for s in seeds]
    linear = [_linear(s) for s in seeds]
    kinds = [_kind(s) for s in seeds]
    loops = [_closed_loop(s) for s in seeds]
    _row("WH: BLA inside its 95 % band (share)", [w[0] for w in wh], ">= 0.90",
         sum(w[0] >= 0.9 for w in wh))  # fmt: skip
    _row("WH: mean over lines of dB(est / MC) [dB]", [w[1] for w in wh], "|.|<=1.5",
         sum(abs(w[1]) <= 1.5 for w in wh))  # fmt: skip
    _row("WH: dB(mean est / mean MC) [dB]", [w[2] for w in wh], "|.|<=1.5",
         sum(abs(w[2]) <= 1.5 for w in wh))  # fmt: skip
    _row("linear 1 % noise: lines not detected (share)", linear, ">= 0.95",
         sum(v >= 0.95 for v in linear))  # fmt: skip
    _row("squarer and cuber both classified right", [float(k) for k in kinds], "1",
         sum(kinds))  # fmt: skip
    _row("closed loop: indirect inside band (share)", [v[0] for v in loops], ">= 0.90",
         sum(v[0] >= 0.9 for v in loops))  # fmt: skip
    _row("closed loop: direct inside band (share)", [v[1] for v in loops], "(fails)",
         sum(v[1] < 0.5 for v in loops))  # fmt: skip
    print(f"{n_seeds} seeds in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20)
