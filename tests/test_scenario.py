"""Scenario files: the shipped ones load, and every kind of bad input is named."""

import math

import pytest

from fuzzynav.world.scenario import (
    Scenario,
    ScenarioError,
    load_scenario,
    scenario_from_dict,
    scenario_names,
)

VALID = """
name = "test"
duration_s = 60.0
[robot]
start = [0.0, 0.0]
heading_rad = 0.0
[target]
position = [8.0, 8.0]
tolerance_m = 0.15
[[obstacles]]
position = [4.0, 4.0]
radius_m = 0.2
"""


def test_shipped_scenarios_match_the_paper():
    assert {"s1", "s2", "s3"} <= set(scenario_names())
    s1, s2, s3 = (load_scenario(n) for n in ("s1", "s2", "s3"))
    assert [o.position for o in s1.obstacles] == [(4.0, 4.0), (5.7, 5.0), (7.5, 6.4)]
    assert all(o.radius_m == 0.2 and o.is_static for o in s1.obstacles)
    assert s1.start == (0.0, 0.0) and s1.target == (8.0, 8.0)
    assert s1.heading_rad == 0.0  # facing +x: the selected reading
    # ideal perception senses a 60-degree cone ahead: the readings table's field
    assert all(s.field_of_view_deg == pytest.approx(60.0) for s in (s1, s2, s3))
    static, moving = s2.obstacles
    assert static.position == (4.0, 3.58) and static.is_static
    assert moving.position == (8.0, 8.0) and moving.radius_m == 0.3
    assert moving.acceleration == (-0.001, -0.00123) and moving.velocity == (0.0, 0.0)
    assert s2.disturbance is None
    assert s3.obstacles == s2.obstacles
    d = s3.disturbance
    assert (d.amplitude, d.angular_frequency_rad_s, d.start_s, d.stop_s) == (1.0, 2.0, 25.0, 35.0)
    assert d.value(24.99) == 0.0 and d.value(35.0) == 0.0
    assert d.value(30.0) == pytest.approx(math.sin(60.0))


def test_round_trip_through_toml(write_toml):
    s3 = load_scenario("s3")
    again = load_scenario(write_toml(s3.to_toml()))
    assert again == s3


def test_valid_file_loads(write_toml):
    sc = load_scenario(write_toml(VALID))
    assert isinstance(sc, Scenario) and sc.duration_s == 60.0
    assert sc.field_of_view_rad == 2 * math.pi  # all around unless the file says otherwise
    assert "field_of_view_deg" not in sc.to_toml()


def test_a_field_of_view_is_read_and_written_back(write_toml):
    sc = load_scenario(write_toml(VALID.replace("heading_rad = 0.0", "field_of_view_deg = 120")))
    assert sc.field_of_view_rad == pytest.approx(math.radians(120.0))
    again = load_scenario(write_toml(sc.to_toml()))
    assert again == sc and "field_of_view_deg = 120.0" in sc.to_toml()


