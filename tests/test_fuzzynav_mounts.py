"""fuzzynav's navigator knows the robot's own sonars (issue 36): ``--sonar-side`` moves
the mounts, and its memory keeps side echoes on the moved axes (it kept its own 45-degree
copy and dropped them)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fuzzynav.app.runs import build_simulation
from fuzzynav.world.sensors import default_mounts


@pytest.mark.parametrize("side_deg", [15.0, 30.0])
def test_the_memory_keeps_side_echoes_on_the_robots_axes(side_deg):
    sim = build_simulation("s1", "fuzzynav", perception="ultrasonic", sonar_side_deg=side_deg)
    c = sim.controller
    angles = [m[2] for m in c.memory.mounts]
    assert angles == pytest.approx([math.radians(side_deg), 0.0, -math.radians(side_deg)])
    side = sim.sensors.config.mounts[0].angle_rad  # what the left sonar reports as phi_o
    assert side in c.memory.axes and side in c.planner.axes and side in c.tracker.axes
    # a left-sonar sighting 1 m from the footprint is remembered, on the left axis
    memory = c.memory
    memory.reset()
    memory.update([math.inf] * 3, 1.0, side, 0.0, True)
    assert len(memory.points) == 1
    x, y, _ = memory.points[0]
    assert math.atan2(y, x) == pytest.approx(side, abs=0.02)
    # the old fixed 45-degree axes would not have taken it
    assert side not in {math.radians(45.0), -math.radians(45.0), 0.0}


def test_the_default_mounts_are_the_worlds():
    from fuzzynav.controller.navigator.robot import _MOUNTS, mounts_of

    assert _MOUNTS == mounts_of(default_mounts())
    sim = build_simulation("s1", "fuzzynav", perception="ultrasonic")
    assert sim.controller.memory.mounts == _MOUNTS
    result = sim.run()  # drives as before
    assert result.outcome == "reached" and np.isfinite(result.log.pose).all()
