"""One contact rule for both engines (issue 37 item 8): the robot touches an obstacle when
its footprint-to-surface clearance is <= 0, touching included. A moving obstacle that
comes to rest exactly against the robot's side (clearance 0.0) was "collided" on the
batch engine and "timeout" on pymunk, whose Chipmunk does not count every exact touch."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fuzzynav.world.arena import Arena
from fuzzynav.world.batch import run_batch
from fuzzynav.world.robot import HUSKY
from fuzzynav.world.scenario import ObstacleSpec, Scenario, check_layout
from fuzzynav.world.simulation import OUTCOMES, Simulation

#: A binary period: every step's end is an exact multiple of it in both engines, so the
#: obstacle's law gives the same floats in both.
PERIOD_S = 1 / 32
REST_S = 1.0  # when the obstacle comes to rest (a step's end)


class Still:
    """Both wheels at 0 V: the robot stays exactly where it starts."""

    def reset(self):
        pass

    def __call__(self, inputs):
        return (0.0, 0.0)

    def decide(self, inputs, runs, ranges_m):
        return np.zeros((len(runs), 2))


def touching_layout(
    heading_rad: float, radius_m: float, along_m: float, rests: bool = True
) -> Scenario:
    """The robot at the origin facing ``heading_rad``; an obstacle of ``radius_m`` comes
    along the x axis, decelerating, to rest at ``REST_S`` exactly touching the robot's
    left side ``along_m`` ahead of its centre: the arena's clearance then is 0.0 exactly.
    With ``rests`` False it comes at a constant 1 m/s instead, touches then and goes on
    into the robot."""
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    bx, by = along_m, HUSKY.half_width_m + radius_m
    aim = (c * bx - s * by, s * bx + c * by)
    # from outside the side (its normal's x sign), along x; y stays as it starts
    toward = 1.0 if -s > 0 else -1.0
    if rests:
        acceleration, velocity = toward, -toward * REST_S
    else:
        acceleration, velocity = 0.0, -toward
    x0 = aim[0] - velocity * REST_S - 0.5 * acceleration * REST_S**2
    law = ObstacleSpec((x0, aim[1]), radius_m, (velocity, 0.0), (acceleration, 0.0))
    arena = Arena()
    arena.reset((0.0, 0.0), heading_rad, (8.0, 8.0), [law])
    x_rest = float(next(iter(arena.obstacles.values())).position_at(REST_S)[0])

    def clearance(y):
        arena.reset((0.0, 0.0), heading_rad, (8.0, 8.0), [ObstacleSpec((x_rest, y), radius_m)])
        return float(arena.clearances()[0])

    # move the line it comes along by ulps until its clearance at REST_S is 0.0 exactly
    y = aim[1]
    for _ in range(5000):
        gap = clearance(y)
        if gap == 0.0:
            break
        y = math.nextafter(y, -math.inf if (gap > 0) == (c > 0) else math.inf)
    assert clearance(y) == 0.0
    law = ObstacleSpec((x0, y), radius_m, (velocity, 0.0), (acceleration, 0.0))
    scenario = Scenario(
        name="comes to rest touching the side",
        duration_s=2.0,
        start=(0.0, 0.0),
        heading_rad=heading_rad,
        target=(8.0, 8.0),
        tolerance_m=0.15,
        obstacles=(law,),
    )
    check_layout(scenario)  # a legal layout: it starts clear of the robot
    return scenario


# Headings and places along the side where Chipmunk alone did not count the touch
# (the pymunk engine said "timeout"), and one where it did.
@pytest.mark.parametrize(
    ("heading_rad", "radius_m", "along_m"),
    [(0.3, 0.2, 0.0), (-0.7, 0.3, 0.0), (2.0, 0.3, 0.1), (-1.8632456747047232, 0.2, 0.0)]
    + [(0.5, 0.3, 0.0)],
)
def test_a_touch_is_a_contact_in_both_engines(heading_rad, radius_m, along_m):
    scenario = touching_layout(heading_rad, radius_m, along_m)
    sim = Simulation(scenario, Still(), control_period_s=PERIOD_S)
    result = sim.run()
    batch = run_batch([scenario], Still(), control_period_s=PERIOD_S)
    # the obstacle came to rest touching, never overlapping: the closest is 0.0 exactly
    assert sim.arena.min_clearance_m == 0.0
    assert float(batch.min_clearance_m[0]) == 0.0
    assert result.outcome == "collided"
    assert bool(batch.collided[0]) and OUTCOMES[int(batch.outcome[0])] == "collided"
    # at the instant it came to rest, where it rests
    (hit,) = result.collisions
    assert hit.time_s == pytest.approx(REST_S)
    assert result.metrics["sim_time_s"] == pytest.approx(REST_S)
    assert float(batch.sim_time_s[0]) == pytest.approx(REST_S)


def test_a_touch_is_reported_once_when_it_deepens():
    """Going on after contacts, a touch that becomes an overlap is one contact, not a
    touch (the rule) and then a begin (Chipmunk)."""
    pressing = touching_layout(0.3, 0.2, 0.0, rests=False)
    sim = Simulation(pressing, Still(), control_period_s=PERIOD_S, stop_on_collision=False)
    result = sim.run()
    clearance = result.log.clearance_m[:, 0]
    assert clearance.min() < -0.1  # it went well into the robot
    assert len(result.collisions) == 1
    assert result.collisions[0].time_s == pytest.approx(REST_S)
