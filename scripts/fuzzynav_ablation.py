"""What each part of fuzzynav buys: the shipped controller, then each part switched off in
turn (``assets/rules/fuzzynav_parts.toml``), on the same seeded random layouts of
every family, in both perception modes. Prints a table of success rates (reached without
collision) and draws ``docs/img/fuzzynav_ablation.png``: one row per ablation, one column
per family and perception mode, each cell the success rate and its change from shipped.

    .venv/bin/python scripts/fuzzynav_ablation.py [--seed 59] [--n 200] [--n-hard 100]
        [--n-jitter 48] [--executor serial|local|dask] [--workers N] [--scheduler ADDRESS]
        [--runs RUNS.jsonl [--resume]] [--out docs/img/fuzzynav_ablation.png] [--json OUT]
    .venv/bin/python scripts/fuzzynav_ablation.py --from-json docs/data/fuzzynav_ablation_seed59.json

The first form runs (about 30 minutes on 2 cores for the defaults); the second redraws the
figure and the table from counts written before.

An ablation describes; it chooses nothing. Seed 59 was fresh when this was first run.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from fuzzynav.app.experiments.executor import add_executor_options
from fuzzynav.app.experiments.studies import (
    SAFE_CLEARANCE_M,
    LayoutJob,
    StudyInterrupted,
    run_study,
)
from fuzzynav.controller.navigator.parts import load_parts
from fuzzynav.world.layouts import FAMILIES

ROOT = Path(__file__).resolve().parents[1]

MODES = ("ideal", "ultrasonic")


def versions(parts) -> list[dict]:
    """The shipped controller, then one version per part with that part switched off."""
    return [{"name": "shipped", "off": None, "what": "the shipped controller"}] + [
        {"name": f"no {p.name}", "off": p.name, "what": p.what} for p in parts
    ]


def outcome(k: int, row: dict) -> tuple:
    """(version index, family, mode, ok, safe, collided, timeout) of a sweep row, judged as
    `fuzzynav sweep --off` judges it (the row is the sweep's own: app.experiments.studies)."""
    ok = row["success"]
    clearance = row["min_clearance_m"]
    return (
        k,
        row["family"],
        row["perception"],
        ok,
        ok and (clearance is None or clearance >= SAFE_CLEARANCE_M),
        row["collided"],
        row["outcome"] == "timeout",
    )


def tally(rows, n_ablations: int, sizes: dict[str, int]) -> dict:
    """Counts per (ablation, family, mode): n, ok, safe, collided, timeout."""
    out = {
        (k, f, m): {"n": 0, "ok": 0, "safe": 0, "collided": 0, "timeout": 0}
        for k in range(n_ablations)
        for f in sizes
        for m in MODES
    }
    for k, family, mode, ok, safe, collided, timeout in rows:
        cell = out[(k, family, mode)]
        cell["n"] += 1
        cell["ok"] += ok
        cell["safe"] += safe
        cell["collided"] += collided
        cell["timeout"] += timeout
    return out


def draw(ablations, counts, sizes, out: Path, seed: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    columns = [(f, m) for f in sizes for m in MODES]
    rate = np.array(
        [
            [100.0 * counts[(k, f, m)]["ok"] / counts[(k, f, m)]["n"] for f, m in columns]
            for k in range(len(ablations))
        ]
    )
    delta = rate - rate[0]
    fig, ax = plt.subplots(figsize=(1.05 * len(columns) + 3.2, 0.42 * len(ablations) + 1.6))
    limit = max(10.0, float(np.abs(delta).max()))
    ax.imshow(delta, cmap="RdBu", vmin=-limit, vmax=limit, aspect="auto")
    for i in range(len(ablations)):
        for j in range(len(columns)):
            text = f"{rate[i, j]:.0f}" if i == 0 else f"{rate[i, j]:.0f}\n({delta[i, j]:+.0f})"
            ax.text(
                j,
                i,
                text,
                ha="center",
                va="center",
                fontsize=7,
                color="white" if abs(delta[i, j]) > 0.6 * limit else "black",
            )
    ax.set_xticks(range(len(columns)), [f"{f}\n{m} (n={sizes[f]})" for f, m in columns], fontsize=7)
    ax.set_yticks(range(len(ablations)), [a["name"] for a in ablations], fontsize=8)
    ax.set_title(
        f"fuzzynav with one part switched off: reached without collision, % "
        f"(change from shipped), seed {seed}",
        fontsize=9,
    )
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=59)
    parser.add_argument("--n", type=int, default=200, help="standard layouts")
    parser.add_argument(
        "--n-hard", type=int, default=100, help="clutter, u_trap, two_moving layouts each"
    )
    parser.add_argument(
        "--n-jitter", type=int, default=48, help="paper_jitter copies (a third per scenario)"
    )
    add_executor_options(parser)
    parser.add_argument(
        "--runs",
        dest="out_runs",
        type=Path,
        default=None,
        metavar="PATH.jsonl",
        help="write every run as one JSON line as it finishes (as `sweep --out`)",
    )
    parser.add_argument(
        "--resume", action="store_true", help="go on with the --runs file: its runs are kept"
    )
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "img" / "fuzzynav_ablation.png")
    parser.add_argument("--json", type=Path, default=None, help="also write the counts as JSON")
    parser.add_argument(
        "--from-json",
        type=Path,
        default=None,
        metavar="JSON",
        help="draw the figure and print the table from counts written before "
        "(docs/data/fuzzynav_ablation_seed59.json), without running",
    )
    args = parser.parse_args(argv)
    if args.from_json is not None:
        ablations, counts, sizes, seed = read_counts(args.from_json)
        print_table(ablations, counts, sizes, seed)
        draw(ablations, counts, sizes, args.out, seed)
        print(f"wrote {args.out}")
        return 0
    ablations = versions(load_parts())
    sizes = {
        f: (args.n if f == "standard" else args.n_jitter if f == "paper_jitter" else args.n_hard)
        for f in FAMILIES
    }
    sizes = {f: n for f, n in sizes.items() if n > 0}
    jobs = [
        LayoutJob(f, args.seed, i, "fuzzynav", m, (a["off"],) if a["off"] else ())
        for a in ablations
        for f, n in sizes.items()
        for m in MODES
        for i in range(n)
    ]
    version_of = {a["off"]: k for k, a in enumerate(ablations)}
    study = argparse.Namespace(
        executor=args.executor,
        workers=args.workers,
        scheduler=args.scheduler,
        out=args.out_runs,
        resume=args.resume,
    )
    from fuzzynav.app.cli import UsageError

    try:
        found, _ = run_study(
            jobs, study, f"{len(ablations)} versions x {len(jobs) // len(ablations)} runs", False
        )
    except StudyInterrupted:
        return 130
    except (UsageError, ValueError) as exc:
        print(f"fuzzynav_ablation: error: {exc}", file=sys.stderr)
        return 2
    rows = [outcome(version_of[r["parts_off"][0] if r["parts_off"] else None], r) for r in found]
    counts = tally(rows, len(ablations), sizes)
    print_table(ablations, counts, sizes, args.seed)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(
            json.dumps(
                {
                    "seed": args.seed,
                    "sizes": sizes,
                    "ablations": [
                        {
                            "name": a["name"],
                            "what": a["what"],
                            "part_off": a["off"],
                            "counts": {f"{f}/{m}": counts[(k, f, m)] for f in sizes for m in MODES},
                        }
                        for k, a in enumerate(ablations)
                    ],
                },
                indent=1,
            )
        )
    draw(ablations, counts, sizes, args.out, args.seed)
    print(f"wrote {args.out}")
    return 0


