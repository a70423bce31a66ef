"""Does the paper's controller generalise? Held-out layouts, reported, never tuned to.

Both shipped rule bases of the paper's controller on ``--n`` layouts of the standard
family, seed ``--seed`` (5: held out, never used by any fit): ``paper.toml`` in the
paper's geometry (a point robot, ideal perception), its Husky twin ``paper_husky.toml``
in the Husky's geometry with ideal perception and with the sonars (ideal perception
senses the shipped reading's field, s1-s3's, unless ``--field-of-view``);
fuzzynav's navigator beside it in the Husky geometry (its own sensing, within the
budget). Each run is given 4x its layout's time budget; its outcome within the budget
itself is read off the same run (the runs are deterministic: a run that arrives by the
budget's end arrives then; one that collides before it, collided). Each failure within
the budget is classified by what the same run did with 4x the budget: it collides, it
arrives (slow), or it never arrives (stuck or orbiting).

    .venv/bin/python scripts/paper_generalise.py --json docs/data/paper_generalise.json \\
        [--n 500 --seed 5] [--fuzzynav-n 500 | --keep-fuzzynav]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

from fuzzynav.controller.batch import batch_controller
from fuzzynav.controller.paper import RULES_BY_GEOMETRY, paper_controller
from fuzzynav.safe_files import write_text_atomically
from fuzzynav.world.batch import run_batch
from fuzzynav.world.layouts import generate_layouts

BUDGET_FACTOR = 4.0
SAFE_DISTANCE_M = 0.25  # the paper's safe distance (footprint in the Husky geometry)
MODES = [("paper", "ideal"), ("husky", "ideal"), ("husky", "ultrasonic")]


def rule_base_digest(path: Path) -> str:
    """sha256 of a rule base's content (its TOML parsed, keys sorted): its comments and
    layout may change without making the runs stale, any number or name may not."""
    content = tomllib.loads(path.read_text(encoding="utf-8"))
    return hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest()


def outcomes(result, layouts, budgets) -> dict:
    """Counts within the budget and within 4x it, and the failures' kinds."""
    within, within4 = (
        {"reached": 0, "collided": 0, "timeout": 0},
        dict.fromkeys(("reached", "collided", "timeout"), 0),
    )
    kinds = {"collided": 0, "slow (arrives within 4x)": 0, "stuck or orbiting": 0}
    safe, safe4 = 0, 0
    for i, budget in enumerate(budgets):
        m = result.metrics(i)
        reached, collided = bool(m["reached"]), bool(m["collided"])
        end = float(result.sim_time_s[i])
        long = "reached" if reached and not collided else "collided" if collided else "timeout"
        within4[long] += 1
        if reached and not collided and float(m["time_to_target_s"]) <= budget:
            short = "reached"
        elif collided and end <= budget:
            short = "collided"
        else:
            short = "timeout"
        within[short] += 1
        clear = float(result.min_safety_distance_m[i]) >= SAFE_DISTANCE_M
        safe += short == "reached" and clear
        safe4 += long == "reached" and clear
        if short != "reached":
            if long == "collided":
                kinds["collided"] += 1
            elif long == "reached":
                kinds["slow (arrives within 4x)"] += 1
            else:
                kinds["stuck or orbiting"] += 1
    n = len(budgets)
    return {
        "n": n,
        "reached_pct": 100.0 * within["reached"] / n,
        "reached_4x_pct": 100.0 * within4["reached"] / n,
        "reached_safely_pct": 100.0 * safe / n,
        "reached_safely_4x_pct": 100.0 * safe4 / n,
        "within_budget": within,
        "within_4x_budget": within4,
        "failures_within_budget": kinds,
    }


def paper_modes(layouts, field_of_view_deg: float) -> list[dict]:
    budgets = [s.duration_s for s in layouts]
    longer = [
        s.replace(duration_s=BUDGET_FACTOR * s.duration_s, field_of_view_deg=field_of_view_deg)
        for s in layouts
    ]
    out = []
    for geometry, perception in MODES:
        started = time.perf_counter()
        controller = paper_controller(geometry=geometry)
        result = run_batch(
            longer,
            batch_controller([controller]),
            perception=perception,
            geometry=geometry,
            seeds=0,
        )
        row = {
            "controller": "paper",
            "rule_base": RULES_BY_GEOMETRY[geometry].name,
            # which rule base's runs these are: tests/test_paper_docs.py finds the data
            # stale when the shipped one is no longer this one
            "rule_base_sha256": rule_base_digest(RULES_BY_GEOMETRY[geometry]),
            "geometry": geometry,
            "perception": perception
            + (f", front {field_of_view_deg:g} deg" if perception == "ideal" else ""),
            **outcomes(result, layouts, budgets),
            "wall_s": round(time.perf_counter() - started, 1),
        }
        print(json.dumps({k: row[k] for k in row if k != "within_4x_budget"}), flush=True)
        out.append(row)
    return out


def fuzzynav_modes(layouts, n: int) -> list[dict]:
    """fuzzynav's navigator (pymunk: it keeps a memory), within the budget only."""
    from fuzzynav.app.experiments.sweep import sweep

    out = []
    for perception in ("ideal", "ultrasonic"):
        started = time.perf_counter()
        summary = sweep("fuzzynav", n, SEED, "standard", perception)
        out.append(
            {
                "controller": "fuzzynav",
                "geometry": "husky",
                "perception": perception,
                "n": n,
                "reached_pct": 100.0 * summary["success_rate"],
                "reached_safely_pct": 100.0 * summary["safe_success_rate"],
                "wall_s": round(time.perf_counter() - started, 1),
            }
        )
        print(json.dumps(out[-1]), flush=True)
    return out


SEED = 5


def main(argv=None) -> int:
    global SEED
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=500)
    p.add_argument("--seed", type=int, default=5)
    p.add_argument("--fuzzynav-n", type=int, default=0, help="0: leave fuzzynav out")
    p.add_argument("--json", type=Path, required=True)
    p.add_argument(
        "--field-of-view",
        type=float,
        default=None,
        help="what ideal perception senses, degrees (default: s1-s3's, the shipped reading)",
    )
    p.add_argument(
        "--keep-fuzzynav",
        action="store_true",
        help="keep the fuzzynav rows of the existing --json file instead of running them",
    )
    args = p.parse_args(argv)
    SEED = args.seed
    layouts = generate_layouts("standard", args.n, args.seed)
    if args.field_of_view is None:
        from fuzzynav.world.scenario import load_scenario

        args.field_of_view = load_scenario("s1").field_of_view_deg
    rows = paper_modes(layouts, args.field_of_view)
    if args.keep_fuzzynav:
        old = json.loads(args.json.read_text(encoding="utf-8"))
        rows += [r for r in old["rows"] if r["controller"] == "fuzzynav"]
    elif args.fuzzynav_n:
        rows += fuzzynav_modes(layouts, args.fuzzynav_n)
    write_text_atomically(
        args.json,
        json.dumps(
            {"family": "standard", "seed": args.seed, "budget_factor": BUDGET_FACTOR, "rows": rows},
            indent=1,
        )
        + "\n",
    )
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
