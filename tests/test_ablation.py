"""The ablation study of fuzzynav (scripts/fuzzynav_ablation.py): its file of ablations is
checked like any input, and every switch in it really switches its part off."""

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from controller.fuzzynav import CRISP_DEFAULTS, DECISION_FIELDS, fuzzynav_controller  # noqa: E402
from world.layouts import generate_layout  # noqa: E402
from world.scenario import load_scenario  # noqa: E402
from world.simulation import Simulation  # noqa: E402


def _script():
    spec = importlib.util.spec_from_file_location("fuzzynav_ablation",
                                                  ROOT / "scripts" / "fuzzynav_ablation.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


ABLATION = _script()
SHIPPED = ABLATION.load_ablations()


def _decisions(scenario, mode, overrides):
    controller = fuzzynav_controller()
    controller.params.update(overrides)
    controller.reset()
    Simulation(scenario, controller, perception=mode, seed=0).run()
    return np.array(controller.decisions)


# Runs that exercise every part: a crossing obstacle (yield, time to contact), s3's
# disturbance (doubted readings), cluttered layouts (memory, planner, the turn charge,
# the deadlock turn, the reversing limit) and a U-trap (the side kept, edge following).
RUNS = (("crossing", None, "ideal"), ("s3", None, "ideal"), ("clutter", 68, "ideal"),
        ("clutter", 3, "ultrasonic"), ("u_trap", 14, "ideal"), ("u_trap", 14, "ultrasonic"))
_SHIPPED_RUNS: dict = {}


def _scenario(name, index):
    return load_scenario(name) if index is None else generate_layout(name, 1, index)


def test_the_shipped_ablations_load_and_each_changes_a_parameter():
    assert SHIPPED[0]["name"] == "shipped" and SHIPPED[0]["overrides"] == {}
    assert len(SHIPPED) >= 10
    for entry in SHIPPED[1:]:
        assert entry["overrides"], entry["name"]
        assert any(CRISP_DEFAULTS[k] != v for k, v in entry["overrides"].items()), entry["name"]


@pytest.mark.parametrize("entry", SHIPPED[1:], ids=lambda e: e["name"])
def test_each_switch_changes_how_the_robot_drives(entry):
    """No switch is a no-op: on one of a few runs it changes the voltages commanded."""
    for name, index, mode in RUNS:
        scenario = _scenario(name, index)
        if (name, index, mode) not in _SHIPPED_RUNS:
            _SHIPPED_RUNS[(name, index, mode)] = _decisions(scenario, mode, {})
        shipped = _SHIPPED_RUNS[(name, index, mode)]
        ablated = _decisions(scenario, mode, entry["overrides"])
        if shipped.shape != ablated.shape or not np.array_equal(shipped[:, :2], ablated[:, :2]):
            return
    pytest.fail(f"{entry['name']}: the same voltages as shipped on every run")


def _field(decisions, name):
    return decisions[:, DECISION_FIELDS.index(name)]


@pytest.mark.parametrize("ablation, run, field", [
    ("no bearing planner", ("clutter", 68, "ideal"), "plan_offset_rad"),
    ("no edge following", ("u_trap", 14, "ultrasonic"), "follow"),
    ("no yield or pass first", ("crossing", None, "ideal"), "dodge"),
    ("no doubted readings", ("s3", None, "ideal"), "target_doubted"),
])
def test_a_switched_off_part_never_acts(ablation, run, field):
    """The part's own trace is busy in the shipped run and flat zero with it off."""
    (entry,) = [e for e in SHIPPED if e["name"] == ablation]
    name, index, mode = run
    scenario = _scenario(name, index)
    assert np.any(_field(_decisions(scenario, mode, {}), field) != 0.0)
    assert np.all(_field(_decisions(scenario, mode, entry["overrides"]), field) == 0.0)


@pytest.mark.parametrize("text, named", [
    ('[[ablation]]\nname = "shipped"\nwhat = ""\nitem = 0\noverrides = {}\ncolour = 1\n', "colour"),
    ('[[ablation]]\nname = "shipped"\nwhat = ""\nitem = 0\noverrides = {}\n'
     '[[ablation]]\nname = "x"\nwhat = ""\nitem = 1\noverrides = { stall_z = 1.0 }\n', "stall_z = 1.0"),
    ('[[ablation]]\nname = "shipped"\nwhat = ""\nitem = 0\noverrides = {}\n'
     '[[ablation]]\nname = "x"\nwhat = ""\nitem = 1\noverrides = { stall_s = nan }\n', "stall_s = nan"),
    ('[[ablation]]\nname = "x"\nwhat = ""\nitem = 1\noverrides = { stall_s = 1.0 }\n', "shipped"),
    ('[[ablation]]\nname = "shipped"\nwhat = ""\nitem = 0\noverrides = {}\n'
     '[[ablation]]\nname = "shipped"\nwhat = ""\nitem = 0\noverrides = {}\n', "name = 'shipped'"),
    ('[[ablation]]\nname = "shipped"\nitem = 0\noverrides = {}\n', "what"),
    ('[[ablation]\n', "not valid TOML"),
    ('title = "x"\n', "title"),
])
def test_a_bad_ablation_file_is_refused_with_file_key_and_value(tmp_path, text, named):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ValueError) as info:
        ABLATION.load_ablations(path)
    assert str(path) in str(info.value) and named in str(info.value)


def test_the_tally_counts_each_cell():
    rows = [(0, "standard", "ideal", True, True, False, False),
            (0, "standard", "ideal", False, False, True, False),
            (1, "standard", "ultrasonic", False, False, False, True)]
    counts = ABLATION.tally(rows, 2, {"standard": 2})
    assert counts[(0, "standard", "ideal")] == {"n": 2, "ok": 1, "safe": 1, "collided": 1, "timeout": 0}
    assert counts[(1, "standard", "ultrasonic")]["timeout"] == 1
    assert counts[(1, "standard", "ideal")]["n"] == 0
    assert math.isclose(sum(c["n"] for c in counts.values()), 3)
