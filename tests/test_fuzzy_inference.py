"""Issue 27: the inference choices (controller/inference.py) against independent evaluators.

* simpful 2.12 (test extra) covers AND min|prod x aggregation max|sum|probor with min
  implication and centroid: its Mamdani inference takes the same 101-point grid, so the
  two agree to 1e-9 V (measured: at most 9.3e-15 V).
* Implication prod and the other defuzzifications, which simpful does not offer, are
  checked against a reference built from scikit-fuzzy 0.5 (test extra): its membership
  functions on the input values and on the output grid, numpy for the AND, the
  implication and the fold over the rules, and ``skfuzzy.defuzz`` for mom, som, lom and
  bisector (its centroid integrates the continuous set, so the centroid is MATLAB's sum
  formula on that aggregate: 1e-9 V, measured 1.3e-14 V). mom agrees to 1e-9 V
  (measured 1.8e-15 V); som and lom are MATLAB's "smallest / largest in magnitude", so
  ``|ours|`` is compared with skfuzzy's som / lom over ``|grid|`` (1e-9 V, measured 0)
  and ours must be a maximiser of the reference aggregate; the bisector is the same grid
  point (see :func:`_bisector_by_skfuzzy`: skfuzzy's own bisector cuts the continuous
  set, up to 4 grid steps away here, and goes wrong after a stretch of zero membership).
* MATLAB's own documented examples pin what skfuzzy does not share: SOM/LOM by
  magnitude (-2 and -8 on the "Defuzzification Methods" example, where skfuzzy says -8
  and -2), the discrete bisector, the defuzz page's centroid.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import math
import pickle
from pathlib import Path

import numpy as np
import pytest

from fuzzynav.controller import membership as mf
from fuzzynav.controller.fis import FisFormatError, dumps_fis, loads_fis
from fuzzynav.controller.fuzzy import FuzzySystem, Rule
from fuzzynav.controller.fuzzy_batch import BatchFuzzy
from fuzzynav.controller.inference import CHOICES, Inference, defuzzify
from fuzzynav.controller.rulebase import dumps_toml, loads_toml, read_toml

ROOT = Path(__file__).resolve().parents[1]
PAPER_TOML = ROOT / "assets" / "rules" / "paper_first_design.toml"
METHODS = CHOICES["defuzz_method"]
COMBOS = list(
    itertools.product(CHOICES["and_method"], CHOICES["imp_method"], CHOICES["agg_method"])
)


@pytest.fixture(scope="module")
def paper() -> FuzzySystem:
    """The frozen first design with random rule weights (so the weights take part)."""
    system = read_toml(PAPER_TOML)
    rng = np.random.default_rng(27)
    return system.with_rules(
        [
            Rule(r.antecedent, r.consequent, float(rng.choice([1.0, rng.uniform(0.2, 1.0)])))
            for r in system.rules
        ]
    )


def _inputs(n: int, seed: int, nan_frac: float = 0.2) -> np.ndarray:
    rng = np.random.default_rng(seed)
    X = np.column_stack(
        [
            rng.uniform(-1.13, 30, n),
            rng.uniform(0, 3, n),
            rng.uniform(-2 * math.pi, 2 * math.pi, n),
            rng.uniform(-math.pi, math.pi, n),
        ]
    )
    X[rng.random(n) < nan_frac, 1] = np.nan  # nothing sensed
    return X


# ============================================================ MATLAB's documented examples


def test_defuzz_on_matlabs_defuzzification_methods_example():
    """MATLAB's 'Defuzzification Methods' example: x = -10:0.1:10, a plateau at 0.9 from
    -8 to -2; MATLAB gives MOM -5, SOM -2, LOM -8 (smallest / largest in magnitude).
    scikit-fuzzy's som / lom are the smallest / largest value: -8 and -2."""
    import skfuzzy as fuzz

    x = np.linspace(-10, 10, 201)
    m1 = mf.trapmf(x, [-10, -8, -2, 2])
    m2 = mf.trapmf(x, [-5, -3, 2, 4])
    m3 = mf.trapmf(x, [2, 3, 8, 9])
    agg = np.maximum(0.5 * m2, np.maximum(0.9 * m1, 0.1 * m3))[:, None]
    got = {m: float(defuzzify(m, x, agg, 0.0)[0]) for m in METHODS}
    assert got["mom"] == pytest.approx(-5.0, abs=1e-12)
    assert got["som"] == pytest.approx(-2.0, abs=1e-12)
    assert got["lom"] == pytest.approx(-8.0, abs=1e-12)
    assert fuzz.defuzz(x, agg[:, 0], "som") == pytest.approx(-8.0)  # the other convention
    assert fuzz.defuzz(x, agg[:, 0], "lom") == pytest.approx(-2.0)
    # the bisector is a grid point, and the centroid MATLAB's sum formula
    assert np.isclose(x, got["bisector"], rtol=0, atol=1e-12).any()
    assert got["centroid"] == pytest.approx(np.sum(x * agg[:, 0]) / np.sum(agg), abs=1e-12)


