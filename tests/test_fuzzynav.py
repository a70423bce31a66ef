"""fuzzynav's own navigator (issue 6): acceptance on s1-s3, a held-out sweep, .fis export,
memory reset, determinism, the tuning protocol."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzynav.controller.fis import read_fis
from fuzzynav.controller.navigator.controller import (
    AVOID_PATH,
    GOAL_PATH,
    FuzzyNavController,
    export_fis,
    fuzzynav_controller,
    merge_blocks,
)
from fuzzynav.controller.navigator.planner import blocked_cones, free_bearing
from fuzzynav.controller.navigator.tuning import tunable
from fuzzynav.controller.rulebase import read_toml
from fuzzynav.world.layouts import generate_layouts
from fuzzynav.world.scenario import load_scenario
from fuzzynav.world.simulation import Simulation

PAPER_PATH_M = {"s1": 11.8332, "s2": 11.8672, "s3": 11.8263}
SAFE_M = 0.25
HELD_OUT_SEED = 7  # tuning used seed 1
SWEEP_N = 30


# The navigator's guards were measured on s1-s3 (and their jittered copies) sensing the
# front half-plane in ideal perception; the paper's reading since narrowed those files'
# field to 60 degrees (docs/paper-controller.md), which the navigator was not designed
# for (docs/fuzzynav.md, "s1-s3's field of view"). The guards keep their conditions.
DESIGNED_FIELD_DEG = 180.0


def _as_designed(scenario):
    return scenario.replace(field_of_view_deg=DESIGNED_FIELD_DEG)


def _run(scenario, perception):
    return Simulation(scenario, fuzzynav_controller(), perception=perception, seed=0).run()


@pytest.fixture(scope="module")
def scenario_runs():
    return {
        (name, mode): _run(_as_designed(load_scenario(name)), mode)
        for name in ("s1", "s2", "s3")
        for mode in ("ideal", "ultrasonic")
    }


@pytest.mark.parametrize("mode", ["ideal", "ultrasonic"])
@pytest.mark.parametrize("name", ["s1", "s2", "s3"])
def test_scenario_reached_safely(scenario_runs, name, mode):
    # (s2 ideal passed its static obstacle 1 mm inside the safe distance while ideal
    # perception sensed all around; with s1-s3's front half-plane it keeps it.)
    r = scenario_runs[(name, mode)]
    assert r.outcome == "reached", r.metrics
    assert not r.collided
    assert r.metrics["min_clearance_m"] >= SAFE_M, r.metrics


@pytest.mark.parametrize("mode", ["ideal", "ultrasonic"])
@pytest.mark.parametrize("name", ["s1", "s2", "s3"])
def test_path_length_at_or_below_paper(scenario_runs, name, mode, request):
    r = scenario_runs[(name, mode)]
    length = r.metrics["path_length_m"]
    if length > PAPER_PATH_M[name]:
        # The requirement is kept as it is; where it is not met, the test says so.
        request.applymarker(
            pytest.mark.xfail(
                reason=f"not achieved: {length:.2f} m > paper {PAPER_PATH_M[name]} m", strict=True
            )
        )
    assert length <= PAPER_PATH_M[name]


@pytest.mark.parametrize("mode,threshold", [("ideal", 0.9), ("ultrasonic", 0.8)])
def test_held_out_sweep(mode, threshold):
    layouts = generate_layouts("standard", SWEEP_N, HELD_OUT_SEED)
    ok = 0
    for sc in layouts:
        r = _run(sc, mode)
        ok += r.outcome == "reached" and not r.collided
    assert ok / len(layouts) >= threshold, f"{ok}/{len(layouts)} reached without collision"


def test_deterministic():
    sc = load_scenario("s2")
    a = _run(sc, "ultrasonic")
    b = _run(sc, "ultrasonic")
    assert np.array_equal(a.log.pose, b.log.pose)
    assert np.array_equal(a.log.voltages_v, b.log.voltages_v, equal_nan=True)


def test_reset_clears_memory():
    c = fuzzynav_controller()
    fresh = c.state()
    rng = np.random.default_rng(0)
    for _ in range(300):
        x = np.array(
            [rng.uniform(1, 10), rng.uniform(0, 3), rng.uniform(-3, 3), rng.uniform(-3, 3)]
        )
        c(x, ranges_m=rng.uniform(0.3, 4.0, 3))
    assert c.state() != fresh
    c.reset()
    assert c.state() == fresh
    # and the same input sequence gives the same outputs as a fresh controller
    d = fuzzynav_controller()
    for _ in range(50):
        x = np.array([5.0, 1.0, 0.3, -0.4])
        r = np.array([1.2, 0.9, math.inf])
        assert np.array_equal(c(x, ranges_m=r), d(x, ranges_m=r))


def test_outputs_within_limits_and_can_reverse_or_spin():
    c = fuzzynav_controller()
    # target behind: turn in place (wheels of opposite signs)
    left, right = c(np.array([8.0, math.nan, 3.0, math.nan]), ranges_m=np.full(3, math.inf))
    assert left < 0 < right
    c.reset()
    for _ in range(10):
        left, right = c(np.array([8.0, 0.1, 0.0, 0.0]), ranges_m=np.array([0.3, 0.1, 0.3]))
    assert max(abs(left), abs(right)) <= 12.0 + 1e-9
    assert left + right < 0  # something close ahead: backs off


def test_fis_export_round_trip(tmp_path):
    paths = export_fis(tmp_path)
    assert [p.name for p in paths] == ["fuzzynav_goal.fis", "fuzzynav_avoid.fis"]
    rng = np.random.default_rng(1)
    for path, toml in zip(paths, (GOAL_PATH, AVOID_PATH)):
        original = read_toml(toml)
        back = read_fis(path)
        assert back == original
        lo = [v.range[0] for v in original.inputs]
        hi = [v.range[1] for v in original.inputs]
        X = rng.uniform(lo, hi, size=(200, len(lo)))
        assert np.array_equal(back.evaluate(X), original.evaluate(X))


def test_merged_system_equals_blocks():
    goal, avoid = read_toml(GOAL_PATH), read_toml(AVOID_PATH)
    merged = merge_blocks(goal, avoid)
    rng = np.random.default_rng(2)
    for _ in range(200):
        g = [rng.uniform(-3.2, 3.2), rng.uniform(0, 12)]
        a = [rng.uniform(0, 4.5), rng.uniform(0, 4.5), rng.uniform(0, 4.5), rng.choice([-1.0, 1.0])]
        out = merged.evaluate_one_list(g + a)
        assert out[:2] == goal.evaluate_one_list(g)
        assert out[2:] == avoid.evaluate_one_list(a)


def test_tunable_protocol(tmp_path):
    t = tunable()
    names, x0, bounds = t.parameter_names(), t.initial_vector(), t.bounds()
    assert len(names) == len(x0) == len(bounds)
    assert all(lo <= x <= hi for x, (lo, hi) in zip(x0, bounds))
    built = t.build(x0)
    assert isinstance(built, FuzzyNavController)
    ref = fuzzynav_controller()
    x = np.array([6.0, 0.8, 0.2, -0.3])
    r = np.array([2.0, 0.8, math.inf])
    assert np.array_equal(built(x, ranges_m=r), ref(x, ranges_m=r))
    t2 = pickle.loads(pickle.dumps(t))
    assert np.array_equal(t2.initial_vector(), x0)
    written = t.save(x0, tmp_path / "fuzzynav_params.toml")
    assert written[0].exists()


def test_registry_builds_it():
    from fuzzynav.controller.registry import make_controller

    c = make_controller("fuzzynav")
    assert isinstance(c, FuzzyNavController) and c.needs_ranges


# -- the bearing planner's geometry, against hand-worked answers ----------------------


def test_blocked_cone_is_the_tangent_cone_of_the_inflated_point():
    (cone,) = blocked_cones([(2.0, 0.0)], radius_m=0.5, horizon_m=4.0, beyond_m=10.0, nearest_m=0.0)
    half = math.asin(0.5 / 2.0)
    assert cone == pytest.approx((-half, half))
    # a ray along the cone's edge passes the point at exactly the radius
    assert 2.0 * math.sin(cone[1]) == pytest.approx(0.5)
    (cone,) = blocked_cones([(1.0, 1.0)], 0.5, 4.0, 10.0, 0.0)
    beta, half = math.pi / 4, math.asin(0.5 / math.sqrt(2.0))
    assert cone == pytest.approx((beta - half, beta + half))


def test_blocked_cones_ignore_points_behind_far_beyond_or_too_near():
    pts = [
        (-0.5, 1.0),  # behind
        (5.0, 0.0),  # beyond the horizon
        (2.5, 0.0),  # beyond the target (beyond_m)
        (0.5, 0.0),
    ]  # nearer than nearest_m: left to the avoidance block
    assert blocked_cones(pts, 0.5, 4.0, 2.0, 0.8) == []
    # inside the inflation radius: a half plane
    (cone,) = blocked_cones([(0.3, 0.0)], 0.5, 4.0, 10.0, 0.0)
    assert cone == pytest.approx((-math.pi / 2, math.pi / 2))


def test_blocked_cones_count_points_beside_the_robot_down_to_rearmost():
    """A point beside the robot (x between the rear edge and the centre) blocks
    bearings past 90 deg, which a detour out of a trap has to take."""
    beside = [(-0.3, 1.5)]
    assert blocked_cones(beside, 0.5, 4.0, 10.0, 0.8) == []
    (cone,) = blocked_cones(beside, 0.5, 4.0, 10.0, 0.8, rearmost_m=-0.495)
    beta, half = math.atan2(1.5, -0.3), math.asin(0.5 / math.hypot(0.3, 1.5))
    assert cone == pytest.approx((beta - half, beta + half))
    assert cone[0] > math.pi / 2 - half and cone[1] > math.pi / 2
    assert blocked_cones([(-0.6, 1.5)], 0.5, 4.0, 10.0, 0.8, rearmost_m=-0.495) == []


def test_free_bearing_hand_cases():
    assert free_bearing([], 0.3, 1.0) == (0.3, 0.0)
    assert free_bearing([(0.5, 0.9)], 0.3, 1.0) == (0.3, 0.0)  # target bearing free
    assert free_bearing([(-0.2, 0.1)], 0.0, 1.0) == (0.1, 1.0)  # pass on the left
    assert free_bearing([(-0.2, 0.1)], 0.0, -1.0) == (-0.2, -1.0)  # ... or the right
    assert free_bearing([(-0.2, 0.1)], 0.0, 0.0) == (0.1, 1.0)  # nearer edge
    assert free_bearing([(-0.1, 0.2)], 0.0, 0.0) == (-0.1, -1.0)
    # overlapping cones merge; a separate cone beyond a free gap does not
    assert free_bearing([(-0.2, 0.1), (0.05, 0.4)], 0.0, 1.0) == (0.4, 1.0)
    assert free_bearing([(0.05, 0.4), (-0.2, 0.1)], 0.0, 1.0) == (0.4, 1.0)
    assert free_bearing([(-0.2, 0.1), (0.3, 0.5)], 0.0, 1.0) == (0.1, 1.0)


_cone = st.tuples(st.floats(-1.5, 1.5), st.floats(0.01, 0.8)).map(
    lambda c: (c[0] - c[1], c[0] + c[1])
)


@settings(max_examples=300, deadline=None)
@given(st.lists(_cone, max_size=6), st.floats(-1.0, 1.0), st.sampled_from([-1.0, 0.0, 1.0]))
def test_free_bearing_is_the_nearest_free_bearing_on_its_side(cones, phi_t, side):
    psi, passed = free_bearing(cones, phi_t, side)

    def inside(a):
        return any(lo < a < hi for lo, hi in cones)

    assert not inside(psi)  # the answer is free (an edge at most)
    if passed == 0.0:
        assert psi == phi_t
        return
    if side != 0.0:
        assert passed == side
    assert (psi - phi_t) * passed >= 0.0  # on the side it says (0: phi_t on an edge)
    # every bearing between the target's and the answer is blocked
    for k in range(1, 50):
        a = phi_t + (psi - phi_t) * k / 50
        assert any(lo <= a <= hi for lo, hi in cones), a


def test_shipped_params_file_is_the_hand_design():
    """The README says the shipped parameters are the hand design (tuning did not validate):
    the file and CRISP_DEFAULTS must not drift apart."""
    from fuzzynav.controller.navigator.controller import CRISP_DEFAULTS, load_params

    assert load_params() == CRISP_DEFAULTS


def test_range_at_clearance_hand_cases():
    from fuzzynav.controller.navigator.robot import _HX, _HY, range_at_clearance

    assert range_at_clearance(0.0, 0.5) == pytest.approx(_HX + 0.5)  # ahead
    assert range_at_clearance(math.pi / 2, 0.5) == pytest.approx(_HY + 0.5)  # beside
    assert range_at_clearance(math.pi, 0.2) == pytest.approx(_HX + 0.2)  # behind


@settings(max_examples=300, deadline=None)
@given(st.floats(-math.pi, math.pi), st.floats(0.0, 3.0))
def test_range_at_clearance_puts_the_point_at_that_clearance(bearing, clearance):
    """The stored surface point is exactly d_o from the footprint (the sectors read d_o
    back), also off a corner, where d_o beyond the footprint's extent would be too near."""
    from fuzzynav.controller.navigator.robot import _HX, _HY, range_at_clearance

    r = range_at_clearance(bearing, clearance)
    x, y = abs(r * math.cos(bearing)), abs(r * math.sin(bearing))
    gap = math.hypot(max(x - _HX, 0.0), max(y - _HY, 0.0))
    assert gap == pytest.approx(clearance, abs=1e-9)


