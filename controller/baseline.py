"""Baseline: a STAND-IN for the paper's reference [19].

The paper compares its controller with the method of its ref. [19] (a fuzzy controller
on a bond-graph model), which we could not identify. This is the textbook design the
notes (section 3) propose as a fair stand-in, on the same fuzzy engine, hand-made and
not tuned to beat anything:

* a goal-seeking block (``assets/rules/baseline_goal.toml``): distance to the target x
  bearing of the target -> wheel voltages;
* an avoidance block (``assets/rules/baseline_avoid.toml``): the nearest obstacle's
  distance in a left (0.35 < phi_o <= 1.6 rad), front (|phi_o| <= 0.35 rad) or right
  (-1.6 <= phi_o < -0.35 rad) sector -> voltages that steer away (an obstacle behind,
  |phi_o| > 1.6 rad, is ignored);
* blended by the strength of "near": ``u = (1 - w) u_goal + w u_avoid`` with ``w`` the
  strongest firing of the avoidance block.

Its numbers are NOT the paper's ref. [19] numbers; ``fuzzynav compare`` prints both.
"""

from __future__ import annotations

import math

import numpy as np

from fuzzynav.controller.fuzzy import FuzzySystem
from fuzzynav.controller.rulebase import read_toml
from fuzzynav.resources import asset_path

ASSETS = asset_path("rules")
GOAL_RULES = ASSETS / "baseline_goal.toml"
AVOID_RULES = ASSETS / "baseline_avoid.toml"
FRONT_HALF_WIDTH_RAD = 0.35
SIDE_LIMIT_RAD = 1.6


class BaselineController:
    """Stand-in for ref. [19]: goal block + avoidance block blended by "near" (module doc)."""

    needs_ranges = False
    name = "baseline"
    description = "stand-in for the paper's ref. [19] (goal-seeking + avoidance fuzzy blocks)"

    def __init__(self, goal: FuzzySystem | None = None, avoid: FuzzySystem | None = None):
        self.goal = goal or read_toml(GOAL_RULES)
        self.avoid = avoid or read_toml(AVOID_RULES)

    def reset(self) -> None:
        """Stateless."""

    def rule_blocks(self) -> dict[str, FuzzySystem]:
        """The fuzzy blocks by name (for recordings and ``fuzzynav fis export``)."""
        return {"goal": self.goal, "avoid": self.avoid}

    @property
    def merged(self) -> FuzzySystem:
        """Both blocks as one system (for the membership figures; outputs prefixed
        ``goal_`` / ``avoid_``)."""
        from fuzzynav.controller.fuzzynav import merge_blocks

        return merge_blocks(self.goal, self.avoid)

    @staticmethod
    def sectors(d_o: float, phi_o: float) -> tuple[float, float, float]:
        """(left, front, right) distances: d_o in the nearest obstacle's sector, NaN elsewhere."""
        nan = math.nan
        if not math.isfinite(d_o) or not math.isfinite(phi_o) or abs(phi_o) > SIDE_LIMIT_RAD:
            return nan, nan, nan
        if phi_o > FRONT_HALF_WIDTH_RAD:
            return d_o, nan, nan
        if phi_o < -FRONT_HALF_WIDTH_RAD:
            return nan, nan, d_o
        return nan, d_o, nan

    def __call__(self, inputs) -> np.ndarray:
        d_t, d_o, phi_t, phi_o = (float(x) for x in np.asarray(inputs, dtype=float).reshape(4))
        u_goal = self.goal.evaluate_one([d_t, phi_t])
        left, front, right = self.sectors(d_o, phi_o)
        if math.isnan(left) and math.isnan(front) and math.isnan(right):
            return u_goal
        x = [left, front, right, phi_o]
        w = float(np.max(self.avoid.firing_strengths(np.array([x]))))
        if w <= 0.0:
            return u_goal
        return (1.0 - w) * u_goal + w * self.avoid.evaluate_one(x)


def baseline_controller() -> BaselineController:
    return BaselineController()
