"""Each fact of one step is defined once (world/kernels.py, world/geometry.py): where the
pymunk engine keeps a scalar form for its speed, it is checked here against the one
definition on many values, bit for bit (issue 36 item 3)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fuzzynav.world import kernels
from fuzzynav.world.arena import Arena, Obstacle
from fuzzynav.world.batch_world import BatchWorld
from fuzzynav.world.geometry import target_input, wrap_angle_scalar, wrap_angles
from fuzzynav.world.scenario import Disturbance, ObstacleSpec, load_scenario

RNG = np.random.default_rng(36)


def _same_bits(a, b) -> bool:
    return np.array_equal(np.asarray(a, float).view(np.int64), np.asarray(b, float).view(np.int64))


def _within_one_ulp(a, b) -> bool:
    """math.hypot against numpy's hypot (and math.atan2 against numpy's arctan2): the
    known last-bit differences (world/kernels.py)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return bool(np.all(np.abs(a - b) <= np.spacing(np.maximum(np.abs(a), np.abs(b)))))


def test_angle_wrapping_for_one_float_is_the_array_form_bit_for_bit():
    angles = np.concatenate(
        [
            RNG.uniform(-50.0, 50.0, 20_000),
            np.array([0.0, -0.0, math.pi, -math.pi, 3 * math.pi, -3 * math.pi, 2 * math.pi]),
            np.nextafter(math.pi, [0.0, 4.0]),
            np.nextafter(-math.pi, [0.0, -4.0]),
        ]
    )
    scalar = [wrap_angle_scalar(a) for a in angles.tolist()]
    assert _same_bits(scalar, wrap_angles(angles))


def test_the_obstacles_law_for_one_float_is_the_array_form_bit_for_bit():
    n = 2_000
    p, v, a = RNG.uniform(-10, 10, (n, 2)), RNG.uniform(-3, 3, (n, 2)), RNG.uniform(-1, 1, (n, 2))
    t = RNG.uniform(0.0, 150.0, n)
    specs = [ObstacleSpec(tuple(p[i]), 0.3, tuple(v[i]), tuple(a[i])) for i in range(n)]
    law = np.array([kernels.obstacle_law(spec) for spec in specs])[:, :, None]  # (n, 6, 1)
    cx, cy = kernels.obstacle_centres(law, t)
    bound = kernels.obstacle_path_bound(law, t, 0.02)
    for i in range(0, n, 7):
        obstacle = Obstacle(0, specs[i])
        assert _same_bits(obstacle._xy_at(float(t[i])), (cx[i, 0], cy[i, 0]))
        assert _same_bits(obstacle.position_at(float(t[i])), (cx[i, 0], cy[i, 0]))
        path = kernels.law_path_bound(obstacle._law, float(t[i]), 0.02)
        assert _within_one_ulp(path, bound[i, 0])  # a float's ** 0.5 against numpy's sqrt


def test_a_motion_law_written_once_moves_both_engines_obstacles(monkeypatch):
    """Issue 36 (c): the obstacles' law is written once (world/kernels.py); a toy law
    patched there alone (each obstacle travels twice as far, as a key ``speed_factor =
    2`` would make it) moves the pymunk engine's bodies and the batch engine's arrays."""
    plain = kernels.obstacle_law

    def twice_as_far(spec):
        px, py, *motion = plain(spec)
        return (px, py, *(2.0 * m for m in motion))

    monkeypatch.setattr(kernels, "obstacle_law", twice_as_far)
    scenario = load_scenario("s2")
    dt, steps = 0.05, 400
    arena = Arena((0.0, 0.0))
    arena.reset(scenario.start, scenario.heading_rad, scenario.target, scenario.obstacles)
    batch = BatchWorld(geometry="paper", control_period_s=dt)
    batch.reset([scenario])
    for _ in range(steps):
        arena.step(0.0, 0.0, dt)
        batch.step(np.zeros((1, 2)))
    t = arena.time_s
    want = [
        np.asarray(o.position) + 2.0 * (np.asarray(o.velocity) * t + 0.5 * np.asarray(o.acceleration) * t * t)
        for o in scenario.obstacles
    ]  # fmt: skip
    assert np.linalg.norm(want[1] - np.asarray(scenario.obstacles[1].position)) > 0.5
    bodies = [tuple(arena.obstacles[i].body.position) for i in sorted(arena.obstacles)]
    np.testing.assert_allclose(bodies, want, atol=1e-9)
    np.testing.assert_allclose(np.stack([batch.s.cx[0], batch.s.cy[0]], axis=1), want, atol=1e-9)


