"""Decision time of the fuzzynav controller: median of one call over the inputs of real runs.

    .venv/bin/python bench/bench_fuzzynav.py [--repeat 3] [--json]

The inputs and ranges of s1 and s2 runs (both perception modes) are recorded, then replayed
through a fresh controller, timing every call with perf_counter_ns. Budget: 50 us median.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from fuzzynav.controller.navigator.controller import fuzzynav_controller
from fuzzynav.world.scenario import load_scenario
from fuzzynav.world.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]

BUDGET_US = 50.0


def recorded_inputs():
    rows = []
    for name in ("s1", "s2"):
        for mode in ("ideal", "ultrasonic"):
            log = (
                Simulation(load_scenario(name), fuzzynav_controller(), perception=mode, seed=0)
                .run()
                .log
            )
            ok = np.isfinite(log.voltages_v[:, 0])
            rows.append((log.inputs[ok], log.ranges_m[ok]))
    return rows


def time_calls(rows, repeat: int) -> list[float]:
    times = []
    for _ in range(repeat):
        for inputs, ranges in rows:
            c = fuzzynav_controller()
            c.reset()
            clock = time.perf_counter_ns
            for x, r in zip(inputs, ranges):
                t0 = clock()
                c(x, ranges_m=r)
                times.append((clock() - t0) / 1e3)
    return times


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    rows = recorded_inputs()
    times = time_calls(rows, args.repeat)
    result = {
        "calls": len(times),
        "median_us": statistics.median(times),
        "p90_us": float(np.percentile(times, 90)),
        "budget_us": BUDGET_US,
    }
    result["within_budget"] = result["median_us"] <= BUDGET_US
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"fuzzynav decision: median {result['median_us']:.1f} us, p90 "
            f"{result['p90_us']:.1f} us over {result['calls']} calls "
            f"(budget {BUDGET_US:.0f} us: {'OK' if result['within_budget'] else 'OVER'})"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