# -- moving obstacles: closest approach, yield or pass first, the tracker -----------------


@settings(max_examples=300, deadline=None)
@given(
    st.tuples(st.floats(-5, 5), st.floats(-5, 5)),
    st.tuples(st.floats(-1, 1), st.floats(-1, 1)),
    st.tuples(st.floats(-1, 1), st.floats(-1, 1)),
    st.floats(0.0, 6.0),
)
def test_closest_approach_matches_dense_sampling(rel, v_obstacle, v_robot, horizon):
    """The closed form against the distance sampled on a fine time grid."""
    from fuzzynav.controller.navigator.tracker import closest_approach_m

    t = np.linspace(0.0, horizon, 4001)
    dx = rel[0] + (v_obstacle[0] - v_robot[0]) * t
    dy = rel[1] + (v_obstacle[1] - v_robot[1]) * t
    sampled = float(np.min(np.hypot(dx, dy)))
    exact = closest_approach_m(rel, v_obstacle, v_robot, horizon)
    assert exact <= sampled + 1e-9
    assert exact == pytest.approx(sampled, abs=2e-3 * (1 + horizon))


def test_dodge_speed_yields_passes_first_or_keeps_going():
    from fuzzynav.controller.navigator.robot import VOLTAGE_LIMIT_V
    from fuzzynav.controller.navigator.tracker import dodge_speed

    # Heading +x at about 0.5 m/s (10 V). An obstacle 2 m ahead, 1.5 m to the right,
    # crossing towards the line at 0.5 m/s: it gets there when we do -> stop.
    assert dodge_speed(10.0, (2.0, -1.5), (0.0, 0.5), 0.0, 3.0, 1.1) == 0.0
    # The same obstacle 0.6 m behind our centre, coming from the side: it would hit a
    # robot that stops -> go on at full speed.
    assert dodge_speed(3.0, (-0.2, -1.4), (0.0, 0.6), 0.0, 3.0, 1.1) == VOLTAGE_LIMIT_V
    # One moving away, or passing far ahead: the command is kept.
    assert dodge_speed(10.0, (2.0, -1.5), (0.0, -0.5), 0.0, 3.0, 1.1) == 10.0
    assert dodge_speed(10.0, (6.0, -1.5), (0.0, 0.2), 0.0, 3.0, 1.1) == 10.0


