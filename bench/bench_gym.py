"""Benchmark of the gymnasium vector environment (fuzzynav.gym.HuskyVectorEnv, on the
batch engine) against N single environments (gymnasium's SyncVectorEnv), on one core.

    .venv/bin/python bench/bench_gym.py [--n 1000] [--repeats 3] [--vector-steps 200]
        [--sync-steps 10] [--perception ideal] [--json out.json]

Both are made by ``gymnasium.make_vec("fuzzynav/Husky-v0", num_envs=N, ...)``:
``vectorization_mode="vector_entry_point"`` (the native one) and ``"sync"`` (N
:class:`fuzzynav.gym.HuskyEnv` s with gymnasium's default wrappers, as a user gets
them), reset with the same seed and driven by the same random actions (autoresets
included), at the paper's 20 ms period on standard layouts. Measured: environment
steps per second of CPU time (N x vector steps / CPU s) of this process, pinned to one
CPU with one BLAS thread; the median of ``--repeats`` repeats, and the ratio of the
medians (issue 40's aim: >= 20x at N = 1,000). The two forms' observations are checked
equal (to 1e-12) over the sync run's steps.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")  # before numpy: one BLAS thread

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402


def _pin_one_cpu() -> str:
    try:
        cpu = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpu})
        return f"pinned to CPU {cpu}"
    except (AttributeError, OSError):
        return "not pinned (no sched_setaffinity)"


def _actions(n: int, steps: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-0.2, 1.0, (steps, n, 2))


def steps_per_s(mode: str, n: int, steps: int, perception: str) -> tuple[float, np.ndarray]:
    """Environment steps per CPU second of one run of ``steps`` vector steps, and the
    observations of every step (steps, n, 7)."""
    import gymnasium as gym

    import fuzzynav.gym  # noqa: F401  (registers the environment)

    envs = gym.make_vec(
        "fuzzynav/Husky-v0", num_envs=n, vectorization_mode=mode, perception=perception
    )
    actions = _actions(n, steps)
    seen = np.empty((steps, n, 7))
    envs.reset(seed=1)
    t0 = time.process_time()
    for k in range(steps):
        seen[k] = envs.step(actions[k])[0]
    cpu = time.process_time() - t0
    envs.close()
    return n * steps / cpu, seen


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000, help="environments (default 1000)")
    ap.add_argument("--repeats", type=int, default=3, help="repeats of each (median)")
    ap.add_argument("--vector-steps", type=int, default=200, help="native vector steps")
    ap.add_argument("--sync-steps", type=int, default=10, help="sync vector steps")
    ap.add_argument("--perception", default="ideal", choices=("ideal", "ultrasonic"))
    ap.add_argument("--json", type=Path, default=None, help="also write the numbers here")
    args = ap.parse_args(argv)
    pinned = _pin_one_cpu()
    native, sync = [], []
    worst = 0.0
    for _ in range(args.repeats):
        rate, fast = steps_per_s("vector_entry_point", args.n, args.vector_steps, args.perception)
        native.append(rate)
        rate, slow = steps_per_s("sync", args.n, args.sync_steps, args.perception)
        sync.append(rate)
        k = min(args.sync_steps, args.vector_steps)
        worst = max(worst, float(np.abs(fast[:k] - slow[:k]).max()))
    numbers = {
        "pinned": pinned,
        "load": os.getloadavg(),
        "n": args.n,
        "perception": args.perception,
        "vector_steps_per_s": native,
        "sync_steps_per_s": sync,
        "vector_median": statistics.median(native),
        "sync_median": statistics.median(sync),
        "ratio": statistics.median(native) / statistics.median(sync),
        "max_observation_diff": worst,
    }
    print(f"bench_gym: {pinned}; one BLAS thread; load {numbers['load']}")
    print(f"N = {args.n}, {args.perception} perception, 20 ms period, standard layouts")
    print("| form | env steps/s (median) | repeats |")
    print("|---|---|---|")
    print(
        f"| native vector (vector_entry_point) | {numbers['vector_median']:,.0f} | "
        + ", ".join(f"{v:,.0f}" for v in native)
        + " |"
    )
    print(
        f"| {args.n} single envs (sync) | {numbers['sync_median']:,.0f} | "
        + ", ".join(f"{v:,.0f}" for v in sync)
        + " |"
    )
    print(f"ratio of the medians: {numbers['ratio']:.1f}x (aim >= 20x)")
    print(f"largest observation difference over the common steps: {worst:.1e}")
    if args.json:
        args.json.write_text(json.dumps(numbers, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
