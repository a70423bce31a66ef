"""Benchmark of :func:`fuzzynav.evaluate` (a population on the batch engine) against
one :func:`fuzzynav.simulate` call per candidate and layout, on one core, in one run.

    .venv/bin/python bench/bench_evaluate.py [--candidates 64] [--layouts 30]
        [--sample 8] [--json]

The population: ``--candidates`` design vectors of the paper controller, one
generation of :class:`~fuzzynav.app.experiments.search.DesignSearch` (seed 0,
first step 0.2 of each span), on standard layouts 0 .. ``--layouts`` - 1 (seed 1),
ideal perception. ``evaluate`` runs them all once; ``simulate`` runs every layout of
``--sample`` candidates spread over the population (``--sample`` = ``--candidates``
runs them all), and the whole population's time is the median per candidate times
the candidates (the mean is printed beside it). The sampled candidates' costs (success
and path length, :func:`cost`) are compared with evaluate's.

The machine may be shared: pinned to one CPU with one BLAS thread, both measured in
the same run, back to back, in CPU seconds of this process.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")  # before numpy: one BLAS thread

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402


def cost(metrics) -> float:
    """A tuning cost of one run: 0 for a success, 100 otherwise, plus the path in m."""
    success = metrics["reached"] and not metrics["collided"]
    return (0.0 if success else 100.0) + metrics["path_length_m"]


def _pin_one_cpu() -> str:
    try:
        cpu = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpu})
        return f"pinned to CPU {cpu}"
    except (AttributeError, OSError):
        return "not pinned (no sched_setaffinity)"


def measure(candidates: int, layouts: int, sample: int) -> dict:
    import fuzzynav
    from fuzzynav.app.experiments.search import DesignSearch

    search = DesignSearch("paper", popsize=candidates, seed=0)
    controllers = [search.build(v) for v in search.ask()]
    t0 = time.process_time()
    evaluation = fuzzynav.evaluate(controllers, layouts, cost, seed=1)
    evaluate_cpu = time.process_time() - t0
    picked = np.linspace(0, candidates - 1, min(sample, candidates)).round().astype(int)
    per_candidate, worst = [], 0.0
    for i in picked:
        t0 = time.process_time()
        runs = [fuzzynav.simulate(s, controllers[i], seed=1) for s in evaluation.scenarios]
        per_candidate.append(time.process_time() - t0)
        for j, run in enumerate(runs):
            worst = max(worst, abs(cost(run.result.metrics) - evaluation.costs[i, j]))
    simulate_cpu = statistics.median(per_candidate) * candidates
    return {
        "candidates": candidates,
        "layouts": layouts,
        "runs": candidates * layouts,
        "engines": sorted(set(evaluation.engines)),
        "success_rate": float(evaluation.success.mean()),
        "evaluate_cpu_s": evaluate_cpu,
        "simulate_sampled_candidates": len(picked),
        "simulate_cpu_per_candidate_median_s": statistics.median(per_candidate),
        "simulate_cpu_s_from_median": simulate_cpu,
        "simulate_cpu_s_from_mean": statistics.mean(per_candidate) * candidates,
        "ratio": simulate_cpu / evaluate_cpu,
        "ratio_from_mean": statistics.mean(per_candidate) * candidates / evaluate_cpu,
        "max_cost_diff": worst,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--candidates", type=int, default=64)
    parser.add_argument("--layouts", type=int, default=30)
    parser.add_argument("--sample", type=int, default=8, help="candidates run by simulate")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    pinned = _pin_one_cpu()
    out = {"pinned": pinned, **measure(args.candidates, args.layouts, args.sample)}
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(f"fuzzynav.evaluate against simulate, one core ({pinned})")
    print(
        f"{out['candidates']} candidates x {out['layouts']} layouts = {out['runs']} runs "
        f"(success {out['success_rate']:.0%}, engine {', '.join(out['engines'])})"
    )
    print(f"evaluate: {out['evaluate_cpu_s']:.1f} s CPU")
    print(
        f"simulate: {out['simulate_cpu_per_candidate_median_s']:.2f} s CPU per candidate "
        f"(median of {out['simulate_sampled_candidates']}), x {out['candidates']} = "
        f"{out['simulate_cpu_s_from_median']:.1f} s (from the mean: "
        f"{out['simulate_cpu_s_from_mean']:.1f} s)"
    )
    print(
        f"ratio {out['ratio']:.1f}x (from the mean {out['ratio_from_mean']:.1f}x); "
        f"largest cost difference {out['max_cost_diff']:.1e}"
    )


if __name__ == "__main__":
    main()
