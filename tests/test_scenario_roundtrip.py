"""The scenario format from its dataclasses (issue 36 item 4): ``Scenario.to_toml`` writes
the plain data of :data:`world.scenario.FORMAT` and the obstacles' and disturbance's own
fields, each value by tomli-w; whatever it writes loads again to an equal scenario,
multi-line and unicode descriptions, obstacles and disturbances included."""

from __future__ import annotations

import dataclasses
import tomllib

import tomli_w
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzynav.world.layouts import FAMILIES, generate_layout
from fuzzynav.world.scenario import (
    FORMAT,
    MAX_ACCELERATION_MPS2,
    MAX_DISTURBANCE,
    MAX_DURATION_S,
    MAX_SPEED_MPS,
    Disturbance,
    ObstacleSpec,
    Scenario,
    load_scenario,
    loads_scenario,
    scenario_from_dict,
    scenario_names,
)


def numbers(low: float, high: float, *, positive: bool = False):
    values = st.floats(low, high, allow_nan=False, allow_infinity=False)
    return values.filter(lambda v: v > 0) if positive else values


#: Text as a file keeps it: a description keeps its line breaks and tabs, every other
#: control character is read back as a visible escape (so it is left out here, and
#: tests/test_robustness_edges.py holds that case); any other unicode, quotes and
#: backslashes included.
PRINTABLE = st.characters(blacklist_categories=("Cs", "Cc"))
descriptions = st.text(st.one_of(PRINTABLE, st.sampled_from("\n\t")), max_size=60)
names = st.text(PRINTABLE, min_size=1, max_size=30)
pairs = st.tuples


@st.composite
def obstacles(draw):
    """Up to four obstacles, each in its own 3 m column from x = 10 m: never on the
    start or the target, never overlapping another."""
    out = []
    for i in range(draw(st.integers(0, 4))):
        out.append(
            ObstacleSpec(
                position=(10.0 + 3.0 * i, draw(numbers(-100.0, 100.0))),
                radius_m=draw(numbers(0.0, 1.0, positive=True)),
                velocity=draw(pairs(*[numbers(-MAX_SPEED_MPS, MAX_SPEED_MPS)] * 2)),
                acceleration=draw(
                    pairs(*[numbers(-MAX_ACCELERATION_MPS2, MAX_ACCELERATION_MPS2)] * 2)
                ),
            )
        )
    return tuple(out)


@st.composite
def disturbances(draw):
    start, stop = sorted(draw(pairs(*[numbers(0.0, MAX_DURATION_S)] * 2)))
    return Disturbance(
        amplitude=draw(numbers(-MAX_DISTURBANCE, MAX_DISTURBANCE)),
        angular_frequency_rad_s=draw(numbers(-1e4, 1e4)),
        start_s=start,
        stop_s=stop,
    )


@st.composite
def scenarios(draw):
    return Scenario(
        name=draw(names),
        description=draw(descriptions),
        duration_s=draw(numbers(0.0, MAX_DURATION_S, positive=True)),
        start=(0.0, 0.0),
        heading_rad=draw(numbers(-1000.0, 1000.0)),
        target=(draw(numbers(-9000.0, -20.0)), draw(numbers(-9000.0, 9000.0))),
        tolerance_m=draw(numbers(0.0, 10.0, positive=True)),
        obstacles=draw(obstacles()),
        disturbance=draw(st.none() | disturbances()),
        field_of_view_deg=draw(st.just(360.0) | numbers(0.0, 360.0, positive=True)),
        source="<hypothesis>",
    )


@settings(max_examples=300, deadline=None)
@given(scenarios())
def test_what_to_toml_writes_loads_again_to_an_equal_scenario(scenario):
    text = scenario.to_toml()
    back = loads_scenario(text, "saved.toml")
    assert back == scenario
    assert (back.name, back.description) == (scenario.name, scenario.description)
    # the text is the plain data, and writing what was read gives the same bytes
    assert tomllib.loads(text) == scenario.to_dict()
    assert back.to_toml() == text


@settings(max_examples=200, deadline=None)
@given(scenarios())
def test_tomli_w_writing_the_same_data_loads_to_the_same_scenario(scenario):
    """The one-line pairs are layout only: tomli-w's own layout of the data is the
    same scenario."""
    data = tomllib.loads(tomli_w.dumps(scenario.to_dict()))
    assert data == scenario.to_dict()
    assert scenario_from_dict(data, "tomli-w.toml") == scenario


def test_every_field_is_in_the_format():
    """A field added to Scenario is written only once it is in FORMAT (the obstacles and
    the disturbance are their dataclasses' own fields; ``source`` is where it came from,
    not part of the file)."""
    in_format = {attribute for _, keys in FORMAT for _, attribute in keys}
    fields = {f.name for f in dataclasses.fields(Scenario)}
    assert fields - in_format == {"obstacles", "disturbance", "source"}
    assert in_format <= fields


def test_the_shipped_scenarios_and_layouts_write_as_before():
    """The layout people read: one [x, y] per line, the shipped files' key order; a
    shipped scenario and every family's layouts load again equal."""
    s3 = load_scenario("s3")
    text = s3.to_toml()
    assert text.splitlines()[:3] == [
        f"name = {tomli_w.dumps({'v': s3.name})[4:-1]}",
        f"description = {tomli_w.dumps({'v': s3.description})[4:-1]}",
        "duration_s = 150.0",
    ]
    assert "start = [0.0, 0.0]" in text and "acceleration = [-0.001, -0.00123]" in text
    assert text.index("[robot]") < text.index("[target]") < text.index("[[obstacles]]")
    assert text.index("[[obstacles]]") < text.index("[disturbance]")
    for name in scenario_names():
        scenario = load_scenario(name)
        assert loads_scenario(scenario.to_toml(), name) == scenario
    for family in FAMILIES:
        for i in range(5):
            layout = generate_layout(family, 1, i)
            assert loads_scenario(layout.to_toml(), "layout") == layout


def test_the_module_docstring_shows_every_key_of_the_format():
    """The format's prose example (world/scenario.py's docstring) is a scenario that
    loads, and it names every key the format has."""
    import re

    from fuzzynav.world import scenario as module

    block = module.__doc__.split("::\n", 1)[1].split("\n\n", 1)[0]
    text = re.sub(r"^    ", "", block, flags=re.M)
    data = tomllib.loads(text)
    scenario_from_dict(data, "docstring")
    for table, keys in FORMAT:
        held = data if table is None else data[table]
        assert {key for key, _ in keys} - {"description"} <= set(held), table
    assert set(data["obstacles"][0]) == {f.name for f in dataclasses.fields(ObstacleSpec)}
    assert set(data["disturbance"]) == {f.name for f in dataclasses.fields(Disturbance)}
