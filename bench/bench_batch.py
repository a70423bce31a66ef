"""Benchmark of the lockstep batch engine (world/batch.py) against the pymunk engine, on
one core, in one run.

    .venv/bin/python bench/bench_batch.py [--n 1000] [--pymunk-sample 100]
        [--scaling 1,10,100,1000,10000] [--figure docs/img/batch_scaling.png]
    .venv/bin/python bench/bench_batch.py --crosscheck 500
    .venv/bin/python bench/bench_batch.py --tangent 1000

What it measures (CPU seconds of this process, pinned to one CPU, one BLAS thread):

1. runs/s of the paper controller on ``--n`` standard layouts (seed 1), ideal and
   ultrasonic perception: the batch engine runs all ``--n`` at once; the pymunk engine
   runs every ``n / pymunk-sample``-th of the same layouts one after the other (an
   unbiased sample of the same runs; ``--pymunk-sample`` = ``--n`` runs them all), and
   their rows are checked against the batch's (outcome and metrics to 1e-6);
2. one tuning generation: 64 candidates of the paper tunable on s1-s3 in both
   perceptions at tuning's 50 ms period (384 runs), the batch objective against the
   pymunk objective, costs compared;
3. the cost per run as N grows (``--scaling``), each N in a fresh process: CPU per
   run and the process's peak memory (the 10,000-run point is the memory bound), as a
   table and a log-log figure.

``--split PARTS`` instead runs ``--n`` layouts as one batch and as PARTS batches,
twice, alternating (the CPU a sweep's smaller tasks cost).

``--crosscheck N`` instead runs the issue's cross-check at full size: N layouts spread
over every family, both perceptions and the paper, baseline and p controllers (and
the paper's point robot), default period and full durations, batch against pymunk:
outcome agreement, metric and trajectory differences.

``--tangent N`` instead runs the seeded search of tangent layouts
(:func:`world.layouts.tangent_layout`, seed 11: one obstacle whose path is tangent to
the robot's straight one) with the P controller, which drives straight at the target and
so grazes, in both engines: outcome and step agreement, the largest path difference.

The machine may be shared: the two engines are measured in the same run, back to
back, and CPU time (not wall time) is compared.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")  # before numpy: one BLAS thread, as the workers

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
METRICS = (
    "path_length_m",
    "min_clearance_m",
    "min_center_distance_m",
    "mad_m",
    "rmse_m",
    "time_to_target_s",
    "max_abs_voltage_v",
)


def _pin_one_cpu() -> str:
    try:
        cpu = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpu})
        return f"pinned to CPU {cpu}"
    except (AttributeError, OSError):
        return "not pinned (no sched_setaffinity)"


def _compare(reference: dict, mine: dict) -> tuple[bool, float]:
    """(same outcome, largest metric difference where both exist)."""
    same = (reference["outcome"], reference["collided"]) == (mine["outcome"], mine["collided"])
    worst = 0.0
    for key in METRICS:
        a, b = reference[key], mine[key]
        if a is not None and b is not None:
            worst = max(worst, abs(a - b))
    return same, worst


def layouts_runs(n: int, sample: int, perception: str) -> dict:
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.controller.batch import batch_controller
    from fuzzynav.controller.registry import make_controller
    from fuzzynav.world.batch import run_batch
    from fuzzynav.world.layouts import generate_layout

    scenarios = [generate_layout("standard", 1, i) for i in range(n)]
    picked = list(range(0, n, max(1, n // sample)))[:sample]
    t0 = time.process_time()
    batch = run_batch(
        scenarios, batch_controller(make_controller("paper")), perception=perception, seeds=1
    )
    batch_cpu = time.process_time() - t0
    pymunk_cpu, agree, worst = 0.0, 0, 0.0
    for i in picked:
        t0 = time.process_time()
        result = build_simulation(scenarios[i], "paper", perception=perception, seed=1).run()
        pymunk_cpu += time.process_time() - t0
        same, diff = _compare(result.metrics, batch.metrics(i))
        agree += same
        if same:
            worst = max(worst, diff)
    batch_rate = n / batch_cpu
    pymunk_rate = len(picked) / pymunk_cpu
    return {
        "perception": perception,
        "n": n,
        "pymunk_runs": len(picked),
        "batch_cpu_s": batch_cpu,
        "pymunk_cpu_s": pymunk_cpu,
        "batch_runs_per_s": batch_rate,
        "pymunk_runs_per_s": pymunk_rate,
        "ratio": batch_rate / pymunk_rate,
        "same_outcome": f"{agree}/{len(picked)}",
        "max_metric_diff": worst,
        "outcomes": {k: batch.outcomes.count(k) for k in ("reached", "collided", "timeout")},
    }


def tuning_generation(candidates: int = 64) -> dict:
    from fuzzynav.app.experiments.batch_runs import objective_costs
    from fuzzynav.app.experiments.objective import STALL_S, Objective, build_cases, outcome_cost
    from fuzzynav.controller.tuning import tunable

    t = tunable("paper")
    objective = Objective(t, build_cases(["s1", "s2", "s3"], ["ideal", "ultrasonic"]), 0.05)
    low, high = np.array(t.bounds()).T
    rng = np.random.default_rng(0)
    x0 = t.initial_vector()
    vectors = [x0] + [
        np.clip(x0 + 0.1 * (high - low) * rng.standard_normal(len(low)), low, high)
        for _ in range(candidates - 1)
    ]
    t0 = time.process_time()
    batch = objective_costs(objective, outcome_cost, STALL_S, vectors)
    batch_cpu = time.process_time() - t0
    t0 = time.process_time()
    pymunk = [objective(v) for v in vectors]
    pymunk_cpu = time.process_time() - t0
    return {
        "candidates": candidates,
        "runs": candidates * len(objective.cases),
        "batch_cpu_s": batch_cpu,
        "pymunk_cpu_s": pymunk_cpu,
        "ratio": pymunk_cpu / batch_cpu,
        "max_cost_diff": float(np.max(np.abs(np.array(batch) - np.array(pymunk)))),
    }


def scaling_point(n: int) -> dict:
    """One N in this process (called in a fresh one): CPU per run, peak memory."""
    from fuzzynav.app.experiments.batch_runs import run_layouts

    t0 = time.process_time()
    result = run_layouts("standard", n, 1, controller="paper")
    cpu = time.process_time() - t0
    peak_kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return {
        "n": n,
        "cpu_s": cpu,
        "cpu_ms_per_run": 1000 * cpu / n,
        "peak_rss_mb": peak_kib / 1024,
        "steps_max": int(result.steps.max()),
    }


def batch_split(n: int, parts: int, repeats: int = 2) -> dict:
    """CPU of ``n`` standard layouts (seed 1) as one batch against ``parts`` batches of
    ``n / parts`` (a sweep's tasks: app.experiments.batch_runs.MAX_BATCH), ``repeats``
    times alternating."""
    from fuzzynav.app.experiments.batch_runs import run_layouts

    size = n // parts
    one, split = [], []
    for _ in range(repeats):
        t0 = time.process_time()
        run_layouts("standard", n, 1, indices=range(n))
        one.append(time.process_time() - t0)
        t0 = time.process_time()
        for k in range(parts):
            run_layouts("standard", size, 1, indices=range(k * size, (k + 1) * size))
        split.append(time.process_time() - t0)
    return {
        "n": n,
        "parts": parts,
        "one_batch_cpu_s": one,
        "split_cpu_s": split,
        "ratios": [b / a for a, b in zip(one, split)],
    }


def crosscheck(n: int) -> dict:
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.controller.batch import batch_controller
    from fuzzynav.controller.registry import make_controller
    from fuzzynav.world.batch import run_batch
    from fuzzynav.world.layouts import FAMILIES, generate_layout

    combos = [
        (p, c, "husky") for p in ("ideal", "ultrasonic") for c in ("paper", "baseline", "p")
    ] + [("ideal", "paper", "paper")]
    per = math.ceil(n / (len(combos) * len(FAMILIES)))
    total = agree = 0
    worst_metric = worst_pose = 0.0
    differences = []
    for perception, controller, geometry in combos:
        scenarios = []
        for family in FAMILIES:
            for i in range(per):
                sc = generate_layout(family, 11, i)
                scenarios.append(sc)
        batch = run_batch(
            scenarios,
            batch_controller(make_controller(controller, geometry=geometry)),
            perception=perception,
            geometry=geometry,
            seeds=11,
            record_poses=perception == "ideal",
        )
        for i, sc in enumerate(scenarios):
            ref = build_simulation(
                sc, controller, perception=perception, seed=11, geometry=geometry
            ).run()
            total += 1
            same, diff = _compare(ref.metrics, batch.metrics(i))
            agree += same
            if same:
                worst_metric = max(worst_metric, diff)
                if perception == "ideal":
                    pose = batch.poses[i]
                    if pose.shape == ref.log.pose.shape:
                        worst_pose = max(
                            worst_pose, float(np.abs(pose - ref.log.pose)[:, :2].max())
                        )
                    else:
                        worst_pose = math.inf
            else:
                differences.append(
                    f"{perception} {controller} {geometry} {sc.name}: pymunk {ref.outcome} "
                    f"(min clearance {ref.metrics['min_clearance_m']}), batch "
                    f"{batch.metrics(i)['outcome']} ({batch.metrics(i)['min_clearance_m']})"
                )
    return {
        "runs": total,
        "same_outcome": agree,
        "agreement": agree / total,
        "max_metric_diff_where_same": worst_metric,
        "max_ideal_pose_diff_m": worst_pose,
        "differences": differences,
    }


def tangent_search(n: int) -> dict:
    from fuzzynav.controller.batch import batch_controller
    from fuzzynav.controller.registry import make_controller
    from fuzzynav.world.batch import run_batch
    from fuzzynav.world.layouts import tangent_layout
    from fuzzynav.world.simulation import Simulation

    scenarios = [tangent_layout(11, i) for i in range(n)]
    batch = run_batch(scenarios, batch_controller(make_controller("p")), record_poses=True)
    agree = grazes = 0
    worst_pose = 0.0
    outcomes: dict[str, int] = {}
    differences = []
    for i, sc in enumerate(scenarios):
        ref = Simulation(sc, make_controller("p")).run()
        mine = batch.metrics(i)
        outcomes[ref.outcome] = outcomes.get(ref.outcome, 0) + 1
        grazes += abs(ref.metrics["min_clearance_m"]) <= 1e-12
        if (mine["outcome"], mine["steps"]) == (ref.outcome, ref.metrics["steps"]):
            agree += 1
            diff = float(np.abs(batch.poses[i][:, :2] - ref.log.pose[:, :2]).max())
            worst_pose = max(worst_pose, diff)
        else:
            differences.append(
                f"{sc.name}: pymunk {ref.outcome} at step {ref.metrics['steps']}, batch "
                f"{mine['outcome']} at step {mine['steps']}"
            )
    return {
        "runs": n,
        "pymunk_outcomes": outcomes,
        "grazes_within_1e-12_m": grazes,
        "same_outcome_and_steps": agree,
        "max_pose_diff_m_where_same": worst_pose,
        "differences": differences,
    }


def figure(points: list[dict], pymunk_ms: float, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = [p["n"] for p in points]
    ms = [p["cpu_ms_per_run"] for p in points]
    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=120)
    ax.loglog(n, ms, "o-", label="batch engine (CPU per run)")
    ax.axhline(pymunk_ms, color="C3", ls="--", label=f"pymunk engine, serial ({pymunk_ms:.0f} ms)")
    for x, y in zip(n, ms):
        ax.annotate(f"{y:.1f} ms", (x, y), textcoords="offset points", xytext=(4, 6), fontsize=8)
    ax.set_xlabel("runs at once, N")
    ax.set_ylabel("CPU ms per run (paper controller, ideal)")
    ax.set_title("Cost per run as the batch grows (standard layouts, one core)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000, help="standard layouts (default 1000)")
    ap.add_argument(
        "--pymunk-sample", type=int, default=100, help="of them run on pymunk (default 100)"
    )
    ap.add_argument("--scaling", default="1,10,100,1000,10000", help="batch sizes N")
    ap.add_argument("--candidates", type=int, default=64, help="tuning generation size")
    ap.add_argument("--figure", type=Path, default=ROOT / "docs" / "img" / "batch_scaling.png")
    ap.add_argument("--json", type=Path, default=None, help="also write the numbers here")
    ap.add_argument("--crosscheck", type=int, default=0, metavar="N", help="run the cross-check")
    ap.add_argument(
        "--split", type=int, default=0, metavar="PARTS", help="--n as one batch and as PARTS"
    )
    ap.add_argument(
        "--tangent", type=int, default=0, metavar="N", help="run the tangent-layout search"
    )
    ap.add_argument("--point", type=int, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    pinned = _pin_one_cpu()
    if args.point is not None:  # a scaling point, in its own process
        print(json.dumps(scaling_point(args.point)))
        return 0
    from rich.console import Console
    from rich.table import Table

    console = Console(width=150)
    console.print(f"bench_batch: {pinned}; one BLAS thread; load {os.getloadavg()}")
    if args.split:
        console.print(json.dumps(batch_split(args.n, args.split), indent=1))
        return 0
    if args.crosscheck or args.tangent:
        out = crosscheck(args.crosscheck) if args.crosscheck else tangent_search(args.tangent)
        console.print(json.dumps(out, indent=1))
        if args.json:
            args.json.write_text(json.dumps(out, indent=1) + "\n")
        return 0
    numbers: dict = {"pinned": pinned}
    layouts = [layouts_runs(args.n, args.pymunk_sample, p) for p in ("ideal", "ultrasonic")]
    numbers["layouts"] = layouts
    table = Table(title=f"paper controller, {args.n} standard layouts (seed 1), one core")
    for col in (
        "perception",
        "batch runs/s",
        "pymunk runs/s",
        "ratio",
        "batch CPU s",
        "pymunk runs",
        "pymunk CPU s",
        "same outcome",
        "max metric diff",
    ):
        table.add_column(col, justify="right")
    for row in layouts:
        table.add_row(
            row["perception"],
            f"{row['batch_runs_per_s']:.1f}",
            f"{row['pymunk_runs_per_s']:.2f}",
            f"{row['ratio']:.1f}x",
            f"{row['batch_cpu_s']:.1f}",
            str(row["pymunk_runs"]),
            f"{row['pymunk_cpu_s']:.1f}",
            row["same_outcome"],
            f"{row['max_metric_diff']:.1e}",
        )
    console.print(table)
    generation = tuning_generation(args.candidates)
    numbers["tuning_generation"] = generation
    console.print(
        f"one tuning generation: {generation['candidates']} candidates x s1-s3 x 2 "
        f"perceptions = {generation['runs']} runs at 50 ms: batch {generation['batch_cpu_s']:.1f} "
        f"s CPU, pymunk {generation['pymunk_cpu_s']:.1f} s: {generation['ratio']:.1f}x; "
        f"costs differ by at most {generation['max_cost_diff']:.1e}"
    )
    points = []
    for n in [int(v) for v in args.scaling.split(",") if v]:
        done = subprocess.run(
            [sys.executable, __file__, "--point", str(n)],
            capture_output=True,
            text=True,
            check=True,
        )
        points.append(json.loads(done.stdout.strip().splitlines()[-1]))
    numbers["scaling"] = points
    pymunk_ms = 1000 / layouts[0]["pymunk_runs_per_s"]
    scaling = Table(title="cost per run as N grows (paper, ideal, standard layouts, one core)")
    for col in ("N", "CPU s", "CPU ms per run", "vs pymunk", "peak memory MB", "longest run steps"):
        scaling.add_column(col, justify="right")
    for p in points:
        scaling.add_row(
            str(p["n"]),
            f"{p['cpu_s']:.1f}",
            f"{p['cpu_ms_per_run']:.2f}",
            f"{pymunk_ms / p['cpu_ms_per_run']:.1f}x",
            f"{p['peak_rss_mb']:.0f}",
            str(p["steps_max"]),
        )
    console.print(scaling)
    console.print(f"pymunk engine, serial: {pymunk_ms:.1f} ms CPU per run (ideal, above)")
    if args.figure:
        figure(points, pymunk_ms, args.figure)
        console.print(f"figure: {args.figure}")
    if args.json:
        args.json.write_text(json.dumps(numbers, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
