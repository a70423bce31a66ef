"""Peak memory of `fuzzynav run` against the length of the run (issue 26).

A run's log used to stay whole in memory (twice at the end), so its peak grew with the
run's length; it now keeps a block (``world.sim_log.LOG_BLOCK_BYTES``) and maps the
rest back from an unnamed temporary file. This bench runs the command line in a child
process on s1 with its obstacles moved off the path and the target kilometres away (so
every run lasts its whole duration) and samples the child's ``/proc/PID/status`` every
10 ms:

- ``anon``: the peak of ``RssAnon``, memory only swap could free: what exhausts a
  machine. The claim is that it does not grow with the length.
- ``file``: the peak of ``RssFile``, pages of files (the mapped log among them) that the
  operating system drops and reads again when memory is short.
- ``hwm``: ``VmHWM``, the peak resident set (what ``/usr/bin/time`` shows as maximum
  resident set size): both of the above.

Lengths: 300, 1,200 and 3,600 s at the default 20 ms, each with and without ``--rrd``
and ``--trace``; with ``--long`` also 2,000 s at 1 ms (2 million steps, the most one
run may take: about 4 minutes a row). Linux only.

Run: ``.venv/bin/python bench/bench_memory.py [--long] [--controller paper]``
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SCENARIO = """name = "long run"
duration_s = {duration_s}
[robot]
start = [0.0, 0.0]
heading_rad = 0.7853981633974483
[target]
position = [5000.0, 5000.0]
tolerance_m = 0.15
[[obstacles]]
position = [4.0, -4.0]
radius_m = 0.2
[[obstacles]]
position = [5.7, -5.0]
radius_m = 0.2
[[obstacles]]
position = [7.5, -6.4]
radius_m = 0.2
"""


def peak_memory_mb(argv: list[str]) -> dict:
    """Run ``argv``; the peaks of its RssAnon and RssFile (sampled) and VmHWM [MB]."""
    started = time.perf_counter()
    child = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    anon = file = hwm = 0
    while child.poll() is None:
        try:
            with open(f"/proc/{child.pid}/status") as status:
                for line in status:
                    if line.startswith("RssAnon:"):
                        anon = max(anon, int(line.split()[1]))
                    elif line.startswith("RssFile:"):
                        file = max(file, int(line.split()[1]))
                    elif line.startswith("VmHWM:"):
                        hwm = max(hwm, int(line.split()[1]))
        except (FileNotFoundError, ProcessLookupError):
            pass
        time.sleep(0.01)
    error = child.stderr.read()
    if child.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} failed: {error[-500:]}")
    return {
        "anon": anon / 1024,
        "file": file / 1024,
        "hwm": hwm / 1024,
        "wall_s": time.perf_counter() - started,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--long", action="store_true", help="also 2,000 s at 1 ms")
    parser.add_argument("--controller", default="paper")
    args = parser.parse_args(argv)
    if not Path("/proc/self/status").exists():
        print("bench_memory: needs Linux's /proc", file=sys.stderr)
        return 2
    fuzzynav = [sys.executable, "-m", "fuzzynav"]
    cases = [(d, 0.02) for d in (300.0, 1200.0, 3600.0)] + ([(2000.0, 0.001)] if args.long else [])
    print(f"controller {args.controller}; peaks in MB (anon: RssAnon, file: RssFile)")
    print(
        f"{'run':>18} {'outputs':>14} {'steps':>9} {'anon':>6} {'file':>6} {'hwm':>7} {'wall s':>7}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for duration_s, period_s in cases:
            scenario = Path(tmp) / f"long_{duration_s:g}.toml"
            scenario.write_text(SCENARIO.format(duration_s=duration_s))
            base = [*fuzzynav, "run", str(scenario), "--controller", args.controller]
            base += ["--dt", str(period_s)]
            outputs = {
                "none": [],
                "--rrd --trace": ["--rrd", f"{tmp}/run.rrd", "--trace", f"{tmp}/run.csv"],
            }
            for label, extra in outputs.items():
                row = peak_memory_mb(base + extra)
                print(
                    f"{f'{duration_s:g} s at {period_s * 1000:g} ms':>18} {label:>14} "
                    f"{round(duration_s / period_s):>9} {row['anon']:>6.0f} {row['file']:>6.0f} "
                    f"{row['hwm']:>7.0f} {row['wall_s']:>7.1f}",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