@pytest.mark.parametrize("footprint", [(0.99, 0.67), (0.0, 0.0)])
def test_the_arenas_clearances_are_the_array_form(footprint):
    arena = Arena(footprint)
    centres = RNG.uniform(-3.0, 3.0, (300, 2))
    radii = RNG.uniform(0.05, 1.0, 300)
    specs = [ObstacleSpec(tuple(c), float(r)) for c, r in zip(centres, radii)]
    for heading in RNG.uniform(-7.0, 7.0, 5).tolist():
        arena.reset((0.1, -0.2), heading, (9.0, 9.0), specs)
        x, y, h = arena.pose
        array = kernels.footprint_clearances(
            np.array([x]), np.array([y]), np.array([h]), centres[None, :, 0],
            centres[None, :, 1], radii[None], 0.5 * footprint[0], 0.5 * footprint[1],
        )[0]  # fmt: skip
        # the same bits but where math.hypot and numpy's differ in the last bit of the
        # outside distance (about a + radius)
        slack = np.spacing(np.abs(array) + radii)
        assert np.all(np.abs(arena.clearances() - array) <= slack)
        assert np.mean(arena.clearances() == array) > 0.95


def test_the_target_inputs_for_one_pose_are_the_array_form():
    n = 5_000
    x, y, h = RNG.uniform(-20, 20, n), RNG.uniform(-20, 20, n), RNG.uniform(-20, 20, n)
    target = RNG.uniform(-20, 20, (n, 2))
    d_t, phi_t = kernels.target_inputs(x, y, h, target)
    scalar = [target_input((x[i], y[i], h[i]), target[i].tolist()) for i in range(n)]
    assert _within_one_ulp([d for d, _ in scalar], d_t)
    # math.atan2 and numpy's arctan2 differ in the last bit of some: an ulp of the sum
    phi = np.array([phi for _, phi in scalar])
    assert np.all(np.abs(wrap_angles(phi - phi_t)) <= np.spacing(32.0))  # |heading| < 20
    assert np.mean(phi == phi_t) > 0.8


def test_the_scenarios_disturbance_is_the_array_form_bit_for_bit():
    n = 3_000
    amplitude, omega = RNG.uniform(-2, 2, n), RNG.uniform(0.1, 10, n)
    start, length = RNG.uniform(0, 50, n), RNG.uniform(0, 30, n)
    t = RNG.uniform(0, 100, n)
    t[::5] = start[::5]  # the window's edges
    t[1::5] = (start + length)[1::5]
    table = np.stack([amplitude, omega, start, start + length], axis=1)
    values = kernels.disturbance_values(table, t)
    scalar = [
        Disturbance(float(a), float(w), float(s0), float(s1)).value(float(tt))
        for a, w, s0, s1, tt in zip(amplitude, omega, start, start + length, t)
    ]
    assert _same_bits(scalar, values)


@pytest.mark.parametrize("footprint, fov", [((0.99, 0.67), None), ((0.0, 0.0), math.pi)])
def test_the_pymunk_engines_obstacle_inputs_are_the_array_form(footprint, fov):
    from fuzzynav.world.kernels import nearest_obstacle

    arena = Arena(footprint)
    n_obstacles = 12
    for _ in range(200):
        centres = RNG.uniform(-4.0, 4.0, (n_obstacles, 2))
        radii = RNG.uniform(0.05, 0.6, n_obstacles)
        heading = float(RNG.uniform(-7.0, 7.0))
        specs = [ObstacleSpec(tuple(c), float(r)) for c, r in zip(centres, radii)]
        arena.reset((0.1, -0.2), heading, (9.0, 9.0), specs)
        x, y, h = (np.array([v]) for v in arena.pose)
        half = None if fov is None else 0.5 * fov
        d_o, phi_o, _ = nearest_obstacle(arena._scene(), arena.pose, 3.0, fov is not None, half)
        want_d, want_phi = kernels.ideal_obstacle_inputs(
            x, y, h, centres[None, :, 0], centres[None, :, 1], radii[None],
            np.ones((1, n_obstacles), bool), arena.clearances()[None],
            np.array([np.inf if half is None else half]), fov is not None, 3.0,
        )  # fmt: skip
        assert _same_bits(d_o, want_d[0])
        assert math.isnan(phi_o) == math.isnan(want_phi[0])
        if not math.isnan(phi_o):
            assert abs(wrap_angles(np.array(phi_o - want_phi[0]))) <= np.spacing(16.0)


