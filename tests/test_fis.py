"""MATLAB .fis reader/writer (controller.fis)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from fuzzynav.controller.fis import FisFormatError, dumps_fis, loads_fis, read_fis, write_fis
from fuzzynav.controller.fuzzy import FuzzySystem, Rule, Term, Variable
from fuzzynav.controller.rulebase import read_toml

ROOT = Path(__file__).resolve().parents[1]
# The Husky twin. Its rule base reads Table 1's NONE as the text does, which a .fis cannot
# say (the export is refused: tests/test_none_reading.py); with MATLAB's NONE it is a
# system a .fis can hold, the one these tests write.
PAPER_TOML = ROOT / "assets" / "rules" / "paper_husky.toml"
nan = float("nan")


@pytest.fixture(scope="module")
def paper() -> FuzzySystem:
    return read_toml(PAPER_TOML).replace(unsensed_none=())


def _X(n, seed=0):
    rng = np.random.default_rng(seed)
    X = np.column_stack(
        [
            rng.uniform(-3, 33, n),
            rng.uniform(-0.5, 3.5, n),
            rng.uniform(-7, 7, n),
            rng.uniform(-3.5, 3.5, n),
        ]
    )
    X[rng.random(n) < 0.2, 1] = nan
    return X


def test_round_trip_paper(paper, tmp_path):
    p = tmp_path / "paper.fis"
    write_fis(paper, p)
    back = read_fis(p)
    assert back == paper
    assert back.name == paper.name
    X = _X(3000)
    np.testing.assert_array_equal(back.evaluate(X), paper.evaluate(X))
    # and writing again gives the same text
    assert dumps_fis(back) == p.read_text()


def test_paper_fis_text(paper):
    text = dumps_fis(paper)
    assert "Type='mamdani'" in text and "DefuzzMethod='centroid'" in text
    assert "Range=[-1.13 30]" in text
    a, b = paper.inputs[0].terms[0].params
    assert f"MF1='VS':'linzmf',[{a!r} {b!r}]".replace(".0 ", " ").replace(".0]", "]") in text
    rules = text.split("[Rules]\n")[1].strip().splitlines()
    assert len(rules) == 40
    assert rules[0] == "5 0 1 0, 4 1 (1) : 1"  # VL NONE VN NONE -> L VS
    assert rules[3] == "5 0 4 0, 1 3 (1) : 1"  # VL NONE P NONE -> VS M
    assert rules[39] == "0 3 0 5, 4 4 (1) : 1"  # NONE far NONE VP -> L L


def test_round_trip_other_features():
    """Weights, NONE consequents, trapmf, gauss2mf, degenerate shapes, odd numbers."""
    x = Variable(
        "x",
        (-1.0, 1.0),
        (
            Term("lo", "trapmf", (-1.0, -1.0, -0.5, 0.0)),
            Term("hi", "gauss2mf", (0.2, 0.3, 0.1, 0.5)),
            Term("spike", "trimf", (0.1, 0.1, 0.1)),
        ),
    )
    y = Variable(
        "y", (0.0, 1e-3), (Term("a", "linzmf", (1e-4, 3.3e-4)), Term("b", "linsmf", (2e-4, 2e-4)))
    )
    y2 = Variable("y2", (-5.0, 5.0), (Term("c", "gaussmf", (1 / 3, 0.1)),))
    s = FuzzySystem(
        [x],
        [y, y2],
        [Rule((0,), (0, None), 0.3), Rule((1,), (1, 0), 1.0), Rule((2,), (None, 0), 0.0)],
        name="odd system",
    )
    back = loads_fis(dumps_fis(s))
    assert back == s
    X = np.linspace(-1.2, 1.2, 241)[:, None]
    np.testing.assert_array_equal(back.evaluate(X), s.evaluate(X))


MATLAB_STYLE = """[System]
Name='tipper'
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
Name='service'
Range=[0 10]
NumMFs=3
MF1='poor':'gaussmf',[1.5 0]
MF2='good':'gaussmf',[1.5 5]
MF3='excellent':'gaussmf',[1.5 10]

[Input2]
Name='food'
Range=[0 10]
NumMFs=2
MF1='rancid':'trapmf',[0 0 1 3]
MF2='delicious':'trapmf',[7 9 10 10]

