"""Tests of the Mamdani engine (controller.fuzzy), the membership functions
(controller.membership), the TOML rule base (controller.rulebase) and the paper's rule
base (assets/rules/paper.toml).

Oracles: simpful (exact: same grid, agreement <= 1e-9) and scikit-fuzzy (a second opinion
with a looser tolerance). Both are imported here only (test extra)."""

from __future__ import annotations

import contextlib
import io
import math
import pickle
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzzynav.controller import membership as mf
from fuzzynav.controller.fuzzy import FuzzySystem, Rule, Term, Variable
from fuzzynav.controller.rulebase import (
    dumps_toml,
    format_rule,
    loads_toml,
    parse_rule,
    read_toml,
    write_toml,
)

ROOT = Path(__file__).resolve().parents[1]
# The engine's mechanics are tested on the frozen first design: the shipped paper.toml
# is rewritten by `fuzzynav tune`, and its Table 1 rules are checked below as well.
PAPER_TOML = ROOT / "assets" / "rules" / "paper_first_design.toml"
SHIPPED_PAPER_TOML = ROOT / "assets" / "rules" / "paper.toml"
PAPER_TXT = ROOT.parent / "shared" / "paper" / "fuzzy-husky-paper.txt"

nan = float("nan")
inf = float("inf")


@pytest.fixture(scope="module")
def paper() -> FuzzySystem:
    return read_toml(PAPER_TOML)


# =========================================================================== membership


class TestMembershipClosedForms:
    def test_trimf(self):
        p = [1.0, 3.0, 7.0]
        x = np.array([0.0, 1.0, 2.0, 3.0, 5.0, 7.0, 8.0])
        np.testing.assert_array_equal(mf.trimf(x, p), [0, 0, 0.5, 1, 0.5, 0, 0])

    def test_trimf_matlab_edges(self):
        # a == b: 0 left of a, 1 at a, right slope after; b == c mirrored; a == b == c spike
        np.testing.assert_array_equal(
            mf.trimf([-1.0, 0.0, 0.5, 1.0, 2.0], [0, 0, 1]), [0, 1, 0.5, 0, 0]
        )
        np.testing.assert_array_equal(
            mf.trimf([-1.0, 0.0, 0.5, 1.0, 2.0], [0, 1, 1]), [0, 0, 0.5, 1, 0]
        )
        np.testing.assert_array_equal(mf.trimf([0.9, 1.0, 1.1], [1, 1, 1]), [0, 1, 0])

    def test_trapmf(self):
        p = [1.0, 2.0, 4.0, 8.0]
        x = np.array([0.0, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 9.0])
        np.testing.assert_array_equal(mf.trapmf(x, p), [0, 0, 0.5, 1, 1, 1, 0.5, 0, 0])
        # a == b: a step up at a (1 at a); c == d: 1 at d, 0 after
        np.testing.assert_array_equal(mf.trapmf([0.9, 1.0, 5.0, 5.1], [1, 1, 5, 5]), [0, 1, 1, 0])
        # b > c is allowed (MATLAB): a triangle whose top is below 1
        np.testing.assert_allclose(mf.trapmf([2.5], [0, 4, 1, 5]), [min(2.5 / 4, 2.5 / 4)])

    def test_linsmf_linzmf(self):
        x = np.array([-1.0, 0.0, 1.0, 2.0, 3.0])
        np.testing.assert_array_equal(mf.linsmf(x, [0, 2]), [0, 0, 0.5, 1, 1])
        np.testing.assert_array_equal(mf.linzmf(x, [0, 2]), [1, 1, 0.5, 0, 0])
        # a == b (MATLAB docs): linsmf 0 for x < a, 1 for x >= a; linzmf 1 for x < a, 0 for x >= a
        np.testing.assert_array_equal(mf.linsmf([0.9, 1.0, 1.1], [1, 1]), [0, 1, 1])
        np.testing.assert_array_equal(mf.linzmf([0.9, 1.0, 1.1], [1, 1]), [1, 0, 0])

    def test_gaussmf_gauss2mf(self):
        sigma, c = 0.7, 2.0
        x = np.array([2.0, 2.7, 0.6])
        np.testing.assert_allclose(
            mf.gaussmf(x, [sigma, c]), np.exp(-((x - c) ** 2) / (2 * sigma**2)), rtol=1e-15
        )
        assert mf.gaussmf([2.0 + 0.7], [0.7, 2.0])[0] == pytest.approx(math.exp(-0.5), rel=1e-15)
        y = mf.gauss2mf([0.0, 1.0, 1.5, 2.0, 3.0], [0.5, 1.0, 1.0, 2.0])
        np.testing.assert_allclose(y, [math.exp(-2.0), 1, 1, 1, math.exp(-0.5)], rtol=1e-15)

    @pytest.mark.parametrize(
        "shape,params",
        [
            ("trimf", [0, 1, 2]),
            ("trapmf", [0, 1, 2, 3]),
            ("linsmf", [0, 1]),
            ("linzmf", [0, 1]),
            ("gaussmf", [1, 0]),
            ("gauss2mf", [1, 0, 1, 1]),
            ("trimf", [0, 0, 1]),
            ("linsmf", [1, 1]),
        ],
    )
    def test_nan_is_zero_inf_limits(self, shape, params):
        f = mf.SHAPES[shape].func
        assert f([nan], params)[0] == 0.0
        y = f([-inf, inf], params)
        assert np.all(np.isfinite(y)) and np.all((0 <= y) & (y <= 1))
        if shape == "linzmf":
            assert list(y) == [1.0, 0.0]
        if shape == "linsmf":
            assert list(y) == [0.0, 1.0]

    @pytest.mark.parametrize(
        "shape,params,msg",
        [
            ("trimf", [2, 1, 3], "a <= b <= c"),
            ("trapmf", [2, 1, 3, 4], "a <= b"),
            ("linsmf", [2, 1], "a <= b"),
            ("gaussmf", [0, 1], "sigma > 0"),
            ("gaussmf", [1], "takes 2 parameters"),
            ("trimf", [0, nan, 1], "finite"),
            ("bellmf", [1, 2, 3], "unknown membership function shape"),
        ],
    )
    def test_check_params(self, shape, params, msg):
        with pytest.raises(ValueError, match=re.escape(msg)):
            mf.check_params(shape, params)


