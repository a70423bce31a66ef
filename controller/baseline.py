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
from collections.abc import Sequence

import numpy as np

from fuzzynav.controller.batch import run_groups
from fuzzynav.controller.fuzzy import FuzzySystem
from fuzzynav.controller.fuzzy_batch import BatchFuzzy
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

    @classmethod
    def batched(cls, controllers, run_sets=None):
        """The batch engine's form of ``controllers`` (one parameter set each; run ``i``
        uses ``controllers[run_sets[i]]``): :class:`BaselineBatch`."""
        return BaselineBatch(controllers, run_sets)

    def reset(self) -> None:
        """Stateless."""

    def rule_blocks(self) -> dict[str, FuzzySystem]:
        """The fuzzy blocks by name (for recordings and ``fuzzynav fis export``)."""
        return {"goal": self.goal, "avoid": self.avoid}

    @property
    def merged(self) -> FuzzySystem:
        """Both blocks as one system (for the membership figures; outputs prefixed
        ``goal_`` / ``avoid_``)."""
        from fuzzynav.controller.navigator.blocks import merge_blocks

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


class BaselineBatch:
    """:class:`BaselineController`'s goal and avoidance blocks and their blend."""

    needs_ranges = False

    def __init__(self, controllers: Sequence[BaselineController], run_sets=None):
        self.goal = BatchFuzzy([c.goal for c in controllers])
        self.avoid = BatchFuzzy([c.avoid for c in controllers])
        self._avoid_systems = [c.avoid for c in controllers]
        self.run_sets = None if run_sets is None else np.asarray(run_sets, dtype=np.intp)

    def decide(self, inputs, runs, ranges_m=None) -> np.ndarray:
        groups = run_groups(runs, self.run_sets)
        d_t, d_o, phi_t, phi_o = inputs.T
        u = self.goal.evaluate(np.stack([d_t, phi_t], axis=1), groups)
        # BaselineController.sectors: d_o in the nearest obstacle's sector, NaN elsewhere
        seen = np.isfinite(d_o) & np.isfinite(phi_o) & ~(np.abs(phi_o) > SIDE_LIMIT_RAD)
        left = seen & (phi_o > FRONT_HALF_WIDTH_RAD)
        right = seen & ~left & (phi_o < -FRONT_HALF_WIDTH_RAD)
        front = seen & ~left & ~right
        rows = np.flatnonzero(seen)
        if rows.size == 0:
            return u
        nan = np.nan
        x = np.stack(
            [
                np.where(left, d_o, nan)[rows],
                np.where(front, d_o, nan)[rows],
                np.where(right, d_o, nan)[rows],
                phi_o[rows],
            ],
            axis=1,
        )
        sub = None if groups is None else groups[rows]
        weight = self._firing_max(x, sub)
        blend = weight > 0.0
        if not blend.any():
            return u
        rows, x, weight = rows[blend], x[blend], weight[blend]
        avoid = self.avoid.evaluate(x, None if sub is None else sub[blend])
        u[rows] = (1.0 - weight)[:, None] * u[rows] + weight[:, None] * avoid
        return u

    def _firing_max(self, x: np.ndarray, groups) -> np.ndarray:
        """The strongest firing of the avoidance block per row (its parameter set's)."""
        if groups is None or len(self._avoid_systems) == 1:
            return self._avoid_systems[0].firing_strengths(x).max(axis=1)
        weight = np.empty(len(x))
        for k in np.unique(groups).tolist():
            mask = groups == k
            weight[mask] = self._avoid_systems[k].firing_strengths(x[mask]).max(axis=1)
        return weight
