"""fuzzynav's controllers for the lockstep batch engine (:mod:`world.batch`).

:func:`batch_controller` turns what the pymunk engine drives (a
:class:`~controller.fis_controller.FisController` such as ``paper``, the
:class:`~controller.baseline.BaselineController`, the
:class:`~controller.proportional.ProportionalController`) into an object with
``decide(inputs (n, 4), runs (n,), ranges_m (n, 3)) -> voltages (n, 2)`` that makes
the same decisions for many runs at once. Several controllers of one structure (a
tuning generation's candidates) become one batched controller with a parameter set
per run (``runs`` picks each row's set).

The decisions are the scalar controllers' formulas on arrays: the fuzzy systems
through :class:`~controller.fuzzy_batch.BatchFuzzy` (the same numbers as
``evaluate``), the baseline's sectors and blend and the P law operation for operation.

Controllers that keep state or plan (fuzzynav's own navigator, with its memory and
its planner) and a user's Python controller cannot be batched:
:class:`NotBatchable` says so and why, and the commands fall back to the pymunk
engine.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fuzzynav.controller.baseline import (
    FRONT_HALF_WIDTH_RAD,
    SIDE_LIMIT_RAD,
    BaselineController,
)
from fuzzynav.controller.fis_controller import GATED_INPUT, FisController
from fuzzynav.controller.fuzzy_batch import BatchFuzzy
from fuzzynav.controller.proportional import ProportionalController

__all__ = ["NotBatchable", "batch_controller", "BATCHABLE"]

#: The registry's controllers the batch engine can drive.
BATCHABLE = ("paper", "baseline", "p")


class NotBatchable(ValueError):
    """A controller the batch engine cannot drive (the message says why)."""


def _groups(runs: np.ndarray, run_sets: np.ndarray | None) -> np.ndarray | None:
    return None if run_sets is None else run_sets[runs]


class FisBatch:
    """Mamdani systems (4 inputs -> 2 voltages) of one structure, a set per run."""

    needs_ranges = False

    def __init__(self, controllers: Sequence[FisController], run_sets=None):
        readings = {c.none_reading for c in controllers}
        if len(readings) > 1:
            raise NotBatchable("one batch reads NONE one way: the controllers mix readings")
        # the text's reading of NONE: the obstacle rules alone where d_o is sensed
        self.fuzzy = BatchFuzzy([c.fis.replace(unsensed_none=()) for c in controllers])
        self.sensed = (
            BatchFuzzy([c.sensed_fis for c in controllers]) if readings == {"unsensed"} else None
        )
        self.run_sets = None if run_sets is None else np.asarray(run_sets, dtype=np.intp)

    def decide(self, inputs, runs, ranges_m=None) -> np.ndarray:
        groups = _groups(runs, self.run_sets)
        if self.sensed is None:
            return self.fuzzy.evaluate(inputs, groups)
        sensed = ~np.isnan(inputs[:, GATED_INPUT])
        out = np.empty((len(inputs), 2))
        for mask, fuzzy in ((sensed, self.sensed), (~sensed, self.fuzzy)):
            if mask.any():
                out[mask] = fuzzy.evaluate(inputs[mask], None if groups is None else groups[mask])
        return out


class BaselineBatch:
    """:class:`BaselineController`'s goal and avoidance blocks and their blend."""

    needs_ranges = False

    def __init__(self, controllers: Sequence[BaselineController], run_sets=None):
        self.goal = BatchFuzzy([c.goal for c in controllers])
        self.avoid = BatchFuzzy([c.avoid for c in controllers])
        self._avoid_systems = [c.avoid for c in controllers]
        self.run_sets = None if run_sets is None else np.asarray(run_sets, dtype=np.intp)

    def decide(self, inputs, runs, ranges_m=None) -> np.ndarray:
        groups = _groups(runs, self.run_sets)
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


class ProportionalBatch:
    """:class:`ProportionalController`'s law on arrays (gains per run)."""

    needs_ranges = False

    def __init__(self, controllers: Sequence[ProportionalController], run_sets=None):
        self.gains = np.array(
            [
                (c.gain_distance_v_per_m, c.max_forward_v, c.gain_heading_v_per_rad)
                for c in controllers
            ],
            dtype=float,
        )
        self.run_sets = None if run_sets is None else np.asarray(run_sets, dtype=np.intp)

    def decide(self, inputs, runs, ranges_m=None) -> np.ndarray:
        groups = _groups(runs, self.run_sets)
        g = self.gains[0 if groups is None else groups]
        g = np.broadcast_to(g, (len(inputs), 3))
        d_t, phi_t = inputs[:, 0], inputs[:, 2]
        forward = g[:, 0] * np.where(0.0 > d_t, 0.0, d_t)
        forward = np.where(g[:, 1] < forward, g[:, 1], forward)  # min(forward, max_v)
        cos = np.cos(phi_t)
        forward = forward * np.where(0.0 > cos, 0.0, cos)
        turn = g[:, 2] * phi_t
        return np.stack([forward - turn, forward + turn], axis=1)


def batch_controller(controllers, run_sets=None):
    """One batched controller for a whole batch.

    Parameters
    ----------
    controllers : controller or sequence of controllers
        One controller for every run, or one per parameter set (all of one kind and,
        for fuzzy ones, of one structure).
    run_sets : int array (N,), optional
        Which of ``controllers`` each run of the batch uses (run ``i`` uses
        ``controllers[run_sets[i]]``); every run uses the first if omitted.

    Raises
    ------
    NotBatchable
        A controller the batch engine cannot drive (fuzzynav's navigator, a controller
        with state, a user's Python controller), or a mix of kinds.
    """
    if not isinstance(controllers, (list, tuple)):
        controllers = [controllers]
    if not controllers:
        raise NotBatchable("no controller given")
    kinds = {type(c) for c in controllers}
    if len(kinds) > 1:
        raise NotBatchable(
            f"controllers of several kinds ({', '.join(sorted(k.__name__ for k in kinds))}): "
            "one batch drives one kind"
        )
    kind = kinds.pop()
    if kind is FisController:
        return FisBatch(controllers, run_sets)
    if kind is BaselineController:
        return BaselineBatch(controllers, run_sets)
    if kind is ProportionalController:
        return ProportionalBatch(controllers, run_sets)
    name = getattr(controllers[0], "name", kind.__name__)
    raise NotBatchable(
        f"controller {name!r} ({kind.__module__}.{kind.__name__}) cannot run on the batch "
        f"engine: it batches only stateless controllers it knows ({', '.join(BATCHABLE)}, "
        "or a .fis/.toml rule base); fuzzynav's navigator keeps a memory and plans, and a "
        "Python controller of your own runs one world at a time; use --engine pymunk"
    )
