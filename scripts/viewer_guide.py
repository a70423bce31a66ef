"""The numbers docs/viewer.md states about the shipped controllers, computed, never typed.

Every figure the teacher's guide gives about what the shipped rule bases do (how long
the paper controller takes on s1, which of MATLAB's inference choices arrive and which
collide, how many rules there are and which read the obstacle, ...) is produced here:

    .venv/bin/python scripts/viewer_guide.py            # write docs/data/viewer_guide.json
                                                        # and the marked parts of docs/viewer.md
    .venv/bin/python scripts/viewer_guide.py --check    # exit 1 if either is out of date

Rerun it after a rule base changes (``assets/rules/*.toml``): the guide follows. The runs
go through the viewer itself (:class:`fuzzynav.app.viewer.model.ViewerApp`, a choice set
as the Editor's dropdown sets it, stepped as Step steps), so the numbers are the ones a
teacher sees on the page. ``tests/test_viewer_guide.py`` recomputes them and compares
them with the guide.

In docs/viewer.md, a block between ``<!-- guide:NAME -->`` and ``<!-- /guide:NAME -->``
on lines of their own is replaced by :func:`render_blocks`' text for NAME; an inline
``<!-- guide:KEY -->VALUE<!-- /guide -->`` gets the fact KEY of :func:`facts`.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "viewer.md"
DATA = ROOT / "docs" / "data" / "viewer_guide.json"

SCENARIO = "s1"
# The Editor's four dropdowns (app/viewer/editor_panel.py), MATLAB's names.
FIELDS = {
    "and_method": "AND",
    "imp_method": "implication",
    "agg_method": "aggregation",
    "defuzz_method": "defuzzification",
}
# The Editor's layouts (app/viewer/editor.py), as the guide names them.
EDITOR_LAYOUTS = {
    "PaperDesignTunable": "design",
    "PaperPartitionTunable": "partition",
    "PaperTunable": "27-number",
}
BLOCK = re.compile(
    r"(<!-- guide:(?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /guide:(?P=name) -->)", re.S
)
INLINE = re.compile(r"(<!-- guide:(?P<key>[\w.-]+) -->)(?P<value>[^<\n]*)(<!-- /guide -->)")


def _run(field: str | None = None, value: str | None = None) -> dict:
    """One run of s1 in the viewer (husky geometry, ideal perception, seed 0, 20 ms) with
    the shipped paper controller, or with one inference choice changed."""
    from fuzzynav.app.viewer.model import ViewerApp

    app = ViewerApp(SCENARIO, "paper")
    if field is not None:
        app.set_inference_choice(field, value)
    while not app.sim.done:
        app.driver._step_locked()
    m = app.metrics or {}
    return {
        "outcome": app.sim.outcome,
        "time_s": round(float(app.sim.time_s), 2),
        "min_clearance_m": round(float(m.get("min_clearance_m", math.nan)), 2),
    }


def choice_runs() -> list[dict]:
    """The shipped controller's run, then one per other option of each dropdown."""
    from fuzzynav.controller.inference import CHOICES
    from fuzzynav.controller.paper import paper_controller

    shipped = paper_controller().fis.inference
    runs = [{"field": None, "label": "shipped", "choice": "", **_run()}]
    for field, label in FIELDS.items():
        for value in CHOICES[field]:
            if value == getattr(shipped, field):
                continue
            runs.append({"field": field, "label": label, "choice": value, **_run(field, value)})
    return runs


