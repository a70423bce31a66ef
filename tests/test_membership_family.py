"""The membership-function families are one table (controller.membership.SHAPES):
every family's one formula gives the same bits with one parameter set and with one per
row (the single-row path evaluates a family's terms as rows); and a new family added to
the table at run time is taken by the single-row and batch paths, the batch engine and
the rule-base and .fis formats with no other change."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzynav.controller import membership as mf
from fuzzynav.controller.fis import dumps_fis, loads_fis
from fuzzynav.controller.fuzzy import FuzzySystem, Rule, Term, Variable
from fuzzynav.controller.fuzzy_batch import BatchFuzzy
from fuzzynav.controller.rulebase import dumps_toml, loads_toml

BUILT_IN = sorted(mf.SHAPES)


def _grid(params) -> np.ndarray:
    """Points around and between the parameters, the parameters themselves, +-inf, NaN."""
    lo, hi = min(params) - 3.0, max(params) + 3.0
    near = [np.nextafter(p, q) for p in params for q in (-np.inf, np.inf)]
    return np.concatenate(
        [np.linspace(lo, hi, 601), params, near, [-np.inf, np.inf, np.nan, 0.0, -0.0]]
    )


def _same_bits(shape: mf.Shape, params) -> None:
    x = _grid(params)
    ref = shape.evaluate(x, params)
    one_by_one = [shape.evaluate(np.array([v]), np.array([params]))[0] for v in x]
    assert np.array_equal(ref, one_by_one), (shape.name, params)
    per_row = shape.evaluate(x, np.tile(params, (x.size, 1)))
    assert np.array_equal(ref, per_row), (shape.name, params)
    two_d = shape.evaluate(np.column_stack([x, x]), np.tile(params, (x.size, 1)))
    assert np.array_equal(two_d, np.column_stack([ref, ref])), (shape.name, params)
    assert np.all((ref >= 0.0) & (ref <= 1.0)) and ref[np.isnan(x)].tolist() == [0.0]


@pytest.mark.parametrize("name", BUILT_IN)
def test_every_family_has_examples_and_gives_the_same_bits_per_row(name):
    shape = mf.SHAPES[name]
    assert shape.examples, f"{name} lists no example parameters"
    for params in shape.examples:
        mf.check_params(name, params)
        _same_bits(shape, params)


def test_per_row_parameters_mix_ordinary_and_degenerate_sets():
    """One call, a different set on every row (degenerate sides among them): each row is
    the value its set gives alone."""
    for name in BUILT_IN:
        shape = mf.SHAPES[name]
        sets = np.array(shape.examples)
        rng = np.random.default_rng(len(name))
        x = _grid(sets.ravel())
        rows = rng.integers(0, len(sets), x.size)
        got = shape.evaluate(x, sets[rows])
        alone = np.array([shape.evaluate(x[i : i + 1], sets[k])[0] for i, k in enumerate(rows)])
        assert np.array_equal(got, alone), name


# ------------------------------------------------------------ a new family, at run time


def _cosmf(x, c, w):
    u = (x - c) / w
    y = 0.5 + 0.5 * np.cos(3.141592653589793 * u)
    return np.where(np.abs(u) < 1.0, y, 0.0)


COSMF = mf.Shape(
    "cosmf",
    ("c", "w"),
    "w > 0",
    _cosmf,
    "raised cosine: centre c, half-width w",
    examples=((0.0, 1.0), (2.5, 0.3)),
    centre="c",
)


@pytest.fixture
def cosmf():
    mf.register_shape(COSMF)
    yield COSMF
    del mf.SHAPES["cosmf"]


def _system(centre: float = 0.0) -> FuzzySystem:
    """Two inputs, one of them with a raised-cosine term; an output with one as well."""
    a = Variable(
        "a",
        (-2.0, 2.0),
        (
            Term("low", "linzmf", (-1.0, 0.0)),
            Term("mid", "cosmf", (centre, 1.0)),
            Term("high", "linsmf", (0.0, 1.0)),
        ),
    )
    b = Variable(
        "b", (0.0, 1.0), (Term("near", "linzmf", (0.2, 0.6)), Term("far", "trimf", (0.2, 1.0, 1.0)))
    )
    out = Variable(
        "u",
        (-1.0, 1.0),
        (
            Term("neg", "trimf", (-1.0, -1.0, 0.0)),
            Term("zero", "cosmf", (0.0, 0.5)),
            Term("pos", "trimf", (0.0, 1.0, 1.0)),
        ),
    )
    rules = [
        Rule((0, None), (0,)),
        Rule((1, 1), (1,)),
        Rule((1, 0), (0,)),
        Rule((2, None), (2,), 0.75),
    ]
    return FuzzySystem([a, b], [out], rules, name="cos")


def _inputs(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    X = np.column_stack([rng.uniform(-2.5, 2.5, n), rng.uniform(0.0, 1.0, n)])
    X[rng.random(n) < 0.1, 1] = np.nan
    X[:4, 0] = [0.0, 1.0, -1.0, 0.5]  # the centre, both feet, half height
    return X


def test_a_new_family_is_checked_and_evaluated_from_its_table_entry(cosmf):
    assert mf.SHAPES["cosmf"].evaluate(
        [0.0, 0.5, 1.0, np.nan], [0.0, 1.0]
    ).tolist() == pytest.approx([1.0, 0.5, 0.0, 0.0], abs=1e-15)
    with pytest.raises(ValueError, match=r"cosmf needs w > 0"):
        Term("bad", "cosmf", (0.0, 0.0))
    for params in cosmf.examples:
        _same_bits(cosmf, params)


def test_the_scalar_engine_takes_a_new_family(cosmf):
    system = _system()
    X = _inputs(400)
    Y = system.evaluate(X)  # the batch path of the engine
    one = np.array([system.evaluate_one(x) for x in X])  # the single-row path
    assert np.array_equal(Y, one)
    mu = system.memberships(X)[0][:, 1]
    assert mu[0] == 1.0 and mu[1] == 0.0 and mu[2] == 0.0 and mu[3] == pytest.approx(0.5)
    # the rule with the cosine term fires at its membership: a row at its centre with b far
    assert system.firing_strengths([[0.0, 1.0]])[0, 1] == 1.0
    assert np.isfinite(Y).all()


def test_the_batch_engine_takes_a_new_family_with_parameters_per_row(cosmf):
    systems = [_system(c) for c in (0.0, 0.4, -0.7)]
    X = _inputs(300, seed=1)
    groups = np.arange(len(X)) % len(systems)
    got = BatchFuzzy(systems).evaluate(X, groups)
    for k, system in enumerate(systems):
        assert np.array_equal(got[groups == k], system.evaluate(X[groups == k]))


def test_the_rule_base_and_fis_formats_round_trip_a_new_family(cosmf):
    system = _system(0.25)
    X = _inputs(200, seed=2)
    from_toml = loads_toml(dumps_toml(system))
    text = dumps_fis(system)
    assert "'mid':'cosmf',[0.25 1]" in text
    from_fis = loads_fis(text)
    for back in (from_toml, from_fis):
        assert back == system
        assert np.array_equal(back.evaluate(X), system.evaluate(X))


def test_registration_refuses_a_taken_name_and_a_family_matlab_does_not_know(cosmf, monkeypatch):
    with pytest.raises(ValueError, match="registered already"):
        mf.register_shape(COSMF)
    twin = mf.Shape("cos2", ("c", "w"), "w > 0", _cosmf, "twin", matlab="cosmf")
    with pytest.raises(ValueError, match="MATLAB name 'cosmf' belongs to 'cosmf'"):
        mf.register_shape(twin)
    own = mf.Shape("ownmf", ("c", "w"), "w > 0", _cosmf, "ours only", matlab=None)
    monkeypatch.setitem(mf.SHAPES, "ownmf", own)
    system = _system().with_term_params("a", "mid", (0.0, 1.0), shape="ownmf")
    assert np.array_equal(system.evaluate(_inputs(50)), _system().evaluate(_inputs(50)))
    with pytest.raises(ValueError, match="MATLAB has no ownmf"):
        dumps_fis(system)
    with pytest.raises(ValueError, match="unsupported membership function type 'ownmf'"):
        loads_fis(dumps_fis(_system()).replace("cosmf", "ownmf"))


def test_the_design_rules_read_centre_and_ramps_from_the_table():
    from fuzzynav.controller.design_rules import centre

    assert centre(Term("t", "trimf", (0.0, 1.0, 3.0))) == 1.0
    assert centre(Term("z", "linzmf", (0.5, 2.0))) == 0.5
    assert mf.SHAPES["trimf"].ramps_of((0.0, 1.0, 3.0)) == (1.0, 2.0)
    with pytest.raises(ValueError, match="has no centre"):
        centre(Term("t", "trapmf", (0.0, 1.0, 2.0, 3.0)))


def test_a_family_s_expressions_are_parsed_not_run():
    """The conditions, centres and ramps are read by a small walker: a call, an
    attribute or an unknown name is refused when the family is made."""
    for requires in ("__import__('os').getcwd()", "w.real > 0", "q > 0", "[w][0] > 0"):
        with pytest.raises(ValueError, match="expression"):
            mf.Shape("bad", ("c", "w"), requires, _cosmf, "refused")
    shape = mf.Shape("ok", ("c", "w"), "not w <= 0 and -1 < c / w < 1 or c == 0", _cosmf, "ok")
    assert shape.holds((0.5, 1.0)) and not shape.holds((2.0, 1.0)) and shape.holds((0.0, -1.0))
    assert mf.Shape("r", ("c", "w"), "w > 0", _cosmf, "r", ramps="(w - c, 2 * w)").ramps_of(
        (1.0, 3.0)
    ) == (2.0, 6.0)
