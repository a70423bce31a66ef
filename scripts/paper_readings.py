"""Every reading of the paper's text, fitted alike and judged by the paper's results.

The readings (``READINGS``) are the shipped one (start heading 0, Table 1's NONE as the
text has it, the front half-plane) and one change at a time: the field of view (the
sonars' coverage from the robot description, 60, 90, 120 degrees), the metric's horizon
(``fixed``: MAD and RMSE to the scenario's stop time) and the layout the printed ranges
hint at (``clues``); app/experiments/paper_fit.py's ``Reading`` says what each means.
For each, the design numbers are fitted in the paper's geometry alone with the same
budget: ``--screen`` seeded uniform draws of the box, then seeded CMA-ES (``--popsize``
x ``--maxiter``) from the best draw, on the batch engine at ``--dt``, with the
``--force`` costs added. Each best vector is then run on the pymunk engine at the
command line's period (0.02 s, what ``fuzzynav run --trace`` gives) and held to the
done bounds; the best vector of every generation is printed, so a fit cut short is
not lost.

Selection rule (written down before the fits ran, docs/paper-controller.md,
``paper_fit.select_reading``): a rule base that keeps every design rule first; then the
most done bounds met; then the smaller worst scaled residual (the largest |error| /
bound over the numeric bounds); then the smaller fit cost.

    .venv/bin/python scripts/paper_readings.py --json docs/data/paper_readings_behaviour.json \\
        [--only 2] [--screen 96 --popsize 16 --maxiter 25 --seed 1] \\
        [--force count --force bounds --force chatter]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from fuzzynav.app.experiments import paper_fit
from fuzzynav.app.experiments.batch_runs import fit_measures
from fuzzynav.app.experiments.evolution import cmaes
from fuzzynav.app.experiments.paper_docs import MAX_JUMPS, bound_checks
from fuzzynav.controller.design_rules import violations
from fuzzynav.controller.paper_design import PaperDesignTunable
from fuzzynav.safe_files import write_text_atomically

# The shipped reading (start heading 0, NONE as the text has it) and one change at a
# time: the field of view (the front half-plane; the three sonars' coverage from the
# robot description and the US-100's beam; 60, 90, 120 degrees), the metric's horizon (a
# fixed stop time) and the layout the printed ranges hint at.
BASE = paper_fit.Reading(0.0, "unsensed", 180.0)
READINGS = [
    BASE,
    *(
        replace(BASE, field_of_view_deg=fov)
        for fov in (paper_fit.sonar_coverage_deg(), 60, 90, 120)
    ),
    replace(BASE, horizon="fixed"),
    replace(BASE, layout="clues"),
]
FORCE_STORY = ("bounds", "chatter", "count")
CHECK_PERIOD_S = 0.02  # fuzzynav run's own period: the numbers a user recomputes


def fit_reading(reading, args) -> dict:
    """The budgeted search for one reading (module doc); its best vector and cost."""
    tunable = reading.tunable()
    fit = paper_fit.FitCost(args.dt, reading=reading)

    def costs(vectors):
        measured = fit_measures(fit, paper_fit.SCENARIOS, list(vectors), "paper", "ideal")
        return [
            1e6
            if m is None
            else fit.combine([m]) + forced([reading.scored(r) for r in m], args.force)
            for m in measured
        ]

    started = time.perf_counter()
    rng = np.random.default_rng(args.seed)
    bounds = search_bounds(tunable, args.bound)
    lo, hi = np.array(bounds).T
    # the first draw: --x0 if given (a polish of an earlier fit), else the hand layout
    first = tunable.initial_vector() if args.x0 is None else np.asarray(args.x0, float)
    draws = np.vstack([first, lo + rng.random((args.screen, len(lo))) * (hi - lo)])
    screened = []
    for k in range(0, len(draws), 48):
        screened += costs(draws[k : k + 48])
    x0 = draws[int(np.argmin(screened))]

    def report(generation, best_f, best_x, sigma):
        print(
            f"  [{reading.label}] gen {generation}: best {best_f:.1f} "
            f"({time.perf_counter() - started:.0f} s) at {','.join(repr(float(v)) for v in best_x)}",
            flush=True,
        )

    x, best, nit, nfev = cmaes(
        None,
        bounds,
        x0,
        args.sigma,
        args.maxiter,
        args.popsize,
        args.seed,
        lambda _f, xs: costs(xs),
        report,
    )
    if min(screened) < best:
        x, best = x0, min(screened)
    return {
        "vector": [float(v) for v in x],
        "fit_cost": float(best),
        "evaluations": int(len(draws) + nfev),
        "fit_seconds": round(time.perf_counter() - started, 1),
    }


def forced(measured: list[dict], names) -> float:
    """``--force``: an uncapped hinge, 100 per unit, for every numeric done bound
    (``bounds``: the fit's own penalty is flat past 1.3 times a bound), or for the
    jumps over 2 V past the two a run may have (``chatter``), or 1000 for each done
    bound not met (``count``: the bounds counted first), or for one numeric done
    bound by its name (``s1.path``, ten times the weight ``bounds`` gives each): what
    meeting them costs the others."""
    by = {m["scenario"]: m for m in measured}
    cost = 0.0
    if "bounds" in names:  # every numeric done bound, uncapped, with a 10 % margin
        for check in bound_checks(by):
            if check["scaled"] is not None:
                cost += 100.0 * max(0.0, check["scaled"] - 0.9) ** 2
    if "chatter" in names:  # the jumps over 2 V past the two a run may have
        for m in measured:
            cost += 100.0 * max(0, m["chatter_steps"] - MAX_JUMPS) ** 2
    if "count" in names:  # the done bounds counted first: 1000 for each not met
        cost += 1000.0 * sum(not check["met"] for check in bound_checks(by))
    for check in bound_checks(by):  # one numeric bound by name: ten times the weight
        if check["name"] in names and check["scaled"] is not None:
            cost += 1000.0 * max(0.0, check["scaled"] - 0.9) ** 2
    return cost


def numeric_bound_names() -> list[str]:
    """The names of the numeric done bounds (``--force`` accepts each), read off a
    judged run of the hand layout's shape: the checks name themselves."""
    fit = paper_fit.FitCost(0.1, stall_s=None, reading=READINGS[0])
    runs = fit.measure_all(np.asarray(PaperDesignTunable().initial_vector(), float))
    found = bound_checks({m["scenario"]: m for m in runs}, fit.paper)
    return [c["name"] for c in found if c["scaled"] is not None]


def search_bounds(tunable, overrides) -> list[tuple[float, float]]:
    """The layout's bounds with ``--bound NAME=LO:HI`` overrides: an experiment that
    widens the box past a design rule shows whether that rule binds (the vectors it
    finds may break the rule; :func:`judge` names what they break)."""
    names = [p[0] for p in tunable.PARAMETERS]
    bounds = list(tunable.bounds())
    for text in overrides or ():
        name, _, span = text.partition("=")
        if name not in names or ":" not in span:
            raise SystemExit(f"--bound {text!r}: expected NAME=LO:HI, NAME one of {names}")
        lo, hi = (float(v) for v in span.split(":"))
        if not lo < hi:
            raise SystemExit(f"--bound {text!r}: LO must be below HI")
        bounds[names.index(name)] = (lo, hi)
    return bounds


def judge(reading, vector) -> dict:
    fit = paper_fit.FitCost(CHECK_PERIOD_S, stall_s=None, reading=reading)
    runs = [reading.scored(m) for m in fit.measure_all(np.asarray(vector, float))]
    found = bound_checks({m["scenario"]: m for m in runs}, fit.paper)
    numeric = [c["scaled"] for c in found if c["scaled"] is not None]
    summary = {
        m["scenario"]: {
            "reached": m["reached"],
            "collided": m["collided"],
            "time_to_target_s": m["time_to_target_s"],
            "path_length_m": m["path_length_m"],
            "mad_m": m["mad_m"],
            "rmse_m": m["rmse_m"],
            "min_center_distance_m": m["min_center_distance_m"],
            "passes": m["passes"],
            "final_phi_t_rad": m["final_phi_t_rad"],
            "max_voltage_v": m["max_voltage_v"],
            "largest_right_offset_m": m["largest_right_offset_m"],
            "chatter_steps": m["chatter_steps"],
            "approach_speed_ratio": m["approach_speed_ratio"],
        }
        for m in runs
    }
    broken = violations(reading.tunable().system(np.asarray(vector, float)))
    return {
        "design_rules_broken": [str(v) for v in broken],
        "bounds_met": sum(c["met"] for c in found),
        "bounds": len(found),
        "worst_scaled": float(max(numeric)),
        "checks": found,
        "runs": summary,
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--screen", type=int, default=160)
    p.add_argument("--popsize", type=int, default=16)
    p.add_argument("--maxiter", type=int, default=30)
    p.add_argument("--sigma", type=float, default=0.2)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--dt", type=float, default=0.05)
    p.add_argument("--only", type=str, default=None, help="comma-separated reading indices 0-7")
    p.add_argument("--json", type=Path, required=True)
    p.add_argument(
        "--x0",
        type=lambda text: [float(v) for v in text.split(",")],
        default=None,
        help="start from this vector (12 numbers, comma-separated) instead of the hand layout",
    )
    p.add_argument(
        "--bound",
        action="append",
        default=[],
        help="NAME=LO:HI: search this number over another interval (which design rule binds)",
    )
    p.add_argument(
        "--force",
        action="append",
        default=[],
        help="add an uncapped cost for this story bound (what meeting it costs the others): "
        f"one of {', '.join(FORCE_STORY)} or a numeric bound's name (s1.path, ...)",
    )
    args = p.parse_args(argv)
    for name in args.force:
        if name not in FORCE_STORY and name not in numeric_bound_names():
            p.error(f"--force {name!r}: not one of {FORCE_STORY} nor a numeric bound's name")
    picked = range(len(READINGS)) if args.only is None else [int(k) for k in args.only.split(",")]
    results = []
    for k in picked:
        reading = READINGS[k]
        print(f"reading {k}: {reading.label}", flush=True)
        found = {"index": k, "reading": reading.label, **fit_reading(reading, args)}
        found.update(judge(reading, found["vector"]))
        print(
            f"reading {k}: {found['bounds_met']}/{found['bounds']} bounds, worst "
            f"{found['worst_scaled']:.2f}, cost {found['fit_cost']:.1f}",
            flush=True,
        )
        results.append(found)
    budget = {
        k: getattr(args, k)
        for k in ("screen", "popsize", "maxiter", "sigma", "seed", "dt", "x0", "bound", "force")
    }
    text = json.dumps({"budget": budget, "results": results}, indent=1) + "\n"
    write_text_atomically(args.json, text)  # whole or not at all, after the fits
    print("selected:", paper_fit.select_reading(results)["reading"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