@st.composite
def shape_and_params(draw):
    shape = draw(st.sampled_from(sorted(mf.SHAPES)))
    fl = st.floats(-50, 50, allow_nan=False)
    if shape == "trimf":
        p = sorted(draw(st.lists(fl, min_size=3, max_size=3)))
    elif shape == "trapmf":
        a, b = sorted(draw(st.lists(fl, min_size=2, max_size=2)))
        c, d = sorted(draw(st.lists(fl, min_size=2, max_size=2)))
        p = [a, b, c, d]
    elif shape in ("linsmf", "linzmf"):
        p = sorted(draw(st.lists(fl, min_size=2, max_size=2)))
    elif shape == "gaussmf":
        p = [draw(st.floats(1e-3, 20)), draw(fl)]
    else:
        p = [draw(st.floats(1e-3, 20)), draw(fl), draw(st.floats(1e-3, 20)), draw(fl)]
    return shape, p


@settings(max_examples=400, deadline=None)
@given(
    sp=shape_and_params(),
    xs=st.lists(
        st.one_of(st.floats(-60, 60), st.sampled_from([nan, inf, -inf, 0.0])),
        min_size=1,
        max_size=30,
    ),
    use_params=st.booleans(),
)
def test_formula_per_row_and_one_by_one_identical(sp, xs, use_params):
    """Each family's one formula, with one parameter set, with the set repeated per row
    and value by value agree to the last bit (the engine's two paths rely on it); the
    parameters themselves are also evaluation points, to hit the edges."""
    shape, p = sp
    x = np.array(xs + (list(p) if use_params else []), dtype=float)
    ref = mf.SHAPES[shape].evaluate(x, p)
    per_row = mf.SHAPES[shape].evaluate(x, np.tile(p, (x.size, 1)))
    sca = np.array([mf.SHAPES[shape].evaluate(np.array([v]), np.array([p]))[0] for v in x])
    assert np.array_equal(ref, per_row), (shape, p, x, ref, per_row)
    assert np.array_equal(ref, sca), (shape, p, x, ref, sca)
    assert np.all((ref >= 0) & (ref <= 1))
    assert np.all(ref[np.isnan(x)] == 0)


# =========================================================================== the paper's rule base

_TERMS = {
    "d_t": ["VS", "S", "M", "L", "VL"],
    "d_o": ["near", "medium", "far"],
    "phi_t": ["VN", "N", "Z", "P", "VP"],
    "phi_o": ["VN", "N", "Z", "P", "VP"],
    "left": ["VS", "S", "M", "L", "VL"],
    "right": ["VS", "S", "M", "L", "VL"],
}


def test_paper_structure(paper):
    assert paper.input_names == ["d_t", "d_o", "phi_t", "phi_o"]
    assert paper.output_names == ["left", "right"]
    ranges = {
        "d_t": (-1.13, 30.0),
        "d_o": (0.0, 3.0),
        "phi_t": (-2 * math.pi, 2 * math.pi),
        "phi_o": (-math.pi, math.pi),
        "left": (-0.28, 14.0),
        "right": (-0.28, 14.0),
    }
    for v in paper.inputs + paper.outputs:
        assert v.range == ranges[v.name]
        assert v.term_names == _TERMS[v.name]
        # the lowest term is a linear Z, the highest a linear S (the paper's shapes)
        assert v.terms[0].shape == "linzmf" and v.terms[-1].shape == "linsmf"
        assert {t.shape for t in v.terms[1:-1]} <= {"trimf", "gaussmf"}
    assert len(paper.rules) == 40
    assert all(r.weight == 1.0 for r in paper.rules)
    assert paper.n_points == 101


