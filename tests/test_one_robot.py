"""One robot description (issue 36 item 1): the footprint, the sonar mounts and the
voltage limit are read once from assets/husky.toml (world/robot.py, ``HUSKY``), and
every other place takes them from there. The production code carries none of their
numbers, and a changed description reaches the arena, the sensors, the scenario
checks, the layouts and fuzzynav's model of the robot."""

from __future__ import annotations

import dataclasses
import io
import math
import tokenize
from pathlib import Path

import pytest

from fuzzynav.world.robot import HUSKY, RobotDescription

ROOT = Path(__file__).resolve().parents[1]
PRODUCTION = ("world", "controller", "app", "fuzzynav")

#: The footprint's numbers, whole and halved.
FOOTPRINT_LITERALS = {0.99, 0.67, 0.495, 0.335}
#: The sonars' mounting angles (degrees, as passed to radians(), and in radians).
ANGLE_DEGREES = {45.0, 15.0}
ANGLE_RADIANS = {math.radians(45.0), math.radians(15.0)}
#: The same numbers meaning something else: (file, the line's text) -> why.
UNRELATED = {
    ("controller/design_rules.py", "GRADED_LOW, GRADED_HIGH = 0.01, 0.99"): "a membership grade",
    ("app/viewer/camera.py", "cam.fov = math.radians(45.0)"): "the camera's field of view",
    (
        "app/viewer/camera.py",
        "tan = math.tan(0.5 * math.radians(45.0))",
    ): "the camera's field of view",
    ("app/viewer/camera.py", "camera.fov = math.radians(45.0)"): "the camera's field of view",
}


def robot_literals(source: str) -> list[tuple[int, str]]:
    """``(line number, line)`` of every footprint or sonar-angle literal in Python source:
    a NUMBER token of the footprint's, a radian value of a mounting angle, or a degree
    value of one passed to ``radians(`` / ``deg2rad(``."""
    tokens = [
        t
        for t in tokenize.generate_tokens(io.StringIO(source).readline)
        if t.type not in (tokenize.NL, tokenize.NEWLINE, tokenize.COMMENT)
    ]
    found = []
    for i, tok in enumerate(tokens):
        if tok.type != tokenize.NUMBER:
            continue
        try:
            value = float(tok.string.replace("_", ""))
        except ValueError:  # complex literals
            continue
        after_radians = (
            i >= 2
            and tokens[i - 1].string == "("
            and tokens[i - 2].string in ("radians", "deg2rad")
        )
        if (
            value in FOOTPRINT_LITERALS
            or value in ANGLE_RADIANS
            or (after_radians and value in ANGLE_DEGREES)
        ):
            found.append((tok.start[0], tok.line.strip()))
    return found


def test_the_scan_finds_what_it_looks_for():
    source = (
        "FOOTPRINT = (0.99, 0.67)\n"
        "_HX, _HY = 0.495, 0.335\n"
        "SIDE = math.radians(45.0)\n"
        "GAP = np.deg2rad(15)\n"
        "SIDE_RAD = 0.7853981633974483\n"
        "fine = (1.99, 0.6, 45.0, radians(30.0))  # 0.99 in a comment\n"
        "text = '0.99 x 0.67 m'\n"
    )
    assert [line for line, _ in robot_literals(source)] == [1, 1, 2, 2, 3, 4, 5]


