"""Steps per second of the plant + world + sensors loop (issue 2: >= 20,000 on one core).

A step is one 20 ms control period of :meth:`world.simulation.Simulation.step`:
perception (ideal or ultrasonic: the three sensors' pymunk ray casts at 25 Hz), a
controller, the 12 V saturation, the exact ZOH plant step, the pymunk world step with
its collision detection, and the log row.

(a) The loop with a trivial controller (constant 10 V left, 12 V right): the robot
    circles for the whole 150 s (7,500 steps) through the region of the obstacles, so
    the sensors see them in about a sixth of the steps, and nothing is hit. The timing
    covers the steps and the final ``sim.log`` (the log is written in blocks, so its
    last block is part of the loop's cost), not building the simulation.
(b) The real-time factor (simulated seconds per second of CPU time, and of wall time) of
    a whole ``s1`` run with the P controller, ``sim.run()`` including the result and its
    metrics. The P controller is obstacle-blind: the run ends in a collision after
    13.5 s (674 steps), so it is short and its timings swing more.

Every number is the median over several repeats. The machine is shared, so each run is
timed twice: by the process's CPU time (``time.process_time``: the time the loop had a
core, the "one core" of the issue, and the headline) and by the wall clock (which also
counts the waits for a core when other jobs run). The spread column shows how much the
CPU-time rates swing; a trivial numpy operation is timed as a yardstick of the load.

Run: ``.venv/bin/python bench/bench_world.py`` (``--repeats N`` to change the count).
"""

from __future__ import annotations

import argparse
import statistics
import time
import timeit

import numpy as np
from rich.console import Console
from rich.table import Table

from fuzzynav.controller.proportional import ProportionalController
from fuzzynav.world.scenario import load_scenario
from fuzzynav.world.simulation import Simulation

TARGET_STEPS_PER_S = 20_000
CONSTANT_V = (10.0, 12.0)


class ConstantVoltage:
    """The trivial controller: the same two voltages whatever the inputs."""

    def __init__(self, left: float, right: float):
        self.v = np.array((left, right), dtype=float)

    def reset(self) -> None:
        pass

    def __call__(self, inputs) -> np.ndarray:
        return self.v


def time_loop(sim: Simulation) -> tuple[int, float, float]:
    """(steps, CPU seconds, wall seconds) of one run of ``sim`` from its start."""
    sim.reset()
    steps = 0
    cpu, wall = time.process_time(), time.perf_counter()
    while not sim.done:
        sim.step()
        steps += 1
    _ = sim.log  # the last block of the log is written here
    return steps, time.process_time() - cpu, time.perf_counter() - wall


def time_run(sim: Simulation) -> tuple[int, float, float, float]:
    """(steps, simulated s, CPU s, wall s) of ``sim.run()`` from its start."""
    sim.reset()
    cpu, wall = time.process_time(), time.perf_counter()
    result = sim.run()
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    return result.metrics["steps"], result.metrics["sim_time_s"], cpu, wall


def spread(values: list[float]) -> str:
    return f"{min(values):,.0f}-{max(values):,.0f}"


def median(values) -> float:
    return statistics.median(list(values))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=9, help="runs per case (default 9)")
    args = parser.parse_args(argv)
    repeats = max(1, args.repeats)
    console = Console(width=max(Console().width, 112))

    yardstick_x = np.ones(6)
    yardstick_us = statistics.median(
        t / 100_000 * 1e6
        for t in timeit.repeat(lambda: yardstick_x + yardstick_x, number=100_000, repeat=5)
    )

    loop = Table(
        title=f"(a) plant + world + sensors, constant {CONSTANT_V[0]:g} V / "
        f"{CONSTANT_V[1]:g} V: median of {repeats} runs"
    )
    for name in (
        "scenario",
        "perception",
        "steps/run",
        "steps/s (CPU)",
        "us/step (CPU)",
        "spread (CPU)",
        "steps/s (wall)",
        f">= {TARGET_STEPS_PER_S:,}",
    ):
        loop.add_column(name, justify="left" if name in ("scenario", "perception") else "right")
    for scenario_name in ("s1", "s2"):
        for perception in ("ideal", "ultrasonic"):
            sim = Simulation(
                load_scenario(scenario_name),
                ConstantVoltage(*CONSTANT_V),
                perception=perception,
                seed=0,
            )
            time_loop(sim)  # warm-up: ZOH matrices, caches, allocator
            runs = [time_loop(sim) for _ in range(repeats)]
            cpu_rates = [steps / cpu for steps, cpu, _ in runs]
            rate = median(cpu_rates)
            loop.add_row(
                scenario_name,
                perception,
                f"{runs[0][0]:,}",
                f"{rate:,.0f}",
                f"{1e6 / rate:.1f}",
                spread(cpu_rates),
                f"{median(steps / wall for steps, _, wall in runs):,.0f}",
                "[green]yes[/]" if rate >= TARGET_STEPS_PER_S else "[red]no[/]",
            )

    rtf = Table(
        title=f"(b) real-time factor of an s1 run with the P controller: median of {repeats} runs"
    )
    for name in (
        "perception",
        "outcome",
        "steps",
        "sim s",
        "RTF (CPU)",
        "spread (CPU)",
        "RTF (wall)",
        "steps/s (CPU)",
    ):
        rtf.add_column(name, justify="left" if name in ("perception", "outcome") else "right")
    for perception in ("ideal", "ultrasonic"):
        sim = Simulation(
            load_scenario("s1"), ProportionalController(), perception=perception, seed=0
        )
        outcome = sim.run().outcome  # warm-up
        runs = [time_run(sim) for _ in range(repeats)]
        factors = [sim_s / cpu for _, sim_s, cpu, _ in runs]
        rtf.add_row(
            perception,
            outcome,
            f"{runs[0][0]:,}",
            f"{runs[0][1]:.2f}",
            f"{median(factors):,.0f}x",
            spread(factors),
            f"{median(sim_s / wall for _, sim_s, _, wall in runs):,.0f}x",
            f"{median(steps / cpu for steps, _, cpu, _ in runs):,.0f}",
        )

    console.print(loop)
    console.print(rtf)
    console.print(
        f"yardstick: a 6-vector numpy add takes {yardstick_us:.2f} us now "
        f"(the machine is shared; compare runs by it)."
    )


if __name__ == "__main__":
    main()