[Output1]
Name='tip'
Range=[0 30]
NumMFs=3
MF1='cheap':'trimf',[0 5 10]
MF2='average':'trimf',[10 15 20]
MF3='generous':'trimf',[20 25 30]

[Rules]
1 1, 1 (1) : 1
2 0, 2 (1) : 1
3 2, 3 (0.5) : 1
"""


def test_reads_matlab_style_file(tmp_path):
    p = tmp_path / "tipper.fis"
    p.write_text(MATLAB_STYLE)
    s = read_fis(p)
    assert s.name == "tipper" and s.input_names == ["service", "food"] and s.output_names == ["tip"]
    assert s.inputs[1].terms[1] == Term("delicious", "trapmf", (7.0, 9.0, 10.0, 10.0))
    assert s.rules[1] == Rule((1, None), (1,), 1.0)
    assert s.rules[2].weight == 0.5
    assert s.n_points == 101
    # a hand check: service exactly 'good' (5), food nowhere: only rule 2 fires, fully
    assert s.evaluate_one([5.0, 5.0])[0] == pytest.approx(15.0, abs=1e-12)


# (text to replace, replacement, expected message fragment, line number or None)
BAD = [
    ("Type='mamdani'", "Type='sugeno'", "only Mamdani", 3),
    # prod, probor, sum, bisector, mom, som and lom are read since issue 27: only
    # MATLAB's custom (user function) methods are refused
    ("AndMethod='min'", "AndMethod='myand'", "unsupported AndMethod 'myand'", 8),
    ("OrMethod='max'", "OrMethod='sum'", "unsupported OrMethod", 9),
    ("ImpMethod='min'", "ImpMethod='max'", "unsupported ImpMethod", 10),
    ("AggMethod='max'", "AggMethod='min'", "unsupported AggMethod", 11),
    (
        "DefuzzMethod='centroid'",
        "DefuzzMethod='wtaver'",
        "unsupported DefuzzMethod 'wtaver'",
        12,
    ),
    ("Version=2.0", "Version=3.0", "unsupported Version", 4),
    ("NumRules=3", "NumRules=4", "NumRules=4 but the [Rules] section has 3", 37),
    (
        "MF3='excellent':'gaussmf',[1.5 10]",
        "MF3='excellent':'gbellmf',[2 4 10]",
        "unsupported membership function type 'gbellmf'",
        20,
    ),
    (
        "MF3='excellent':'gaussmf',[1.5 10]",
        "MF3='excellent':'gaussmf',[1.5 1..0]",
        "not a number",
        20,
    ),
    (
        "MF3='excellent':'gaussmf',[1.5 10]",
        "MF3='excellent':'gaussmf',[1.5 NaN]",
        "not a number",
        20,
    ),
    (
        "MF3='excellent':'gaussmf',[1.5 10]",
        "MF3='excellent':'gaussmf',[1.5]",
        "takes 2 parameters",
        20,
    ),
    ("MF3='excellent':'gaussmf',[1.5 10]", "MF3='excellent':'gaussmf',[-1.5 10]", "sigma > 0", 20),
    (
        "MF3='excellent':'gaussmf',[1.5 10]",
        "MF4='excellent':'gaussmf',[1.5 10]",
        "expected MF1..MF3",
        17,
    ),
    (
        "MF1='cheap':'trimf',[0 5 10]",
        "MF1='cheap':'trimf',[0 5 10",
        "expected 'name':'type',[params]",
        33,
    ),
    ("Range=[0 30]", "Range=[30 0]", "lo < hi", 31),
    ("Range=[0 30]", "Range=[0 1e999]", "not a finite number", 31),
    ("NumMFs=2", "NumMFs=two", "not an integer", 25),
    # a count below 1 was read, then reported as sections [Input1]..[Input-2] missing
    ("NumMFs=2", "NumMFs=-2", "NumMFs: must be at least 1", 25),
    ("NumInputs=2", "NumInputs=-2", "NumInputs: must be at least 1", 5),
    ("NumOutputs=1", "NumOutputs=0", "NumOutputs: must be at least 1", 6),
    ("Name='food'", "Name='food'\nColor='red'", "unknown [Input2] key 'Color'", 24),
    ("Name='tipper'", "Name='tipper'\nDisableStructuralChecks=0", "unknown [System] key", 3),
    ("1 1, 1 (1) : 1", "1 1, 1 (1) : 1\n\n", None, None),  # blank lines are fine (control)
    ("2 0, 2 (1) : 1", "2 1, 2 (1) : 0", "connection must be 1 (AND) or 2 (OR)", 39),
    ("2 0, 2 (1) : 1", "-4 0, 2 (1) : 1", "term index -4 out of range for input 'service'", 39),
    ("2 0, 2 (1) : 1", "2 0, -2 (1) : 1", "negated consequents", 39),
    ("2 0, 2 (1) : 1", "4 0, 2 (1) : 1", "term index 4 out of range for input 'service'", 39),
    ("2 0, 2 (1) : 1", "2 0 1, 2 (1) : 1", "3 antecedent indices", 39),
    ("2 0, 2 (1) : 1", "2 0, 2 (1.5) : 1", "rule weight must be in [0, 1]", 39),
    ("2 0, 2 (1) : 1", "2 0, 2 : 1", "expected a rule like", 39),
    ("2 0, 2 (1) : 1", "0 0, 2 (1) : 1", "no antecedent", 39),
    ("[Output1]", "[Output2]", "expected sections [Output1]..[Output1]", 29),
    ("[Rules]", "[Rulez]", "unknown section", 37),
    ("[System]\n", "junk\n[System]\n", "text before the first [section]", 1),
]


@pytest.mark.parametrize("old,new,fragment,line", BAD)
def test_malformed_fis(tmp_path, old, new, fragment, line):
    assert old in MATLAB_STYLE
    p = tmp_path / "bad.fis"
    p.write_text(MATLAB_STYLE.replace(old, new, 1))
    if fragment is None:
        read_fis(p)
        return
    with pytest.raises(FisFormatError) as e:
        read_fis(p)
    msg = str(e.value)
    assert fragment in msg, msg
    assert msg.startswith(f"{p}:{line}:" if line else f"{p}:"), msg
    assert isinstance(e.value, ValueError)


def test_a_huge_term_index_is_named_in_one_short_line(paper):
    """``MF<6000 digits>=...``: the error names the line and the key, cut to one line
    (found by tests/test_fuzz_parsers.py's mutations of the twin's text)."""
    text = dumps_fis(paper).replace("MF4='L'", "MF" + "1" * 6000 + "5='L'", 1)
    with pytest.raises(FisFormatError) as caught:
        loads_fis(text, source="huge.fis")
    message = str(caught.value)
    assert message.startswith("huge.fis:") and "too large (at most" in message
    assert len(message) < 400


def test_missing_file_and_sections(tmp_path):
    with pytest.raises(FisFormatError, match="cannot read"):
        read_fis(tmp_path / "nope.fis")
    with pytest.raises(FisFormatError, match=re.escape("exactly one [Rules] section")):
        loads_fis(MATLAB_STYLE.split("[Rules]")[0], "x.fis")


def test_never_evaluates(tmp_path):
    """Values are parsed, not evaluated: an expression is just a bad number."""
    text = MATLAB_STYLE.replace("Range=[0 10]", "Range=[0 __import__('os').getpid()]", 1)
    with pytest.raises(FisFormatError, match="not a number"):
        loads_fis(text, "evil.fis")
    text = MATLAB_STYLE.replace("Name='tipper'", "Name='__import__(\"os\")'", 1)
    assert loads_fis(text).name == '__import__("os")'


def test_writer_rejects_unwritable_names(paper):
    s = paper.with_rules(paper.rules)
    s.name = "it's"
    with pytest.raises(ValueError, match="quote"):
        dumps_fis(s)


def test_numbers_round_trip_exactly():
    vals = [math.pi, -1 / 3, 1e-300, 123456789.123456789, 0.1 + 0.2]
    x = Variable(
        "x",
        (-400.0, 1e9),
        tuple(Term(f"t{i}", "gaussmf", (abs(v) or 1.0, v)) for i, v in enumerate(vals)),
    )
    y = Variable("y", (0.0, 1.0), (Term("a", "trimf", (0.0, 0.5, 1.0)),))
    s = FuzzySystem([x], [y], [Rule((i,), (0,)) for i in range(len(vals))])
    back = loads_fis(dumps_fis(s))
    assert [t.params for t in back.inputs[0].terms] == [t.params for t in s.inputs[0].terms]
