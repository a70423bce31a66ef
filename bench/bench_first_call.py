"""Wall time of a first call in a fresh interpreter: ``import fuzzynav`` and the first
step of s1 with the paper controller, and a whole s1 run, each a median over fresh
processes taken in turns with a process that only imports numpy (what any numpy
program waits for).

Run: ``.venv/bin/python bench/bench_first_call.py [--repeats 7]``
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys

CASES = {
    "numpy alone": "import numpy",
    "first step": (
        "import fuzzynav\n"
        "from fuzzynav.app.runs import build_simulation\n"
        "build_simulation('s1', 'paper').step()"
    ),
    "whole s1 run": "import fuzzynav\nfuzzynav.simulate('s1', 'paper')",
}

# Timed from the script's first line (the interpreter's own start is left out).
TIMED = "import time\nstart = time.perf_counter()\n{body}\nprint(time.perf_counter() - start)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    times: dict[str, list[float]] = {name: [] for name in CASES}
    for _ in range(args.repeats):
        for name, body in CASES.items():  # in turns: a changing load hits all alike
            out = subprocess.run(
                [sys.executable, "-c", TIMED.format(body=body)],
                capture_output=True,
                text=True,
                check=True,
            )
            times[name].append(float(out.stdout.strip().splitlines()[-1]))
    base = statistics.median(times["numpy alone"])
    for name, values in times.items():
        median = statistics.median(values)
        print(
            f"{name:>14}: median {median:.3f} s over {args.repeats} fresh processes "
            f"(min {min(values):.3f}, max {max(values):.3f}); {median / base:.1f}x numpy alone"
        )


if __name__ == "__main__":
    main()