def _paper_table() -> list[list[str]]:
    rows = []
    for line in PAPER_TXT.read_text(encoding="utf-8").splitlines():
        f = line.split("\t")
        if len(f) == 8 and f[0].strip().isdigit():
            rows.append([c.strip() for c in f])
    return rows


@pytest.mark.skipif(not PAPER_TXT.exists(), reason="paper text not available")
@pytest.mark.parametrize("path", [PAPER_TOML, SHIPPED_PAPER_TOML], ids=["first_design", "shipped"])
def test_table1_transcription_matches_the_paper(path):
    """Every rule of the paper rule bases against the lines of Table 1 in the paper."""
    paper = read_toml(path)
    rows = _paper_table()
    assert [int(r[0]) for r in rows] == list(range(1, 41))
    assert len(paper.rules) == len(rows)
    variables = paper.inputs + paper.outputs
    for rule, row in zip(paper.rules, rows):
        cells = row[1:7]
        for v, idx, cell in zip(variables, rule.antecedent + rule.consequent, cells):
            got = "NONE" if idx is None else v.terms[idx].name
            assert got.upper() == cell.upper(), (
                f"rule {row[0]}: {v.name} is {got}, table says {cell}"
            )
        assert float(row[7]) == rule.weight, f"rule {row[0]} weight"


def test_sign_convention(paper):
    """phi_t > 0 (target on the left) speeds up the right wheel, and vice versa; an
    obstacle on the left (phi_o > 0) close by speeds up the left wheel."""
    L, R = paper.evaluate_one([10.0, nan, 0.6, 0.0])
    assert R > L + 1.0
    L, R = paper.evaluate_one([10.0, nan, -0.6, 0.0])
    assert L > R + 1.0
    L, R = paper.evaluate_one([10.0, nan, 0.0, 0.0])
    assert L == pytest.approx(R, abs=1e-12)
    # obstacle near, ahead-left, target straight ahead: the turn goes right (left wheel faster)
    L, R = paper.evaluate_one([10.0, 0.3, 0.0, 0.7])
    assert L > R


# =========================================================================== engine semantics


def _random_X(rng, n, nan_frac=0.2):
    X = np.column_stack(
        [
            rng.uniform(-3, 33, n),
            rng.uniform(-0.5, 3.5, n),
            rng.uniform(-7, 7, n),
            rng.uniform(-3.5, 3.5, n),
        ]
    )
    X[rng.random(n) < nan_frac, 1] = nan
    return X


def test_brute_force_reference(paper):
    """evaluate() against a direct, unoptimised transcription of Mamdani min/max/centroid
    (every rule clips its own consequent term; no per-term shortcuts)."""
    rng = np.random.default_rng(1)
    X = _random_X(rng, 300)
    Y = paper.evaluate(X)
    for x, y in zip(X, Y):
        for o, out in enumerate(paper.outputs):
            grid = np.linspace(*out.range, paper.n_points)
            agg = np.zeros_like(grid)
            for r in paper.rules:
                mus = [
                    inp.terms[i](np.array([xi]))[0]
                    for inp, i, xi in zip(paper.inputs, r.antecedent, x)
                    if i is not None
                ]
                w = min(mus) * r.weight
                if r.consequent[o] is not None:
                    agg = np.maximum(agg, np.minimum(w, out.terms[r.consequent[o]](grid)))
            want = (grid * agg).sum() / agg.sum() if agg.sum() > 0 else sum(out.range) / 2
            assert y[o] == pytest.approx(want, abs=1e-12)


_any_input = st.tuples(
    st.one_of(
        st.floats(-40, 60), st.sampled_from([-1.13, 30.0, 0.2, 1.0, 1.5, 3.5, 7.0, 16.0, nan, inf])
    ),
    st.one_of(st.floats(-1, 5), st.sampled_from([0.0, 3.0, 0.5, 1.2, 1.5, 2.6, nan, nan, -inf])),
    st.one_of(st.floats(-10, 10), st.sampled_from([0.0, 0.6, -0.6, 2 * math.pi, nan])),
    st.one_of(st.floats(-5, 5), st.sampled_from([0.0, 0.7, -0.7, math.pi, -math.pi, nan])),
)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(xs=st.lists(_any_input, min_size=1, max_size=25))
def test_evaluate_one_identical_to_batch(paper, xs):
    """Thousands of vectors (300 examples x up to 25): the control-loop path and the
    batch agree to the last bit, whatever the batch size and position in it."""
    batch = paper.evaluate(np.array(xs, dtype=float))
    for i, x in enumerate(xs):
        one = paper.evaluate_one(list(x))
        assert np.array_equal(one, batch[i]), (x, one, batch[i])
        assert np.array_equal(one, paper.evaluate_one(np.array(x)))
    assert np.array_equal(paper.aggregated(list(xs[0])).output, batch[0])