@pytest.mark.parametrize(
    "old, new, key, value_text",
    [
        ('name = "test"', 'name = "test"\ncolour = "red"', "colour", "red"),
        ("heading_rad = 0.0", "heading_rad = 0.0\nspeed = 1", "robot.speed", "1"),
        ("radius_m = 0.2", "radius_m = 0.2\nmass = 3", "obstacles[0].mass", "3"),
        ("tolerance_m = 0.15", "tolerance_m = 0.15\nradius = 1", "target.radius", "1"),
        ("duration_s = 60.0", 'duration_s = "long"', "duration_s", "long"),
        ("duration_s = 60.0", "duration_s = nan", "duration_s", "nan"),
        ("duration_s = 60.0", "duration_s = -1.0", "duration_s", "-1.0"),
        ("duration_s = 60.0", "duration_s = 1e9", "duration_s", "1000000000.0"),
        ("duration_s = 60.0", "duration_s = 3600.5", "duration_s", "3600.5"),
        # Beyond any arena, and beyond what the controllers compute without overflow.
        ("position = [8.0, 8.0]", "position = [1e300, 8.0]", "target.position[0]", "1e+300"),
        ("start = [0.0, 0.0]", "start = [0.0, -2e4]", "robot.start[1]", "-20000.0"),
        ("radius_m = 0.2", "radius_m = 1e300", "obstacles[0].radius_m", "1e+300"),
        (
            "radius_m = 0.2",
            "radius_m = 0.2\nvelocity = [0.0, 1e3]",
            "obstacles[0].velocity[1]",
            "1000.0",
        ),
        (
            "radius_m = 0.2",
            "radius_m = 0.2\nacceleration = [1e308, 0.0]",
            "obstacles[0].acceleration[0]",
            "1e+308",
        ),
        ("tolerance_m = 0.15", "tolerance_m = 1e9", "target.tolerance_m", "1000000000.0"),
        ("start = [0.0, 0.0]", "start = [0.0, inf]", "robot.start[1]", "inf"),
        ("start = [0.0, 0.0]", "start = [0.0]", "robot.start", "[0.0]"),
        ("radius_m = 0.2", "radius_m = 0.0", "obstacles[0].radius_m", "0.0"),
        ("radius_m = 0.2", "radius_m = -0.3", "obstacles[0].radius_m", "-0.3"),
        ("tolerance_m = 0.15", "tolerance_m = 0.0", "target.tolerance_m", "0.0"),
        ("heading_rad = 0.0", "heading_rad = true", "robot.heading_rad", "True"),
        ("heading_rad = 0.0", "field_of_view_deg = 0.0", "robot.field_of_view_deg", "0.0"),
        ("heading_rad = 0.0", "field_of_view_deg = 400", "robot.field_of_view_deg", "400"),
        ("heading_rad = 0.0", "field_of_view_deg = nan", "robot.field_of_view_deg", "nan"),
        ("heading_rad = 0.0", 'field_of_view_deg = "front"', "robot.field_of_view_deg", "front"),
    ],
)
def test_bad_values_are_named(write_toml, old, new, key, value_text):
    path = write_toml(VALID.replace(old, new))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert str(path) in message and key in message and value_text in message
    assert info.value.key == key


def test_missing_required_key(write_toml):
    path = write_toml(VALID.replace("[target]\nposition = [8.0, 8.0]\n", "[target]\n"))
    with pytest.raises(ScenarioError, match=r"target\.position.*missing"):
        load_scenario(path)


def test_start_overlapping_an_obstacle(write_toml):
    # The footprint reaches 0.495 m ahead of the centre: a 0.2 m obstacle at 0.6 m touches it.
    path = write_toml(VALID.replace("position = [4.0, 4.0]", "position = [0.6, 0.0]"))
    with pytest.raises(ScenarioError, match=r"obstacles\[0\]\.position.*footprint"):
        load_scenario(path)
    # ... and one at 0.75 m does not.
    load_scenario(write_toml(VALID.replace("position = [4.0, 4.0]", "position = [0.75, 0.0]")))


def test_target_inside_a_static_obstacle(write_toml):
    path = write_toml(VALID.replace("position = [4.0, 4.0]", "position = [8.1, 8.0]"))
    with pytest.raises(ScenarioError, match=r"target\.position.*inside static obstacle"):
        load_scenario(path)


def test_target_too_near_a_static_obstacle_to_reach(write_toml):
    # The robot's centre stays >= its half-width (0.335 m) from any surface and must come
    # within the tolerance (0.15 m) of the target: a target 0.1 m off a surface is out of
    # reach, one 0.25 m off is not.
    near = write_toml(VALID.replace("position = [4.0, 4.0]", "position = [8.3, 8.0]"))
    with pytest.raises(
        ScenarioError,
        match=r"target\.position = \[8\.0, 8\.0\]: cannot be "
        r"reached: it is 0\.100 m from static obstacle",
    ):
        load_scenario(near)
    load_scenario(write_toml(VALID.replace("position = [4.0, 4.0]", "position = [8.45, 8.0]")))


def test_target_inside_a_moving_obstacle_is_allowed():
    # Scenario 2 of the paper starts its moving obstacle on the target.
    assert load_scenario("s2").obstacles[1].position == load_scenario("s2").target


