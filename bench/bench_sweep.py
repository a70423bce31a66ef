"""Benchmark of the executors (app/executor.py) on one sweep: runs per second, serially, on
a local pool of 1, 2 and all workers, and on a Dask LocalCluster, in one run.

    .venv/bin/python bench/bench_sweep.py [--n 48] [--controller paper] [--repeats 3]

Each executor runs the same ``--n`` layouts (standard family, seed 1) ``--repeats``
times; the table has the median wall time of a sweep and runs/s, the speed-up against
serial, the efficiency (speed-up / workers), the start-up (pool or cluster, measured
apart, paid once per command), and the overhead per task: ``(workers x wall - serial
wall) / tasks``, the time a task costs beyond its runs (sending, pickling, waiting
for the slowest worker at the end) -- negative when the workers ran faster than
serial did (noise on a shared machine). Every executor's rows are checked equal to
the serial rows.

On a shared machine the numbers move from minute to minute; quote medians.
"""

from __future__ import annotations

import argparse
import statistics
import time

from fuzzynav.app.executor import (
    DaskExecutor,
    LocalExecutor,
    SerialExecutor,
    available_cpus,
    chunk_size,
)
from fuzzynav.app.experiments import run_jobs, sweep_jobs


def _time_sweeps(executor, jobs, repeats):
    walls, rows = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        rows = run_jobs(jobs, executor)
        walls.append(time.perf_counter() - t0)
    return statistics.median(walls), rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=48, help="layouts per sweep (default 48)")
    ap.add_argument("--controller", default="paper")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    from rich.console import Console
    from rich.table import Table

    console = Console(width=140)
    jobs = sweep_jobs(args.controller, args.n, 1)
    cpus = available_cpus()
    plans = [("serial", 1), ("local", 1), ("local", 2), ("local", cpus), ("dask", min(2, cpus))]
    if cpus > 2:
        plans.append(("dask", cpus))
    results = []
    reference = None
    for kind, workers in plans:
        t0 = time.perf_counter()
        if kind == "serial":
            executor = SerialExecutor()
        elif kind == "local":
            executor = LocalExecutor(workers)
            executor.map(abs, [0] * workers)  # start the pool: start-up apart from runs
        else:
            executor = DaskExecutor(workers)
            executor.map(abs, [0] * workers)
        startup = time.perf_counter() - t0
        with executor:
            run_jobs(jobs[: max(1, workers)], executor)  # warm: imports in every worker
            wall, rows = _time_sweeps(executor, jobs, args.repeats)
        if reference is None:
            reference = rows
        tasks = 1 if kind == "serial" else -(-len(jobs) // chunk_size(len(jobs), workers))
        results.append((kind, workers, startup, wall, tasks, rows == reference))
        console.print(f"{kind} x{workers}: {wall:.2f} s per sweep", style="dim")

    serial_wall = results[0][3]
    t = Table(
        title=f"{args.n} {args.controller} runs per sweep, {cpus} CPUs available, medians of "
        f"{args.repeats} sweeps"
    )
    for col in (
        "executor",
        "workers",
        "tasks",
        "start-up s",
        "sweep s",
        "runs/s",
        "speed-up",
        "efficiency",
        "overhead per task ms",
        "rows = serial",
    ):
        t.add_column(col, justify="left" if col == "executor" else "right")
    for kind, workers, startup, wall, tasks, same in results:
        speedup = serial_wall / wall
        overhead_ms = (workers * wall - serial_wall) / tasks * 1e3 if kind != "serial" else 0.0
        t.add_row(
            kind,
            str(workers),
            str(tasks),
            f"{startup:.2f}",
            f"{wall:.2f}",
            f"{args.n / wall:.2f}",
            f"{speedup:.2f}",
            f"{speedup / workers:.0%}",
            f"{overhead_ms:.0f}",
            "yes" if same else "NO",
        )
    console.print(t)
    console.print(
        f"serial: {serial_wall / args.n * 1e3:.0f} ms per run; a task carries up to "
        f"{chunk_size(args.n, 1)} runs (app/executor.py: chunk_size)"
    )
    return 0 if all(r[5] for r in results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