@pytest.mark.parametrize("n", [1, 2, 3, 16, 17, 511, 512, 513, 1025, 16385])
def test_batch_equals_one_by_one_across_block_edges(paper, n):
    rng = np.random.default_rng(n)
    X = _random_X(rng, n)
    Y = paper.evaluate(X)
    idx = rng.choice(n, size=min(n, 300), replace=False)
    for i in idx:
        assert np.array_equal(Y[i], paper.evaluate_one(X[i])), i
    # and the batch does not depend on where it is cut
    if n > 3:
        k = n // 3
        assert np.array_equal(np.vstack([paper.evaluate(X[:k]), paper.evaluate(X[k:])]), Y)


def test_shapes_and_errors(paper):
    assert paper.evaluate(np.empty((0, 4))).shape == (0, 2)
    assert paper.firing_strengths(np.zeros((3, 4))).shape == (3, 40)
    with pytest.raises(ValueError, match="shape"):
        paper.evaluate(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="shape"):
        paper.evaluate(np.zeros(4))
    with pytest.raises(ValueError, match="expected 4 inputs"):
        paper.evaluate_one([1.0, 2.0])


def test_no_rule_fired_gives_middle_of_range(paper):
    mid = (-0.28 + 14.0) / 2
    # every rule uses d_t or d_o: with both unsensed nothing fires
    for x in ([nan, nan, 0.3, 0.2], [nan] * 4):
        np.testing.assert_array_equal(paper.evaluate_one(x), [mid, mid])
        np.testing.assert_array_equal(paper.evaluate(np.array([x])), [[mid, mid]])
        agg = paper.aggregated(x)
        assert not agg.membership.any()
    # a system whose only rule cannot fire, and one whose output term is zero on the grid
    v_in = Variable("x", (0.0, 1.0), (Term("a", "trimf", (0.0, 0.5, 1.0)),))
    v_out = Variable(
        "y",
        (10.0, 20.0),
        (Term("b", "trimf", (11.0, 12.0, 13.0)), Term("thin", "trimf", (15.01, 15.02, 15.03))),
    )
    s = FuzzySystem([v_in], [v_out], [Rule((0,), (0,))])
    assert s.evaluate_one([0.9])[0] == pytest.approx(12.0)
    assert s.evaluate_one([1.5])[0] == 15.0
    assert s.evaluate(np.array([[1.5], [0.5]]))[0, 0] == 15.0
    s2 = FuzzySystem(
        [v_in], [v_out], [Rule((0,), (1,))]
    )  # fires, but the term falls between grid points
    assert s2.evaluate_one([0.5])[0] == 15.0


def test_nan_obstacle_equals_system_without_obstacle_rules(paper):
    """d_o = NaN (nothing sensed) must be exactly the target-only controller."""
    target_only = paper.with_rules(paper.rules[:25])
    rng = np.random.default_rng(2)
    X = _random_X(rng, 2000, nan_frac=1.0)
    np.testing.assert_array_equal(paper.evaluate(X), target_only.evaluate(X))
    F = paper.firing_strengths(X)
    assert not F[:, 25:].any()
    assert F[:, :25].any(axis=1).all()
    # and NaN in d_t with an obstacle sensed: only the obstacle rules fire
    X[:, 0] = nan
    X[:, 1] = rng.uniform(0, 3, len(X))
    F = paper.firing_strengths(X)
    assert not F[:, :25].any()


def test_weights(paper):
    rng = np.random.default_rng(3)
    X = _random_X(rng, 500)
    rules = list(paper.rules)
    # weight 0 is the same as deleting the rule
    zeroed = paper.with_rules(
        [
            Rule(r.antecedent, r.consequent, 0.0) if i in (2, 7, 30) else r
            for i, r in enumerate(rules)
        ]
    )
    removed = paper.with_rules([r for i, r in enumerate(rules) if i not in (2, 7, 30)])
    np.testing.assert_array_equal(zeroed.evaluate(X), removed.evaluate(X))
    # weights scale the firing strengths
    w = rng.uniform(0.1, 1.0, len(rules))
    weighted = paper.with_rules(
        [Rule(r.antecedent, r.consequent, float(wi)) for r, wi in zip(rules, w)]
    )
    np.testing.assert_allclose(
        weighted.firing_strengths(X), paper.firing_strengths(X) * w, rtol=1e-15
    )
    assert not np.allclose(weighted.evaluate(X), paper.evaluate(X))
    for x in X[:200]:
        assert np.array_equal(weighted.evaluate_one(x), weighted.evaluate(x[None])[0])


def test_aggregated(paper):
    x = [4.0, 1.1, 0.3, -0.4]
    agg = paper.aggregated(x)
    assert agg.grid.shape == agg.membership.shape == (2, 101)
    np.testing.assert_array_equal(agg.grid[0], np.linspace(-0.28, 14.0, 101))
    c = (agg.grid * agg.membership).sum(axis=1) / agg.membership.sum(axis=1)
    np.testing.assert_allclose(agg.output, c, rtol=1e-14)
    np.testing.assert_array_equal(agg.output, paper.evaluate_one(x))


