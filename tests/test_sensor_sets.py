"""Range sensors as data: any number of sonars from the robot's description, and a ring
of rays (world/lidar.py), in both engines; fuzzynav's navigator finds its front sonar by
mount."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fuzzynav.controller.batch import batch_controller
from fuzzynav.controller.registry import make_controller
from fuzzynav.world.batch import run_batch
from fuzzynav.world.layouts import FAMILIES, generate_layout
from fuzzynav.world.lidar import lidar_config, ring_mounts
from fuzzynav.world.perception import OBSTACLE_CUTOFF_M
from fuzzynav.world.robot import HUSKY, SensorMount
from fuzzynav.world.sensors import SensorConfig
from fuzzynav.world.simulation import Simulation

PERIOD_S = 0.05
#: The Husky's three sonars and a fourth between the left and the front one.
FOUR = SensorConfig(
    mounts=HUSKY.mounts + (SensorMount("front_left", HUSKY.half_length_m, 0.1, 0.35),)
)


def _layouts():
    return [generate_layout(family, 7, i).replace(duration_s=40.0) for i, family in
            enumerate(FAMILIES)]  # fmt: skip


def _both_engines(config: SensorConfig):
    scenarios = _layouts()
    reference = [
        Simulation(
            sc,
            make_controller("paper"),
            perception="ultrasonic",
            sensor_config=config,
            control_period_s=PERIOD_S,
        ).run()
        for sc in scenarios
    ]
    batch = run_batch(
        scenarios,
        batch_controller(make_controller("paper")),
        perception="ultrasonic",
        sensor_config=config,
        control_period_s=PERIOD_S,
        record_poses=True,
    )
    return scenarios, reference, batch


def _check_engines_agree(config: SensorConfig) -> list:
    """Both engines on the layouts: the same outcomes and steps, paths within 1e-9 m;
    the pymunk logs (one column per sensor, d_o the nearest reading at its mount)."""
    n = len(config.mounts)
    angles = np.array([m.angle_rad for m in config.mounts])
    scenarios, reference, batch = _both_engines(config)
    for i, (sc, ref) in enumerate(zip(scenarios, reference)):
        mine = batch.metrics(i)
        assert (mine["outcome"], mine["steps"]) == (ref.outcome, ref.metrics["steps"]), sc.name
        assert batch.poses[i].shape == ref.log.pose.shape, sc.name
        assert np.abs(batch.poses[i][:, :2] - ref.log.pose[:, :2]).max() <= 1e-9, sc.name
        log = ref.log
        assert log.ranges_m.shape == (len(log), n)
        nearest = log.ranges_m.min(axis=1)
        seen = nearest <= OBSTACLE_CUTOFF_M
        assert np.array_equal(np.isfinite(log.inputs[:, 1]), seen)
        assert np.array_equal(log.inputs[seen, 1], nearest[seen])
        k = log.ranges_m[seen].argmin(axis=1)
        assert np.array_equal(log.inputs[seen, 3], angles[k])
    return reference


def test_four_sonars_drive_both_engines():
    reference = _check_engines_agree(FOUR)
    # the fourth sonar is read, and is at times the one that sees the nearest obstacle
    fourth = np.concatenate([r.log.inputs[:, 3] == 0.35 for r in reference])
    assert np.isfinite(np.concatenate([r.log.ranges_m[:, 3] for r in reference])).any()
    assert fourth.sum() > 0


def test_a_ring_of_16_rays_drives_both_engines():
    config = lidar_config(16)
    assert len(config.mounts) == 16 and config.rays_per_beam == 1
    reference = _check_engines_agree(config)
    # rays behind the robot see what the sonars cannot
    behind = [k for k, m in enumerate(config.mounts) if abs(m.angle_rad) > math.pi / 2]
    rows = np.concatenate([r.log.ranges_m[:, behind] for r in reference])
    assert np.isfinite(rows).any()


def test_the_rings_rays_start_on_the_footprints_edge():
    mounts = ring_mounts(16)
    assert [m.name for m in mounts[:2]] == ["ray0", "ray1"]
    assert mounts[0].angle_rad == 0.0 and mounts[8].angle_rad == pytest.approx(math.pi)
    assert all(-math.pi < m.angle_rad <= math.pi for m in mounts)
    hx, hy = HUSKY.half_length_m, HUSKY.half_width_m
    for m in mounts:
        on_edge = math.isclose(abs(m.x_m), hx) or math.isclose(abs(m.y_m), hy)
        assert on_edge and abs(m.x_m) <= hx + 1e-12 and abs(m.y_m) <= hy + 1e-12
        assert math.atan2(m.y_m, m.x_m) == pytest.approx(m.angle_rad)
    with pytest.raises(ValueError, match="n_rays = 0"):
        ring_mounts(0)


def test_fuzzynav_finds_its_front_sonar_by_mount():
    from fuzzynav.controller.navigator.memory import PerceptionMemory
    from fuzzynav.controller.navigator.robot import mounts_of

    memory = PerceptionMemory(make_controller("fuzzynav").params)
    # the front sonar listed first, two on the left, one on the right
    mounts = (
        SensorMount("front", 0.5, 0.0, 0.0),
        SensorMount("left", 0.5, 0.2, 0.8),
        SensorMount("front_left", 0.5, 0.1, 0.3),
        SensorMount("right", 0.5, -0.2, -0.8),
    )
    memory.mounts = mounts_of(mounts)
    assert memory.front_index == 0
    assert memory.fold([2.0, 3.0, 1.5, 4.0]) == (1.5, 2.0, 4.0)
    assert memory.fold([math.inf, 3.0, math.inf, math.inf]) == (3.0, math.inf, math.inf)
    memory.mounts = mounts_of(HUSKY.mounts)
    assert memory.fold([1.0, 2.0, 3.0]) == (1.0, 2.0, 3.0)
    # its time to contact reads the front sonar, wherever it is listed
    memory.mounts = mounts_of(mounts)
    memory.reset()
    args = (math.nan, math.nan, math.nan, True, 0.05, 0.2)
    memory.sectors([2.0, 1.0, 1.0, 1.0], *args)
    assert memory.prev_front == 2.0


@pytest.mark.parametrize("config", [FOUR, lidar_config(16)], ids=["four sonars", "16 rays"])
def test_fuzzynav_drives_with_any_sensor_set(config):
    sc = generate_layout("standard", 7, 3)
    sim = Simulation(sc, make_controller("fuzzynav"), perception="ultrasonic", sensor_config=config)
    result = sim.run()
    memory = sim.controller.memory
    assert memory.mounts[memory.front_index][2] == 0.0
    assert result.log.ranges_m.shape[1] == len(config.mounts)
    assert result.outcome == "reached"


def test_a_side_angle_for_a_ring_of_rays_is_refused(monkeypatch, capsys):
    """``--sonar-side`` turns the side sonars; a ring of rays all around has none (turned,
    its 16 rays collapsed onto +-DEG and its rear ones looked forward across the body):
    refused, naming the option and value, on the robot's description, in the API and
    at the command line (exit 2); a set with no sensor off the heading has nothing to
    turn. The Husky's three sonars still take it."""
    import fuzzynav
    from fuzzynav.app.cli import main
    from fuzzynav.world import sensors

    ring = HUSKY.with_mounts(ring_mounts(16))
    with pytest.raises(ValueError, match=r"side_angle_rad = 0\.5: .*ray5 at 112\.5.*ring of rays"):
        ring.with_sonar_side(0.5)
    sim = Simulation(
        generate_layout("standard", 7, 3),
        make_controller("paper"),
        perception="ultrasonic",
        sensor_config=lidar_config(16),
    )
    with pytest.raises(ValueError, match="ring of rays"):
        sim.robot.with_sonar_side(0.5)
    front_only = HUSKY.with_mounts(HUSKY.mounts[1:2])
    with pytest.raises(ValueError, match="no side sonar to turn"):
        front_only.with_sonar_side(0.5)
    assert [m.angle_rad for m in HUSKY.with_sonar_side(0.5).mounts] == [0.5, 0.0, -0.5]
    # the robot's own sensor set is the ring: the option is refused before a run
    monkeypatch.setattr(sensors, "HUSKY", ring)
    with pytest.raises(ValueError, match=r"sonar_side_deg = 30 \(--sonar-side\): .*ring of rays"):
        fuzzynav.simulate("s1", perception="ultrasonic", sonar_side_deg=30)
    assert main(["run", "s1", "--perception", "ultrasonic", "--sonar-side", "30"]) == 2
    err = capsys.readouterr().err
    assert "error: sonar_side_deg = 30 (--sonar-side): the robot's sensors look behind" in err


