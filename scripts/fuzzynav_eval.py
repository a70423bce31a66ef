"""Evaluate fuzzynav (or any registry controller) on s1-s3 and on seeded layout families.

.venv/bin/python scripts/fuzzynav_eval.py --scenarios
.venv/bin/python scripts/fuzzynav_eval.py --family standard --n 500 --seed 2 --perception ultrasonic --jobs 2
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from fuzzynav.world.layouts import generate_layout
from fuzzynav.world.scenario import load_scenario
from fuzzynav.world.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]


def make(name, vector=None):
    if name == "fuzzynav" and vector is not None:
        from fuzzynav.controller.navigator.tuning import tunable

        return tunable().build(vector)
    from fuzzynav.controller.registry import make_controller

    return make_controller(name)


def run_one(args):
    family, seed, index, perception, controller, vector = args
    sc = (
        load_scenario(family)
        if family in ("s1", "s2", "s3")
        else generate_layout(family, seed, index)
    )
    sim = Simulation(sc, make(controller, vector), perception=perception, seed=0)
    r = sim.run()
    m = r.metrics
    return {
        "family": family,
        "index": index,
        "outcome": r.outcome,
        "collided": r.collided,
        "path_length_m": m["path_length_m"],
        "min_clearance_m": m["min_clearance_m"],
        "time_s": m["time_to_target_s"],
        "wall_s": r.wall_time_s,
    }


def summarise(rows):
    n = len(rows)
    ok = sum(r["outcome"] == "reached" and not r["collided"] for r in rows)
    col = sum(r["collided"] for r in rows)
    to = sum(r["outcome"] == "timeout" for r in rows)
    safe = sum(
        r["outcome"] == "reached" and not r["collided"] and (r["min_clearance_m"] or 9) >= 0.25
        for r in rows
    )
    return {
        "n": n,
        "success": ok / n,
        "collided": col,
        "timeout": to,
        "success_clear_0.25": safe / n,
    }


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenarios", action="store_true")
    ap.add_argument("--family", default="standard")
    ap.add_argument("--n", type=int, default=50)
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--perception", default="both")
    ap.add_argument("--controller", default="fuzzynav")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--fails", action="store_true")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    modes = ["ideal", "ultrasonic"] if a.perception == "both" else [a.perception]
    out = {}
    t0 = time.time()
    with ProcessPoolExecutor(min(a.jobs, 2)) as ex:
        for mode in modes:
            if a.scenarios:
                rows = list(
                    ex.map(
                        run_one, [(s, 0, 0, mode, a.controller, None) for s in ("s1", "s2", "s3")]
                    )
                )
                for r in rows:
                    print(
                        mode,
                        r["family"],
                        r["outcome"],
                        "collided" if r["collided"] else "",
                        f"path {r['path_length_m']:.3f} clear {r['min_clearance_m']:.3f} t {r['time_s']}",
                    )
                out[mode] = rows
            else:
                rows = list(
                    ex.map(
                        run_one,
                        [(a.family, a.seed, i, mode, a.controller, None) for i in range(a.n)],
                        chunksize=4,
                    )
                )
                s = summarise(rows)
                print(a.family, "seed", a.seed, mode, s)
                if a.fails:
                    for r in rows:
                        if r["outcome"] != "reached" or r["collided"]:
                            print(
                                "   fail",
                                r["index"],
                                r["outcome"],
                                f"clear {r['min_clearance_m']:.3f}",
                            )
                out[mode] = s
    print(f"wall {time.time() - t0:.0f} s", file=sys.stderr)
    if a.json:
        print(json.dumps(out))


if __name__ == "__main__":
    main()