def test_n_points_is_used(paper):
    p51 = paper.with_n_points(51)
    x = [4.0, 1.1, 0.3, -0.4]
    assert p51.aggregated(x).grid.shape == (2, 51)
    assert not np.array_equal(p51.evaluate_one(x), paper.evaluate_one(x))


def test_parameter_vector(paper):
    v = paper.parameter_vector()
    names = paper.parameter_names()
    assert len(v) == len(names) == 66
    assert names[0] == "d_t.VS.a" and "phi_t.Z.sigma" in names
    same = paper.with_parameter_vector(v)
    assert same == paper
    v2 = v.copy()
    v2[names.index("left.M.c")] = 8.0
    moved = paper.with_parameter_vector(v2)
    np.testing.assert_array_equal(moved.parameter_vector(), v2)
    assert moved.outputs[0].terms[2].params[-1] == 8.0
    assert moved.outputs[1] == paper.outputs[1] and moved.inputs == paper.inputs
    x = [10.0, nan, 0.0, 0.0]
    assert not np.array_equal(moved.evaluate_one(x), paper.evaluate_one(x))
    bad = v.copy()
    bad[names.index("d_t.S.a")] = 2.0  # a > b for a trimf
    with pytest.raises(ValueError, match="d_t.*S.*a <= b <= c"):
        paper.with_parameter_vector(bad)
    with pytest.raises(ValueError, match="66 entries"):
        paper.with_parameter_vector(v[:-1])
    t = paper.with_term_params("phi_t", "Z", [0.3, 0.0])
    assert t.inputs[2].terms[2].params == (0.3, 0.0)
    with pytest.raises(KeyError):
        paper.with_term_params("phi_t", "nope", [0.3, 0.0])


def test_pickle_round_trip(paper):
    p2 = pickle.loads(pickle.dumps(paper))
    assert p2 == paper
    X = _random_X(np.random.default_rng(4), 100)
    np.testing.assert_array_equal(p2.evaluate(X), paper.evaluate(X))


def test_invalid_systems():
    v = Variable("x", (0, 1), (Term("a", "trimf", (0, 0.5, 1)),))
    o = Variable("y", (0, 1), (Term("b", "trimf", (0, 0.5, 1)),))
    with pytest.raises(ValueError, match="no antecedent"):
        Rule((None,), (0,))
    with pytest.raises(ValueError, match="weight"):
        Rule((0,), (0,), 1.5)
    with pytest.raises(ValueError, match="out of range"):
        FuzzySystem([v], [o], [Rule((1,), (0,))])
    with pytest.raises(ValueError, match="duplicate variable"):
        FuzzySystem([v], [Variable("x", (0, 1), o.terms)], [Rule((0,), (0,))])
    with pytest.raises(ValueError, match="lo < hi"):
        Variable("x", (1, 0), v.terms)


# =========================================================================== simpful oracle


class _NanGuard:
    """simpful cannot express 'NaN = nothing sensed': its MFs map NaN to 0 or, for a
    Trapezoidal_MF with c == d, to 1. Memberships of NaN are 0 by our definition."""

    def __init__(self, f):
        self.f = f

    def __call__(self, x):
        return 0.0 if x != x else self.f(x)


def _simpful_mf(term: Term):
    import simpful as sf

    p = term.params
    if term.shape == "trimf":
        assert p[0] < p[1] < p[2], "simpful's degenerate triangles follow other conventions"
        return sf.Triangular_MF(*p)
    if term.shape == "trapmf":
        return sf.Trapezoidal_MF(*p)
    if term.shape == "linsmf":
        return sf.Trapezoidal_MF(p[0], p[1], p[1], p[1])  # c == d: flat at 1 from b on
    if term.shape == "linzmf":
        return sf.Trapezoidal_MF(p[0], p[0], p[0], p[1])  # a == b: flat at 1 up to a
    if term.shape == "gaussmf":
        return sf.Gaussian_MF(mu=p[1], sigma=p[0])
    raise NotImplementedError(term.shape)


