"""The benchmark's shortest path (world/shortest_path.py) against layouts computed by hand,
and the benchmark metrics (world/metrics.py)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzynav.world.husky import HuskyModel
from fuzzynav.world.metrics import benchmark_metrics, top_speed_mps
from fuzzynav.world.scenario import ObstacleSpec, load_scenario
from fuzzynav.world.shortest_path import (
    inflation_m,
    robot_shortest_path_m,
    shortest_path,
    shortest_path_m,
)


def test_no_obstacle_is_the_straight_line():
    assert shortest_path_m((0, 0), (3, 4), [], []) == 5.0
    # an obstacle off the line changes nothing
    assert shortest_path_m((0, 0), (10, 0), [(5, 3)], [1.0]) == 10.0


def test_one_obstacle_on_the_line_is_two_tangents_and_an_arc():
    # start (0, 0), target (10, 0), a circle of radius 1 at (5, 0): from each end the
    # tangent has length sqrt(5^2 - 1^2) = sqrt(24) and touches the circle at an angle
    # acos(1/5) from the line to that end (seen from the centre); the arc between the
    # two tangent points spans pi - 2 acos(1/5).
    expected = 2 * math.sqrt(24) + 1.0 * (math.pi - 2 * math.acos(1 / 5))
    path = shortest_path((0, 0), (10, 0), [(5, 0)], [1.0])
    assert path.length_m == pytest.approx(expected, rel=1e-12)
    assert path.circles_visited == (-1, 0, 0, -1)
    # tangent points: (5 - cos(t), sin(t)) with cos(t) = 1/5 (above or below: a tie)
    (x1, y1), (x2, y2) = path.nodes[1], path.nodes[2]
    assert x1 == pytest.approx(4.8) and x2 == pytest.approx(5.2)
    assert abs(y1) == pytest.approx(math.sqrt(24) / 5) and y1 == pytest.approx(y2)


def test_two_obstacles_on_the_line_share_an_outer_tangent():
    # circles of radius 1 at (3, 0) and (7, 0) between (0, 0) and (10, 0): tangent from
    # the start to the first (length sqrt(9 - 1)), an arc from the tangent point to the
    # top (pi/2 - acos(1/3)), the top outer tangent (7 - 3 = 4 long), and the mirror
    # image to the target.
    half = math.sqrt(8) + (math.pi / 2 - math.acos(1 / 3))
    path = shortest_path((0, 0), (10, 0), [(3, 0), (7, 0)], [1.0, 1.0])
    assert path.length_m == pytest.approx(2 * half + 4.0, rel=1e-12)
    assert path.circles_visited == (-1, 0, 0, 1, 1, -1)


def test_two_obstacles_with_a_gap_go_through_it_on_inner_tangents():
    # circles of radius 1 at (5, 1.5) and (5, -1.5): the line y = 0 passes between them
    assert shortest_path_m((0, 0), (10, 0), [(5, 1.5), (5, -1.5)], [1.0, 1.0]) == 10.0
    # shifted so that the line hits the lower circle: the path slips through the gap,
    # touching the lower circle, not round the outside of both
    path = shortest_path((0, 0), (10, 0), [(5, 1.6), (5, -0.9)], [1.0, 1.0])
    assert set(path.circles_visited) == {-1, 1}
    d = math.hypot(5, 0.9)  # start (and target) to the lower centre
    # by hand: tangent points above the lower circle, angle (from its centre) between
    # the direction to the start and the tangent point = acos(1/d); the arc is what is
    # left of the angle between the directions to start and target
    to_start = math.atan2(0.9, -5)  # from (5, -0.9) to (0, 0)
    to_target = math.atan2(0.9, 5)
    arc = (to_start - to_target) - 2 * math.acos(1 / d)
    expected = 2 * math.sqrt(d * d - 1) + arc
    assert path.length_m == pytest.approx(expected, rel=1e-12)


def test_overlapping_obstacles_are_one_wall():
    # circles of radius 1 at (5, +-0.5) overlap: no way between them; round the top one
    # (by symmetry as good as the bottom one): tangent, arc, tangent, as above, with the
    # centre 0.5 off the line
    path = shortest_path((0, 0), (10, 0), [(5, 0.5), (5, -0.5)], [1.0, 1.0])
    d = math.hypot(5, 0.5)
    to_start = math.atan2(-0.5, -5)  # from (5, 0.5)
    to_target = math.atan2(-0.5, 5)
    arc = (to_start - to_target) % (2 * math.pi) - 2 * math.acos(1 / d)
    expected = 2 * math.sqrt(d * d - 1) + arc
    assert path.length_m == pytest.approx(expected, rel=1e-12)
    assert len(set(path.circles_visited) - {-1}) == 1


def test_no_path_when_walled_in_or_inside_an_obstacle():
    angles = np.linspace(0, 2 * np.pi, 13)[:-1]
    ring = np.c_[np.cos(angles), np.sin(angles)] * 1.5
    assert shortest_path_m((0, 0), (10, 0), ring, [0.6] * 12) == math.inf
    assert shortest_path_m((0, 0), (10, 0), [(0.2, 0)], [0.5]) == math.inf
    assert shortest_path((0, 0), (10, 0), [(10, 0.2)], [0.5]).nodes == ()


def test_bad_circles_are_refused():
    with pytest.raises(ValueError, match="radii"):
        shortest_path_m((0, 0), (1, 0), [(0.5, 3)], [0.0])
    with pytest.raises(ValueError, match="2 centres but 1 radii"):
        shortest_path_m((0, 0), (1, 0), [(0.5, 3), (1, 1)], [1.0])
    with pytest.raises(ValueError, match="start"):
        shortest_path_m((math.nan, 0), (1, 0), [], [])


def _sampled(path, centres, radii, step=0.01):
    """Points along the path: its segments, and its arcs on the circle they follow."""
    pts = []
    for (a, b), (ca, cb) in zip(
        zip(path.nodes, path.nodes[1:]), zip(path.circles_visited, path.circles_visited[1:])
    ):
        if ca == cb and ca >= 0:
            c, r = np.asarray(centres[ca], float), radii[ca]
            t0 = math.atan2(a[1] - c[1], a[0] - c[0])
            t1 = math.atan2(b[1] - c[1], b[0] - c[0])
            sweep = (t1 - t0 + math.pi) % (2 * math.pi) - math.pi  # the short way
            for t in np.linspace(t0, t0 + sweep, max(2, int(abs(sweep) * r / step))):
                pts.append(c + r * np.array([math.cos(t), math.sin(t)]))
        else:
            n = max(2, int(math.dist(a, b) / step))
            pts += list(np.linspace(a, b, n))
    return np.array(pts)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(1.5, 8.5), st.floats(-2, 2), st.floats(0.2, 1.0)),
        min_size=1,
        max_size=6,
    )
)
def test_a_found_path_enters_no_circle_and_is_no_shorter_than_the_line(circles):
    centres = [(x, y) for x, y, _ in circles]
    radii = [r for _, _, r in circles]
    path = shortest_path((0, 0), (10, 0), centres, radii)
    if not math.isfinite(path.length_m):
        return
    assert path.length_m >= 10.0 - 1e-12
    pts = _sampled(path, centres, radii)
    for c, r in zip(centres, radii):
        assert np.hypot(*(pts - c).T).min() >= r - 1e-6
    # the polyline through the nodes is no longer than the path (arcs are longer)
    polyline = sum(math.dist(a, b) for a, b in zip(path.nodes, path.nodes[1:]))
    assert polyline <= path.length_m + 1e-9


def test_robot_path_inflates_static_obstacles_by_clearance_and_half_width():
    width = 0.67
    assert inflation_m(width) == pytest.approx(0.25 + 0.335)
    one = [ObstacleSpec((5.0, 0.0), 0.2)]
    rho = 0.2 + 0.585
    expected = 2 * math.sqrt(25 - rho**2) + rho * (math.pi - 2 * math.acos(rho / 5))
    assert robot_shortest_path_m((0, 0), (10, 0), one, width) == pytest.approx(expected)
    moving = [ObstacleSpec((5.0, 0.0), 0.2, velocity=(0.1, 0.0))]
    assert robot_shortest_path_m((0, 0), (10, 0), moving, width) == 10.0


def test_s1_to_s3_shortest_paths():
    """s1: the first post stands on the start-target line; s2/s3: one static post
    near it (the moving obstacle is left out)."""
    lengths = {}
    for name in ("s1", "s2", "s3"):
        sc = load_scenario(name)
        lengths[name] = robot_shortest_path_m(sc.start, sc.target, sc.obstacles, 0.67)
    straight = math.dist((0, 0), (8, 8))
    assert straight < lengths["s1"] < straight + 0.2
    assert lengths["s2"] == lengths["s3"] and straight < lengths["s2"] < straight + 0.2


def test_top_speed_is_the_plants_steady_speed_at_the_limit():
    # model-notes: (12 V, 12 V) -> 0.617 m/s; v = r_w V / T_M is linear in V
    model = HuskyModel.default()
    assert top_speed_mps(model, 12.0) == pytest.approx(0.617, abs=5e-4)
    assert top_speed_mps(model, 6.0) == pytest.approx(top_speed_mps(model, 12.0) / 2)


def test_benchmark_score_is_clipped_between_2_and_8_optimal_times():
    def score(time_s, success=True):
        return benchmark_metrics(
            success=success,
            path_length_m=12.0,
            time_to_target_s=time_s,
            shortest_path_m=10.0,
            top_speed_mps=0.5,
        )

    fast = score(10.0)  # optimal time 20 s: faster than 2 x optimal still scores 1/2
    assert fast["optimal_time_s"] == 20.0 and fast["score"] == 0.5
    assert fast["path_ratio"] == pytest.approx(1.2) and fast["time_ratio"] == 0.5
    assert score(80.0)["score"] == pytest.approx(20 / 80)
    assert score(1000.0)["score"] == pytest.approx(1 / 8)
    failed = score(None, success=False)
    assert failed["score"] == 0.0 and failed["path_ratio"] is None and failed["time_ratio"] is None
    none = benchmark_metrics(
        success=True,
        path_length_m=1.0,
        time_to_target_s=1.0,
        shortest_path_m=math.inf,
        top_speed_mps=0.5,
    )
    assert set(none.values()) == {None}
    with pytest.raises(ValueError, match="top_speed_mps"):
        benchmark_metrics(
            success=True,
            path_length_m=1.0,
            time_to_target_s=1.0,
            shortest_path_m=1.0,
            top_speed_mps=0.0,
        )
