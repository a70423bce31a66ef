"""What a rerun recording adds to a run's wall time (issue 4 allows at most +50 %).

For scenario s1 and each controller, repeated and interleaved: the wall time of a run
(build the simulation and run it to its end) and of ``record_run`` on its result
(open the file, send the columns, metadata and layout, close the file); the overhead is
median(record) / median(run), in wall time (the budget) and in CPU time of all threads
(rerun encodes and writes in background threads). ``LiveRecorder`` (the viewer's chunked mode) is timed the
same way, as run-with-live-recording against run. Once-per-process costs (importing
rerun, reading package versions and the git revision) are paid before the timing and
reported apart.

Controllers: ``p`` (obstacle-blind, it collides after 13.5 s of simulated time, so its
run is short and the recording's fixed costs weigh most), the fuzzy one: the
``paper`` controller if it is installed, otherwise the paper's rule base
(assets/rules/paper.toml) driven directly by the fuzzy engine, and ``fuzzynav``, whose
recording also plots its inner state (from the decisions it logged as it drove).

Run: ``.venv/bin/python bench/bench_recording.py [--repeats N] [--check] [--json PATH]``
(``--check``: exit status 1 when an overhead exceeds 50 %; ``--json``: the medians, the
load average before and after and the versions, for a doc to quote:
``docs/data/recording_overhead.json`` is what docs/recordings.md states, checked by
``tests/test_recording_marks.py``).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

BUDGET = 0.50


def import_time_s() -> float:
    code = "import time; t = time.perf_counter(); import rerun; print(time.perf_counter() - t)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.strip())


def fuzzy_controller_factory():
    """(label, factory) of the fuzzy controller to time, or None."""
    from fuzzynav.controller.registry import controller_names, make_controller

    if "paper" in controller_names():
        return "paper", lambda: make_controller("paper")
    try:
        from fuzzynav.controller.rulebase import read_toml
        from fuzzynav.world.scenario import ASSETS_DIR
    except ImportError:
        return None
    fis = read_toml(ASSETS_DIR / "rules" / "paper.toml")

    class PaperRuleBase:
        name = "paper.toml (engine only)"

        def __init__(self):
            self.fis = fis

        def reset(self):
            pass

        def __call__(self, inputs):
            return self.fis.evaluate_one(inputs)

    return "paper.toml via the engine", PaperRuleBase


def time_controller(label, factory, repeats: int, out_dir: Path) -> dict:
    from fuzzynav.app.recordings.live import LiveRecorder
    from fuzzynav.app.recordings.record import record_simulation
    from fuzzynav.app.runs import build_simulation

    runs, records, lives, rows = [], [], [], 0
    clocks = (time.perf_counter, time.process_time)  # wall; CPU of all threads
    for k in range(repeats):
        started = [c() for c in clocks]
        sim = build_simulation("s1", controller_object=factory())
        result = sim.run()
        runs.append([c() - s for c, s in zip(clocks, started)])
        rows = len(result.log)

        started = [c() for c in clocks]
        record_simulation(sim, result, out_dir / f"{k}.rrd")
        records.append([c() - s for c, s in zip(clocks, started)])

        started = [c() for c in clocks]
        sim = build_simulation("s1", controller_object=factory())
        live = LiveRecorder(out_dir / f"live{k}.rrd")
        while not sim.done:
            sim.step()
            live.update(sim)
        live.close(sim)
        lives.append([c() - s for c, s in zip(clocks, started)])

    def median(samples, i):
        return statistics.median(s[i] for s in samples)

    out = {"label": label, "rows": rows, "outcome": result.outcome}
    for i, clock in enumerate(("wall", "cpu")):
        run, rec, live = median(runs, i), median(records, i), median(lives, i)
        out[clock] = {
            "run": run,
            "record": rec,
            "live": live,
            "overhead": rec / run,
            "live_overhead": live / run - 1.0,
        }
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument(
        "--check", action="store_true", help="exit 1 when an overhead exceeds the 50 %% budget"
    )
    parser.add_argument("--json", type=Path, default=None, help="write the medians here")
    args = parser.parse_args(argv)
    load_before = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")

    imported = import_time_s()
    from fuzzynav.app.provenance import package_versions
    from fuzzynav.app.recordings.record import record_run
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.controller.proportional import ProportionalController

    with tempfile.TemporaryDirectory() as tmp:
        out_dir = Path(tmp)
        # Once-per-process costs, outside the timing.
        started = time.perf_counter()
        package_versions()
        sim = build_simulation("s1", controller_object=ProportionalController())
        record_run(sim.run(), out_dir / "warm.rrd", controller=sim.controller)
        first = time.perf_counter() - started

        rows = [time_controller("p", ProportionalController, args.repeats, out_dir)]
        fuzzy = fuzzy_controller_factory()
        if fuzzy is not None:
            rows.append(time_controller(*fuzzy, max(3, args.repeats // 2), out_dir))
        from fuzzynav.controller.registry import controller_names, make_controller

        if "fuzzynav" in controller_names():
            rows.append(
                time_controller(
                    "fuzzynav",
                    lambda: make_controller("fuzzynav"),
                    max(3, args.repeats // 2),
                    out_dir,
                )
            )

    print(
        f"import rerun: {imported * 1000:.0f} ms; first record_run in a process "
        f"(incl. a run, versions, git): {first * 1000:.0f} ms"
    )
    over = False
    for r in rows:
        w, c = r["wall"], r["cpu"]
        verdict = "within" if w["overhead"] <= BUDGET else "OVER"
        over |= w["overhead"] > BUDGET
        print(
            f"s1, {r['label']}: {r['rows']} rows ({r['outcome']})\n"
            f"  wall: median run {w['run'] * 1000:.0f} ms, record_run "
            f"{w['record'] * 1000:.0f} ms -> +{w['overhead'] * 100:.0f} % ({verdict} the "
            f"+{BUDGET * 100:.0f} % budget); run with LiveRecorder "
            f"{w['live'] * 1000:.0f} ms (+{w['live_overhead'] * 100:.0f} %)\n"
            f"  CPU (all threads): run {c['run'] * 1000:.0f} ms, record_run "
            f"{c['record'] * 1000:.0f} ms -> +{c['overhead'] * 100:.0f} %; with LiveRecorder "
            f"+{c['live_overhead'] * 100:.0f} %"
        )
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"(load average {load:.1f} on {os.cpu_count()} CPUs: timings swing with the "
        f"machine's load; rerun writes from background threads, which a busy machine "
        f"slows most)"
    )
    if args.json is not None:
        import rerun

        args.json.write_text(
            json.dumps(
                {
                    "bench": "bench/bench_recording.py",
                    "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
                    "repeats": args.repeats,
                    "load_average": [round(load_before, 2), round(load, 2)],
                    "cpus": os.cpu_count(),
                    "rerun_sdk": rerun.__version__,
                    "budget": BUDGET,
                    "import_rerun_ms": round(imported * 1000, 1),
                    "controllers": rows,
                },
                indent=1,
            )
            + "\n"
        )
    return 1 if (args.check and over) else 0


if __name__ == "__main__":
    sys.exit(main())
