"""The world: sensors against analytic ray-circle answers, motion against solve_ivp,
collisions in the step they happen, moving obstacles, perception and determinism."""

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from fuzzynav.controller.registry import make_controller
from fuzzynav.world.arena import Arena
from fuzzynav.world.geometry import (
    HUSKY_WHEEL_RADIUS_M,
    beam_cone_outlines,
    beam_cones,
    beam_geometries,
    bearing_segments,
    circle_points,
    footprint_exit_m,
    footprint_outlines,
    husky_body_boxes,
    husky_wheel_centres,
    obstacle_bearings,
    points_along,
    ray_circle_distance,
    rectangle_circle_clearance,
    rounded_rectangle,
    target_geometry,
    to_robot_frame,
    to_world_frame,
    wrap_angle,
    wrap_angle_scalar,
)
from fuzzynav.world.geometry import target_input as target_inputs
from fuzzynav.world.husky import HuskyModel
from fuzzynav.world.perception import Perception, ideal_obstacle_inputs
from fuzzynav.world.scenario import ObstacleSpec, Scenario, load_scenario
from fuzzynav.world.sensors import RangeSensorArray, SensorConfig, SensorMount, default_mounts
from fuzzynav.world.simulation import Simulation

FOOTPRINT = (0.99, 0.67)


class ConstantVoltage:
    def __init__(self, left, right):
        self.v = np.array((left, right), dtype=float)
        self.calls = 0

    def reset(self):
        self.calls = 0

    def __call__(self, inputs):
        self.calls += 1
        return self.v


def open_field(duration_s=10.0, obstacles=(), target=(100.0, 100.0), heading=0.0):
    return Scenario(
        name="open",
        duration_s=duration_s,
        start=(0.0, 0.0),
        heading_rad=heading,
        target=target,
        tolerance_m=0.15,
        obstacles=tuple(obstacles),
    )


# -- geometry ----------------------------------------------------------------------------


@given(st.floats(-50, 50, allow_nan=False))
def test_wrap_angle_range(angle):
    w = wrap_angle_scalar(angle)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(angle), abs_tol=1e-9)
    assert math.isclose(math.sin(w), math.sin(angle), abs_tol=1e-9)
    assert w == pytest.approx(wrap_angle(angle), abs=1e-12)


def test_wrap_angle_edges():
    assert wrap_angle_scalar(math.pi) == math.pi
    assert wrap_angle_scalar(-math.pi) == math.pi
    assert wrap_angle_scalar(3 * math.pi) == pytest.approx(math.pi)


def test_rectangle_circle_clearance_cases():
    # Straight ahead: front edge at 0.495 m.
    assert rectangle_circle_clearance((0, 0), 0.0, *FOOTPRINT, (2.0, 0.0), 0.2) == pytest.approx(
        1.305
    )
    # Off the corner: distance to the corner (0.495, 0.335) minus the radius.
    c = rectangle_circle_clearance((0, 0), 0.0, *FOOTPRINT, (1.495, 1.335), 0.2)
    assert c == pytest.approx(math.hypot(1.0, 1.0) - 0.2)
    # Rotated by 90 degrees: what was the side is now the front.
    assert rectangle_circle_clearance(
        (0, 0), math.pi / 2, *FOOTPRINT, (0.0, 2.0), 0.2
    ) == pytest.approx(1.305)
    assert rectangle_circle_clearance((0, 0), 0.0, *FOOTPRINT, (0.3, 0.0), 0.2) < 0