def test_the_scalar_rectangle_clearance_is_the_array_form():
    from fuzzynav.world.geometry import rectangle_circle_clearance, rectangle_circles_clearance

    centres = RNG.uniform(-3.0, 3.0, (2_000, 2))
    radii = RNG.uniform(0.05, 1.0, 2_000)
    for heading in RNG.uniform(-7.0, 7.0, 5).tolist():
        array = rectangle_circles_clearance((0.3, -0.1), heading, 0.99, 0.67, centres, radii)
        scalar = [
            rectangle_circle_clearance((0.3, -0.1), heading, 0.99, 0.67, c, r)
            for c, r in zip(centres.tolist(), radii.tolist())
        ]
        # an ulp of the outside distance (math.hypot), and the rounding of the sum
        assert np.all(np.abs(np.array(scalar) - array) <= 2 * np.spacing(np.abs(array) + radii))
        assert np.mean(np.array(scalar) == array) > 0.95


def test_the_arenas_motion_is_advance_pose_bit_for_bit():
    arena = Arena()
    for _ in range(300):
        x0, y0, h0 = RNG.uniform(-5, 5), RNG.uniform(-5, 5), RNG.uniform(-7, 7)
        v, w = RNG.uniform(-1, 1), RNG.choice([0.0, *RNG.uniform(-3, 3, 3)])
        arena.reset((x0, y0), h0, (9.0, 9.0))
        start = arena.pose
        arena.step(v, w, 0.02)
        want = kernels.advance_pose(
            *(np.array([p]) for p in start), np.array([v]), np.array([w]), 0.02
        )
        assert _same_bits(arena.pose, [p[0] for p in want])


def test_the_sonar_inputs_for_one_run_are_the_array_form():
    from fuzzynav.world.perception import Perception
    from fuzzynav.world.sensors import RangeSensorArray

    perception = Perception("ultrasonic", RangeSensorArray())
    mounts = np.array(perception._mount_angles)
    ranges = RNG.uniform(0.0, 5.0, (500, len(mounts)))
    ranges[RNG.random(ranges.shape) < 0.3] = np.inf
    d_o, phi_o = kernels.sonar_obstacle_inputs(ranges, mounts, perception.cutoff_m)

    class Sensors:  # readings given, as RangeSensorArray.read returns them
        config = perception.sensors.config

        def read(self, arena, time_s):
            return self.now

    perception.sensors = sensors = Sensors()
    arena = Arena()
    arena.reset((0.0, 0.0), 0.0, (9.0, 9.0))
    for i, row in enumerate(ranges):
        sensors.now = row
        _, d, _, phi, _, _ = perception._sense(arena, 0.0)
        assert _same_bits([d, phi], [d_o[i], phi_o[i]])


def test_the_stop_rules_for_one_run_are_the_array_form():
    from fuzzynav.world.run_limits import OUTCOMES, run_ending, run_endings

    n = 2_000
    to_target = RNG.uniform(0.0, 0.3, n)
    tolerance = np.full(n, 0.15)
    to_target[::7] = tolerance[::7]  # on the tolerance: reached
    touched = RNG.random(n) < 0.3
    time_s = RNG.uniform(0.0, 20.0, n)
    timeout_at = np.full(n, 10.0)
    time_s[::11] = timeout_at[::11]  # at the timeout: timed out
    array = run_endings(to_target, tolerance, touched, time_s, timeout_at)
    scalar = [
        run_ending(*values)
        for values in zip(
            to_target.tolist(), tolerance.tolist(), touched.tolist(), time_s.tolist(),
            timeout_at.tolist(),
        )
    ]  # fmt: skip
    assert array.tolist() == scalar
    assert set(scalar) == {-1, *range(len(OUTCOMES))}
    # the target before a contact, a contact before the time
    assert run_ending(0.1, 0.15, True, 11.0, 10.0) == OUTCOMES.index("reached")
    assert run_ending(0.2, 0.15, True, 11.0, 10.0) == OUTCOMES.index("collided")
    assert run_ending(0.2, 0.15, False, 10.0, 10.0) == OUTCOMES.index("timeout")
