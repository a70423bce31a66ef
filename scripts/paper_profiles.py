"""What the paper's results pin down: each design number of the shipped paper rule base
moved by -10 % and +10 %, the others fixed.

For each move, s1-s3 run in the paper's geometry at the loop's 0.02 s (the batch engine,
whose runs equal pymunk's) and are held to the done bounds
(:func:`app.experiments.paper_docs.bound_checks`); the fit's cost is given beside. A number
whose moves keep the bounds met and barely change the cost is one the paper's results
leave free; a step past a bound of the layout is clipped to it (the design rules still
hold) and said so. Writes ``docs/data/paper_profiles.json``; ``scripts/paper_check.py``
renders it into docs/paper-controller.md.

    .venv/bin/python scripts/paper_profiles.py
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from fuzzynav.app.experiments.paper_docs import profiles

OUT = Path(__file__).resolve().parents[1] / "docs" / "data" / "paper_profiles.json"


def main() -> int:
    data = profiles()
    OUT.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    for row in data["profiles"]:
        print(row["name"], row["minus_10pct"]["bounds_met"], row["plus_10pct"]["bounds_met"])
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
