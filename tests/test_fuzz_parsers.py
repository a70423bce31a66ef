"""Issue 19, item 7: property-based tests of every parser. Whatever the text (mutations
of a valid file, random TOML-ish text, random bytes), a parser either returns its object
or raises the project's own error (ScenarioError, FisFormatError, ValueError with the
source named, ViewerError), never anything else, and quickly. Derandomised and without
deadline (tests/conftest.py); each test runs a bounded number of examples (a few
seconds)."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fuzzynav.controller.fis import FisFormatError, dumps_fis, loads_fis
from fuzzynav.controller.rulebase import dumps_toml, loads_toml
from fuzzynav.resources import asset_path
from fuzzynav.world.husky import HuskyParameters
from fuzzynav.world.scenario import ScenarioError, loads_scenario

FAST = settings(max_examples=150, suppress_health_check=[HealthCheck.too_slow])

SCENARIO_TEXT = asset_path("scenarios", "s3.toml").read_text(encoding="utf-8")
# The Husky twin (MATLAB's NONE): the shipped rule base a .fis can hold.
RULES_TEXT = asset_path("rules", "paper_husky.toml").read_text(encoding="utf-8")
# a .fis holds MATLAB's NONE only: the twin with MATLAB's reading seeds the .fis fuzz
FIS_TEXT = dumps_fis(loads_toml(RULES_TEXT, "paper_husky.toml").replace(unsensed_none=()))
HUSKY_TEXT = asset_path("husky.toml").read_text(encoding="utf-8")

# Pieces the review found troublesome: deep nesting, huge numbers, control characters,
# non-finite values, a byte-order mark, stray quotes and brackets.
NASTY = st.sampled_from(
    [
        "[" * 3000,
        "{a=" * 3000,
        "1" * 6000,
        "9" * 400 + ".5",
        "1e400",
        "-1e-400",
        "nan",
        "inf",
        "\x1b[2J",
        "\x00",
        "\ufeff",
        '"""',
        "'''",
        "]]",
        "[[obstacles]]\nposition = [1.0, 1.0]\nradius_m = 0.2\n" * 3,
        "0x7fffffffffffffffffff",
        "NumInputs=99999999999999999999",
        "MF1='a':'gaussmf',[1e-200 0.5]",
        "1 1 1 1, 1 1 (1) : 1",
        "\n[System]\n",
        "=",
        ".",
        "\\",
    ]
)


@st.composite
def mutated(draw, text: str):
    """``text`` with a few slices replaced, cut, doubled or swapped for nasty pieces."""
    for _ in range(draw(st.integers(1, 4))):
        if not text:
            break
        i = draw(st.integers(0, len(text)))
        j = draw(st.integers(i, min(len(text), i + 40)))
        how = draw(st.sampled_from(["nasty", "chars", "cut", "double"]))
        if how == "nasty":
            piece = draw(NASTY)
        elif how == "chars":
            piece = draw(st.text(max_size=12))
        elif how == "cut":
            piece = ""
        else:
            piece = text[i:j] * 2
        text = text[:i] + piece + text[j:]
    return text


def texts(base: str):
    return st.one_of(mutated(base), st.text(max_size=300), NASTY)


@FAST
@given(texts(SCENARIO_TEXT))
def test_scenario_text_gives_a_scenario_or_a_scenario_error(text):
    try:
        loads_scenario(text, "fuzz.toml")
    except ScenarioError as exc:
        assert "fuzz.toml" in str(exc) and len(str(exc)) < 2000


@FAST
@given(texts(RULES_TEXT))
def test_rule_base_text_gives_a_system_or_a_named_value_error(text):
    try:
        system = loads_toml(text, "fuzz.toml")
    except ValueError as exc:
        assert type(exc) is ValueError and "fuzz.toml" in str(exc) and len(str(exc)) < 2000
    else:
        system.evaluate_one([0.0] * len(system.inputs))


@FAST
@given(texts(FIS_TEXT))
def test_fis_text_gives_a_system_or_a_fis_error(text):
    try:
        system = loads_fis(text, "fuzz.fis")
    except FisFormatError as exc:
        assert "fuzz.fis" in str(exc) and len(str(exc)) < 2000
    else:
        system.evaluate_one([0.5] * len(system.inputs))


@FAST
@given(texts(HUSKY_TEXT))
def test_husky_text_gives_parameters_or_a_named_value_error(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("husky") / "husky.toml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    try:
        HuskyParameters.from_toml(path)
    except ValueError as exc:
        assert type(exc) is ValueError and str(path) in str(exc)


@pytest.fixture(scope="module")
def viewer_app():
    from fuzzynav.app.viewer.model import ViewerApp

    return ViewerApp("s1")


@settings(max_examples=60, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.one_of(
        mutated(SCENARIO_TEXT).map(lambda t: t.encode("utf-8", "surrogatepass")),
        st.binary(max_size=200),
    )
)
def test_viewer_scenario_upload_is_used_or_refused_with_a_viewer_error(viewer_app, content):
    from fuzzynav.app.viewer.model import ViewerError

    try:
        viewer_app.upload_scenario(content, "fuzz.toml")
    except ViewerError as exc:
        assert "fuzz.toml" in str(exc)


@settings(max_examples=60, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.one_of(
        mutated(FIS_TEXT).map(lambda t: t.encode("utf-8", "surrogatepass")),
        st.binary(max_size=200),
    )
)
def test_viewer_fis_upload_is_used_or_refused_with_a_viewer_error(viewer_app, content):
    from fuzzynav.app.viewer.model import ViewerError

    try:
        viewer_app.upload_fis(content, "fuzz.fis")
    except ViewerError as exc:
        assert "fuzz.fis" in str(exc)


def test_the_round_trips_still_hold():
    """The fuzz's seeds are valid files: they parse back to themselves."""
    system = loads_toml(RULES_TEXT, "paper_husky.toml")
    assert loads_toml(dumps_toml(system), "again.toml") == system
    matlab = system.replace(unsensed_none=())
    assert loads_fis(FIS_TEXT, "paper.fis") == matlab.with_n_points(matlab.n_points)
    assert loads_scenario(SCENARIO_TEXT, "s3.toml").name