def test_drawn_geometry_agrees_with_the_world():
    """What the viewer, the recordings and the figures draw (world.geometry, issue 24):
    the outline's corners lie on the footprint, the beams start where the sensors'
    own geometry says, bearings and the target's distance are the robot frame's."""
    pose = np.array([[1.0, -2.0, 0.7], [0.0, 0.0, -3.0], [-4.0, 5.0, math.pi]])
    outlines = footprint_outlines(pose, *FOOTPRINT)
    assert outlines.shape == (3, 5, 2) and np.array_equal(outlines[:, 0], outlines[:, 4])
    for (x, y, h), outline in zip(pose, outlines):
        for corner in outline[:4]:
            local = to_robot_frame(corner, (x, y), h)
            assert np.allclose(np.abs(local), np.multiply(FOOTPRINT, 0.5))
    sensors = RangeSensorArray(SensorConfig())
    origins, directions = beam_geometries(pose, sensors.config.mounts)
    for k, p in enumerate(pose):
        for j, (origin, direction) in enumerate(sensors.beam_geometry(tuple(p))):
            assert np.allclose(origins[k, j], origin) and directions[k, j] == pytest.approx(
                direction
            )
    left, right = beam_cones(origins[:, 0], directions[:, 0], np.full(3, 2.0), 0.1)
    assert np.allclose(np.hypot(*(left - origins[:, 0]).T), 2.0)
    assert np.allclose(np.hypot(*(right - origins[:, 0]).T), 2.0)
    ends = points_along(origins[:, 0], directions[:, 0], np.full(3, 2.0))
    assert np.allclose(
        0.5 * (left + right), ends * math.cos(0.1) + origins[:, 0] * (1 - math.cos(0.1))
    )
    obstacles = np.array([[[3.0, 4.0]]] * 3)
    bearings = obstacle_bearings(pose, obstacles)
    distance, phi_t = target_geometry(pose, obstacles[:, 0])
    for k, (x, y, h) in enumerate(pose):
        lx, ly = to_robot_frame(obstacles[k, 0], (x, y), h)
        assert bearings[k, 0] == pytest.approx(math.atan2(ly, lx)) == pytest.approx(phi_t[k])
        assert distance[k] == pytest.approx(math.hypot(lx, ly))
    assert np.all((bearings > -math.pi) & (bearings <= math.pi))
    # straight behind is +pi, never -pi, as wrap_angle gives it
    assert target_geometry(np.array([[0.0, 0.0, 0.0]]), np.array([[-1.0, 0.0]]))[1][0] == math.pi
    ring = circle_points(0.5, 48)
    assert ring.shape == (49, 2) and np.allclose(np.hypot(*ring.T), 0.5)
    assert np.allclose(ring[0], ring[-1])


