"""How high the paper rule base's right wheel can go where s3 drives (the 12 V of Fig. 26's text).

The paper's s3 right wheel "attempts to exceed 12 volts" (Fig. 26's text). A Mamdani
rule base's output is a centroid, so it has a ceiling for every set of inputs;
:func:`right_wheel_ceiling` finds it on a grid of the inputs the controller can see in
s3: a distance to the target up to :func:`s3_farthest_m` (s3's start-target distance
plus the disturbance's amplitude), every bearing, an obstacle sensed at any distance
or none. ``scripts/paper_binds.py`` asks the same of the whole layout box.
"""

from __future__ import annotations

import math

import numpy as np

#: Grid points per input (d_t; d_o besides "none"; phi_t; phi_o).
GRID = (49, 13, 65, 33)


def s3_farthest_m() -> float:
    """s3's start-target distance plus its disturbance's amplitude (m): the largest
    d_t the controller sees while the robot is no farther from the target than at its
    start."""
    from fuzzynav.world.scenario import load_scenario

    scenario = load_scenario("s3")
    amplitude = scenario.disturbance.amplitude if scenario.disturbance else 0.0
    return math.dist(scenario.start, scenario.target) + amplitude


def right_wheel_ceiling(system, d_t_max_m: float) -> dict:
    """The highest right-wheel output of ``system`` on the grid :data:`GRID` of inputs
    with ``0 <= d_t <= d_t_max_m``, and where it is.

    Parameters
    ----------
    system : FuzzySystem
        A rule base with inputs (d_t, d_o, phi_t, phi_o) and outputs (left, right).
    d_t_max_m : float
        The largest distance to the target on the grid, m.

    Returns
    -------
    dict
        ``right_max_v`` and ``inputs`` (d_t, d_o or None, phi_t, phi_o) where it is.
    """
    n_dt, n_do, n_phi_t, n_phi_o = GRID
    axes = (
        np.linspace(0.0, d_t_max_m, n_dt),
        np.r_[np.nan, np.linspace(0.0, 3.0, n_do)],
        np.linspace(-math.pi, math.pi, n_phi_t),
        np.linspace(-math.pi, math.pi, n_phi_o),
    )
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 4)
    right = system.evaluate(grid)[:, 1]
    k = int(np.nanargmax(right))
    inputs = [None if math.isnan(v) else float(v) for v in grid[k]]
    return {"right_max_v": float(right[k]), "inputs": inputs}