def test_centroid_on_matlabs_defuzz_page_example():
    """MATLAB's defuzz page: x = -10:0.1:10, trapmf [-10 -8 -4 7], centroid -3.2857."""
    x = np.linspace(-10, 10, 201)
    agg = mf.trapmf(x, [-10, -8, -4, 7])[:, None]
    assert defuzzify("centroid", x, agg, 0.0)[0] == pytest.approx(-3.2857, abs=5e-5)


def test_bisector_som_lom_definitions_by_hand():
    x = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
    # running sums 0, 1, 2, 3, 3 of a total 3: the first to reach 1.5 is at x = 0
    assert defuzzify("bisector", x, np.array([[0.0, 1, 1, 1, 0]]).T, 9.0)[0] == 0.0
    # 1, 1, 2 of 2: reached at the first point already
    assert defuzzify("bisector", x, np.array([[1.0, 0, 0, 0, 1]]).T, 9.0)[0] == -2.0
    # a tie in magnitude (-1 and 1 both maximal): the first, as MATLAB's loop keeps
    peaks = np.array([[0.0, 1, 0, 1, 0]]).T
    assert defuzzify("som", x, peaks, 9.0)[0] == -1.0
    assert defuzzify("lom", x, peaks, 9.0)[0] == -1.0
    assert defuzzify("mom", x, peaks, 9.0)[0] == 0.0
    # nothing anywhere: the middle of the range, whatever the method
    for method in METHODS:
        assert defuzzify(method, x, np.zeros((5, 1)), 9.0)[0] == 9.0


# ============================================================ simpful: AND x aggregation


def _simpful_system(system: FuzzySystem, and_method: str):
    """The rule base in simpful (one rule per output; NONE inputs left out)."""
    import simpful as sf

    def shape(term):
        p = term.params
        if term.shape == "trimf":
            return sf.Triangular_MF(*p)
        if term.shape == "trapmf":
            return sf.Trapezoidal_MF(*p)
        if term.shape == "linsmf":
            return sf.Trapezoidal_MF(p[0], p[1], p[1], p[1])
        if term.shape == "linzmf":
            return sf.Trapezoidal_MF(p[0], p[0], p[0], p[1])
        if term.shape == "gaussmf":
            return sf.Gaussian_MF(mu=p[1], sigma=p[0])
        raise NotImplementedError(term.shape)

    class NanIsZero:  # our convention: nothing sensed
        def __init__(self, f):
            self.f = f

        def __call__(self, x):
            return 0.0 if x != x else self.f(x)

    operators = ["AND_PRODUCT"] if and_method == "prod" else None
    with contextlib.redirect_stdout(io.StringIO()):
        S = sf.FuzzySystem(show_banner=False, verbose=False, operators=operators)
        for v in system.inputs + system.outputs:
            sets = [sf.FuzzySet(function=NanIsZero(shape(t)), term=t.name) for t in v.terms]
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
            ant = clauses[0]
            for c in clauses[1:]:
                ant = f"({ant}) AND {c}" if ant != clauses[0] else f"{ant} AND {c}"
            for o, (v, k) in enumerate(zip(system.outputs, r.consequent)):
                if k is not None:
                    texts.append(
                        f"IF {ant} THEN ({v.name} IS {v.terms[k].name}) WEIGHT {r.weight!r}"
                    )
                    owner.append(o)
        S.add_rules(texts)
    return S, owner


