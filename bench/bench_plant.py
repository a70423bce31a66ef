"""Median time of one ``HuskyModel.step`` call.

The world calls it 50 times per simulated second, in tight loops.

Run: ``.venv/bin/python bench/bench_plant.py``
"""

from __future__ import annotations

import statistics
import timeit

import numpy as np

from fuzzynav.world.husky import HuskyModel

STEP_S = 0.02
CALLS_PER_REPEAT = 100_000
REPEATS = 7


def main() -> None:
    model = HuskyModel.default()
    rng = np.random.default_rng(0)
    x = rng.normal(size=6)
    u = rng.uniform(-12.0, 12.0, size=2)
    model.step(x, u, STEP_S)  # builds the cached ZOH matrices outside the timing

    timings_s = timeit.repeat(
        lambda: model.step(x, u, STEP_S), number=CALLS_PER_REPEAT, repeat=REPEATS
    )
    per_call_us = [t / CALLS_PER_REPEAT * 1e6 for t in timings_s]
    # A trivial numpy op as a yardstick: timings here swing with the machine's load.
    yardstick_s = timeit.repeat(lambda: x + x, number=CALLS_PER_REPEAT, repeat=REPEATS)
    yardstick_us = statistics.median(t / CALLS_PER_REPEAT * 1e6 for t in yardstick_s)
    print(
        f"HuskyModel.step: median {statistics.median(per_call_us):.2f} us/call, "
        f"best {min(per_call_us):.2f} us/call "
        f"({REPEATS} repeats x {CALLS_PER_REPEAT} calls, dt = {STEP_S} s); "
        f"yardstick 6-vector add: {yardstick_us:.2f} us"
    )


if __name__ == "__main__":
    main()