def test_a_side_angle_for_the_paper_geometry_is_refused(tmp_path, capsys):
    """The paper geometry's robot is a point without sonars (its inputs exact, its
    ranges none): ``--sonar-side`` there changed nothing of the run, and was taken
    silently. Refused, naming the option and the geometry, before anything runs or is
    written: in build_simulation, simulate and at the command line (exit 2). The
    Husky geometry still takes it."""
    import fuzzynav
    from fuzzynav.app.cli import main
    from fuzzynav.app.runs import build_simulation

    why = r"sonar_side_deg = 30 \(--sonar-side\): with geometry = 'paper'.*no sonars"
    with pytest.raises(ValueError, match=why):
        build_simulation("s1", "paper", geometry="paper", sonar_side_deg=30)
    with pytest.raises(ValueError, match=why):
        fuzzynav.simulate("s1", geometry="paper", sonar_side_deg=30)
    trace = tmp_path / "trace.csv"
    argv = ["run", "s1", "--geometry", "paper", "--sonar-side", "30", "--trace", str(trace)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "error: sonar_side_deg = 30 (--sonar-side): with geometry = 'paper'" in err, err
    assert "Traceback" not in err and not trace.exists()
    sim = build_simulation("s1", "paper", geometry="husky", sonar_side_deg=30)
    assert [m.angle_rad for m in sim.sensors.config.mounts] == pytest.approx(
        [math.radians(30), 0.0, -math.radians(30)]
    )