@pytest.mark.parametrize("and_method", CHOICES["and_method"])
@pytest.mark.parametrize("agg_method", CHOICES["agg_method"])
def test_and_and_aggregation_match_simpful(paper, and_method, agg_method):
    import simpful as sf

    system = paper.with_inference(and_method=and_method, agg_method=agg_method)
    S, owner = _simpful_system(system, and_method)
    aggregate = {"max": max, "sum": sum, "probor": sf.probor}[agg_method]
    worst = 0.0
    for x in _inputs(30, seed=sum(map(ord, and_method + agg_method))):
        with contextlib.redirect_stdout(io.StringIO()):
            for v, xi in zip(system.inputs, x):
                S.set_variable(v.name, float(xi))
            res = S.Mamdani_inference(
                subdivisions=system.n_points, aggregation_function=aggregate, ignore_warnings=True
            )
            firing = S.get_firing_strengths()
        weights = [
            w for r in system.rules for w in [r.weight] * sum(c is not None for c in r.consequent)
        ]
        want = []
        for o, v in enumerate(system.outputs):
            fired = any(f * w > 0 for f, w, oo in zip(firing, weights, owner) if oo == o)
            # simpful says 0 when nothing fired; MATLAB (and we) the middle of the range
            want.append(float(res[v.name]) if fired else 0.5 * sum(v.range))
        got = system.evaluate_one(x)
        worst = max(worst, float(np.max(np.abs(got - want))))
    assert worst <= 1e-9, worst


# ============================================================ scikit-fuzzy: the rest


def _sk_mf(term, u) -> np.ndarray:
    import skfuzzy as fuzz

    u = np.atleast_1d(np.asarray(u, dtype=float))
    p = list(term.params)
    big = 1e9  # linear S / Z as trapezoids: skfuzzy has no linsmf / linzmf
    if term.shape == "trimf":
        return fuzz.trimf(u, p)
    if term.shape == "trapmf":
        return fuzz.trapmf(u, p)
    if term.shape == "gaussmf":
        return fuzz.gaussmf(u, p[1], p[0])
    if term.shape == "linsmf":
        return fuzz.trapmf(u, [p[0], p[1], big, big])
    if term.shape == "linzmf":
        return fuzz.trapmf(u, [-big, -big, p[0], p[1]])
    raise NotImplementedError(term.shape)


def _reference_aggregates(system: FuzzySystem, x, and_method, imp_method, agg_method):
    """Per output (grid, aggregate or None) built from skfuzzy's membership functions."""
    mu = [
        [0.0 if xi != xi else float(_sk_mf(t, xi)[0]) for t in v.terms]
        for v, xi in zip(system.inputs, x)
    ]
    out = []
    for o, v in enumerate(system.outputs):
        grid = np.linspace(v.range[0], v.range[1], system.n_points)
        agg = None
        for r in system.rules:
            ms = [mu[i][a] for i, a in enumerate(r.antecedent) if a is not None]
            w = (min(ms) if and_method == "min" else math.prod(ms)) * r.weight
            k = r.consequent[o]
            if k is None:
                continue
            term = _sk_mf(v.terms[k], grid)
            implied = np.fmin(w, term) if imp_method == "min" else w * term
            if agg is None:
                agg = implied
            elif agg_method == "max":
                agg = np.fmax(agg, implied)
            elif agg_method == "sum":
                agg = agg + implied
            else:
                agg = agg + implied - agg * implied
        out.append((grid, agg))
    return out


def _bisector_by_skfuzzy(grid: np.ndarray, agg: np.ndarray) -> float:
    """MATLAB's bisector from skfuzzy's area arithmetic. MATLAB sums the grid values: the
    area of a staircase, a step of height agg[i] around each grid point, and picks the
    grid point of the step in which half the area is reached. skfuzzy's bisector cuts
    piecewise-linear sets; fed a staircase of the non-zero steps only (skfuzzy loses the
    running area after a segment of zero height or width, and then cuts far off), laid
    side by side with nearly vertical risers of width 1e-12, its cut falls in step
    floor(cut)."""
    import skfuzzy as fuzz

    steps = np.flatnonzero(agg)
    j = np.arange(len(steps), dtype=float)
    x = np.column_stack([j, j + 1.0 - 1e-12]).ravel()
    y = np.repeat(agg[steps], 2)
    return float(grid[steps[int(fuzz.defuzz(x, y, "bisector"))]])