def test_the_robot_is_written_once():
    offenders = []
    for folder in PRODUCTION:
        for path in sorted((ROOT / folder).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            for line, text in robot_literals(path.read_text(encoding="utf-8")):
                if (rel, text) not in UNRELATED:
                    offenders.append(f"{rel}:{line}: {text}")
    assert not offenders, (
        "the robot's numbers belong in assets/husky.toml (world/robot.py reads them):\n"
        + "\n".join(offenders)
    )


def test_every_unrelated_use_is_still_there():
    # an entry that no longer matches would hide a new literal on a line like it
    for (rel, text), why in UNRELATED.items():
        lines = [ln.strip() for ln in (ROOT / rel).read_text(encoding="utf-8").splitlines()]
        assert text in lines, f"{rel}: {text!r} ({why}) is gone: drop it from UNRELATED"


def test_the_description_is_husky_toml():
    from fuzzynav.world.husky import ROBOT_TABLES, HuskyModel
    from fuzzynav.world.robot import DESCRIPTION_TABLES

    p = HuskyModel.default().parameters
    assert HUSKY.footprint_m == (p.footprint_length_m, p.footprint_width_m) == (0.99, 0.67)
    assert (HUSKY.mass_kg, HUSKY.inertia_kg_m2) == (p.hull_mass_kg, p.hull_inertia_kg_m2)
    assert HUSKY.side_mount_rad == math.radians(45.0)
    assert HUSKY.gapless_side_mount_rad == HUSKY.beam_width_rad == math.radians(15.0)
    assert HUSKY.voltage_limit_v == 12.0
    assert [m.name for m in HUSKY.mounts] == ["left", "front", "right"]
    assert all(m.x_m == HUSKY.half_length_m == 0.495 for m in HUSKY.mounts)
    assert HUSKY.mounts[0].y_m == pytest.approx(0.75 * 0.335)
    assert set(ROBOT_TABLES) == set(DESCRIPTION_TABLES) | {"sonars"}


def test_the_worlds_defaults_are_the_description():
    from fuzzynav.controller.navigator.robot import _HX, _HY, _MOUNTS, VOLTAGE_LIMIT_V, mounts_of
    from fuzzynav.world.arena import Arena
    from fuzzynav.world.layouts import PASSABLE_GAP_M, SAFE_DISTANCE_M
    from fuzzynav.world.scenario import DEFAULT_FOOTPRINT_M
    from fuzzynav.world.sensors import SensorConfig, default_mounts

    assert Arena().footprint_m == DEFAULT_FOOTPRINT_M == HUSKY.footprint_m
    assert default_mounts() == SensorConfig().mounts == HUSKY.mounts
    assert SensorConfig().beam_width_rad == HUSKY.beam_width_rad
    assert PASSABLE_GAP_M == HUSKY.footprint_m[1] + 2 * SAFE_DISTANCE_M
    assert (_HX, _HY) == (HUSKY.half_length_m, HUSKY.half_width_m)
    assert _MOUNTS == mounts_of(HUSKY.mounts)
    assert VOLTAGE_LIMIT_V == HUSKY.voltage_limit_v


def test_the_sonar_side_reaches_the_sensors_and_fuzzynav():
    from fuzzynav.app.runs import build_simulation

    sim = build_simulation("s1", "fuzzynav", perception="ultrasonic", sonar_side_deg=15.0)
    side = math.radians(15.0)
    assert sim.robot.mounts == sim.sensors.config.mounts == HUSKY.with_sonar_side(side).mounts
    assert [m.angle_rad for m in sim.sensors.config.mounts] == [side, 0.0, -side]
    c = sim.controller
    assert [m[2] for m in c.memory.mounts] == [side, 0.0, -side]
    assert side in c.memory.axes and side in c.planner.axes and side in c.tracker.axes


def _wide() -> RobotDescription:
    return HUSKY.with_footprint((1.3, 0.9))


def test_a_changed_footprint_reaches_the_arena_sensors_and_fuzzynav():
    from fuzzynav.controller.registry import make_controller
    from fuzzynav.world.husky import HuskyModel
    from fuzzynav.world.scenario import load_scenario
    from fuzzynav.world.sensors import SensorConfig
    from fuzzynav.world.simulation import Simulation

    robot = _wide()
    params = dataclasses.replace(
        HuskyModel.default().parameters,
        footprint_length_m=robot.footprint_m[0],
        footprint_width_m=robot.footprint_m[1],
    )
    sim = Simulation(
        load_scenario("s1", footprint_m=robot.footprint_m),
        make_controller("fuzzynav"),
        perception="ultrasonic",
        model=HuskyModel(params),
        sensor_config=SensorConfig(mounts=robot.mounts),
    )
    assert sim.arena.footprint_m == robot.footprint_m
    assert sim.robot == robot
    # the sonars on the new front edge, the side ones the same fraction of the half-width out
    assert [m.x_m for m in sim.sensors.config.mounts] == [0.65] * 3
    assert sim.sensors.config.mounts[0].y_m == pytest.approx(0.75 * 0.45)
    c = sim.controller
    for part in (c.memory, c.planner, c.tracker):
        assert (part.hx, part.hy) == (0.65, 0.45)
    assert c.memory.mounts[0][:2] == (0.65, pytest.approx(0.75 * 0.45))
    # and the memory places a sonar's echo by that footprint: 1 m ahead of the front edge
    c.memory.reset()
    c.memory.update([math.inf] * 3, 1.0, 0.0, 0.0, True)
    assert c.memory.points[0][:2] == pytest.approx((1.65, 0.0))
    # a fresh controller is back on the default robot
    fresh = make_controller("fuzzynav")
    assert (fresh.memory.hx, fresh.memory.hy) == (HUSKY.half_length_m, HUSKY.half_width_m)


def test_a_changed_footprint_reaches_the_scenario_checks_and_the_layouts():
    from fuzzynav.world.layouts import generate_layout, passable_gap_m
    from fuzzynav.world.scenario import ObstacleSpec, Scenario, ScenarioError, check_layout

    robot = _wide()
    # an obstacle 0.1 m off the Husky's flank overlaps the wider robot's footprint
    near = Scenario(
        name="flank",
        duration_s=10.0,
        start=(0.0, 0.0),
        heading_rad=0.0,
        target=(5.0, 0.0),
        tolerance_m=0.15,
        obstacles=(ObstacleSpec((0.0, HUSKY.half_width_m + 0.1 + 0.2), 0.2),),
    )
    check_layout(near)
    with pytest.raises(ScenarioError, match="overlaps the robot's footprint"):
        check_layout(near, robot.footprint_m)
    # the layouts leave gaps the wider robot passes with its safe distance both sides
    assert passable_gap_m(robot) == pytest.approx(0.9 + 0.5)
    for i in range(12):
        sc = generate_layout("clutter", 3, i, robot=robot)
        statics = [o for o in sc.obstacles if o.is_static]
        for j, a in enumerate(statics):
            for b in statics[j + 1 :]:
                gap = math.dist(a.position, b.position) - a.radius_m - b.radius_m
                assert gap >= passable_gap_m(robot) - 1e-9
    # and the Husky's layouts are those of before (the default robot)
    assert generate_layout("clutter", 3, 0) == generate_layout("clutter", 3, 0, robot=HUSKY)


def test_a_bad_description_table_is_named(tmp_path):
    from fuzzynav.world.husky import DEFAULT_PARAMETER_FILE

    text = DEFAULT_PARAMETER_FILE.read_text(encoding="utf-8")
    path = tmp_path / "husky.toml"
    path.write_text(text.replace("width_deg = 15.0", "width_deg = 190.0"))
    with pytest.raises(ValueError, match=r"sonar_beam\.width_deg = 190\.0"):
        RobotDescription.from_toml(path)
    path.write_text(text.replace("angle_deg = -45.0", "angle_deg = -200.0"))
    with pytest.raises(ValueError, match=r"sonars\[2\]\.angle_deg = -200\.0"):
        RobotDescription.from_toml(path)
    path.write_text(text.replace('name = "right"', 'name = "left"'))
    with pytest.raises(ValueError, match=r"sonars\[2\]\.name = 'left': named twice"):
        RobotDescription.from_toml(path)
    path.write_text(text.replace("y_half_widths = 0.0", "y_half_widths = 0.0\nz_m = 1.0"))
    with pytest.raises(ValueError, match=r"unknown key sonars\[1\]\.z_m"):
        RobotDescription.from_toml(path)
    no_sonars = text[: text.index("\n[[sonars]]\n")] + text[text.index("# --- Drive -") :]
    path.write_text(no_sonars)
    with pytest.raises(ValueError, match=r"\[\[sonars\]\]"):
        RobotDescription.from_toml(path)
    path.write_text(text.replace("\n[drive]\n", "\n[drive]\nvoltage_limit_kv = 1.0\n"))
    with pytest.raises(ValueError, match=r"unknown key drive\.voltage_limit_kv"):
        RobotDescription.from_toml(path)
    path.write_text(text.replace("\n[drive]\nvoltage_limit_v = 12.0", "\n"))
    with pytest.raises(ValueError, match=r"\[drive\]"):
        RobotDescription.from_toml(path)


def test_sensors_rebuilt_after_the_start_reach_fuzzynav_at_the_next_reset():
    """A caller that rebuilds the simulation's sensors (the viewer does, for the noise)
    briefs the controller with the sonars it now has, as before the description."""
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.world.sensors import RangeSensorArray, SensorConfig

    sim = build_simulation("s1", "fuzzynav", perception="ultrasonic")
    side = math.radians(30.0)
    sim.sensors = RangeSensorArray(SensorConfig(mounts=HUSKY.with_sonar_side(side).mounts))
    sim.reset()
    assert [m[2] for m in sim.controller.memory.mounts] == [side, 0.0, -side]