def build_simpful(system: FuzzySystem):
    """The same rule base as a simpful system. A rule with two consequents becomes one
    simpful rule per output (simpful rules have one consequent); NONE inputs are left
    out; weights use simpful's WEIGHT."""
    import simpful as sf

    with contextlib.redirect_stdout(io.StringIO()):
        S = sf.FuzzySystem(show_banner=False, verbose=False)
        for v in system.inputs + system.outputs:
            sets = [sf.FuzzySet(function=_NanGuard(_simpful_mf(t)), term=t.name) for t in v.terms]
            S.add_linguistic_variable(
                v.name, sf.LinguisticVariable(sets, universe_of_discourse=list(v.range))
            )
        texts, owner = [], []
        for r in system.rules:
            clauses = [
                f"({v.name} IS {v.terms[i].name})"
                for v, i in zip(system.inputs, r.antecedent)
                if i is not None
            ]
            ant = clauses[0] if len(clauses) == 1 else f"{clauses[0]} AND {clauses[1]}"
            for c in clauses[2:]:
                ant = f"({ant}) AND {c}"
            for o, (v, k) in enumerate(zip(system.outputs, r.consequent)):
                if k is not None:
                    w = f" WEIGHT {r.weight!r}" if r.weight != 1.0 else ""
                    texts.append(f"IF {ant} THEN ({v.name} IS {v.terms[k].name}){w}")
                    owner.append((o, r.weight))
        S.add_rules(texts)
    return S, owner


def simpful_eval(system: FuzzySystem, S, owner, x):
    with contextlib.redirect_stdout(io.StringIO()):
        for v, xi in zip(system.inputs, x):
            S.set_variable(v.name, float(xi))
        res = S.Mamdani_inference(subdivisions=system.n_points, ignore_warnings=True)
        firing = S.get_firing_strengths()
    out = []
    for o, v in enumerate(system.outputs):
        fired = any(f * w > 0 for f, (oo, w) in zip(firing, owner) if oo == o)
        # simpful returns 0 when nothing fired; MATLAB (and we) return the middle
        out.append(float(res[v.name]) if fired else 0.5 * (v.range[0] + v.range[1]))
    return np.array(out)


_edge_dt = st.sampled_from(
    [-1.13, 30.0, 0.2, 1.0, 0.3, 1.5, 3.0, 3.5, 7.0, 12.0, 8.0, 16.0, -5.0, 40.0]
)
_edge_do = st.sampled_from([0.0, 3.0, 0.5, 1.2, 1.5, 1.8, 2.6, -0.5, 4.0, nan])
_edge_pt = st.sampled_from(
    [0.0, 0.6, -0.6, 1.4, -1.4, 0.8, 1.6, -1.6, 2 * math.pi, -2 * math.pi, 9.0]
)
_edge_po = st.sampled_from([0.0, 0.7, -0.7, 1.5, -1.5, 1.0, 1.8, -1.8, math.pi, -math.pi, -4.0])
_paper_inputs = st.tuples(
    st.one_of(st.floats(-5, 40), _edge_dt),
    st.one_of(st.floats(-0.5, 4), _edge_do, st.just(nan)),
    st.one_of(st.floats(-9, 9), _edge_pt),
    st.one_of(st.floats(-4.5, 4.5), _edge_po),
)


@pytest.fixture(scope="module")
def paper_simpful(paper):
    return build_simpful(paper)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(x=_paper_inputs)
def test_paper_matches_simpful(paper, paper_simpful, x):
    """Same rule base, same 101-point grid: simpful and our engine agree to 1e-9
    (measured ~1e-14; simpful sums in Python order, we in grid order too, the
    linear shapes use algebraically equal but different formulas)."""
    want = simpful_eval(paper, *paper_simpful, x)
    got = paper.evaluate_one(list(x))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1))
def test_perturbed_weighted_system_matches_simpful(paper, seed):
    """A different system with the same structure: parameters moved at random, random
    rule weights, a coarser grid -- still equal to simpful."""
    rng = np.random.default_rng(seed)
    system = paper
    for v in paper.inputs + paper.outputs:
        span = v.range[1] - v.range[0]
        for t in v.terms:
            p = np.array(t.params)
            if t.shape == "gaussmf":
                p = [p[0] * rng.uniform(0.5, 2.0), p[1] + rng.normal(0, 0.05 * span)]
            else:
                p = np.sort(p + rng.normal(0, 0.03 * span))
                if t.shape == "trimf" and not (p[0] < p[1] < p[2]):
                    continue
            system = system.with_term_params(v.name, t.name, [float(q) for q in p])
    system = system.with_rules(
        [
            Rule(r.antecedent, r.consequent, float(rng.choice([1.0, rng.uniform(0, 1)])))
            for r in system.rules
        ]
    ).with_n_points(int(rng.integers(21, 202)))
    S = build_simpful(system)
    X = _random_X(rng, 4, nan_frac=0.3)
    for x in X:
        np.testing.assert_allclose(
            system.evaluate_one(x), simpful_eval(system, *S, x), rtol=0, atol=1e-9
        )
        assert np.array_equal(system.evaluate_one(x), system.evaluate(x[None])[0])


# =========================================================================== scikit-fuzzy