@pytest.mark.parametrize("and_method,imp_method,agg_method", COMBOS)
def test_every_choice_matches_a_scikit_fuzzy_reference(paper, and_method, imp_method, agg_method):
    import skfuzzy as fuzz

    systems = {
        m: paper.with_inference(
            and_method=and_method, imp_method=imp_method, agg_method=agg_method, defuzz_method=m
        )
        for m in METHODS
    }
    worst = dict.fromkeys(METHODS, 0.0)
    X = _inputs(40, seed=sum(map(ord, and_method + imp_method + agg_method)))
    got = {m: s.evaluate(X) for m, s in systems.items()}
    for row, x in enumerate(X):
        for o, (grid, agg) in enumerate(
            _reference_aggregates(paper, x, and_method, imp_method, agg_method)
        ):
            step = grid[1] - grid[0]
            if agg is None or agg.sum() == 0.0:
                for m in METHODS:
                    assert got[m][row, o] == 0.5 * (grid[0] + grid[-1])
                continue
            top = agg.max()
            want = {
                "centroid": np.sum(grid * agg) / np.sum(agg),
                "mom": fuzz.defuzz(grid, agg, "mom"),
                "som": fuzz.defuzz(np.abs(grid), agg, "som"),  # magnitudes
                "lom": fuzz.defuzz(np.abs(grid), agg, "lom"),
                "bisector": _bisector_by_skfuzzy(grid, agg),
            }
            for m in METHODS:
                y = got[m][row, o]
                if m in ("som", "lom"):
                    # a maximiser of the reference aggregate, the smallest / largest |x|
                    assert agg[int(round((y - grid[0]) / step))] == top
                    y = abs(y)
                err = abs(y - want[m])
                worst[m] = max(worst[m], err / step if m == "bisector" else err)
    assert worst["bisector"] == 0.0, worst  # in grid steps: the same grid point
    for m in ("centroid", "mom", "som", "lom"):
        assert worst[m] <= 1e-9, worst


# ============================================================ the engine's own promises


def test_one_row_and_many_agree_bit_for_bit_for_every_choice(paper):
    X = _inputs(24, seed=3)
    for and_m, imp_m, agg_m in COMBOS:
        for method in METHODS:
            s = paper.with_inference(
                and_method=and_m, imp_method=imp_m, agg_method=agg_m, defuzz_method=method
            )
            Y = s.evaluate(X)
            assert np.array_equal(Y, np.array([s.evaluate_one(x) for x in X]))
            agg = s.aggregated(X[0])
            assert np.array_equal(agg.output, Y[0])


def test_defaults_are_unchanged_and_the_plain_path_gives_their_bits(paper):
    """The default inference keeps its fast path; forced through the plain path (the
    per-rule fold other choices take), the same choices give the same bits."""
    assert paper.inference == Inference() and not paper._plain
    plain = paper.replace()
    plain._plain = True
    X = _inputs(300, seed=4)
    assert np.array_equal(plain.evaluate(X), paper.evaluate(X))
    assert np.array_equal(plain.evaluate_one(X[5]), paper.evaluate_one(X[5]))


def test_choices_change_the_outputs(paper):
    X = _inputs(50, seed=5, nan_frac=0.0)
    base = paper.evaluate(X)
    for field, values in CHOICES.items():
        for value in values[1:]:
            changed = paper.with_inference(**{field: value}).evaluate(X)
            if field == "or_method":  # no OR rules: nothing to change
                assert np.array_equal(changed, base)
            else:
                assert not np.allclose(changed, base), (field, value)


def test_inference_is_checked_kept_and_compared(paper):
    with pytest.raises(ValueError, match="agg_method = 'median': must be one of 'max'"):
        Inference(agg_method="median")
    with pytest.raises(ValueError, match="unknown inference choices"):
        paper.with_inference(defuzz="mom")
    s = paper.with_inference(imp_method="prod", defuzz_method="lom")
    assert s != paper and s == paper.with_inference(imp_method="prod", defuzz_method="lom")
    assert pickle.loads(pickle.dumps(s)).inference == s.inference
    assert s.with_n_points(51).inference == s.inference
    assert "defuzz_method='lom'" in repr(s) and "Inference" not in repr(paper)