def facts() -> dict:
    """Counts and choices of the shipped rule bases that the guide quotes."""
    import numpy as np

    from fuzzynav.app.viewer.editor import PaperEditor
    from fuzzynav.controller.paper import RULES_BY_GEOMETRY, paper_controller

    fis = paper_controller().fis
    editor = PaperEditor()
    d_o = fis.input_names.index("d_o")
    obstacle_rules = [k + 1 for k, r in enumerate(fis.rules) if r.antecedent[d_o] is not None]
    # a gap: inputs where no rule fires (d_o, phi_o none, and over the obstacle plane)
    lo_t, hi_t = fis.inputs[0].range
    lo_p, hi_p = fis.inputs[2].range
    grid = np.array(
        [
            (dt, math.nan, pt, math.nan)
            for dt in np.linspace(lo_t, hi_t, 61)
            for pt in np.linspace(lo_p, hi_p, 121)
        ]
    )
    lo_o, hi_o = fis.inputs[1].range
    grid_o = np.array(
        [
            (5.0, do, 0.0, po)
            for do in np.linspace(lo_o, hi_o, 41)
            for po in np.linspace(-math.pi / 2, math.pi / 2, 61)
        ]
    )
    strengths = np.asarray(fis.firing_strengths(np.vstack([grid, grid_o])))
    gap = bool((strengths.max(axis=1) <= 0.0).any())
    inference = fis.inference
    from fuzzynav.controller.registry import make_controller

    blocks = make_controller("fuzzynav").rule_blocks()
    return {
        "fuzzynav.goal_rules": len(blocks["goal"].rules),
        "fuzzynav.avoid_rules": len(blocks["avoid"].rules),
        "paper.rules": len(fis.rules),
        "paper.obstacle_rules": (
            f"{obstacle_rules[0]}-{obstacle_rules[-1]}"
            if obstacle_rules == list(range(obstacle_rules[0], obstacle_rules[-1] + 1))
            else ", ".join(map(str, obstacle_rules))
        )
        if obstacle_rules
        else "none",
        "paper.editor_numbers": len(editor.names),
        "paper.editor_layout": EDITOR_LAYOUTS.get(type(editor.tunable).__name__, "?"),
        "paper.editor_exact": "yes" if editor.exact else "no",
        "paper.rule_file": f"rules/{RULES_BY_GEOMETRY['husky'].name}",
        "paper.gap": "a gap" if gap else "no gap",
        "paper.choices": ", ".join(f"{FIELDS[f]} {getattr(inference, f)}" for f in FIELDS),
    }


def starter_runs() -> dict:
    """The starter system (app/viewer/starter.py) on s1 as shipped, and with its
    obstacles removed (Remove newest, as in the page)."""
    from fuzzynav.app.viewer.model import ViewerApp
    from fuzzynav.app.viewer.starter import STARTER_LABEL

    out = {}
    for case in ("obstacles", "no obstacles"):
        app = ViewerApp(SCENARIO, "paper")
        app.set_controller(STARTER_LABEL)
        if case == "no obstacles":
            for obstacle_id in list(app.sim.arena.obstacles):
                app.remove_obstacle(obstacle_id)
        while not app.sim.done:
            app.driver._step_locked()
        out[case] = {"outcome": app.sim.outcome, "time_s": round(float(app.sim.time_s), 2)}
    fis = app.controller.inner.fis
    out["rules"] = len(fis.rules)
    return out


def compute() -> dict:
    return {
        "scenario": SCENARIO,
        "facts": facts(),
        "choices": choice_runs(),
        "starter": starter_runs(),
    }


def _m(value: float) -> str:
    """Metres in two decimals (a touch, -0.001 m, reads 0.00, not -0.00)."""
    return f"{value + 0.0:.2f} m" if round(value, 2) != 0 else "0.00 m"


def _said(run: dict) -> str:
    if run["outcome"] == "reached":
        return f"arrives after {run['time_s']:.2f} s"
    if run["outcome"] == "collided":
        return f"collides at {run['time_s']:.2f} s"
    if run["outcome"] == "timeout":
        return f"times out at {run['time_s']:.2f} s"
    return f"ends ({run['outcome']}) at {run['time_s']:.2f} s"


def _choices_in_words(runs: list[dict]) -> str:
    """``defuzzification `mom`, `som` or `lom`, aggregation `sum```: the choices of
    these runs, grouped by what they change ("" for none)."""
    groups: dict[str, list[str]] = {}
    for r in runs:
        groups.setdefault(r["label"], []).append(f"`{r['choice']}`")
    parts = [
        f"{label} {', '.join(names[:-1]) + ' or ' + names[-1] if len(names) > 1 else names[0]}"
        for label, names in groups.items()
    ]
    return ", ".join(parts[:-1]) + " or " + parts[-1] if len(parts) > 1 else "".join(parts)