def _skfuzzy_sim(system: FuzzySystem, n_out_universe: int):
    import skfuzzy as fuzz
    from skfuzzy import control as ctrl

    shapes = {
        "trimf": lambda u, p: fuzz.trimf(u, list(p)),
        "trapmf": lambda u, p: fuzz.trapmf(u, list(p)),
        "gaussmf": lambda u, p: fuzz.gaussmf(u, p[1], p[0]),
        "linsmf": lambda u, p: mf.linsmf(u, p),  # skfuzzy has no linear S/Z
        "linzmf": lambda u, p: mf.linzmf(u, p),
    }
    ants, cons = [], []
    for v in system.inputs:
        a = ctrl.Antecedent(np.linspace(*v.range, 6001), v.name)
        for t in v.terms:
            a[t.name] = shapes[t.shape](a.universe, t.params)
        ants.append(a)
    for v in system.outputs:
        c = ctrl.Consequent(
            np.linspace(*v.range, n_out_universe), v.name, defuzzify_method="centroid"
        )
        for t in v.terms:
            c[t.name] = shapes[t.shape](c.universe, t.params)
        cons.append(c)
    rules = []
    for r in system.rules:
        terms = [
            a[v.terms[i].name]
            for a, v, i in zip(ants, system.inputs, r.antecedent)
            if i is not None
        ]
        ant = terms[0]
        for t in terms[1:]:
            ant = ant & t
        rules.append(
            ctrl.Rule(
                ant,
                tuple(c[v.terms[k].name] for c, v, k in zip(cons, system.outputs, r.consequent)),
            )
        )
    return ctrl.ControlSystemSimulation(ctrl.ControlSystem(rules))


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_paper_against_scikit_fuzzy(paper):
    """A second opinion, with a looser tolerance. scikit-fuzzy's centroid is not the
    sampled centroid sum(g*mu)/sum(mu) of MATLAB/simpful/us: it integrates the piecewise-
    linear interpolant of the aggregated set and first adds to the output universe the
    points where each clipping level crosses a term -- i.e. it approximates the centroid
    of the *continuous* aggregated set. On the 101-point grid that differs from the
    sampled centroid by up to ~0.12 V here (steep clipped triangles, 0.14 V grid step);
    both converge to the continuous centroid on fine grids (~6e-4 V with 2001 / 20001
    points). It also interpolates input memberships on a sampled input universe (6001
    points here), clips inputs to the universe (we do not) and raises when nothing
    fires (we return the middle): so inputs in range, no NaN."""
    rng = np.random.default_rng(5)
    n = 25
    X = np.column_stack(
        [
            rng.uniform(-1.13, 30, n),
            rng.uniform(0, 3, n),
            rng.uniform(-2 * math.pi, 2 * math.pi, n),
            rng.uniform(-math.pi, math.pi, n),
        ]
    )
    fine = paper.with_n_points(20001)
    sims = {101: _skfuzzy_sim(paper, 101), 2001: _skfuzzy_sim(paper, 2001)}
    diffs = {101: [], 2001: []}
    for x in X:
        for size, sim in sims.items():
            for v, xi in zip(paper.inputs, x):
                sim.input[v.name] = xi
            sim.compute()
            theirs = np.array([sim.output[v.name] for v in paper.outputs])
            ours = paper.evaluate_one(x) if size == 101 else fine.evaluate_one(x)
            diffs[size].append(np.abs(theirs - ours).max())
    assert max(diffs[101]) < 0.25
    assert max(diffs[2001]) < 2e-3
    assert np.median(diffs[2001]) < np.median(diffs[101])  # the fine grids agree better


# =========================================================================== TOML rule base


def test_toml_round_trip(paper, tmp_path):
    p = tmp_path / "rb.toml"
    write_toml(paper, p)
    back = read_toml(p)
    assert back == paper
    assert back.name == paper.name and back.description == paper.description
    assert [v.unit for v in back.inputs] == ["m", "m", "rad", "rad"]
    X = _random_X(np.random.default_rng(6), 500)
    np.testing.assert_array_equal(back.evaluate(X), paper.evaluate(X))
    # weights survive too
    w = paper.with_rules([Rule(r.antecedent, r.consequent, 0.25) for r in paper.rules])
    assert loads_toml(dumps_toml(w)) == w
    assert "WEIGHT 0.25" in dumps_toml(w)


def test_rule_sentences(paper):
    ins, outs = list(paper.inputs), list(paper.outputs)
    r = parse_rule(
        "if d_o is near and phi_o is Z then right is M and left is VS weight 0.5", ins, outs
    )
    assert r == Rule((None, 0, None, 2), (0, 2), 0.5)
    assert (
        format_rule(paper, r)
        == "IF d_o IS near AND phi_o IS Z THEN left IS VS AND right IS M WEIGHT 0.5"
    )
    for i, rule in enumerate(paper.rules):
        assert parse_rule(paper.rule_text(i), ins, outs) == rule


_GOOD = PAPER_TOML.read_text(encoding="utf-8")