def test_batch_fuzzy_runs_every_set_with_its_choices(paper):
    s = paper.with_inference(agg_method="sum", defuzz_method="bisector")
    moved = s.with_term_params("left", s.outputs[0].terms[1].name, [1.0, 3.0, 5.0])
    X = _inputs(60, seed=6)
    groups = np.arange(60) % 2
    got = BatchFuzzy([s, moved]).evaluate(X, groups)
    assert np.array_equal(got[groups == 0], s.evaluate(X[groups == 0]))
    assert np.array_equal(got[groups == 1], moved.evaluate(X[groups == 1]))
    with pytest.raises(ValueError, match="another structure"):
        BatchFuzzy([s, paper])


# ============================================================ files: .fis and TOML


ALL_CHOICES = [
    Inference(and_method=a, or_method=o, imp_method=i, agg_method=g, defuzz_method=d)
    for (a, o, i, g), d in zip(
        itertools.product(
            CHOICES["and_method"],
            CHOICES["or_method"],
            CHOICES["imp_method"],
            CHOICES["agg_method"],
        ),
        itertools.cycle(METHODS),
    )
]


@pytest.mark.parametrize("inference", ALL_CHOICES, ids=lambda i: "-".join(i.as_dict().values()))
def test_fis_and_toml_round_trip_the_choices(paper, inference):
    s = paper.replace(inference=inference)
    text = dumps_fis(s)
    for field, key in (
        ("and_method", "AndMethod"),
        ("or_method", "OrMethod"),
        ("imp_method", "ImpMethod"),
        ("agg_method", "AggMethod"),
        ("defuzz_method", "DefuzzMethod"),
    ):
        assert f"{key}='{getattr(inference, field)}'" in text
    for back in (loads_fis(text), loads_toml(dumps_toml(s))):
        assert back.inference == inference
        assert back == s
        x = _inputs(1, seed=7)[0]
        assert np.array_equal(back.evaluate_one(x), s.evaluate_one(x))


def test_default_files_keep_their_text(paper):
    """A default system's TOML has no 'or' line (as before issue 27), and its .fis the
    five default methods."""
    toml = dumps_toml(paper)
    assert (
        'and = "min"\nimplication = "min"\naggregation = "max"\ndefuzzification = "centroid"'
        in toml
    )
    assert "\nor = " not in toml
    assert (
        "AndMethod='min'\nOrMethod='max'\nImpMethod='min'\nAggMethod='max'\nDefuzzMethod='centroid'"
        in dumps_fis(paper)
    )


@pytest.mark.parametrize(
    "key,value",
    [
        ("and", "max"),
        ("or", "sum"),
        ("implication", "sum"),
        ("aggregation", "min"),
        ("defuzzification", "wtaver"),
    ],
)
def test_toml_refuses_unknown_choices_naming_file_key_and_value(paper, key, value):
    text = dumps_toml(paper.with_inference(or_method="probor"))
    bad = "\n".join(
        f'{key} = "{value}"' if line.startswith(f"{key} = ") else line for line in text.splitlines()
    )
    with pytest.raises(
        ValueError, match=rf"rules\.toml: key 'system\.{key}': value .*{value}.*must be one of"
    ):
        loads_toml(bad, "rules.toml")


def test_fis_refuses_unknown_choices_naming_file_line_key_and_value(paper):
    text = dumps_fis(paper).replace("AggMethod='max'", "AggMethod='median'")
    line = text.splitlines().index("AggMethod='median'") + 1
    with pytest.raises(FisFormatError, match=rf"my\.fis:{line}: unsupported AggMethod 'median'"):
        loads_fis(text, "my.fis")
    # MATLAB's names are lower case; an upper-case spelling reads as the same choice
    upper = dumps_fis(paper).replace("DefuzzMethod='centroid'", "DefuzzMethod='MOM'")
    assert loads_fis(upper).inference.defuzz_method == "mom"


def test_a_fis_bound_by_name_keeps_its_choices(paper):
    """A .fis whose inputs are the robot's in another order is reordered (issue 26); its
    inference choices go with it."""
    from fuzzynav.controller.fis_controller import FisController, reordered

    shuffled = reordered(
        paper.with_inference(and_method="prod", defuzz_method="bisector"), inputs=(2, 0, 3, 1)
    )
    controller = FisController(loads_fis(dumps_fis(shuffled)))
    assert controller.bound_by_name
    assert controller.fis.inference == Inference(and_method="prod", defuzz_method="bisector")
