"""fuzzynav's parts (assets/rules/fuzzynav_parts.toml): the file is checked like any input,
every switch in it really switches its part off, and back on; the ablation study
(scripts/fuzzynav_ablation.py) counts what it runs."""

import math
from pathlib import Path

import numpy as np
import pytest
from load_file import load_file

from fuzzynav.controller.navigator.controller import (
    CRISP_DEFAULTS,
    DECISION_FIELDS,
    fuzzynav_controller,
)
from fuzzynav.controller.navigator.parts import load_parts
from fuzzynav.world.layouts import generate_layout
from fuzzynav.world.scenario import load_scenario
from fuzzynav.world.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]


def _script():
    return load_file(ROOT / "scripts" / "fuzzynav_ablation.py")


PARTS = load_parts()
ABLATION = _script()


def _decisions(scenario, mode, parts_off=()):
    controller = fuzzynav_controller()
    controller.set_parts_off(parts_off)
    Simulation(scenario, controller, perception=mode, seed=0).run()
    return np.array(controller.decisions)


# Runs that exercise every part: a crossing obstacle (yield, time to contact), s3's
# disturbance (doubted readings), cluttered layouts (memory, planner, the turn charge,
# the deadlock turn, the reversing limit) and a U-trap (the side kept, edge following).
RUNS = (
    ("crossing", None, "ideal"),
    ("s3", None, "ideal"),
    ("clutter", 68, "ideal"),
    ("clutter", 3, "ultrasonic"),
    ("u_trap", 14, "ideal"),
    ("u_trap", 14, "ultrasonic"),
)
_SHIPPED_RUNS: dict = {}


def _scenario(name, index):
    return load_scenario(name) if index is None else generate_layout(name, 1, index)


def test_the_parts_load_and_each_changes_a_parameter():
    assert len(PARTS) >= 10
    for part in PARTS:
        assert part.off and part.what, part.name
        assert any(CRISP_DEFAULTS[k] != v for k, v in part.off.items()), part.name


def test_switching_parts_off_and_on_again_restores_every_parameter():
    controller = fuzzynav_controller()
    controller.params["stall_s"] = 12.5  # a value of the user's survives the round trip
    before = dict(controller.params)
    controller.set_parts_off(["edge following", "echo memory"])
    assert controller.parts_off == ("echo memory", "edge following")
    assert controller.params["stall_s"] == 1e9 and controller.params["memory_s"] == 0.0
    controller.set_parts_off(["echo memory"])
    assert controller.params["stall_s"] == 12.5 and controller.params["memory_s"] == 0.0
    controller.set_parts_off([])
    assert controller.params == before and controller.parts_off == ()
    with pytest.raises(ValueError, match="unknown fuzzynav part.*'sonar'"):
        controller.set_parts_off(["echo memory", "sonar"])
    assert controller.params == before  # nothing changed


@pytest.mark.parametrize("part", PARTS, ids=lambda p: p.name)
def test_each_switch_changes_how_the_robot_drives(part):
    """No switch is a no-op: on one of a few runs it changes the voltages commanded."""
    for name, index, mode in RUNS:
        scenario = _scenario(name, index)
        if (name, index, mode) not in _SHIPPED_RUNS:
            _SHIPPED_RUNS[(name, index, mode)] = _decisions(scenario, mode)
        shipped = _SHIPPED_RUNS[(name, index, mode)]
        ablated = _decisions(scenario, mode, [part.name])
        if shipped.shape != ablated.shape or not np.array_equal(shipped[:, :2], ablated[:, :2]):
            return
    pytest.fail(f"{part.name}: the same voltages as shipped on every run")


def _field(decisions, name):
    return decisions[:, DECISION_FIELDS.index(name)]


@pytest.mark.parametrize(
    "part, run, field",
    [
        ("bearing planner", ("clutter", 68, "ideal"), "plan_offset_rad"),
        ("edge following", ("u_trap", 14, "ultrasonic"), "follow"),
        ("yield or pass first", ("crossing", None, "ideal"), "dodge"),
        ("doubted readings", ("s3", None, "ideal"), "target_doubted"),
    ],
)
def test_a_switched_off_part_never_acts(part, run, field):
    """The part's own trace is busy in the shipped run and flat zero with it off."""
    name, index, mode = run
    scenario = _scenario(name, index)
    assert np.any(_field(_decisions(scenario, mode), field) != 0.0)
    assert np.all(_field(_decisions(scenario, mode, [part]), field) == 0.0)


