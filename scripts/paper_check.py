"""The shipped paper controller against the paper and issue 35's bounds, written into
the docs.

Runs s1-s3 as ``fuzzynav run sN --controller paper`` does (the paper's geometry with
``rules/paper.toml``; the Husky's with its twin ``rules/paper_husky.toml``, ideal and
ultrasonic, at the loop's 0.02 s), writes the measures to
``docs/data/paper_controller.json`` and the generated blocks of
``docs/paper-controller.md`` (with the readings table of
``docs/data/paper_readings.json`` and the held-out layouts of
``docs/data/paper_generalise.json``). ``tests/test_paper_docs.py`` checks that the page,
the data and the rule bases agree. About 9 runs (half a minute on a free core).

    .venv/bin/python scripts/paper_check.py [--check]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from fuzzynav.app.experiments import paper_docs

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "docs" / "data"
PAGE = ROOT / "docs" / "paper-controller.md"
README = ROOT / "README.md"


def run_compare() -> dict:
    """``fuzzynav compare --json`` in both perception modes (100 held-out layouts)."""
    import subprocess

    out = {}
    for perception in ("ideal", "ultrasonic"):
        text = subprocess.run(
            [
                sys.executable,
                "-m",
                "fuzzynav.app.cli",
                "compare",
                "--json",
                "--perception",
                perception,
            ],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        data = json.loads(text)
        out[perception] = {"controllers": data["controllers"], "sweeps": data["sweeps"]}
    return out


def load(name: str):
    path = DATA / name
    return json.loads(path.read_text(encoding="utf-8")) if path.exists() else None


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--check", action="store_true", help="only say whether the page is current")
    p.add_argument(
        "--compare", action="store_true", help="also run fuzzynav compare for the README's table"
    )
    args = p.parse_args(argv)
    data = paper_docs.shipped_runs()
    blocks = paper_docs.blocks(
        data,
        load("paper_readings.json"),
        load("paper_generalise.json"),
        load("paper_profiles.json"),
        load("paper_binds.json"),
        load("paper_twin_binds.json"),
        load("paper_readings_count.json"),
        load("paper_readings_behaviour.json"),
    )
    text = PAGE.read_text(encoding="utf-8")
    new = paper_docs.with_blocks(text, blocks)
    if args.compare:
        compare = run_compare()
        (DATA / "readme_compare.json").write_text(json.dumps(compare, indent=1) + "\n")
    readme_blocks = paper_docs.readme_blocks(
        data, load("paper_generalise.json"), load("readme_compare.json")
    )
    readme = README.read_text(encoding="utf-8")
    new_readme = paper_docs.with_blocks(readme, readme_blocks)
    if args.check:
        stale = (
            new != text
            or new_readme != readme
            or load("paper_controller.json") != json.loads(json.dumps(data))
        )
        print("stale" if stale else "current")
        return 1 if stale else 0
    (DATA / "paper_controller.json").write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    PAGE.write_text(new, encoding="utf-8")
    README.write_text(new_readme, encoding="utf-8")
    print(blocks["paper-results"].splitlines()[-1])
    print(blocks["twin-results"].splitlines()[-1])
    return 0


if __name__ == "__main__":
    sys.exit(main())