def test_the_viewers_shapes_against_closed_forms():
    """The shapes the viewer draws from world.geometry (issue 24): each against a
    closed form it does not use."""
    rng = np.random.default_rng(7)
    # to_world_frame undoes to_robot_frame, and rotates by complex multiplication
    for x, y, h in ((1.0, -2.0, 0.7), (0.0, 0.0, -3.0), (-4.0, 5.0, math.pi)):
        local = rng.normal(size=(6, 2))
        world = to_world_frame(local, (x, y), h)
        expected = (local[:, 0] + 1j * local[:, 1]) * np.exp(1j * h) + (x + 1j * y)
        assert np.allclose(world[:, 0] + 1j * world[:, 1], expected, atol=1e-12)
        for p, q in zip(world, local):
            assert np.allclose(to_robot_frame(p, (x, y), h), q, atol=1e-12)
        assert np.allclose(to_world_frame(local[0], (x, y), h), world[0])
    # the safe ring: every point offset from the footprint, i.e. its clearance is 0
    for length, width, offset in ((0.99, 0.67, 0.25), (0.0, 0.0, 0.25), (2.0, 0.5, 0.1)):
        ring = rounded_rectangle(length, width, offset)
        assert ring.shape == (37, 2) and np.array_equal(ring[0], ring[-1])
        for p in ring:
            gap = rectangle_circle_clearance((0, 0), 0.0, length, width, p, 0.0)
            assert gap == pytest.approx(offset, abs=1e-12)
        # counter-clockwise: the shoelace area is the grown rectangle's, corners rounded
        area = 0.5 * np.sum(ring[:-1, 0] * ring[1:, 1] - ring[1:, 0] * ring[:-1, 1])
        n = 4 * 8  # the circle's chords: a regular 32-gon of radius ``offset``
        polygon = 0.5 * n * offset**2 * math.sin(2 * math.pi / n)
        assert area == pytest.approx(
            length * width + 2 * offset * (length + width) + polygon, rel=1e-12
        )
    # where a ray leaves the footprint: on its edge, max(|x| / hl, |y| / hw) = 1
    for bearing in rng.uniform(-math.pi, math.pi, 50):
        r = footprint_exit_m(0.99, 0.67, bearing)
        lx, ly = r * math.cos(bearing), r * math.sin(bearing)
        assert max(abs(lx) / 0.495, abs(ly) / 0.335) == pytest.approx(1.0, abs=1e-12)
    assert footprint_exit_m(0.99, 0.67, 0.0) == pytest.approx(0.495)
    assert footprint_exit_m(0.99, 0.67, -0.5 * math.pi) == pytest.approx(0.335)
    assert footprint_exit_m(0.0, 0.0, 1.0) == 0.0
    assert np.allclose(footprint_exit_m(0.99, 0.67, np.array([0.0, math.pi])), 0.495)
    # a distance and a bearing on the robot: the line from the exit along the bearing,
    # the heading's radius, an arc of that radius from the heading to the bearing
    x, y, h = 1.0, 2.0, 0.4
    seg = bearing_segments((x, y, h), 1.5, -0.9, 0.8, start_m=0.3, arc_segments=6)
    assert seg.shape == (8, 2, 2)
    assert np.allclose(
        seg[0, 0], to_world_frame((0.3 * math.cos(-0.9), 0.3 * math.sin(-0.9)), (x, y), h)
    )
    assert np.hypot(*(seg[0, 1] - seg[0, 0])) == pytest.approx(1.5)
    assert to_robot_frame(seg[0, 1], (x, y), h)[1] / to_robot_frame(seg[0, 1], (x, y), h)[
        0
    ] == pytest.approx(math.tan(-0.9))
    assert np.allclose(seg[1], [(x, y), (x + 0.8 * math.cos(h), y + 0.8 * math.sin(h))])
    arc = np.vstack([seg[2:, 0], seg[-1:, 1]])
    assert np.allclose(np.hypot(arc[:, 0] - x, arc[:, 1] - y), 0.8)
    assert np.allclose(np.arctan2(arc[:, 1] - y, arc[:, 0] - x), h + np.linspace(0, -0.9, 7))
    assert np.array_equal(seg[2:-1, 1], seg[3:, 0])  # the arc is joined
    # beam cones: closed, the arc at the cone's length, its ends the two corners
    origins = rng.normal(size=(4, 2))
    directions = rng.uniform(-3, 3, 4)
    lengths = rng.uniform(0.1, 4.0, 4)
    cones = beam_cone_outlines(origins, directions, lengths, 0.2, arc_points=5)
    assert cones.shape == (4, 7, 2)
    assert np.array_equal(cones[:, 0], origins) and np.array_equal(cones[:, -1], origins)
    offsets = cones[:, 1:-1] - origins[:, None]
    assert np.allclose(np.hypot(offsets[..., 0], offsets[..., 1]), lengths[:, None])
    angles = np.arctan2(offsets[..., 1], offsets[..., 0])
    assert np.allclose(wrap_angle(angles - directions[:, None]), np.linspace(-0.2, 0.2, 5))
    left, right = beam_cones(origins, directions, lengths, 0.2)
    assert np.allclose(left, cones[:, -2]) and np.allclose(right, cones[:, 1])
    # the drawn Husky: the hull is the footprint long, everything inside the footprint,
    # the wheels on the ground
    boxes = husky_body_boxes(0.99, 0.67)
    assert boxes["body"][0][0] == 0.99
    for size, centre in boxes.values():
        assert abs(centre[0]) + 0.5 * size[0] <= 0.495 + 1e-12
        assert abs(centre[1]) + 0.5 * size[1] <= 0.335 + 1e-12
    wheels = husky_wheel_centres(0.67)
    assert np.allclose(wheels[:, 2], HUSKY_WHEEL_RADIUS_M)
    assert np.all(np.abs(wheels[:, 0]) + HUSKY_WHEEL_RADIUS_M <= 0.495)
    assert np.allclose(np.abs(wheels[:, 1]), 0.335 - 0.055)


# -- sensors -----------------------------------------------------------------------------


