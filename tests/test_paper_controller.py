"""The paper's controller: Table 1 exactly, the tuning parametrisation, and issue 3's
acceptance test (s1-s3 x both perception modes with the SHIPPED rule base)."""

import pickle
import re
from pathlib import Path

import numpy as np
import pytest

from fuzzynav.app.experiments.tuning import read_vector
from fuzzynav.app.runs import run_scenario
from fuzzynav.controller.fuzzy import FuzzySystem
from fuzzynav.controller.paper import (
    FIRST_DESIGN,
    PAPER_HUSKY_RULES,
    PAPER_RULES,
    paper_controller,
)
from fuzzynav.controller.paper_design import PaperDesignTunable
from fuzzynav.controller.rulebase import read_toml
from fuzzynav.controller.tuning import Tunable, tunable

ROOT = Path(__file__).resolve().parents[1]

PAPER_TEXT = Path(__file__).resolve().parents[2] / "shared" / "paper" / "fuzzy-husky-paper.txt"

# Table 1 of the paper: d_t, d_o, phi_t, phi_o, left, right (NONE: input not used).
TABLE1 = """
VL NONE VN NONE L VS|VL NONE N NONE M VS|VL NONE Z NONE VL VL|VL NONE P NONE VS M|VL NONE VP NONE VS L
L NONE VN NONE L VS|L NONE N NONE M VS|L NONE Z NONE L L|L NONE P NONE VS M|L NONE VP NONE VS L
M NONE VN NONE M VS|M NONE N NONE S VS|M NONE Z NONE M M|M NONE P NONE VS S|M NONE VP NONE VS M
S NONE VN NONE M VS|S NONE N NONE S VS|S NONE Z NONE S S|S NONE P NONE VS S|S NONE VP NONE VS M
VS NONE VN NONE S VS|VS NONE N NONE S VS|VS NONE Z NONE VS VS|VS NONE P NONE VS S|VS NONE VP NONE VS S
NONE NEAR NONE VN S S|NONE NEAR NONE N VS S|NONE NEAR NONE Z VS M|NONE NEAR NONE P M VS|NONE NEAR NONE VP S S
NONE MEDIUM NONE VN M M|NONE MEDIUM NONE N VS S|NONE MEDIUM NONE Z VS M|NONE MEDIUM NONE P M VS|NONE MEDIUM NONE VP M M
NONE FAR NONE VN L L|NONE FAR NONE N VS S|NONE FAR NONE Z VS M|NONE FAR NONE P S VS|NONE FAR NONE VP L L
"""


def table1_rows():
    return [tuple(r.split()) for line in TABLE1.strip().splitlines() for r in line.split("|")]


def rule_rows(fis: FuzzySystem):
    rows = []
    for rule in fis.rules:
        row = []
        for var, k in zip(fis.inputs, rule.antecedent):
            row.append("NONE" if k is None else var.terms[k].name.upper())
        for var, k in zip(fis.outputs, rule.consequent):
            row.append(var.terms[k].name.upper())
        rows.append((tuple(row), rule.weight))
    return rows


@pytest.mark.parametrize("path", [PAPER_RULES, FIRST_DESIGN])
def test_rule_base_is_table1_exactly(path):
    fis = read_toml(path)
    assert fis.input_names == ["d_t", "d_o", "phi_t", "phi_o"]
    assert fis.output_names == ["left", "right"]
    rows = rule_rows(fis)
    assert len(rows) == 40
    assert [r for r, _ in rows] == table1_rows()
    assert all(w == 1 for _, w in rows)
    assert [v.range for v in fis.inputs] == [
        (-1.13, 30.0),
        (0.0, 3.0),
        (-2 * np.pi, 2 * np.pi),
        (-np.pi, np.pi),
    ]
    assert [v.range for v in fis.outputs] == [(-0.28, 14.0)] * 2
    for v in fis.inputs + fis.outputs:
        assert {t.shape for t in v.terms} <= {"trimf", "linsmf", "linzmf", "gaussmf"}


@pytest.mark.skipif(not PAPER_TEXT.exists(), reason="the paper's text is not beside the repo")
def test_table1_here_matches_the_papers_text():
    lines = PAPER_TEXT.read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Table 1."))
    rows = [line.split("\t") for line in lines[start + 3 : start + 43]]
    assert [tuple(r[1:7]) for r in rows] == table1_rows()
    assert all(r[7].strip() == "1" for r in rows)


@pytest.mark.parametrize("path", [PAPER_RULES, PAPER_HUSKY_RULES], ids=lambda p: p.name)
def test_shipped_file_differs_from_first_design_only_in_membership_parameters(path):
    """Both shipped rule bases (the paper's and its Husky twin) are Table 1 with the
    first design's variables and their own membership parameters; both read NONE for d_o
    as the text has it (the reading selected, docs/paper-controller.md), the twin as the
    paper's does."""
    shipped, first = read_toml(path), read_toml(FIRST_DESIGN)
    assert shipped.rules == first.rules and shipped.n_points == first.n_points
    assert shipped.unsensed_none == ("d_o",)
    assert first.unsensed_none == ()
    for a, b in zip(shipped.inputs + shipped.outputs, first.inputs + first.outputs):
        assert (a.name, a.range, a.term_names) == (b.name, b.range, b.term_names)
    header = path.read_text(encoding="utf-8").split("[system]")[0]
    script = re.search(r"python (scripts/\w+\.py)", header)
    assert "Reproduce with" in header and script and (ROOT / script.group(1)).is_file()