def render_blocks(data: dict) -> dict[str, str]:
    """The guide's generated blocks (markdown, each ending in a newline)."""
    runs = data["choices"]
    shipped = runs[0]
    rows = [
        "| choice | outcome | time | min clearance |",
        "|---|---|---|---|",
        f"| shipped ({data['facts']['paper.choices']}) | {shipped['outcome']} | "
        f"{shipped['time_s']:.2f} s | {_m(shipped['min_clearance_m'])} |",
    ]
    for r in runs[1:]:
        rows.append(
            f"| {r['label']} `{r['choice']}` | {r['outcome']} | {r['time_s']:.2f} s | "
            f"{_m(r['min_clearance_m'])} |"
        )
    collided = _choices_in_words([r for r in runs[1:] if r["outcome"] == "collided"])
    arrived = [r for r in runs[1:] if r["outcome"] == "reached"]
    text = [
        f"On {data['scenario']} (ideal perception, 20 ms steps) the shipped paper controller "
        f"{_said(shipped)}, its footprint never nearer than {_m(shipped['min_clearance_m'])} "
        "to an obstacle. One choice changed at a time, in the Editor's dropdowns:",
        "",
        *rows,
        "",
    ]
    if collided:
        text.append(
            "With " + collided + " it collides: the lesson of what a choice does to the same rules."
        )
    if arrived:
        fastest = min(arrived, key=lambda r: r["time_s"])
        slowest = max(arrived, key=lambda r: r["time_s"])
        text.append(
            f"Of the choices that arrive, {fastest['label']} `{fastest['choice']}` is the "
            f"quickest ({fastest['time_s']:.2f} s) and {slowest['label']} "
            f"`{slowest['choice']}` the slowest ({slowest['time_s']:.2f} s)."
        )
    text.append(
        "(Computed by `scripts/viewer_guide.py`, which runs the viewer itself; rerun it "
        "after a rule base changes. `tests/test_viewer_guide.py` checks this table.)"
    )
    return {
        "choices": "\n".join(text) + "\n",
        "editor": _editor_block(data["facts"]),
        "starter": _starter_block(data),
    }


def _starter_block(data: dict) -> str:
    st = data["starter"]
    return (
        f"On {data['scenario']}, driven by the starter's {st['rules']} rules, the robot "
        f"{_said(st['obstacles'])}; with the obstacles removed (**Remove newest** until "
        f"none is left) it {_said(st['no obstacles'])}.\n"
    )


def _editor_block(f: dict) -> str:
    """What the Editor's sliders are for the shipped rule base, as it is today."""
    n, layout = f["paper.editor_numbers"], f["paper.editor_layout"]
    if f["paper.editor_exact"] == "yes":
        start = (
            f"They start from the numbers the shipped `{f['paper.rule_file']}` records in "
            "its header (`# tuned vector:`), which rebuild it exactly."
        )
    else:
        start = (
            f"The shipped `{f['paper.rule_file']}` records no numbers of a layout that "
            "rebuild it, so they start from the tuner's starting point, and the Editor says so; Reset "
            "to shipped drives with the shipped system itself."
        )
    holds = (
        " Each is a centre, a width or a spacing inside the design's bounds, so whatever "
        "you do the terms of each variable stay in order and no input is left uncovered: "
        "the design rules of `controller/design_rules.py` hold at every slider position."
        if layout in ("design", "partition")
        else " Each builds the shapes from positive widths, so every shape stays valid and "
        "the terms stay in order, but a slider can open a hole between two terms: the "
        'Inference tab then shows "No rule fires: fallback".'
    )
    return (
        f"For the shipped paper rule base (the Husky's) the sliders hold the {n} numbers of the "
        f"{layout} layout, each named by what it does, in two decimals. {start}{holds}\n"
    )


def render_guide(text: str, data: dict) -> str:
    """docs/viewer.md's text with its marked parts from ``data``."""
    blocks = render_blocks(data)

    def block(m: re.Match) -> str:
        name = m.group("name")
        if name not in blocks:
            raise KeyError(f"docs/viewer.md: no generated block {name!r}")
        return m.group(1) + blocks[name] + m.group(4)

    def inline(m: re.Match) -> str:
        key = m.group("key")
        if key not in data["facts"]:
            raise KeyError(f"docs/viewer.md: no fact {key!r}")
        return m.group(1) + str(data["facts"][key]) + m.group(4)

    return INLINE.sub(inline, BLOCK.sub(block, text))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if out of date")
    args = parser.parse_args(argv)
    data = compute()
    guide = GUIDE.read_text(encoding="utf-8")
    new_guide = render_guide(guide, data)
    new_data = json.dumps(data, indent=2) + "\n"
    if args.check:
        stale = [
            str(p.relative_to(ROOT))
            for p, new in ((GUIDE, new_guide), (DATA, new_data))
            if not p.exists() or p.read_text(encoding="utf-8") != new
        ]
        if stale:
            print(f"out of date (run scripts/viewer_guide.py): {', '.join(stale)}")
            return 1
        print("docs/viewer.md and docs/data/viewer_guide.json are up to date")
        return 0
    DATA.parent.mkdir(parents=True, exist_ok=True)
    DATA.write_text(new_data, encoding="utf-8")
    GUIDE.write_text(new_guide, encoding="utf-8")
    print(f"wrote {DATA.relative_to(ROOT)} and {GUIDE.relative_to(ROOT)}")
    print(render_blocks(data)["choices"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
