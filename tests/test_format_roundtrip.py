"""Rule bases written by the project load back as the same system (issue 36 item 4):
the TOML rule base and MATLAB's .fis, for random systems of every shape family, with
unicode and multi-line descriptions, units and names; a name the format cannot hold is
refused at writing, never written into a file that does not load."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzzynav.controller.fis import dumps_fis, loads_fis
from fuzzynav.controller.fuzzy import FuzzySystem, Rule, Term, Variable
from fuzzynav.controller.rulebase import dumps_toml, loads_toml

NAMES = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,11}", fullmatch=True).filter(
    lambda s: s.upper() not in {"IF", "AND", "THEN", "IS", "WEIGHT", "OR", "NOT"}
)
#: Free text as a file keeps it: unicode, quotes, backslashes, line breaks and tabs.
TEXT = st.text(
    st.characters(blacklist_categories=("Cs", "Cc"), blacklist_characters="\x7f")
    | st.sampled_from("\n\t"),
    max_size=40,
)


def _term(name: str, shape: str, lo: float, hi: float, u: list[float]) -> Term:
    """A term of ``shape`` with parameters placed by ``u`` (numbers in [0, 1])."""
    span = hi - lo
    points = sorted(lo + span * x for x in u[:4])
    width = span * (0.05 + 0.5 * u[4])
    params = {
        "trimf": points[:3],
        "trapmf": points[:4],
        "linsmf": [points[0], points[0] + width],
        "linzmf": [points[0], points[0] + width],
        "gaussmf": [width, points[1]],
        "gauss2mf": [width, points[0], width * 0.7, points[2]],
    }[shape]
    return Term(name, shape, tuple(params))


@st.composite
def variables(draw, n_terms: int):
    lo = draw(st.floats(-50, 50, allow_nan=False))
    hi = lo + draw(st.floats(0.5, 100))
    names = draw(st.lists(NAMES, min_size=n_terms, max_size=n_terms, unique=True))
    terms = []
    for name in names:
        shape = draw(
            st.sampled_from(["trimf", "trapmf", "linsmf", "linzmf", "gaussmf", "gauss2mf"])
        )
        u = draw(st.lists(st.floats(0, 1), min_size=5, max_size=5))
        terms.append(_term(name, shape, lo, hi, u))
    return Variable(draw(NAMES), (lo, hi), tuple(terms), unit=draw(TEXT), description=draw(TEXT))


@st.composite
def systems(draw):
    n_in, n_out = draw(st.integers(1, 3)), draw(st.integers(1, 2))
    inputs = [draw(variables(draw(st.integers(2, 4)))) for _ in range(n_in)]
    outputs = [draw(variables(draw(st.integers(2, 4)))) for _ in range(n_out)]
    names = [v.name for v in inputs + outputs]
    if len(set(names)) < len(names):  # variable names are unique in a system
        inputs = [
            Variable(f"in{k}_{v.name}", v.range, v.terms, v.unit, v.description)
            for k, v in enumerate(inputs)
        ]
        outputs = [
            Variable(f"out{k}_{v.name}", v.range, v.terms, v.unit, v.description)
            for k, v in enumerate(outputs)
        ]
    rules = []
    for _ in range(draw(st.integers(1, 6))):
        antecedent = [draw(st.sampled_from([None, *range(len(v.terms))])) for v in inputs]
        if all(a is None for a in antecedent):
            antecedent[0] = 0
        consequent = [draw(st.sampled_from(range(len(v.terms)))) for v in outputs]
        weight = draw(st.sampled_from([1.0, 0.5, 0.25, draw(st.floats(0, 1))]))
        rules.append(Rule(tuple(antecedent), tuple(consequent), weight))
    return FuzzySystem(
        inputs,
        outputs,
        rules,
        name=draw(NAMES),
        description=draw(TEXT),
        n_points=draw(st.sampled_from([101, 101, 101, 51])),  # MATLAB's grid, mostly
    )


def _same(a: FuzzySystem, b: FuzzySystem) -> None:
    assert dumps_toml(a) == dumps_toml(b)
    assert (a.name, a.description, a.n_points) == (b.name, b.description, b.n_points)
    for va, vb in zip(a.inputs + a.outputs, b.inputs + b.outputs):
        assert (va.name, va.unit, va.description, va.range) == (
            vb.name,
            vb.unit,
            vb.description,
            vb.range,
        )
        assert [(t.name, t.shape, t.params) for t in va.terms] == [
            (t.name, t.shape, t.params) for t in vb.terms
        ]
    assert a.rules == b.rules
    rng = np.random.default_rng(0)
    lo = np.array([v.range[0] for v in a.inputs])
    hi = np.array([v.range[1] for v in a.inputs])
    x = lo + rng.random((16, len(lo))) * (hi - lo)
    np.testing.assert_array_equal(a.evaluate(x), b.evaluate(x))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(systems())
def test_a_toml_rule_base_reads_back_as_the_system_written(system):
    _same(system, loads_toml(dumps_toml(system), "round trip"))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(systems())
def test_a_fis_file_reads_back_as_the_system_written(system):
    try:
        text = dumps_fis(system)
    except ValueError as exc:  # a quote or line break in a name, or a grid not of 101 points
        assert "cannot write" in str(exc)
        return
    back = loads_fis(text, "round trip")
    # .fis keeps no units, and a description only as MATLAB's one-line comment
    assert dumps_fis(back) == text
    np.testing.assert_array_equal(
        back.evaluate(np.array([[v.range[0] for v in system.inputs]])),
        system.evaluate(np.array([[v.range[0] for v in system.inputs]])),
    )


@pytest.mark.parametrize("name", ["IF", "2x", "a-b", "é"])
def test_a_name_the_rule_base_cannot_hold_is_refused_when_written(name):
    term = Term("low", "trimf", (0.0, 0.5, 1.0))
    system = FuzzySystem(
        [Variable(name, (0.0, 1.0), (term,))],
        [Variable("out", (0.0, 1.0), (term,))],
        [Rule((0,), (0,))],
    )
    with pytest.raises(ValueError, match="cannot write"):
        dumps_toml(system)