def arena_with(obstacles, pose=(0.0, 0.0, 0.0)):
    arena = Arena(FOOTPRINT)
    arena.reset(pose[:2], pose[2], (50.0, 50.0), obstacles)
    return arena


obstacle_strategy = st.tuples(st.floats(-6, 6), st.floats(-6, 6), st.floats(0.1, 0.6))


@given(
    st.lists(obstacle_strategy, min_size=1, max_size=4),
    st.floats(-math.pi, math.pi),
    st.integers(1, 7),
)
def test_ray_casts_match_analytic_ray_circle_intersection(circles, heading, rays):
    specs = []
    for x, y, r in circles:
        spec = ObstacleSpec((x, y), r)
        if rectangle_circle_clearance((0, 0), heading, *FOOTPRINT, spec.position, r) > 0.05:
            specs.append(spec)
    arena = arena_with(specs, (0.0, 0.0, heading))
    config = SensorConfig(rays_per_beam=rays, min_range_m=1e-6)
    sensors = RangeSensorArray(config)
    readings = sensors.read(arena, 0.0)
    for k, (origin, direction) in enumerate(sensors.beam_geometry(arena.pose)):
        expected = math.inf
        for offset in config.ray_offsets_rad():
            for spec in specs:
                # A ray that grazes a circle (tangent to within 1e-9 m) is hit or missed
                # by rounding alone: no answer to compare with.
                angle = direction + offset
                dx, dy = spec.position[0] - origin[0], spec.position[1] - origin[1]
                miss_m = abs(dx * math.sin(angle) - dy * math.cos(angle))
                assume(abs(miss_m - spec.radius_m) > 1e-9)
                expected = min(
                    expected,
                    ray_circle_distance(origin, direction + offset, spec.position, spec.radius_m),
                )
        if expected > config.max_range_m:
            expected = math.inf
        if math.isinf(expected):
            assert math.isinf(readings[k])
        else:
            assert readings[k] == pytest.approx(expected, abs=1e-9)


def test_rays_ignore_the_robot_and_see_nothing_in_an_empty_world():
    readings = RangeSensorArray().read(arena_with([]), 0.0)
    assert np.all(np.isinf(readings))


def test_sensor_range_limits_and_blind_zone():
    mount = SensorMount("front", 0.495, 0.0, 0.0)
    config = SensorConfig(mounts=(mount,), rays_per_beam=1, min_range_m=0.05)
    far = arena_with([ObstacleSpec((0.495 + 4.6 + 0.2, 0.0), 0.2)])
    assert math.isinf(RangeSensorArray(config).read(far, 0.0)[0])
    near = arena_with([ObstacleSpec((0.495 + 0.02 + 0.2, 0.0), 0.2)])
    assert RangeSensorArray(config).read(near, 0.0)[0] == pytest.approx(0.05)


def test_noise_is_seeded_and_update_rate_holds_readings():
    arena = arena_with([ObstacleSpec((2.0, 0.0), 0.3)])
    config = SensorConfig(noise_std_m=0.05, update_rate_hz=10.0)
    a, b, c = (
        RangeSensorArray(config, seed=7),
        RangeSensorArray(config, seed=7),
        RangeSensorArray(config, seed=8),
    )
    ra = [a.read(arena, t)[1] for t in np.arange(0, 1, 0.02)]
    rb = [b.read(arena, t)[1] for t in np.arange(0, 1, 0.02)]
    rc = [c.read(arena, t)[1] for t in np.arange(0, 1, 0.02)]
    assert ra == rb and ra != rc
    # 10 Hz with a 50 Hz caller: each value is held for 5 calls.
    assert len(set(ra)) == 10
    assert ra[0] == ra[4] != ra[5]


def test_sensor_config_rejects_bad_values():
    with pytest.raises(ValueError, match="noise_std_m"):
        SensorConfig(noise_std_m=-1.0)
    with pytest.raises(ValueError, match="min_range_m"):
        SensorConfig(min_range_m=5.0)


# -- motion: the world against an independent integration -------------------------------


