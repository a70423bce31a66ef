"""The baseline: a stand-in for the paper's ref. [19] (goal block + avoidance block)."""

import math

import numpy as np

from fuzzynav.app.runs import run_scenario
from fuzzynav.controller.baseline import BaselineController, baseline_controller
from fuzzynav.controller.registry import controller_names, describe


def test_named_as_a_stand_in():
    assert "baseline" in controller_names()
    assert "stand-in" in describe("baseline")
    assert "stand-in" in BaselineController.__doc__.lower()
    assert "stand-in" in BaselineController.description


def test_sectors():
    s = BaselineController.sectors
    assert s(1.0, 0.0)[1] == 1.0 and math.isnan(s(1.0, 0.0)[0])
    assert s(1.0, 0.8)[0] == 1.0 and s(1.0, -0.8)[2] == 1.0
    assert all(math.isnan(x) for x in s(1.0, 2.5))  # behind: ignored
    assert all(math.isnan(x) for x in s(math.nan, math.nan))


def test_goal_seeking_and_avoiding_directions():
    c = baseline_controller()
    left, right = c([8.0, np.nan, 0.6, np.nan])  # target on the left: turn left
    assert right > left
    left, right = c([8.0, 0.2, 0.0, 0.6])  # obstacle close on the left: turn right
    assert left > right
    left, right = c([8.0, 0.2, 0.0, -0.6])  # on the right: turn left
    assert right > left
    far = c([8.0, 2.9, 0.0, 0.6])  # far away: the goal block alone
    assert np.allclose(far, c([8.0, np.nan, 0.0, np.nan]))


def test_baseline_runs_a_scenario():
    result = run_scenario("s2", "baseline", perception="ideal")
    assert result.outcome in ("reached", "collided", "timeout")
    assert result.metrics["max_abs_voltage_v"] <= 12.0 and result.metrics["path_length_m"] > 1.0