@pytest.mark.parametrize(
    "old,new,fragment",
    [
        ("points = 101", 'points = 101\ncolour = "red"', "key 'system.colour'"),
        ("points = 101", "points = 1", "key 'system.points'"),
        ('defuzzification = "centroid"', 'defuzzification = "median"', "must be one of"),
        ('name = "d_o"', 'name = "d_o"\nspeed = 3', "key 'inputs[1].speed'"),
        (
            '{ name = "near",   shape = "linzmf",  params = [0.5, 1.2] }',
            '{ name = "near",   shape = "zmf",  params = [0.5, 1.2] }',
            "unknown shape",
        ),
        (
            '{ name = "near",   shape = "linzmf",  params = [0.5, 1.2] }',
            '{ name = "near",   shape = "linzmf",  params = [0.5] }',
            "takes 2 parameters",
        ),
        (
            '{ name = "near",   shape = "linzmf",  params = [0.5, 1.2] }',
            '{ name = "near",   shape = "linzmf",  params = [0.5, inf] }',
            "must be finite",
        ),
        (
            '{ name = "near",   shape = "linzmf",  params = [0.5, 1.2] }',
            '{ name = "near",   shape = "linzmf",  params = [0.5, 1.2], colour = 1 }',
            "unknown key",
        ),
        ("range = [0.0, 3.0]", "range = [0.0, nan]", "must be finite"),
        ("range = [0.0, 3.0]", "range = [3.0, 0.0]", "lo < hi"),
        (
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS"',
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS HUGE"',
            "unknown term 'HUGE'",
        ),
        (
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS"',
            '"IF d_x IS VL AND phi_t IS VN THEN left IS L AND right IS VS"',
            "unknown variable 'd_x'",
        ),
        (
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS"',
            '"IF d_t IS VL AND d_o IS NONE THEN left IS L"',
            "leave the input out",
        ),
        (
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS"',
            '"IF d_t IS VL OR phi_t IS VN AND d_o IS near THEN left IS L"',
            "mixes AND and OR",
        ),
        (
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS"',
            '"IF d_t IS VL THEN left IS NOT L"',
            "NOT is for the antecedent",
        ),
        (
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS"',
            '"IF d_t IS VL THEN left IS L OR right IS VS"',
            "joins its outputs with AND",
        ),
        (
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS"',
            '"IF d_t IS NOT THEN left IS L"',
            "unknown term 'NOT'",
        ),
        (
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS"',
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L WEIGHT 2"',
            "not in [0, 1]",
        ),
        (
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS"',
            '"IF left IS VL THEN right IS VS"',
            "is an output",
        ),
        (
            '"IF d_t IS VL AND phi_t IS VN THEN left IS L AND right IS VS"',
            '"IF d_t IS VL AND d_t IS VS THEN left IS L"',
            "appears twice",
        ),
        ("[rulebase]", "[rulebase]\nextra = 1", "key 'rulebase.extra'"),
        ("[rulebase]", "[rulez]", "key 'rulez'"),
        ('[[outputs]]\nname = "right"', '[[outputz]]\nname = "right"', "key 'outputz'"),
        ('name = "d_t"', 'name = "d t"', "must be a name"),
    ],
)
def test_malformed_toml(fragment, old, new):
    assert old in _GOOD
    text = _GOOD.replace(old, new, 1)
    with pytest.raises(ValueError) as e:
        loads_toml(text, "bad.toml")
    msg = str(e.value)
    assert msg.startswith("bad.toml"), msg
    assert fragment in msg, msg


def test_toml_syntax_error_names_file(tmp_path):
    p = tmp_path / "broken.toml"
    p.write_text("[system\nname = 1\n")
    with pytest.raises(ValueError, match="broken.toml: not valid TOML"):
        read_toml(p)


@pytest.mark.parametrize(
    "change", [{}, {"and_method": "prod"}, {"defuzz_method": "bisector"}, {"agg_method": "sum"}]
)
def test_aggregated_many_is_aggregated_row_by_row(change):
    """The recording's inference view takes every decision's aggregated outputs through
    the batch path (row by row was most of a paper run's recording): the same bits, NaN
    inputs (nothing sensed) included, for the default and the plain inference."""
    import dataclasses

    from fuzzynav.controller.registry import make_controller

    fis = make_controller("paper").fis
    fis = fis.replace(inference=dataclasses.replace(fis.inference, **change))
    rng = np.random.default_rng(3)
    X = np.column_stack(
        [
            rng.uniform(0, 15, 700),
            rng.uniform(0, 3, 700),
            rng.uniform(-3.2, 3.2, 700),
            rng.uniform(-3.2, 3.2, 700),
        ]
    )
    X[::5, 1] = X[::5, 3] = np.nan
    grids, memberships, outputs = fis.aggregated_many(X)
    assert memberships.shape == (700, 2, fis.n_points) and outputs.shape == (700, 2)
    for i in range(len(X)):
        one = fis.aggregated(X[i])
        assert np.array_equal(one.grid, grids)
        assert np.array_equal(one.membership, memberships[i]), i
        assert np.array_equal(one.output, outputs[i]), i
    assert np.array_equal(outputs, fis.evaluate(X))