class _Spy:
    """Wraps the controller to record the tracker after every call."""

    needs_ranges = True
    name = "fuzzynav"

    def __init__(self, controller):
        self.c = controller
        self.goal, self.avoid = controller.goal, controller.avoid
        self.rows = []

    def reset(self):
        self.c.reset()

    def __call__(self, inputs, ranges_m=None):
        out = self.c(inputs, ranges_m)
        self.rows.append((self.c.obs_sightings, self.c.obs_vel))
        return out


def _tracked(scenario, perception, **params):
    c = fuzzynav_controller()
    c.params.update(params)
    spy = _Spy(c)
    result = Simulation(scenario, spy, perception=perception, seed=0).run()
    return result, spy.rows


def test_tracker_sees_static_obstacles_as_static():
    """s1's obstacles never look faster than the dodge's threshold once tracked, so the
    dodge never acts there (a heading that lags the turn made them seem to move)."""
    _, rows = _tracked(load_scenario("s1"), "ideal")
    speeds = [math.hypot(*v) for k, v in rows if k >= 3]
    assert speeds, "the tracker never followed an obstacle"
    assert max(speeds) < fuzzynav_controller().params["dodge_min_speed_mps"]


def test_tracker_estimates_a_moving_obstacles_velocity():
    scenario = load_scenario("crossing")
    moving = next(o for o in scenario.obstacles if not o.is_static)
    result, rows = _tracked(scenario, "ideal")
    tracked = [v for k, v in rows if k >= 5]
    assert len(tracked) > 50
    # The crossing obstacle is the nearest one here; its velocity is (0, 0.3) m/s in the
    # world. The tracker's frame is turned by the start heading (0 here) plus drift.
    vx, vy = np.median(np.array(tracked), axis=0)
    assert math.hypot(vx - moving.velocity[0], vy - moving.velocity[1]) < 0.08


