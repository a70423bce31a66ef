"""MATLAB's OR rules (connection 2) and NOT terms (negative term indices) that a user's
.fis may hold: read, evaluated as worked by hand and as simpful evaluates them, the same
bits in the single-row, batch and per-row-parameter paths, and written back equal (the
.fis text and the TOML rule base)."""

from __future__ import annotations

import contextlib
import io
import math

import numpy as np
import pytest

from fuzzynav.controller.fis import FisFormatError, dumps_fis, loads_fis
from fuzzynav.controller.fuzzy import FuzzySystem, Rule
from fuzzynav.controller.fuzzy_batch import BatchFuzzy
from fuzzynav.controller.rulebase import dumps_toml, loads_toml, parse_rule

# a and b on [0, 10], each with low = (10 - x) / 10 and high = x / 10; the output's two
# terms are spikes at the grid's ends (0 and 10), so the centroid is 10 * hi / (lo + hi)
FIS = """[System]
Name='ornot'
Type='mamdani'
Version=2.0
NumInputs=2
NumOutputs=1
NumRules=3
AndMethod='min'
OrMethod='max'
ImpMethod='min'
AggMethod='max'
DefuzzMethod='centroid'

[Input1]
Name='a'
Range=[0 10]
NumMFs=2
MF1='low':'trimf',[0 0 10]
MF2='high':'trimf',[0 10 10]

[Input2]
Name='b'
Range=[0 10]
NumMFs=2
MF1='low':'trimf',[0 0 10]
MF2='high':'trimf',[0 10 10]

[Output1]
Name='u'
Range=[0 10]
NumMFs=2
MF1='lo':'trimf',[0 0 0.1]
MF2='hi':'trimf',[9.9 10 10]

[Rules]
1 -2, 1 (1) : 2
2 -1, 2 (1) : 1
-1 2, 2 (0.5) : 2
"""


@pytest.fixture(scope="module")
def system() -> FuzzySystem:
    return loads_fis(FIS, "ornot.fis")


def test_the_rules_are_read_with_or_and_not(system):
    assert system.rules == (
        Rule((0, ~1), (0,), 1.0, "or"),
        Rule((1, ~0), (1,), 1.0, "and"),
        Rule((~0, 1), (1,), 0.5, "or"),
    )
    assert [system.rule_text(r) for r in range(3)] == [
        "IF a IS low OR b IS NOT high THEN u IS lo",
        "IF a IS high AND b IS NOT low THEN u IS hi",
        "IF a IS NOT low OR b IS high THEN u IS hi WEIGHT 0.5",
    ]


def test_a_hand_worked_case(system):
    """a = 3, b = 6: low(a) 0.7, high(a) 0.3, low(b) 0.4, high(b) 0.6.
    Rule 1: max(0.7, 1 - 0.6) = 0.7 (lo); rule 2: min(0.3, 1 - 0.4) = 0.3 (hi);
    rule 3: 0.5 * max(1 - 0.7, 0.6) = 0.3 (hi). Centroid 10 * 0.3 / (0.7 + 0.3) = 3.
    With probor: rule 1 0.7 + 0.4 - 0.28 = 0.82, rule 3 0.5 * (0.3 + 0.6 - 0.18) = 0.36,
    hi = max(0.3, 0.36): 10 * 0.36 / 1.18.
    b NaN (nothing sensed): its memberships 0, NOT them 1: rule 1 fires at 1, rule 2 at
    min(0.3, 1) = 0.3, rule 3 at 0.5 * max(0.3, 0) = 0.15: 10 * 0.3 / 1.3."""
    assert system.firing_strengths([[3.0, 6.0]])[0] == pytest.approx([0.7, 0.3, 0.3], abs=1e-15)
    assert system.evaluate_one([3.0, 6.0])[0] == pytest.approx(3.0, abs=1e-12)
    probor = system.with_inference(or_method="probor")
    assert probor.firing_strengths([[3.0, 6.0]])[0] == pytest.approx([0.82, 0.3, 0.36], abs=1e-15)
    assert probor.evaluate_one([3.0, 6.0])[0] == pytest.approx(3.6 / 1.18, abs=1e-12)
    assert system.evaluate_one([3.0, math.nan])[0] == pytest.approx(3.0 / 1.3, abs=1e-12)
    # an AND reading of the same indices gives another number: the connection is honoured
    as_and = system.replace(
        rules=[Rule(r.antecedent, r.consequent, r.weight) for r in system.rules]
    )
    assert as_and.evaluate_one([3.0, 6.0])[0] != pytest.approx(3.0, abs=1e-3)


def _inputs(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1.0, 11.0, (n, 2))
    X[rng.random((n, 2)) < 0.1] = np.nan
    return X


@pytest.mark.parametrize(
    "choices",
    [
        {},
        {"or_method": "probor"},
        {"and_method": "prod", "or_method": "probor"},
        {"defuzz_method": "bisector"},
        {"agg_method": "sum", "imp_method": "prod"},
    ],
)
def test_single_row_and_batch_paths_give_the_same_bits(system, choices):
    s = system.with_inference(**choices)
    X = _inputs(700, seed=len(choices))
    Y = s.evaluate(X)
    assert np.array_equal(Y, np.array([s.evaluate_one(x) for x in X]))
    assert np.array_equal(Y, s.aggregated_many(X)[2])