def test_sign_convention_target_left_speeds_up_right_wheel():
    c = paper_controller()
    left, right = c([8.0, np.nan, 0.6, np.nan])  # target on the left
    assert right > left
    left, right = c([8.0, np.nan, -0.6, np.nan])  # on the right
    assert left > right
    left, right = c([8.0, np.nan, 0.0, np.nan])  # ahead: straight on
    assert left == pytest.approx(right)


@pytest.mark.parametrize(
    ("d_t", "geometry"),
    [(8.0, "paper"), (30.0, "paper"), (8.0, "husky"), (30.0, "husky")],
)
def test_sign_convention_obstacle_left_turns_right(d_t, geometry):
    """With the text's reading of NONE (both shipped rule bases) the goal rules are off
    while an obstacle is sensed, so however far the target, the obstacle rules steer."""
    c = paper_controller(geometry=geometry)
    # where the shipped phi_o "P" (obstacle ahead-left) term is strongest
    phi_o = next(v for v in c.fis.inputs if v.name == "phi_o")
    grid = np.linspace(0.0, np.pi / 2, 500)
    bearing = float(grid[np.argmax(next(t for t in phi_o.terms if t.name == "P")(grid))])
    left, right = c([d_t, 0.3, 0.0, bearing])  # near obstacle ahead-left, target ahead
    assert left > right
    left, right = c([d_t, 0.3, 0.0, -bearing])  # ahead-right: turn left
    assert right > left


def test_tunable_protocol_and_construction():
    t = tunable("paper")  # the layout rules/paper.toml was fitted in
    assert isinstance(t, Tunable) and isinstance(t, PaperDesignTunable)
    names, bounds, x0 = t.parameter_names(), t.bounds(), t.initial_vector()
    assert len(names) == len(bounds) == len(x0) == len(set(names))
    lo, hi = np.array(bounds).T
    assert np.all(lo < hi) and np.all((lo <= x0) & (x0 <= hi))
    pickle.loads(pickle.dumps(t))
    rng = np.random.default_rng(0)
    for _ in range(50):  # any vector within the bounds is a valid system (ordering by construction)
        v = rng.uniform(lo, hi)
        fis = t.system(v)
        assert fis.rules == read_toml(FIRST_DESIGN).rules
        out = t.build(v)([5.0, 1.0, 0.3, -0.2])
        assert np.all(np.isfinite(out))
    with pytest.raises(ValueError):
        tunable("nope")


@pytest.mark.parametrize("path", [PAPER_RULES, PAPER_HUSKY_RULES], ids=lambda p: p.name)
def test_the_shipped_rule_base_is_its_tuned_vector(path):
    """A shipped rule base's header vector (6 digits) rebuilds its system."""
    t = tunable("paper")
    vector = read_vector(path, t.parameter_names())
    shipped = read_toml(path)
    assert np.allclose(t.system(vector).parameter_vector(), shipped.parameter_vector(), atol=1e-4)


def test_save_writes_a_loadable_rule_base(tmp_path):
    t = tunable("paper")
    [path] = t.save(t.initial_vector(), tmp_path / "x.toml", header="Reproduce with: test")
    assert read_toml(path) == t.system(t.initial_vector())
    assert "Reproduce with: test" in path.read_text()


# Not met by the Husky twin (rules/paper_husky.toml); its numbers are in
# docs/paper-controller.md ("The Husky twin"), generated and tested.
_NOT_MET: dict[tuple[str, str], str] = {  # (perception, scenario): why, while one is not met
    ("ideal", "s1"): "not met by the twin: s1 reached with 0.150 m from footprint to the "
    "second obstacle (>= 0.25)",
    ("ultrasonic", "s1"): "not met by the twin: s1 reached with 0.074 m from footprint to "
    "the third obstacle (>= 0.25)",
}
ACCEPTANCE = [
    pytest.param(
        p,
        s,
        marks=pytest.mark.xfail(strict=True, reason=_NOT_MET[(p, s)]) if (p, s) in _NOT_MET else (),
    )
    for p in ("ideal", "ultrasonic")
    for s in ("s1", "s2", "s3")
]


@pytest.mark.parametrize(("perception", "scenario"), ACCEPTANCE)
def test_acceptance_shipped_rule_base_reaches_safely(scenario, perception):
    """Issue 3's acceptance: the shipped Husky rule base (the twin,
    assets/rules/paper_husky.toml), the real loop (0.02 s)."""
    result = run_scenario(scenario, "paper", perception=perception, seed=0)
    m = result.metrics
    assert result.outcome == "reached", m
    assert not m["collided"]
    assert m["min_clearance_m"] >= 0.25, m["min_clearance_m"]
    assert m["max_abs_voltage_v"] <= 12.0
