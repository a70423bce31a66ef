"""What the paper's numbers pin down: the fit's cost with each design number moved +-10 %.

For the shipped rule base's 12 numbers (its ``# tuned vector:`` line), evaluates the
cost of ``fuzzynav fit-paper`` (app/experiments/paper_fit.py, the same options as the shipped file's
command: 0.02 s control period, ``--husky --husky-perception ideal --husky-weight 10``) at the fitted vector and with one
number at a time multiplied by 0.9 and 1.1 (clipped to its bounds, so the design rules
still hold: a clipped step says so). A number whose moves barely change the cost is one
the paper's results leave free. Writes a JSON file and prints a Markdown table.

    .venv/bin/python scripts/paper_profiles.py [--workers 2 | --workers 0 (batch engine)] [--out docs/data/paper_profiles.json]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
from pathlib import Path

import numpy as np

from fuzzynav.app.experiments.paper_fit import FitCost, read_fitted
from fuzzynav.controller.paper import PAPER_RULES
from fuzzynav.controller.paper_design import PaperDesignTunable

STEP = 0.10


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rules", type=Path, default=PAPER_RULES)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--dt", type=float, default=0.02)
    parser.add_argument("--no-husky", action="store_true")
    parser.add_argument("--husky-perception", default="ideal")
    parser.add_argument("--husky-weight", type=float, default=10.0)
    parser.add_argument("--out", type=Path, default=Path("docs/data/paper_profiles.json"))
    args = parser.parse_args()
    tunable = PaperDesignTunable()
    names = tunable.parameter_names()
    lo, hi = np.array(tunable.bounds()).T
    x = read_fitted(args.rules)
    vectors, labels = [x], [("fitted", "", 1.0)]
    for k, name in enumerate(names):
        for factor in (1.0 - STEP, 1.0 + STEP):
            v = x.copy()
            v[k] = float(np.clip(x[k] * factor, lo[k], hi[k]))
            vectors.append(v)
            labels.append((name, "clipped" if v[k] != x[k] * factor else "", v[k]))
    cost = FitCost(
        args.dt,
        husky=not args.no_husky,
        husky_perception=tuple(args.husky_perception.split(",")),
        husky_weight=args.husky_weight,
    )
    if args.workers == 0:  # the batch engine, one process (the costs equal pymunk's)
        from fuzzynav.app.experiments.batch_runs import fit_costs

        values = fit_costs(cost, vectors)
    else:
        with multiprocessing.get_context("spawn").Pool(args.workers) as pool:
            values = pool.map(cost, vectors)
    base = values[0]
    rows = []
    print(f"fitted cost {base:.3f}\n")
    print("| number | fitted | cost at -10 % | cost at +10 % | largest rise |")
    print("|---|---|---|---|---|")
    for k, name in enumerate(names):
        down, up = values[1 + 2 * k], values[2 + 2 * k]
        notes = [labels[1 + 2 * k][1], labels[2 + 2 * k][1]]
        rise = max(down, up) - base
        rows.append(
            {
                "name": name,
                "fitted": float(x[k]),
                "minus_10pct": {"value": labels[1 + 2 * k][2], "cost": down, "note": notes[0]},
                "plus_10pct": {"value": labels[2 + 2 * k][2], "cost": up, "note": notes[1]},
                "largest_rise": rise,
            }
        )
        print(
            f"| {name} | {x[k]:.4g} | {down:.1f}{' (clipped)' if notes[0] else ''} "
            f"| {up:.1f}{' (clipped)' if notes[1] else ''} | {rise:+.1f} |"
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(
        json.dumps(
            {
                "rules": args.rules.name,
                "dt_s": args.dt,
                "husky_perception": None if args.no_husky else args.husky_perception,
                "fitted_cost": base,
                "profiles": rows,
            },
            indent=1,
        )
        + "\n",
        encoding="utf-8",
    )
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
