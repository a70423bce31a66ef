"""The readings table again, the done bounds counted first, with one budget for every
reading (issue 35).

The readings table (``scripts/paper_readings.py``, docs/data/paper_readings.json) fitted
each reading with the fit's own cost, whose penalty on a bound is capped; only the
selected reading was then searched further, with the done bounds counted first
(``--force count``, which took it from 28 to 30 bounds). Whether another reading would
have done better with the same treatment is what this script asks. For each reading,
from its readings-table vector, two stages of ``paper_readings.py``:

1. ``--force count --force bounds --force chatter --screen 0 --sigma 0.15 --maxiter 40
   --seed 21 --dt 0.02``
2. the same from stage 1's vector, ``--sigma 0.08 --maxiter 30 --seed 22``

each judged on the pymunk engine at 0.02 s against the 36 done bounds. The selection
rule is the readings table's (most bounds met, then the smaller worst residual, then the
smaller fit cost), applied to the stage-2 results.

    .venv/bin/python scripts/paper_readings_count.py \\
        --json docs/data/paper_readings_count.json [--only 0,2] [--workers 2]

History: this script made data for docs/paper-controller.md's history section (the rule
bases shipped until 2026-12-06). The layout's angle numbers, the done bounds and
``paper_readings.py``'s readings have changed since, so it reproduces those data only
from the commit that made them (git log of the data file); it is kept for that.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import paper_readings  # noqa: E402  (the script beside this one)

from fuzzynav.app.experiments import paper_fit  # noqa: E402
from fuzzynav.safe_files import write_text_atomically  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TABLE = ROOT / "docs" / "data" / "paper_readings.json"
FORCE = ["--force", "count", "--force", "bounds", "--force", "chatter"]
STAGES = (  # (sigma, generations, seed) of each stage, at 0.02 s, 16 a generation
    (0.15, 40, 21),
    (0.08, 30, 22),
)


def stage_arguments(index: int, x0: list[float], stage: int, out: Path) -> list[str]:
    sigma, generations, seed = STAGES[stage]
    return [
        "--only", str(index), "--x0=" + ",".join(repr(float(v)) for v in x0), *FORCE,
        "--screen", "0", "--sigma", str(sigma), "--maxiter", str(generations),
        "--seed", str(seed), "--dt", "0.02", "--json", str(out),
    ]  # fmt: skip


def staged(index: int) -> dict:
    """Both stages for one reading, from its readings-table vector; the judged result of
    each stage (``paper_readings.py``'s own JSON row)."""
    start = json.loads(TABLE.read_text())["results"][index]
    x0, stages = start["vector"], []
    with tempfile.TemporaryDirectory() as folder:
        for stage in range(len(STAGES)):
            out = Path(folder) / f"stage{stage}.json"
            with contextlib.redirect_stdout(io.StringIO()):
                paper_readings.main(stage_arguments(index, x0, stage, out))
            row = json.loads(out.read_text())["results"][0]
            print(f"reading {index} stage {stage + 1}: {row['bounds_met']}/36", flush=True)
            stages.append(row)
            x0 = row["vector"]
    return {
        "index": index,
        "reading": start["reading"],
        "table_bounds_met": start["bounds_met"],
        "stages": stages,
        **{k: stages[-1][k] for k in ("vector", "fit_cost", "bounds_met", "worst_scaled")},
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--json", type=Path, required=True)
    p.add_argument("--only", type=str, default=None, help="comma-separated reading indices 0-7")
    p.add_argument("--workers", type=int, default=2)
    args = p.parse_args(argv)
    picked = (
        range(len(paper_readings.READINGS))
        if args.only is None
        else [int(k) for k in args.only.split(",")]
    )
    with ProcessPoolExecutor(args.workers) as pool:
        results = sorted(pool.map(staged, picked), key=lambda r: r["index"])
    budget = {"start": "docs/data/paper_readings.json", "stages": STAGES, "force": FORCE[1::2]}
    text = json.dumps({"budget": budget, "results": results}, indent=1) + "\n"
    write_text_atomically(args.json, text)
    print("selected:", paper_fit.select_reading(results)["reading"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