def read_counts(path: Path):
    """(versions, counts, sizes, seed) from a file written by ``--json``."""
    data = json.loads(Path(path).read_text())
    ablations = [
        {"name": a["name"], "off": a["part_off"], "what": a["what"]} for a in data["ablations"]
    ]
    counts = {}
    for k, a in enumerate(data["ablations"]):
        for key, cell in a["counts"].items():
            family, mode = key.split("/")
            counts[(k, family, mode)] = cell
    return ablations, counts, dict(data["sizes"]), data["seed"]


def print_table(ablations, counts, sizes, seed) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(
        title=f"fuzzynav ablations, seed {seed}: reached without collision "
        f"(ideal / ultrasonic), change from shipped"
    )
    table.add_column("switched off")
    for f in sizes:
        table.add_column(f"{f} (n={sizes[f]})", justify="right")
    for k, a in enumerate(ablations):
        cells = []
        for f in sizes:
            parts = []
            for m in MODES:
                ok = counts[(k, f, m)]["ok"]
                parts.append(f"{ok}" if k == 0 else f"{ok} ({ok - counts[(0, f, m)]['ok']:+d})")
            cells.append(" / ".join(parts))
        table.add_row(a["name"], *cells)
    Console().print(table)


if __name__ == "__main__":
    sys.exit(main())