def test_tracker_ignores_ultrasonic_bearings():
    _, rows = _tracked(load_scenario("crossing"), "ultrasonic")
    assert max(k for k, _ in rows) == 0


def test_crossing_obstacle_is_let_through_in_ideal_perception():
    """The crossing scenario: with the dodge the robot lets the obstacle pass and arrives
    with room to spare; without it (horizon 0) it drives into the obstacle's path and
    only just gets out of the way (6 cm), or is hit."""
    scenario = load_scenario("crossing")
    with_dodge, _ = _tracked(scenario, "ideal")
    assert with_dodge.outcome == "reached", with_dodge.metrics
    assert with_dodge.metrics["min_clearance_m"] >= SAFE_M
    without, _ = _tracked(scenario, "ideal", dodge_horizon_s=0.0)
    assert without.collided or without.metrics["min_clearance_m"] < SAFE_M / 2


def test_a_robot_in_a_u_trap_keeps_its_side_and_gets_out():
    """u_trap layout 14 of seed 1: at the U's mouth both planner detours are near 90 deg;
    without the holds (plan_flip_min_s, plan_flip_hold_s) the side flips back and forth
    and the robot times out turning on the spot; with them it gets round the U, in both
    perception modes, without collision. In ideal perception charging a change of side
    its turn (plan_turn_weight) gets it out as well: without both, it times out."""
    from fuzzynav.world.layouts import generate_layout

    scenario = generate_layout("u_trap", 1, 14)
    no_holds = {"plan_flip_hold_s": 0.0, "plan_flip_min_s": 0.0}
    for mode in ("ideal", "ultrasonic"):
        for params in ({}, {"plan_turn_weight": 0.0}):
            held, _ = _tracked(scenario, mode, **params)
            assert held.outcome == "reached" and not held.collided, (mode, held.metrics)
        dithering, _ = _tracked(scenario, mode, plan_turn_weight=0.0, **no_holds)
        assert dithering.outcome == "timeout", mode
    turn_charged, _ = _tracked(scenario, "ideal", **no_holds)
    assert turn_charged.outcome == "reached" and not turn_charged.collided
    beams_alone, _ = _tracked(scenario, "ultrasonic", **no_holds)  # the charge is off there
    assert beams_alone.outcome == "timeout"


