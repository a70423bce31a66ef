"""Issue 19, physics: collisions cannot tunnel. An obstacle at the schema's top speed
(100 m/s, 2 m a step) passed through the robot between two steps: ``collided: false``,
minimum clearance 0.10 m reported, -0.64 m true. The arena now sweeps each step."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzynav.world.arena import SWEEP_SPACING_M
from fuzzynav.world.scenario import MAX_SPEED_MPS, scenario_from_dict
from fuzzynav.world.simulation import Simulation

HALF_WIDTH_M = 0.335  # the Husky footprint, 0.99 x 0.67 m


class Still:
    """Holds the robot at rest (zero volts), so only the obstacle moves."""

    def reset(self):
        pass

    def __call__(self, inputs):
        return np.zeros(2)


def crossing(speed_mps: float, radius_m: float, start_y_m: float, duration_s: float):
    """An obstacle crossing the resting robot's centre line from below."""
    return scenario_from_dict(
        {
            "name": "crossing",
            "duration_s": duration_s,
            "robot": {"start": [0.0, 0.0]},
            "target": {"position": [30.0, 0.0]},
            "obstacles": [
                {
                    "position": [0.0, -start_y_m],
                    "radius_m": radius_m,
                    "velocity": [0.0, speed_mps],
                }
            ],
        }
    )


@pytest.mark.parametrize(
    "speed, radius, dt, start_y",
    [
        (MAX_SPEED_MPS, 0.2, 0.02, 21.0),  # ends of steps at y = -1 and +1: jumps over
        (20.0, 0.05, 0.05, 20.5),  # ends at -0.5 and +0.5; contact is |y| < 0.385
        (MAX_SPEED_MPS, 0.05, 0.02, 21.0),
    ],
)
def test_a_fast_obstacle_cannot_pass_through_unseen(speed, radius, dt, start_y):
    sim = Simulation(
        crossing(speed, radius, start_y, 2.0 * start_y / speed), Still(), control_period_s=dt
    )
    result = sim.run()
    # The logged steps never see an overlap...
    assert np.nanmin(result.log.clearance_m) > 0.1
    # ... but the sweep does: a collision, at the instant the surfaces met.
    assert result.collided and result.outcome == "collided"
    contact_y = -(HALF_WIDTH_M + radius)
    t_contact = (start_y + contact_y) / speed
    assert result.collisions[0].time_s == pytest.approx(t_contact, abs=SWEEP_SPACING_M / speed * 2)
    # The true minimum clearance: the centre passes through the robot's centre line,
    # so the deepest overlap is the half-width plus the radius.
    true_min = -(HALF_WIDTH_M + radius)
    assert result.metrics["min_clearance_m"] == pytest.approx(true_min, abs=SWEEP_SPACING_M)


def test_a_near_miss_between_steps_reports_the_true_clearance():
    """The obstacle passes 0.3 m beside the robot's front between two steps: no contact,
    and the reported minimum is the true 0.3 m - radius, not the step ends' far value."""
    scenario = scenario_from_dict(
        {
            "name": "pass",
            "duration_s": 0.42,
            "robot": {"start": [0.0, 0.0]},
            "target": {"position": [30.0, 0.0]},
            "obstacles": [
                {"position": [0.495 + 0.3 + 0.2, -21.0], "radius_m": 0.2, "velocity": [0.0, 100.0]}
            ],
        }
    )
    result = Simulation(scenario, Still(), control_period_s=0.02).run()
    assert not result.collided
    assert np.nanmin(result.log.clearance_m) > 0.6  # what the steps alone said
    assert result.metrics["min_clearance_m"] == pytest.approx(0.3, abs=SWEEP_SPACING_M)


def test_ordinary_runs_do_not_sweep_and_are_unchanged():
    """The paper's scenarios at 20 ms: the robot moves 2 cm a step, no sweep is needed and
    the outcome and metrics are those of the steps."""
    from fuzzynav.app.runs import build_simulation

    sim = build_simulation("s1", "paper")
    result = sim.run()
    assert sim.arena.swept_steps == 0
    assert result.outcome == "reached" and not result.collided
    assert result.metrics["min_clearance_m"] == pytest.approx(np.nanmin(result.log.clearance_m))