def test_unsensed_none_gates_or_rules_in_both_paths(system):
    """With b gated, a rule with NONE for b holds only while b sensed nothing, OR rule
    or not; both paths agree, and equal the plain system of the rules that decide."""
    rules = list(system.rules) + [Rule((~1, None), (1,), 1.0, "or")]
    gated = system.replace(rules=rules, unsensed_none=("b",))
    X = _inputs(500, seed=7)
    Y = gated.evaluate(X)
    assert np.array_equal(Y, np.array([gated.evaluate_one(x) for x in X]))
    sensed = ~np.isnan(X[:, 1])
    plain = gated.gated_system([True])[0]
    assert np.array_equal(Y[sensed], plain.evaluate(X[sensed]))
    unsensed = gated.gated_system([False])[0]
    assert np.array_equal(Y[~sensed], unsensed.evaluate(X[~sensed]))
    assert not np.array_equal(Y[~sensed], system.evaluate(X[~sensed]))  # rule 4 counts
    ungated = gated.replace(unsensed_none=())
    assert not np.array_equal(Y[sensed], ungated.evaluate(X[sensed]))  # rule 4 left out


def test_per_row_parameter_sets_give_each_systems_bits(system):
    systems = [system.with_term_params("a", "low", (0.0, 0.0, c)) for c in (10.0, 6.0, 8.0)]
    X = _inputs(600, seed=3)
    groups = np.arange(len(X)) % 3
    got = BatchFuzzy(systems).evaluate(X, groups)
    for k, s in enumerate(systems):
        assert np.array_equal(got[groups == k], s.evaluate(X[groups == k]))


def test_written_back_equal(system):
    assert dumps_fis(system) == FIS
    assert loads_fis(dumps_fis(system)) == system
    toml = dumps_toml(system)
    assert '"IF a IS low OR b IS NOT high THEN u IS lo"' in toml
    back = loads_toml(toml)
    assert back == system
    X = _inputs(200, seed=5)
    assert np.array_equal(back.evaluate(X), system.evaluate(X))


def test_rule_sentences_refuse_what_matlab_cannot_say(system):
    ins, outs = list(system.inputs), list(system.outputs)
    assert parse_rule("IF a is not low or b IS high THEN u IS hi", ins, outs) == Rule(
        (~0, 1), (1,), 1.0, "or"
    )
    for text, fragment in [
        ("IF a IS low OR b IS high OR a IS high THEN u IS hi", "variable 'a' appears twice"),
        ("IF a IS low OR b IS high AND b IS low THEN u IS hi", "mixes AND and OR"),
        ("IF a IS low THEN u IS NOT hi", "NOT is for the antecedent"),
        ("IF a IS NOT NOT low THEN u IS hi", "expected '<variable> IS <term>'"),
    ]:
        with pytest.raises(ValueError, match=fragment):
            parse_rule(text, ins, outs)
    with pytest.raises(ValueError, match="out of range"):
        FuzzySystem(ins, outs, [Rule((~2, None), (0,))])
    with pytest.raises(FisFormatError, match="negated consequents"):
        loads_fis(FIS.replace("2 -1, 2 (1) : 1", "2 -1, -2 (1) : 1"))


def _simpful(system: FuzzySystem):
    """The system in simpful (its OR is max; NOT is 1 - mu); NaN maps to membership 0."""
    import simpful as sf

    def mf(t):
        f = sf.Triangular_MF(*t.params)
        return lambda x: 0.0 if x != x else f(x)

    with contextlib.redirect_stdout(io.StringIO()):
        S = sf.FuzzySystem(show_banner=False, verbose=False)
        for v in system.inputs + system.outputs:
            sets = [sf.FuzzySet(function=mf(t), term=t.name) for t in v.terms]
            S.add_linguistic_variable(
                v.name, sf.LinguisticVariable(sets, universe_of_discourse=list(v.range))
            )
        texts = []
        for r in system.rules:
            used = [(v, k) for v, k in zip(system.inputs, r.antecedent) if k is not None]
            # NOT clauses last: simpful's parser reads a rule that opens with "(NOT" as
            # one clause (AND and OR commute)
            clauses = [f"({v.name} IS {v.terms[k].name})" for v, k in used if k >= 0] + [
                f"(NOT ({v.name} IS {v.terms[~k].name}))" for v, k in used if k < 0
            ]
            joint = f" {r.connection.upper()} "
            (o,) = [k for k in r.consequent]
            w = f" WEIGHT {r.weight!r}" if r.weight != 1.0 else ""
            out = system.outputs[0]
            texts.append(f"IF {joint.join(clauses)} THEN ({out.name} IS {out.terms[o].name}){w}")
        S.add_rules(texts)

    def run(x):
        with contextlib.redirect_stdout(io.StringIO()):
            for v, xi in zip(system.inputs, x):
                S.set_variable(v.name, float(xi))
            return S.Mamdani_inference(subdivisions=system.n_points, ignore_warnings=True)["u"]

    return run


def test_simpful_agrees():
    """simpful (its triangles need a < b < c) on a variant with proper triangles."""
    pytest.importorskip("simpful")
    text = (
        FIS.replace("[0 0 10]", "[-10 0 10]")
        .replace("[0 10 10]", "[0 10 20]")
        .replace("[0 0 0.1]", "[-2 0 4]")
        .replace("[9.9 10 10]", "[6 10 12]")
    )
    system = loads_fis(text)
    run = _simpful(system)
    X = _inputs(40, seed=11)
    X[:, 0] = np.nan_to_num(X[:, 0], nan=5.0)
    for x in X:
        assert system.evaluate_one(x)[0] == pytest.approx(run(x), abs=1e-9), x