def _run_with(scenario, perception, **params):
    c = fuzzynav_controller()
    c.params.update(params)
    return Simulation(scenario, c, perception=perception, seed=0).run()


def _side_changes(scenario, perception, **params):
    c = fuzzynav_controller()
    c.params.update(params)
    sim = Simulation(scenario, c, perception=perception, seed=0)
    changes, side = 0, 0.0
    while not sim.done:
        sim.step()
        changes += c.plan_side != side
        side = c.plan_side
    return sim.result(), changes


def test_a_new_side_pays_for_its_turn_in_clutter():
    """clutter layout 68 of seed 1, ideal perception: turning on the spot towards one
    side, the robot saw the other side come out shorter at each new echo and turned back,
    30 times, until it timed out. Charging a change of side the turn to its bearing
    (plan_turn_weight) keeps it turning one way: it gets through, with under a third of
    the side changes."""
    from fuzzynav.world.layouts import generate_layout

    scenario = generate_layout("clutter", 1, 68)
    shipped, changes = _side_changes(scenario, "ideal")
    assert shipped.outcome == "reached" and not shipped.collided, shipped.metrics
    dithering, changes_without = _side_changes(scenario, "ideal", plan_turn_weight=0.0)
    assert dithering.outcome == "timeout"
    assert 3 * changes < changes_without, (changes, changes_without)