def reference_pose(model, voltages, duration_s, heading0=0.0):
    """LG state and unicycle kinematics integrated together with solve_ivp (Radau)."""
    A, B = model.A, model.B
    u = np.asarray(voltages, dtype=float)

    def rhs(_, z):
        x = z[:6]
        v, w, theta = x[2], x[3], z[8]
        return np.concatenate([A @ x + B @ u, [v * math.cos(theta), v * math.sin(theta), w]])

    z0 = np.zeros(9)
    z0[8] = heading0
    sol = solve_ivp(rhs, (0, duration_s), z0, method="Radau", rtol=1e-10, atol=1e-12)
    return sol.y[6:, -1]


@pytest.mark.parametrize("voltages", [(12.0, 12.0), (4.0, 11.0), (-6.0, 9.0), (10.0, -3.0)])
def test_pose_matches_solve_ivp(voltages):
    model = HuskyModel.default()
    sim = Simulation(open_field(duration_s=8.0), ConstantVoltage(*voltages), model=model)
    result = sim.run()
    assert result.outcome == "timeout"
    x, y, theta = reference_pose(model, voltages, result.log.time_s[-1])
    px, py, ptheta = result.log.pose[-1]
    assert (px, py) == pytest.approx((x, y), abs=2e-4)
    assert ptheta == pytest.approx(theta, abs=2e-5)


class SweptVoltage:
    """Voltages past the 12 V limit either way and within it, changing every call."""

    def reset(self):
        self.k = 0

    def __call__(self, inputs):
        self.k += 1
        return np.array((20.0 * math.sin(0.05 * self.k), 15.0 * math.cos(0.031 * self.k) + 3.0))


def _former_plant_step(model, x, v_left, v_right, dt):
    """The loop's plant step as it was inlined in ``Simulation._advance_plant`` until
    issue 24 (``[x; u]`` packed by hand, the cached step matrix, the mean's two rows)."""
    from fuzzynav.world.husky import N_STATES, step_product

    z = np.empty(N_STATES + 2)
    z[:N_STATES], z[N_STATES:] = x.tolist(), (v_left, v_right)
    result = step_product(model.discrete(dt).step_matrix, z[None, :])[0]
    mean = result[N_STATES + 2 : N_STATES + 4].tolist()
    return result[:N_STATES], mean[0], mean[1]


@pytest.mark.parametrize("dt", [0.02, 0.05])
def test_the_loop_clips_and_steps_the_plant_as_np_clip_and_huskymodel_step(dt):
    """Every row: the applied voltages are np.clip of the controller's to +-12 V, and
    the next LG state is HuskyModel.step's, which is the formerly inlined step's, to
    the bit (the plain forms replaced hand-inlined ones, issue 24)."""
    model = HuskyModel.default()
    log = (
        Simulation(open_field(duration_s=6.0), SweptVoltage(), model=model, control_period_s=dt)
        .run()
        .log
    )
    raw, applied = log.controller_output_v[:-1], log.voltages_v[:-1]
    assert np.abs(raw).max() > 12.0 and np.abs(raw).min() < 12.0  # both sides of the limit
    np.testing.assert_array_equal(applied, np.clip(raw, -12.0, 12.0))
    for k in range(len(log) - 1):
        x, u = log.lg_state[k], applied[k]
        x_next, x_mean = model.step(x, u, dt)
        former_next, former_v, former_w = _former_plant_step(model, x, *u.tolist(), dt)
        np.testing.assert_array_equal(log.lg_state[k + 1], x_next)
        np.testing.assert_array_equal(x_next, former_next)
        assert (float(x_mean[2]), float(x_mean[3])) == (former_v, former_w)


def test_straight_drive_reaches_the_reference_speed():
    sim = Simulation(open_field(duration_s=6.0), ConstantVoltage(12.0, 12.0))
    log = sim.run().log
    model = sim.model
    expected = model.parameters.wheel_radius_m * 12.0 / model.parameters.motor_torque_ratio
    assert log.lg_state[-1, 2] == pytest.approx(expected, rel=1e-3)
    assert abs(log.pose[-1, 1]) < 1e-9 and abs(log.pose[-1, 2]) < 1e-12


# -- collisions and obstacles ------------------------------------------------------------


