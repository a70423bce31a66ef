"""A sweep into a table: two controllers on the same seeded random layouts, summarised
per controller (success rate, median path ratio, median clearance) and written as CSV.

It shows :func:`fuzzynav.sweep`, which returns one plain dict per run (the rows that
``fuzzynav sweep --out`` writes), so any table tool (csv, pandas, a spreadsheet) takes
them as they are.

Run it: ``python examples/sweep_table.py --n 20 --out sweep.csv``
"""

from __future__ import annotations

import argparse
import csv
import statistics
from pathlib import Path

import fuzzynav


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=20, help="layouts per controller")
    parser.add_argument("--seed", type=int, default=5, help="the layouts' seed")
    parser.add_argument("--controllers", default="paper,p", help="comma-separated names")
    parser.add_argument("--out", type=Path, default=Path("sweep.csv"), help="CSV of every run")
    args = parser.parse_args(argv)

    rows = []
    for name in args.controllers.split(","):
        rows += fuzzynav.sweep(name, n=args.n, seed=args.seed, family="standard")

    summary = {}
    print(f"{'controller':<12}{'success':>9}{'path / shortest':>17}{'clearance m':>13}")
    for name in args.controllers.split(","):
        mine = [r for r in rows if r["controller"] == name]
        ok = [r for r in mine if r["success"]]
        ratio = statistics.median(r["path_ratio"] for r in ok) if ok else float("nan")
        clearance = statistics.median(r["min_clearance_m"] for r in mine)
        summary[name] = {"success_rate": len(ok) / len(mine), "median_path_ratio": ratio}
        print(f"{name:<12}{len(ok) / len(mine):>9.0%}{ratio:>17.3f}{clearance:>13.3f}")

    columns = [
        "controller",
        "index",
        "outcome",
        "success",
        "path_length_m",
        "path_ratio",
        "min_clearance_m",
        "time_to_target_s",
        "n_obstacles",
    ]
    with args.out.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    print(f"{len(rows)} runs written to {args.out}")
    return {"rows": rows, "summary": summary, "csv": args.out}


if __name__ == "__main__":
    main()