_PART = '[[part]]\nname = "a"\nwhat = ""\nitem = 1\noff = { stall_s = 1e9 }\n'


@pytest.mark.parametrize(
    "text, named",
    [
        (_PART + "colour = 1\n", "colour"),
        (_PART.replace("stall_s", "stall_z"), "stall_z = 1000000000.0"),
        (_PART.replace("1e9", "nan"), "stall_s = nan"),
        (_PART.replace("1e9", '"off"'), "stall_s = 'off'"),
        (_PART + _PART, "name = 'a'"),
        (_PART + _PART.replace('"a"', '"b"'), "already switched by part 'a'"),
        (_PART.replace('what = ""\n', ""), "what"),
        (_PART.replace("{ stall_s = 1e9 }", "{}"), "off = {}"),
        ("[[part]\n", "not valid TOML"),
        ('title = "x"\n', "title"),
    ],
)
def test_a_bad_parts_file_is_refused_with_file_key_and_value(tmp_path, text, named):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ValueError) as info:
        load_parts(path)
    assert str(path) in str(info.value) and named in str(info.value)


def test_the_ablation_runs_the_shipped_controller_then_each_part_off():
    versions = ABLATION.versions(PARTS)
    assert versions[0]["off"] is None and [v["off"] for v in versions[1:]] == [
        p.name for p in PARTS
    ]


def test_the_tally_counts_each_cell():
    rows = [
        (0, "standard", "ideal", True, True, False, False),
        (0, "standard", "ideal", False, False, True, False),
        (1, "standard", "ultrasonic", False, False, False, True),
    ]
    counts = ABLATION.tally(rows, 2, {"standard": 2})
    assert counts[(0, "standard", "ideal")] == {
        "n": 2,
        "ok": 1,
        "safe": 1,
        "collided": 1,
        "timeout": 0,
    }
    assert counts[(1, "standard", "ultrasonic")]["timeout"] == 1
    assert counts[(1, "standard", "ideal")]["n"] == 0
    assert math.isclose(sum(c["n"] for c in counts.values()), 3)


def test_the_ablation_figure_redraws_from_its_data(tmp_path):
    """docs/img/fuzzynav_ablation.png is drawn from docs/data/fuzzynav_ablation_seed59.json
    (`--from-json`: no 30-minute run); every part in that data is still a part, and each
    cell counts the runs of its family."""
    data = ROOT / "docs" / "data" / "fuzzynav_ablation_seed59.json"
    versions, counts, sizes, seed = ABLATION.read_counts(data)
    assert seed == 59 and versions[0]["off"] is None
    assert {v["off"] for v in versions[1:]} <= {p.name for p in PARTS}
    for (_k, family, _mode), cell in counts.items():
        assert cell["n"] == sizes[family]
        assert cell["safe"] <= cell["ok"] <= cell["n"] - cell["collided"]
    out = tmp_path / "ablation.png"
    assert ABLATION.main(["--from-json", str(data), "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "mode, parts_off, outcome",
    [
        ("ideal", (), "reached"),
        ("ideal", ("echo memory",), "timeout"),
        ("ideal", ("bearing planner",), "timeout"),
        ("ultrasonic", (), "reached"),
        ("ultrasonic", ("echo memory",), "timeout"),
        ("ultrasonic", ("bearing planner",), "timeout"),
        ("ultrasonic", ("edge following",), "timeout"),
        ("ultrasonic", ("side kept in a trap",), "timeout"),
    ],
)
def test_the_trap_scenario_shows_what_the_parts_buy(mode, parts_off, outcome):
    """assets/scenarios/trap.toml, for a class: fuzzynav gets out of the U, and stays in
    it with one of the parts its description names switched off."""
    controller = fuzzynav_controller()
    controller.set_parts_off(parts_off)
    result = Simulation(load_scenario("trap"), controller, perception=mode, seed=0).run()
    assert result.outcome == outcome
    assert not result.collided
    if parts_off == ("echo memory",):  # it never leaves the U (posts at x -2.9..-1.5)
        x, y = result.log.pose[:, 0], result.log.pose[:, 1]
        late = result.log.time_s > 10.0
        assert np.all((x[late] > -3.0) & (x[late] < -1.0) & (np.abs(y[late]) < 1.5))