def test_collision_is_reported_in_the_step_it_happens():
    obstacle = ObstacleSpec((3.0, 0.0), 0.3)
    sim = Simulation(open_field(duration_s=30.0, obstacles=[obstacle]), ConstantVoltage(12, 12))
    result = sim.run()
    assert result.outcome == "collided" and result.collided
    clearance = result.log.clearance_m[:, 0]
    # The last row is the state right after the contact; the one before had daylight.
    assert clearance[-1] <= 0.0 < clearance[-2]
    event = result.collisions[0]
    assert event.obstacle_id == 0 and event.time_s == pytest.approx(result.log.time_s[-1])
    # The robot's front is at the obstacle's surface, not through it.
    assert result.log.pose[-1, 0] + 0.495 == pytest.approx(3.0 - 0.3, abs=0.02)


def test_collision_can_be_recorded_without_stopping():
    obstacle = ObstacleSpec((3.0, 0.0), 0.3)
    sim = Simulation(
        open_field(duration_s=12.0, obstacles=[obstacle]),
        ConstantVoltage(12, 12),
        stop_on_collision=False,
    )
    result = sim.run()
    assert result.outcome == "timeout" and result.collided and len(result.collisions) == 1


def test_moving_obstacle_follows_its_law_and_keeps_it_after_a_move():
    spec = ObstacleSpec((10.0, 10.0), 0.3, velocity=(0.1, 0.0), acceleration=(-0.01, 0.02))
    sim = Simulation(open_field(duration_s=100.0, obstacles=[spec]), ConstantVoltage(0, 0))
    for _ in range(250):  # 5 s
        sim.step()
    t = sim.time_s
    expected = (
        np.array(spec.position)
        + np.array(spec.velocity) * t
        + 0.5 * np.array(spec.acceleration) * t * t
    )
    obstacle = sim.arena.obstacles[0]
    assert np.allclose(tuple(obstacle.body.position), expected, atol=1e-9)
    velocity_before = obstacle.velocity_at(t)
    sim.arena.move_obstacle(0, (20.0, -5.0))
    for _ in range(100):  # 2 s more
        sim.step()
    tau = sim.time_s - t
    expected = (
        np.array((20.0, -5.0))
        + velocity_before * tau
        + 0.5 * np.array(spec.acceleration) * tau * tau
    )
    assert np.allclose(tuple(obstacle.body.position), expected, atol=1e-9)


def test_edits_while_running_add_remove_and_move_target():
    sim = Simulation(open_field(duration_s=50.0), ConstantVoltage(12, 12))
    for _ in range(10):
        sim.step()
    new_id = sim.arena.add_obstacle(ObstacleSpec((6.0, 0.0), 0.3))
    for _ in range(10):
        sim.step()
    assert sim.log.clearance_m.shape[1] == 1 and np.isnan(sim.log.clearance_m[0, 0])
    sim.arena.remove_obstacle(new_id)
    sim.arena.move_target((1.5, 0.0))
    while not sim.done:
        sim.step()
    assert sim.outcome == "reached"


# -- perception --------------------------------------------------------------------------


def test_target_inputs_sign_convention():
    d, phi = target_inputs((0.0, 0.0, 0.0), (0.0, 2.0))
    assert d == pytest.approx(2.0) and phi == pytest.approx(math.pi / 2)  # left is positive
    _, phi = target_inputs((0.0, 0.0, math.pi / 2), (1.0, 0.0))
    assert phi == pytest.approx(-math.pi / 2)


def test_ideal_perception_cutoff_and_bearing():
    arena = arena_with([ObstacleSpec((0.0, 2.0), 0.2)])
    d_o, phi_o, ident = ideal_obstacle_inputs(arena)
    assert (
        d_o == pytest.approx(2.0 - 0.335 - 0.2)
        and phi_o == pytest.approx(math.pi / 2)
        and ident == 0
    )
    # Surface 2.99 m from the front edge: seen; 3.01 m: nothing detected (NaN, NaN).
    inside = arena_with([ObstacleSpec((0.495 + 2.99 + 0.2, 0.0), 0.2)])
    assert ideal_obstacle_inputs(inside)[0] == pytest.approx(2.99)
    beyond = arena_with([ObstacleSpec((0.495 + 3.01 + 0.2, 0.0), 0.2)])
    assert all(math.isnan(v) for v in ideal_obstacle_inputs(beyond)[:2])
    # Behind the robot counts too: the paper's model saw all around.
    behind = arena_with([ObstacleSpec((-1.5, 0.0), 0.2)])
    assert ideal_obstacle_inputs(behind)[1] == pytest.approx(math.pi)


