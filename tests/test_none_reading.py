"""Table 1's NONE, two readings (issue 35): MATLAB's ("the input takes no part") and the
paper's text for d_o ("for more distance, it is 'none'": the goal rules hold only while
no obstacle is sensed), as ``FuzzySystem(unsensed_none=...)``; and the two design rules
issue 35 added (``span`` and ``rates``), each shown to catch its fault."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzynav.controller.batch import batch_controller
from fuzzynav.controller.design_rules import violations
from fuzzynav.controller.fis import dumps_fis
from fuzzynav.controller.fis_controller import FisController
from fuzzynav.controller.paper import FIRST_DESIGN
from fuzzynav.controller.rulebase import dumps_toml, loads_toml, read_toml

GOAL_RULES = slice(0, 25)  # Table 1: NONE for d_o and phi_o
OBSTACLE_RULES = slice(25, 40)


@pytest.fixture(scope="module")
def system():
    return read_toml(FIRST_DESIGN).replace(unsensed_none=("d_o",))


def _inputs(n=300, seed=0):
    rng = np.random.default_rng(seed)
    sensed = rng.random(n) < 0.5
    X = np.column_stack(
        [
            rng.uniform(0, 12, n),
            np.where(sensed, rng.uniform(0, 3, n), np.nan),
            rng.uniform(-3, 3, n),
            np.where(sensed, rng.uniform(-3, 3, n), np.nan),
        ]
    )
    return X, sensed


def test_while_an_obstacle_is_sensed_only_the_obstacle_rules_decide(system):
    X, sensed = _inputs()
    strengths = system.firing_strengths(X)
    assert strengths[sensed][:, GOAL_RULES].max() == 0.0
    assert strengths[sensed][:, OBSTACLE_RULES].max(axis=1).min() > 0.0
    # the definition, computed independently: a system of rules 26-40 alone
    alone = system.replace(rules=system.rules[OBSTACLE_RULES], unsensed_none=())
    np.testing.assert_array_equal(system.evaluate(X[sensed]), alone.evaluate(X[sensed]))
    # nothing sensed: the goal rules decide, as under MATLAB's reading
    matlab = system.replace(unsensed_none=())
    np.testing.assert_array_equal(system.evaluate(X[~sensed]), matlab.evaluate(X[~sensed]))
    # and the two readings differ where something is sensed
    assert np.abs(system.evaluate(X[sensed]) - matlab.evaluate(X[sensed])).max() > 0.1


def test_every_path_gives_the_same_numbers(system):
    X, _ = _inputs(seed=1)
    batch = system.evaluate(X)
    one = np.array([system.evaluate_one(x) for x in X])
    np.testing.assert_array_equal(batch, one)
    _, aggregated, crisp = system.aggregated_many(X)
    np.testing.assert_array_equal(crisp, one)
    for k in (0, 7):
        np.testing.assert_array_equal(system.aggregated(X[k]).membership, aggregated[k])
    controller = FisController(system)
    assert controller.none_reading == "unsensed"
    decided = batch_controller([controller, controller], np.array([0, 1])).decide(
        X, np.arange(len(X)) % 2
    )
    np.testing.assert_array_equal(decided, one)


def test_the_reading_is_kept_by_the_toml_format_and_refused_by_fis(system):
    again = loads_toml(dumps_toml(system))
    assert again.unsensed_none == ("d_o",) and again == system
    assert system != system.replace(unsensed_none=())
    with pytest.raises(ValueError, match="a .fis cannot say"):
        dumps_fis(system)
    dumps_fis(system.replace(unsensed_none=()))  # MATLAB's reading exports
    text = dumps_toml(system).replace('unsensed_none = ["d_o"]', 'unsensed_none = ["d_x"]')
    with pytest.raises(ValueError, match="system.unsensed_none"):
        loads_toml(text, "mine.toml")
    with pytest.raises(ValueError, match="must name inputs"):
        system.replace(unsensed_none=("nope",))


def test_a_controller_asked_for_the_text_reading_gets_it():
    fis = read_toml(FIRST_DESIGN)
    assert FisController(fis).none_reading == "matlab"
    controller = FisController(fis, none_reading="unsensed")
    assert controller.fis.unsensed_none == ("d_o",)
    x = [5.0, 1.0, 0.3, 0.2]
    assert not np.allclose(controller(x), FisController(fis)(x))
    with pytest.raises(ValueError, match="none_reading"):
        FisController(fis, none_reading="sometimes")


# -- the design rules issue 35 added --------------------------------------------------


def _shifted_outputs(system, top):
    """The wheels' terms squeezed into [lo, top] (VL's corner at ``top``)."""
    out = system
    for wheel in ("left", "right"):
        v = next(o for o in system.outputs if o.name == wheel)
        lo = v.range[0]
        scale = (top - lo) / (max(p for t in v.terms for p in t.params) - lo)
        for t in v.terms:
            params = [lo + (p - lo) * scale for p in t.params]
            out = out.with_term_params(wheel, t.name, params, shape=t.shape)
    return out


def _layout_system():
    from fuzzynav.controller.paper_design import PaperDesignTunable

    tunable = PaperDesignTunable()
    return tunable.system(tunable.initial_vector())


def test_span_catches_terms_that_leave_the_upper_half_unused():
    good = _layout_system()
    assert not [v for v in violations(good) if v.rule == "span"]
    squeezed = _shifted_outputs(good, top=6.0)
    found = [v for v in violations(squeezed) if v.rule == "span"]
    assert {(v.variable, v.term) for v in found} == {("left", "VL"), ("right", "VL")}, found


def test_span_bites_on_mirrored_angle_inputs():
    """A mirrored angle input spans each half: the hand-made first design's phi_t holds
    VP from 1.6 rad of a +-2 pi universe and is caught; phi_o's VP from 1.8 rad of +-pi is not."""
    found = [v for v in violations(read_toml(FIRST_DESIGN)) if v.rule == "span"]
    assert {(v.variable, v.term) for v in found} == {("phi_t", "VN"), ("phi_t", "VP")}, found


def test_rates_catches_a_near_crisp_ramp_beside_a_gentle_one():
    good = _layout_system()
    assert not [v for v in violations(good) if v.rule == "rates"]
    # phi_o's VP ramp 0.13 rad against N's about 1 rad (the fault issue 35 found)
    p, w = 0.9, 0.13
    bad = good
    for name, shape, params in (
        ("VN", "linzmf", (-(p + w), -p)),
        ("N", "trimf", (-(p + w), -p, 0.0)),
        ("P", "trimf", (0.0, p, p + w)),
        ("VP", "linsmf", (p, p + w)),
    ):
        bad = bad.with_term_params("phi_o", name, params, shape=shape)
    bad = bad.with_term_params("phi_o", "Z", (p * 0.4247, 0.0), shape="gaussmf")
    found = [v for v in violations(bad) if v.rule == "rates"]
    assert {v.term for v in found} >= {"N", "VP"}, found
    assert all(v.variable == "phi_o" for v in found)