def test_the_turn_charge_needs_all_around_sensing():
    """With the beams alone (ultrasonic perception, every nearest-obstacle bearing on a
    beam axis) the charge does not act: the run is the same with it off."""
    from fuzzynav.world.layouts import generate_layout

    scenario = generate_layout("clutter", 1, 68)
    on, off = (_run_with(scenario, "ultrasonic", plan_turn_weight=w) for w in (1.0, 0.0))
    assert np.array_equal(on.log.voltages_v, off.log.voltages_v, equal_nan=True)


def test_only_sonar_sightings_are_remembered():
    """The all-around nearest obstacle of ideal perception is used in the moment but not
    remembered (a disturbed sample would stay as a phantom obstacle); a sonar's sighting
    (bearing on a beam axis) is remembered."""
    nothing = np.full(3, math.inf)
    c = fuzzynav_controller()
    c(np.array([5.0, 0.3, 0.0, 0.8]), ranges_m=nothing)  # ideal: off every axis
    assert c.points == []
    assert c.last["sectors"][0] <= 0.3  # ... but acted on (left)
    for bearing, remembered in ((0.0, True), (0.001, False)):  # on / off the front axis
        c = fuzzynav_controller()
        c(np.array([5.0, 1.0, 0.0, bearing]), ranges_m=nothing)
        assert (len(c.points) == 1) is remembered, bearing


@pytest.mark.parametrize("index", [2, 5, 35, 44])
def test_s3_jittered_is_survived_in_ideal_perception(index):
    """s3 jittered by a few cm (paper_jitter seed 1): these collided with the moving
    obstacle when disturbed nearest-obstacle samples were remembered."""
    from fuzzynav.world.layouts import generate_layout

    scenario = _as_designed(generate_layout("paper_jitter", 1, index))
    assert "s3" in scenario.name
    result = _run(scenario, "ideal")
    assert result.outcome == "reached", result.metrics
    assert result.metrics["min_clearance_m"] >= SAFE_M


def test_jittered_paper_scenarios_are_reached_without_collision_in_ideal_perception():
    """24 copies of s1-s3 moved by a few cm (paper_jitter, seed 7, never used to design):
    all reached without collision (before only sonar sightings were remembered, about a
    third of the jittered s3 runs collided after the disturbance)."""
    layouts = [_as_designed(sc) for sc in generate_layouts("paper_jitter", 24, 7)]
    for sc in layouts:
        r = _run(sc, "ideal")
        assert r.outcome == "reached" and not r.collided, (sc.name, r.metrics)


def test_edge_following_drives_on_along_the_edge():
    """The escape feeds the goal block a virtual bearing follow_bias_rad towards the
    boundary: at the shipped 0.25 rad (the PS peak) the goal block drives on at speed on
    an arc; at 0.6 rad (fully PB) it would turn on the spot, and against the avoidance
    block the robot crept along the edge. u_trap layout 8 of seed 1 needs the escape:
    reached without collision in both perception modes at 0.25 rad, timed out at 0.6."""
    from fuzzynav.world.layouts import generate_layout

    c = fuzzynav_controller()
    bias = c.params["follow_bias_rad"]
    for side in (1.0, -1.0):
        speed, turn = c.goal.evaluate_one(np.array([-side * bias, 10.0]))
        assert speed > 8.0 and -side * turn > 1.0, (side, speed, turn)
        speed, _ = c.goal.evaluate_one(np.array([-side * 0.6, 10.0]))
        assert abs(speed) < 1.0, speed
    scenario = generate_layout("u_trap", 1, 8)
    for mode in ("ideal", "ultrasonic"):
        drives, _ = _tracked(scenario, mode)
        assert drives.outcome == "reached" and not drives.collided, (mode, drives.metrics)
        creeps, _ = _tracked(scenario, mode, follow_bias_rad=0.6)
        assert creeps.outcome == "timeout", mode