def test_overlapping_static_obstacles(write_toml):
    text = VALID + "[[obstacles]]\nposition = [4.3, 4.0]\nradius_m = 0.2\n"
    with pytest.raises(ScenarioError, match=r"obstacles\[1\]\.position.*overlaps static obstacle"):
        load_scenario(write_toml(text))


def test_missing_file_and_bad_toml(write_toml, tmp_path):
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario(tmp_path / "nope.toml")
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(write_toml("name = \n"))


def test_disturbance_stop_before_start():
    data = {
        "name": "x",
        "duration_s": 1.0,
        "robot": {"start": [0, 0]},
        "target": {"position": [5, 5]},
        "disturbance": {"amplitude": 1, "angular_frequency_rad_s": 2, "start_s": 5, "stop_s": 1},
    }
    with pytest.raises(ScenarioError, match="disturbance.stop_s"):
        scenario_from_dict(data)


def test_an_hour_is_the_longest_run_a_file_may_ask_for(write_toml):
    assert (
        load_scenario(
            write_toml(VALID.replace("duration_s = 60.0", "duration_s = 3600.0"))
        ).duration_s
        == 3600.0
    )


def test_a_huge_duration_built_in_code_runs_without_a_huge_log():
    """Before, the log was allocated for the whole duration at once: 1e9 s asked numpy for
    8.7 TiB and crashed. Now it starts at an hour's worth and grows."""
    from fuzzynav.app.runs import build_simulation
    from fuzzynav.controller.registry import make_controller
    from fuzzynav.world.simulation import Simulation

    scenario = load_scenario("s1").replace(duration_s=1e9)
    with pytest.raises(ScenarioError, match="duration_s"):  # the front doors refuse it
        build_simulation(scenario, "p")
    sim = Simulation(scenario, make_controller("p"))  # the world itself copes
    for _ in range(10):
        sim.step()
    assert len(sim.log) == 10 and not sim.done


def test_a_disturbance_beyond_reason_is_named(write_toml):
    table = (
        "\n[disturbance]\namplitude = {a}\nangular_frequency_rad_s = 2.0\n"
        "start_s = 1.0\nstop_s = 2.0\n"
    )
    assert load_scenario(write_toml(VALID + table.format(a=1.0))).disturbance.amplitude == 1.0
    with pytest.raises(ScenarioError) as info:
        load_scenario(write_toml(VALID + table.format(a=1e300)))
    assert info.value.key == "disturbance.amplitude" and "1e+300" in str(info.value)


@pytest.mark.parametrize("count", [2, 5, 64, 65, 300])
def test_the_first_overlap_is_the_same_found_by_every_pair_or_by_the_tree(count):
    """first_overlap checks every pair up to ALL_PAIRS_UP_TO obstacles and uses a k-d tree
    beyond; either way it names the pair the plain double loop finds first (smallest j,
    then smallest i), touching circles (a gap equal to the radii) not overlapping."""
    import random

    from fuzzynav.world.scenario import ALL_PAIRS_UP_TO, ObstacleSpec, first_overlap

    assert 5 < ALL_PAIRS_UP_TO < 300
    rng = random.Random(count)
    for trial in range(40):
        spread = rng.choice([2.0, 10.0, 60.0])
        obstacles = [
            ObstacleSpec((rng.uniform(0, spread), rng.uniform(0, spread)), rng.uniform(0.1, 0.6))
            for _ in range(count)
        ]
        if trial == 0:  # two that touch exactly: 3-4-5
            obstacles = [ObstacleSpec((0.0, 0.0), 2.0), ObstacleSpec((3.0, 4.0), 3.0)] + [
                ObstacleSpec((100.0 + 2 * k, 100.0), 0.5) for k in range(count - 2)
            ]
        want = next(
            (
                (i, j)
                for j in range(count)
                for i in range(j)
                if math.dist(obstacles[i].position, obstacles[j].position)
                < obstacles[i].radius_m + obstacles[j].radius_m
            ),
            None,
        )
        assert first_overlap(obstacles) == want, (count, trial)