def test_ideal_perception_senses_only_its_field_of_view():
    """With a field of view, the nearest obstacle whose centre bears inside it (not the
    nearest of all) gives d_o and phi_o; nothing inside it gives NaN (s1-s3: the front
    half-plane of the paper's front sonars)."""
    behind = ObstacleSpec((-1.2, 0.3), 0.2)  # nearer, but behind the axle line
    ahead = ObstacleSpec((2.5, -1.0), 0.2)
    arena = arena_with([behind, ahead])
    all_around = Perception("ideal", RangeSensorArray())
    front = Perception("ideal", RangeSensorArray(), field_of_view_rad=math.pi)
    d_all, phi_all = all_around.inputs(arena, 0.0)[0][[1, 3]]
    d_front, phi_front = front.inputs(arena, 0.0)[0][[1, 3]]
    assert abs(phi_all) > math.pi / 2  # all around, the one behind is the nearest
    assert phi_front == pytest.approx(math.atan2(-1.0, 2.5))
    assert d_front > d_all
    only_behind = arena_with([behind])
    assert all(math.isnan(v) for v in front.inputs(only_behind, 0.0)[0][[1, 3]])
    # the edge of the field counts: straight to the left at +-90 degrees is seen
    side = arena_with([ObstacleSpec((0.0, 1.5), 0.2)])
    assert front.inputs(side, 0.0)[0][3] == pytest.approx(math.pi / 2)
    for bad in (0.0, -1.0, 7.0, math.nan):
        with pytest.raises(ValueError, match="field_of_view_rad"):
            Perception("ideal", RangeSensorArray(), field_of_view_rad=bad)


def test_the_simulation_takes_the_scenario_s_field_of_view():
    s1 = load_scenario("s1")
    sim = Simulation(s1, make_controller("paper"))
    assert sim.perception.field_of_view_rad == pytest.approx(math.radians(60.0))
    sim.reset(scenario=s1.replace(field_of_view_deg=360.0))
    assert sim.perception.field_of_view_rad == 2 * math.pi


def test_sonars_one_beam_width_apart_leave_no_gap_ahead():
    """Side sonars at +-15 degrees (``--sonar-side 15``): the three 15-degree beams see
    an obstacle anywhere within +-22.5 degrees (a 0.2 m disc: wider than the rays'
    spacing); at the default +-45 degrees one at 20 degrees is in a gap."""
    gapless = SensorConfig(mounts=default_mounts(side_angle_rad=math.radians(15.0)))
    for bearing_deg in range(-21, 22, 3):
        a = math.radians(bearing_deg)
        seen = arena_with([ObstacleSpec((0.495 + 2.5 * math.cos(a), 2.5 * math.sin(a)), 0.2)])
        assert np.isfinite(RangeSensorArray(gapless).read(seen, 0.0)).any(), bearing_deg
    a = math.radians(20.0)
    gap = arena_with([ObstacleSpec((0.495 + 2.5 * math.cos(a), 2.5 * math.sin(a)), 0.2)])
    assert not np.isfinite(RangeSensorArray().read(gap, 0.0)).any()
    assert np.isfinite(RangeSensorArray(gapless).read(gap, 0.0)).any()
    with pytest.raises(ValueError, match="side_angle_rad"):
        default_mounts(side_angle_rad=2.0)