class _ReverseSpy(_Spy):
    """Records how long the robot has been reversing after every call."""

    def __call__(self, inputs, ranges_m=None):
        out = self.c(inputs, ranges_m)
        self.rows.append(self.c.reverse_s if self.c.last["command"][0] < 0.0 else 0.0)
        return out


@pytest.mark.parametrize("index", [15, 62])
def test_backs_away_from_an_obstacle_coming_at_it_in_ideal_perception(index):
    """two_moving layouts 15 and 62 of seed 1: a moving obstacle comes at the robot after it
    has yielded. Reversing used to stop after back_max_s and the robot, turning on the
    spot in the obstacle's way, was hit. In ideal perception the nearest obstacle all
    around is ahead and closing, so nothing is nearer behind and the robot backs away on;
    in ultrasonic perception (the sonars see nothing behind) the limit holds."""
    from fuzzynav.world.layouts import generate_layout

    scenario = generate_layout("two_moving", 1, index)
    c = fuzzynav_controller()
    spy = _ReverseSpy(c)
    result = Simulation(scenario, spy, perception="ideal", seed=0).run()
    assert not result.collided, result.metrics
    assert max(spy.rows) > c.params["back_max_s"] + 0.1
    c = fuzzynav_controller()
    spy = _ReverseSpy(c)
    Simulation(scenario, spy, perception="ultrasonic", seed=0).run()
    assert max(spy.rows) <= c.params["back_max_s"] + c.params["control_period_s"] + 1e-9


def _target_reading(robot_xy, heading, target_xy):
    dx, dy = target_xy[0] - robot_xy[0], target_xy[1] - robot_xy[1]
    bearing = math.atan2(dy, dx) - heading
    return math.hypot(dx, dy), math.atan2(math.sin(bearing), math.cos(bearing))


def test_a_disturbed_target_reading_is_doubted_and_the_tracked_target_steered_by():
    """s3's disturbance, sin(2 t) added to every input, fed to a robot standing still
    2 m from its target: the target it steers by stays within 0.16 m and 0.16 rad of
    where it is (the disturbance swings the readings by 1), and a nearest-obstacle
    reading is not acted on while the target reading is doubted."""
    c = fuzzynav_controller()
    nothing = np.full(3, math.inf)
    d_true, phi_true = _target_reading((0.0, 0.0), 0.0, (2.0, 0.0))
    worst_d = worst_phi = 0.0
    doubted = 0
    steps = int(10.0 / 0.02)
    for k in range(steps):
        c.cmd = (0.0, 0.0)  # a robot standing still (dead reckoning stays put)
        delta = math.sin(2.0 * k * 0.02)
        c(np.array([d_true + delta, 2.5 + delta, phi_true + delta, 0.1 + delta]), ranges_m=nothing)
        d_fed = c.last["block_inputs"][1]
        phi_fed = c.last["block_inputs"][0] - c.plan_offset
        worst_d = max(worst_d, abs(d_fed - d_true))
        worst_phi = max(worst_phi, abs(phi_fed - phi_true))
        doubted += c.target_doubted
    # A reading is taken as it is while it places the target within the gate (0.3 m) of
    # the tracked one: at 2 m that lets |sin| up to 0.3 / sqrt(1 + 2^2) = 0.13 through
    # (and the tracked target follows agreeing readings a little), never the swing of 1.
    assert worst_d < 0.16 and worst_phi < 0.16, (worst_d, worst_phi)
    assert doubted > 0.8 * steps, doubted  # all but the moments near sin(2 t) = 0
    # A nearest obstacle read with a doubted target is not acted on.
    for gate, front in ((0.3, math.inf), (0.0, 0.2)):
        c = fuzzynav_controller()
        c.params["target_gate_m"] = gate
        c(np.array([d_true, math.inf, phi_true, math.nan]), ranges_m=nothing)
        c(np.array([d_true + 1.0, 0.2, phi_true + 1.0, 0.1]), ranges_m=nothing)
        assert c.target_doubted is (gate > 0.0)
        assert c.last["sectors"][1] == front
        said = c.teaching_view()[2]["target reading"]  # what the viewer's panel says
        assert said.startswith("doubted") is (gate > 0.0), said
    # Off: the disturbance reaches the goal block as it is.
    c = fuzzynav_controller()
    c.params["target_gate_m"] = 0.0
    c(np.array([d_true + 0.5, math.inf, phi_true + 0.5, math.nan]), ranges_m=nothing)
    assert c.last["block_inputs"][1] == pytest.approx(d_true + 0.5)


