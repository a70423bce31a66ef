"""Real-time factor of an s1 run with the paper's fuzzy controller (issue 3 aims >= 200x).

Simulated time / wall time (and / CPU time: the machine is shared) of whole ``Simulation.run()`` calls (the 0.02 s control loop,
ideal perception, then ultrasonic), median of a few runs; also the time one controller
call takes inside the loop. The machine is shared, so the median matters more than the
best.

Usage: .venv/bin/python bench/bench_controller.py [--repeats N] [--controller paper]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

from fuzzynav.app.runs import build_simulation

ROOT = Path(__file__).resolve().parents[1]

TARGET_FACTOR = 200.0


def realtime_factor(controller: str, perception: str, repeats: int) -> dict:
    factors, cpu_factors, sims = [], [], []
    for _ in range(repeats):
        sim = build_simulation("s1", controller, perception=perception)
        start, cpu = time.perf_counter(), time.process_time()
        result = sim.run()
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
        factors.append(result.metrics["sim_time_s"] / wall)
        cpu_factors.append(result.metrics["sim_time_s"] / cpu)
        sims.append(result)
    r = sims[-1]
    return {
        "controller": controller,
        "perception": perception,
        "outcome": r.outcome,
        "sim_time_s": r.metrics["sim_time_s"],
        "steps": r.metrics["steps"],
        "median_realtime_factor": statistics.median(factors),
        "median_cpu_realtime_factor": statistics.median(cpu_factors),
        "all": factors,
    }


def controller_call_us(controller: str, repeats: int = 20000) -> float:
    sim = build_simulation("s1", controller)
    inputs = sim.sense()[0]
    ctrl = sim.controller
    start = time.perf_counter()
    for _ in range(repeats):
        ctrl(inputs)
    return (time.perf_counter() - start) / repeats * 1e6


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--controller", default="paper")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    rows = [realtime_factor(args.controller, p, args.repeats) for p in ("ideal", "ultrasonic")]
    call = controller_call_us(args.controller)
    if args.json:
        print(
            json.dumps({"runs": rows, "controller_call_us": call, "target_factor": TARGET_FACTOR})
        )
        return 0
    for row in rows:
        verdict = "meets" if row["median_realtime_factor"] >= TARGET_FACTOR else "BELOW"
        print(
            f"s1, {row['controller']}, {row['perception']:10s}: {row['outcome']} after "
            f"{row['sim_time_s']:.1f} s simulated; median real-time factor "
            f"{row['median_realtime_factor']:.0f}x by the wall clock, "
            f"{row['median_cpu_realtime_factor']:.0f}x by CPU time, over {args.repeats} runs "
            f"(wall clock {verdict} the {TARGET_FACTOR:.0f}x aim)"
        )
    print(f"one {args.controller} controller call: {call:.1f} us")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