def test_ultrasonic_perception_uses_the_nearest_sensor():
    arena = arena_with([ObstacleSpec((2.0, 1.6), 0.4)])  # ahead and to the left
    sensors = RangeSensorArray()
    inputs, ranges = Perception("ultrasonic", sensors).inputs(arena, 0.0)
    k = int(np.argmin(ranges))
    assert sensors.config.mounts[k].name == "left"
    assert inputs[1] == pytest.approx(ranges[k]) and inputs[3] == pytest.approx(math.radians(45))
    empty = arena_with([])
    inputs, _ = Perception("ultrasonic", RangeSensorArray()).inputs(empty, 0.0)
    assert math.isnan(inputs[1]) and math.isnan(inputs[3])
    with pytest.raises(ValueError, match="perception"):
        Perception("sonar", sensors)


# -- the loop ----------------------------------------------------------------------------


def test_same_seed_same_run_and_noise_matters():
    def run(seed):
        sim = Simulation(
            load_scenario("s1"),
            ConstantVoltage(8, 9),
            perception="ultrasonic",
            seed=seed,
            sensor_config=SensorConfig(noise_std_m=0.05),
        )
        return sim.run().log

    a, b, c = run(3), run(3), run(4)
    assert np.array_equal(a.ranges_m, b.ranges_m) and np.array_equal(a.pose, b.pose)
    finite = np.isfinite(a.ranges_m) & np.isfinite(c.ranges_m)
    assert finite.any() and not np.array_equal(a.ranges_m[finite], c.ranges_m[finite])


def test_reset_reproduces_the_run():
    sim = Simulation(load_scenario("s2"), ConstantVoltage(7, 9))
    first = sim.run().log
    sim.reset()
    second = sim.run().log
    assert np.array_equal(first.pose, second.pose) and np.array_equal(
        first.obstacle_xy, second.obstacle_xy
    )


def test_saturation_and_log_conventions():
    sim = Simulation(open_field(duration_s=1.0), ConstantVoltage(30.0, -20.0))
    log = sim.run().log
    assert np.all(log.voltages_v[:-1] == [12.0, -12.0])
    assert np.all(log.controller_output_v[:-1] == [30.0, -20.0])
    assert np.all(np.isnan(log.voltages_v[-1]))
    assert len(log) == 51 and log.time_s[-1] == pytest.approx(1.0)


def test_disturbance_is_added_to_the_inputs():
    sc = load_scenario("s3")
    sim = Simulation(sc, ConstantVoltage(0.0, 0.0))
    for _ in range(int(40 / 0.02)):
        sim.step()
    log = sim.log
    window = (log.time_s >= 25.0) & (log.time_s < 35.0)
    assert np.allclose(log.disturbance[window], np.sin(2.0 * log.time_s[window]))
    assert np.all(log.disturbance[~window] == 0.0)
    # The robot stands still, so the undisturbed d_t is constant: the difference is the sine.
    base = log.inputs[0, 0]
    assert np.allclose(log.inputs[window, 0] - base, np.sin(2.0 * log.time_s[window]))


def test_non_finite_controller_output_is_an_error():
    sim = Simulation(open_field(), ConstantVoltage(float("nan"), 1.0))
    with pytest.raises(ValueError, match="non-finite"):
        sim.step()


def test_controller_with_ranges_gets_them():
    class WantsRanges(ConstantVoltage):
        needs_ranges = True

        def __call__(self, inputs, ranges_m=None):
            assert ranges_m is not None and ranges_m.shape == (3,)
            return super().__call__(inputs)

    ctrl = WantsRanges(1, 1)
    Simulation(open_field(duration_s=0.2), ctrl).run()
    assert ctrl.calls == 10


def test_an_arena_keeps_no_shape_it_removed_without_a_step():
    """pymunk keeps a removed shape until the space's next step; resets and removals with
    no step between (the viewer's Reset and Remove) kept them all (issue 37). The arena
    lets them go itself."""
    import gc

    import pymunk

    specs = [ObstacleSpec((3.0 + k, 5.0), 0.2) for k in range(50)]
    arena = arena_with(specs)
    for _ in range(20):
        arena.reset((0.0, 0.0), 0.0, (50.0, 50.0), specs)
    for obstacle_id in list(arena.obstacles)[:10]:
        arena.remove_obstacle(obstacle_id)
    gc.collect()
    alive = sum(1 for o in gc.get_objects() if isinstance(o, pymunk.Circle))
    assert alive <= len(arena.obstacles) + 10, alive
