"""Random layouts for sweeps: reproducible, valid, and of the promised shape."""

import numpy as np
import pytest

from fuzzynav.world.layouts import FAMILIES, PASSABLE_GAP_M, generate_layout, generate_layouts
from fuzzynav.world.scenario import check_layout


@pytest.mark.parametrize("family", FAMILIES)
def test_layouts_are_reproducible_and_valid(family):
    a = generate_layouts(family, 20, seed=5)
    b = generate_layouts(family, 20, seed=5)
    c = generate_layouts(family, 20, seed=6)
    assert a == b and a != c
    assert generate_layout(family, 5, 7) == a[7]  # index i does not depend on n
    for sc in a:
        check_layout(sc)
        assert 6.0 <= np.hypot(*sc.target) <= 12.0


def test_standard_family_matches_the_issue():
    layouts = generate_layouts("standard", 200, seed=1)
    counts = [sum(o.is_static for o in sc.obstacles) for sc in layouts]
    assert min(counts) >= 1 and max(counts) <= 4
    moving_share = np.mean([any(not o.is_static for o in sc.obstacles) for sc in layouts])
    assert 0.15 < moving_share < 0.35
    for sc in layouts:
        statics = [o for o in sc.obstacles if o.is_static]
        assert all(0.15 <= o.radius_m <= 0.35 for o in statics)
        for i, a in enumerate(statics):
            for b in statics[i + 1 :]:
                gap = (
                    np.hypot(a.position[0] - b.position[0], a.position[1] - b.position[1])
                    - a.radius_m
                    - b.radius_m
                )
                assert gap >= PASSABLE_GAP_M - 1e-9


def test_u_trap_blocks_the_straight_line():
    from fuzzynav.world.geometry import point_segment_distance

    for sc in generate_layouts("u_trap", 10, seed=2):
        centres = np.array([o.position for o in sc.obstacles])
        radii = np.array([o.radius_m for o in sc.obstacles])
        d = point_segment_distance(centres, sc.start, sc.target)
        # The robot (0.67 m wide) cannot drive the straight line: a wall is in the way.
        assert np.any(d - radii < 0.335)


def test_unknown_family():
    with pytest.raises(ValueError, match="family"):
        generate_layout("maze", 0, 0)


def test_paper_jitter_stays_within_what_the_figures_can_be_read_to():
    from fuzzynav.world.layouts import JITTER_HEADING_RAD, JITTER_MOTION_SCALE, JITTER_POSITION_M
    from fuzzynav.world.scenario import load_scenario

    layouts = generate_layouts("paper_jitter", 12, seed=3)
    for i, sc in enumerate(layouts):
        base = load_scenario(f"s{i % 3 + 1}")
        assert f"s{i % 3 + 1} jittered" in sc.name
        assert sc.target == base.target and sc.start == base.start
        assert sc.disturbance == base.disturbance
        assert 0 < abs(sc.heading_rad - base.heading_rad) <= JITTER_HEADING_RAD
        assert len(sc.obstacles) == len(base.obstacles)
        for o, b in zip(sc.obstacles, base.obstacles):
            assert o.radius_m == b.radius_m and o.is_static == b.is_static
            if b.is_static:
                assert np.max(np.abs(np.subtract(o.position, b.position))) <= JITTER_POSITION_M
                assert o.position != b.position
            else:
                assert o.position == b.position
                ratio = np.divide(o.acceleration, b.acceleration)
                assert np.all(np.abs(ratio - 1) <= JITTER_MOTION_SCALE)
