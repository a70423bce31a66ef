"""Benchmark of the executors (app/experiments/executor.py) on one sweep: runs per second, serially, on
a local pool of 1, 2 and all workers, and on a Dask LocalCluster, in one run.

    .venv/bin/python bench/bench_sweep.py [--n 48] [--controller paper] [--repeats 3]

Each executor runs the same ``--n`` layouts (standard family, seed 1) ``--repeats``
times, the executors taking turns (so that a shared machine's changing load hits all
alike); the table has the median wall time of a sweep and runs/s, the speed-up against
serial, the efficiency (speed-up / workers), the start-up (pool or cluster, measured
apart, paid once per command), and the overhead per task: ``(workers x wall - serial
wall) / tasks``, the time a task costs beyond its runs (sending, pickling, waiting
for the slowest worker at the end) -- negative when the workers ran faster than
serial did (noise on a shared machine) -- and the cost of an empty task (64 tasks of
one trivial item, per task and worker: sending, pickling, scheduling alone). Every executor's rows are checked equal to
the serial rows.

On a shared machine the numbers move from minute to minute; quote medians.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from fuzzynav.app.experiments.executor import (
    DaskExecutor,
    LocalExecutor,
    SerialExecutor,
    available_cpus,
    chunk_size,
)
from fuzzynav.app.experiments.studies import run_jobs, run_layout, sweep_jobs


def cpu_timed_run(job):
    """A sweep run and the CPU seconds it took in its worker process (top level: sent to
    the workers like run_layout)."""
    t0 = time.process_time()
    row = run_layout(job)
    return row, time.process_time() - t0


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
    # local with 1, 2 and all workers (one row when all is 2), then Dask
    plans = [("serial", 1)] + [("local", w) for w in sorted({1, 2, cpus})]
    plans += [("dask", w) for w in sorted({min(2, cpus), cpus})]
    executors = []
    for kind, workers in plans:
        t0 = time.perf_counter()
        if kind == "serial":
            executor = SerialExecutor()
        elif kind == "local":
            executor = LocalExecutor(workers)
        else:
            executor = DaskExecutor(workers)
        executor.map(abs, [0] * workers)  # start the pool or cluster: start-up apart
        startup = time.perf_counter() - t0
        run_jobs(jobs[:workers], executor)  # warm: imports in every worker
        # the cost of one task alone: an empty one (abs), sent one item per task
        t0 = time.perf_counter()
        list(executor._chunked(abs, list(range(64)), 1, 64))
        round_trip = (time.perf_counter() - t0) / 64 * workers
        executors.append((kind, workers, executor, startup, round_trip))
    # interleaved repeats: a shared machine's load changes hit every executor alike
    walls = {i: [] for i in range(len(executors))}
    rows_of = {}
    for rep in range(args.repeats):
        for i, (kind, workers, executor, _, _) in enumerate(executors):
            t0 = time.perf_counter()
            rows_of[i] = run_jobs(jobs, executor)
            walls[i].append(time.perf_counter() - t0)
            console.print(f"repeat {rep + 1}: {kind} x{workers}: {walls[i][-1]:.2f} s", style="dim")
    # CPU time per run inside the workers: what N idle cores can turn into runs/s
    cpu_per_run = {}
    for kind, workers, executor, _, _ in executors:
        timed = executor.map(cpu_timed_run, jobs)
        assert [row for row, _ in timed] == rows_of[0]
        cpu_per_run[(kind, workers)] = statistics.fmean(cpu for _, cpu in timed)
    results = []
    for i, (kind, workers, executor, startup, round_trip) in enumerate(executors):
        executor.close()
        tasks = 1 if kind == "serial" else -(-len(jobs) // chunk_size(len(jobs), workers))
        wall = statistics.median(walls[i])
        results.append((kind, workers, startup, wall, tasks, rows_of[i] == rows_of[0], round_trip))

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
        "empty task ms",
        "rows = serial",
    ):
        t.add_column(col, justify="left" if col == "executor" else "right")
    for kind, workers, startup, wall, tasks, same, round_trip in results:
        speedup = serial_wall / wall
        overhead_ms = (workers * wall - serial_wall) / tasks * 1e3 if kind != "serial" else 0.0
        t.add_row(
            kind,
            f"{workers}" + (" (all)" if workers == cpus and kind != "serial" else ""),
            str(tasks),
            f"{startup:.2f}",
            f"{wall:.2f}",
            f"{args.n / wall:.2f}",
            f"{speedup:.2f}",
            f"{speedup / workers:.0%}",
            f"{overhead_ms:.0f}",
            f"{round_trip * 1e3:.2f}" if kind != "serial" else "-",
            "yes" if same else "NO",
        )
    console.print(t)
    console.print(
        f"serial: {serial_wall / args.n * 1e3:.0f} ms per run (wall); a task carries up to "
        f"{chunk_size(args.n, 1)} runs (app/experiments/executor.py: chunk_size); load average at the "
        f"end {os.getloadavg()[0]:.1f} on {cpus} CPUs"
    )
    c = Table(title="CPU time per run in a worker (mean), and what N idle cores would give")
    for col in ("executor", "workers", "CPU ms per run", "empty task ms", "runs/s per core"):
        c.add_column(col, justify="left" if col == "executor" else "right")
    per_core = {}
    for kind, workers, _, _, _, _, round_trip in results:
        cpu = cpu_per_run[(kind, workers)]
        per_run = cpu + (round_trip / chunk_size(args.n, workers) if kind != "serial" else 0.0)
        per_core[(kind, workers)] = 1.0 / per_run
        c.add_row(
            kind,
            str(workers),
            f"{cpu * 1e3:.0f}",
            f"{round_trip * 1e3:.2f}" if kind != "serial" else "-",
            f"{1.0 / per_run:.2f}",
        )
    console.print(c)
    local = per_core[("local", cpus)]
    console.print(
        "expected on an idle machine with N cores, local executor: about "
        + ", ".join(f"{n * local:.0f} runs/s on {n}" for n in (2, 8, 32))
        + f" (N x {local:.2f}; the efficiency column above is what this shared machine gave)"
    )
    return 0 if all(r[5] for r in results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
