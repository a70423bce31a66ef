"""The design rules (controller/design_rules.py): they hold for the shipped paper
controller and for every vector of its 12-number layout, and each rule catches the
fault it names."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fuzzynav.app.runs import build_simulation
from fuzzynav.controller.design_rules import violations
from fuzzynav.controller.fuzzy import Term
from fuzzynav.controller.paper import RULES_BY_GEOMETRY
from fuzzynav.controller.paper_design import PaperDesignTunable, corners
from fuzzynav.controller.rulebase import read_toml
from fuzzynav.world.scenario import load_scenario

SHIPPED = sorted({p for p in RULES_BY_GEOMETRY.values()})


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_the_shipped_paper_controller_keeps_every_design_rule(path):
    faults = violations(read_toml(path))
    assert faults == [], "\n".join(map(str, faults))


ROOT = Path(__file__).resolve().parents[1]


def test_each_geometry_has_its_rule_base_of_one_layout():
    """The paper's controller in its own geometry and its Husky twin (issue 35): two
    files, Table 1 and the 12-number layout in both, told apart by name."""
    from fuzzynav.controller.paper import RULE_BASE_NAMES

    assert RULES_BY_GEOMETRY["paper"].name == "paper.toml"
    assert RULES_BY_GEOMETRY["husky"].name == "paper_husky.toml"
    assert set(RULE_BASE_NAMES) == set(RULES_BY_GEOMETRY)
    first = read_toml(RULES_BY_GEOMETRY["paper"])
    twin = read_toml(RULES_BY_GEOMETRY["husky"])
    assert first.rules == twin.rules and first != twin


def test_every_vector_of_the_layout_keeps_the_design_rules():
    """By construction, not by penalty: random vectors in the bounds and corners of the
    box (where widths and spacings are at their extremes)."""
    t = PaperDesignTunable()
    lo, hi = np.array(t.bounds()).T
    rng = np.random.default_rng(25)
    box = corners(t)
    vectors = list(rng.uniform(lo, hi, size=(25, len(lo)))) + list(
        box[rng.choice(len(box), 25, replace=False)]
    )
    for v in vectors:
        faults = violations(t.system(v))
        assert faults == [], (v.tolist(), [str(f) for f in faults])


def _with(system, variable, term, shape, params, both_wheels=False):
    out = system.with_term_params(variable, term, list(params), shape=shape)
    if both_wheels:
        out = out.with_term_params("right", term, list(params), shape=shape)
    return out


def _rules(system):
    return {f.rule for f in violations(system)}


@pytest.fixture(scope="module")
def good():
    t = PaperDesignTunable()
    system = t.system(t.initial_vector())
    assert violations(system) == []
    return system


def _term(system, variable, name) -> Term:
    v = next(x for x in system.inputs + system.outputs if x.name == variable)
    return next(t for t in v.terms if t.name == name)


def test_a_family_outside_the_papers_and_no_gaussian_are_faults(good):
    c = _term(good, "d_o", "medium").params[1]
    assert "family" in _rules(_with(good, "d_o", "medium", "trapmf", (c - 0.5, c, c, c + 0.5)))
    no_gauss = good
    for var, name in (("d_t", "M"), ("d_o", "medium"), ("phi_t", "Z"), ("phi_o", "Z")):
        sigma, c = _term(good, var, name).params
        no_gauss = _with(no_gauss, var, name, "trimf", (c - 2.4 * sigma, c, c + 2.4 * sigma))
    assert [f.rule for f in violations(no_gauss)] == ["family"]


def test_a_term_that_never_reaches_one_is_a_fault(good):
    a, b = _term(good, "d_o", "far").params
    assert "peak" in _rules(_with(good, "d_o", "far", "linsmf", (a, 3.4)))


def test_terms_out_of_linguistic_order_are_a_fault(good):
    m = _term(good, "d_t", "M").params[1]
    swapped = _with(good, "d_t", "S", "trimf", (m, m + 1.0, m + 2.0))
    assert "order" in _rules(swapped)


def test_a_spike_and_a_near_crisp_ramp_are_faults(good):
    # phi_t's universe is 4 pi: 2 % is 0.251 rad
    assert "width" in _rules(_with(good, "phi_t", "Z", "gaussmf", (0.05, 0.0)))
    p = _term(good, "phi_o", "VP").params
    near_crisp = _with(good, "phi_o", "VP", "linsmf", (p[1] - 0.05, p[1]))
    near_crisp = _with(near_crisp, "phi_o", "VN", "linzmf", (-p[1], -p[1] + 0.05))
    assert "width" in _rules(near_crisp)


def test_neighbours_that_do_not_overlap_or_sit_inside_each_other_are_faults(good):
    a, b, c = _term(good, "left", "S").params
    narrow = _with(good, "left", "S", "trimf", (b - 0.3, b, b + 0.3), both_wheels=True)
    assert "overlap" in _rules(narrow)
    m = _term(good, "left", "M").params
    l_ = _term(good, "left", "L").params
    inside = _with(
        good, "left", "L", "trimf", (m[0], m[1] + 0.1 * (l_[1] - m[1]), l_[2]), both_wheels=True
    )
    assert "overlap" in _rules(inside)


def test_a_hole_in_an_input_is_a_fault(good):
    # near stops at its centre: between near and medium every term is small
    a, b = _term(good, "d_o", "near").params
    sigma, c = _term(good, "d_o", "medium").params
    holed = _with(good, "d_o", "near", "linzmf", (a, a + 0.07))
    holed = _with(holed, "d_o", "medium", "gaussmf", (0.1 * sigma + 0.05, c))
    assert "coverage" in _rules(holed)


def test_angle_inputs_must_be_mirrored_and_the_wheels_share_their_terms(good):
    a, b, c = _term(good, "phi_o", "P").params
    assert "mirror" in _rules(_with(good, "phi_o", "P", "trimf", (a, b * 1.1, c)))
    a, b, c = _term(good, "right", "M").params
    assert _rules(good.with_term_params("right", "M", [a, b + 0.1, c])) == {"wheels"}


def test_the_scenarios_start_as_the_selected_reading_in_both_geometries():
    """The start heading is a reading of the text, never fitted: the one the readings
    table selected (docs/data/paper_readings_behaviour.json, by the rule written before
    the fits),
    the same for the Husky and the paper's point robot, with the reading's field of view."""
    import json

    from fuzzynav.app.experiments.paper_fit import select_reading

    table = json.loads((ROOT / "docs" / "data" / "paper_readings_behaviour.json").read_text())
    chosen = select_reading(table["results"])
    heading = float(chosen["reading"].split("heading ")[1].split(" rad")[0])
    field = float(chosen["reading"].split("field ")[1].split(" deg")[0])
    for name in ("s1", "s2", "s3"):
        scenario = load_scenario(name)
        assert scenario.heading_rad == pytest.approx(heading, abs=1e-4)
        assert scenario.field_of_view_deg == pytest.approx(field)
        for geometry in ("paper", "husky"):
            sim = build_simulation(name, "p", geometry=geometry)
            assert sim.arena.pose[2] == pytest.approx(scenario.heading_rad, abs=1e-12)