def test_a_target_that_moves_and_stays_is_taken_after_settling():
    """A target dragged in the viewer jumps and then keeps still: it is doubted for
    target_settle_s, then steered to."""
    c = fuzzynav_controller()
    nothing = np.full(3, math.inf)
    old = _target_reading((0.0, 0.0), 0.0, (5.0, 0.0))
    new = _target_reading((0.0, 0.0), 0.0, (0.0, -5.0))
    for _ in range(10):
        c.cmd = (0.0, 0.0)
        c(np.array([old[0], math.inf, old[1], math.nan]), ranges_m=nothing)
    steered = []
    for _ in range(50):
        c.cmd = (0.0, 0.0)
        c(np.array([new[0], math.inf, new[1], math.nan]), ranges_m=nothing)
        steered.append(c.last["block_inputs"][0] - c.plan_offset)
    settle_steps = round(c.params["target_settle_s"] / 0.02)
    assert all(abs(phi - old[1]) < 1e-6 for phi in steered[: settle_steps - 1])
    assert all(abs(phi - new[1]) < 1e-6 for phi in steered[settle_steps + 1 :])


@pytest.mark.parametrize("mode", ["ideal", "ultrasonic"])
def test_s3s_disturbance_costs_next_to_nothing(scenario_runs, mode):
    """s3 is s2 plus the disturbance: with the target check it is driven as s2 is
    (before it: 13.06 / 12.60 m against 12.44 / 12.54 m)."""
    s2, s3 = scenario_runs[("s2", mode)], scenario_runs[("s3", mode)]
    assert abs(s3.metrics["path_length_m"] - s2.metrics["path_length_m"]) < 0.05
    off = fuzzynav_controller()
    off.params["target_gate_m"] = 0.0
    without = Simulation(_as_designed(load_scenario("s3")), off, perception=mode, seed=0).run()
    assert without.metrics["path_length_m"] > s3.metrics["path_length_m"] + 0.05


@pytest.mark.parametrize("mode", ["ideal", "ultrasonic"])
def test_undisturbed_target_readings_are_never_doubted(mode):
    """Without a disturbance the check must never act: the dead-reckoned target stays
    within the gate of every reading, through turns, reversing and escapes (8 standard
    and clutter layouts of design seed 1)."""
    from fuzzynav.world.layouts import generate_layout

    for family in ("standard", "clutter"):
        for index in range(4):
            c = fuzzynav_controller()
            sim = Simulation(generate_layout(family, 1, index), c, perception=mode, seed=0)
            while not sim.done:
                sim.step()
                assert not c.target_doubted, (family, index, c.t)


def _remembered_after(ranges, phi_o, calls=10):
    """The echo memory (robot frame) after ``calls`` decisions on the same readings."""
    controller = fuzzynav_controller()
    d_o = min(ranges)
    for _ in range(calls):
        controller(np.array([6.0, d_o, 0.0, phi_o]), ranges_m=np.array(ranges))
    x0, y0, th = controller.pose
    c, s = math.cos(th), math.sin(th)
    return sorted(
        (c * (px - x0) + s * (py - y0), c * (py - y0) - s * (px - x0))
        for px, py, _ in controller.points
    )


@pytest.mark.xfail(
    strict=True,
    reason=(
        "known defect, not yet fixed: an echo's arc (axis +- echo_spread_deg) collapses to its "
        "last point by merge_m, which is the outer edge of the left beam and the inner edge of "
        "the right one; fixes measured on the design seeds, none shipped yet "
        "(docs/fuzzynav-log.md, 'An echo is remembered differently on the left')"
    ),
)
def test_an_echo_is_remembered_alike_on_either_side():
    """A post 1 m off the left sonar and its mirror image off the right one leave mirrored
    memories: the robot must not hold off obstacles on one side more than on the other."""
    left = _remembered_after([1.0, math.inf, math.inf], math.radians(45.0))
    right = _remembered_after([math.inf, math.inf, 1.0], math.radians(-45.0))
    assert len(left) == len(right) > 0
    mirrored = sorted((x, -y) for x, y in right)
    assert np.allclose(left, mirrored, atol=1e-9), (left, mirrored)
