"""The two engines agree where an obstacle's path is tangent to the robot's: a seeded
search of tangent layouts (world/layouts.py ``tangent_layout``) in both engines, the
same outcomes and steps and paths within 1e-9 m. ``bench/bench_batch.py --tangent 1000``
runs the search at full size."""

from __future__ import annotations

import numpy as np
import pytest

from fuzzynav.controller.batch import batch_controller
from fuzzynav.controller.registry import make_controller
from fuzzynav.world.batch import run_batch
from fuzzynav.world.kernels import CONTACT_CLEARANCE_M
from fuzzynav.world.layouts import tangent_layout
from fuzzynav.world.simulation import Simulation

#: Layouts per controller in the suite (the bench runs 1,000): with the P controller,
#: which drives straight at the target and so grazes, 10 of these 160 ended otherwise
#: in the two engines before the contact rule's nanometre.
COUNT = {"p": 160, "paper": 16}


def _search(controller: str, count: int):
    scenarios = [tangent_layout(11, i) for i in range(count)]
    reference = [Simulation(sc, make_controller(controller)).run() for sc in scenarios]
    batch = run_batch(scenarios, batch_controller(make_controller(controller)), record_poses=True)
    return scenarios, reference, batch


@pytest.mark.parametrize("controller", ["p", "paper"])
def test_the_engines_agree_on_tangent_layouts(controller):
    count = COUNT[controller]
    scenarios, reference, batch = _search(controller, count)
    grazes = 0
    for i, (sc, ref) in enumerate(zip(scenarios, reference)):
        mine = batch.metrics(i)
        assert (mine["outcome"], mine["steps"]) == (ref.outcome, ref.metrics["steps"]), sc.name
        assert np.abs(batch.poses[i][:, :2] - ref.log.pose[:, :2]).max() <= 1e-9, sc.name
        assert abs(mine["min_clearance_m"] - ref.metrics["min_clearance_m"]) <= 1e-9, sc.name
        grazes += abs(ref.metrics["min_clearance_m"]) <= 1e-12
    if controller == "p":  # driven straight at the target: the search really grazes
        outcomes = {ref.outcome for ref in reference}
        assert outcomes == {"reached", "collided"}
        assert grazes >= count // 2


def test_a_graze_within_a_nanometre_is_a_contact_in_both_engines():
    """An obstacle 0.5 nm outside the swept band touches; 2 nm outside it does not."""
    base = tangent_layout(11, 0)
    (obstacle,) = base.obstacles
    x, y = obstacle.position
    h = base.heading_rad
    nx, ny = -np.sin(h), np.cos(h)
    side = np.sign((x - base.start[0]) * nx + (y - base.start[1]) * ny)
    outcomes = {}
    for gap_m in (0.5 * CONTACT_CLEARANCE_M, 2.0 * CONTACT_CLEARANCE_M):
        moved = obstacle.__class__(
            (x + side * gap_m * nx, y + side * gap_m * ny), obstacle.radius_m, obstacle.velocity
        )
        sc = base.replace(obstacles=(moved,))
        ref = Simulation(sc, make_controller("p")).run()
        mine = run_batch([sc], batch_controller(make_controller("p"))).metrics(0)
        assert mine["outcome"] == ref.outcome
        outcomes[gap_m] = ref.outcome
    assert outcomes == {0.5 * CONTACT_CLEARANCE_M: "collided", 2.0 * CONTACT_CLEARANCE_M: "reached"}
