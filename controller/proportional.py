"""A proportional go-to-goal controller: the simplest thing that drives the robot home.

It ignores obstacles on purpose (``d_o`` and ``phi_o`` are not used): it exercises the
loop and, in teaching, shows what the fuzzy controller's obstacle rules add.

Law, with ``d_t`` (m) and ``phi_t`` (rad, positive = target to the left)::

    forward_v = min(gain_distance_v_per_m * d_t, max_forward_v) * max(cos(phi_t), 0)
    turn_v    = gain_heading_v_per_rad * phi_t
    left_v, right_v = forward_v - turn_v, forward_v + turn_v

The ``cos`` factor makes the robot turn on the spot before it drives when the target is
behind it, so that it never orbits the target.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from fuzzynav.controller.batch import run_groups


class ProportionalController:
    """Obstacle-blind proportional go-to-goal controller (``--controller p``)."""

    name = "p"

    def __init__(
        self,
        *,
        gain_distance_v_per_m: float = 4.0,
        max_forward_v: float = 12.0,
        gain_heading_v_per_rad: float = 6.0,
    ):
        for label, value in (
            ("gain_distance_v_per_m", gain_distance_v_per_m),
            ("max_forward_v", max_forward_v),
            ("gain_heading_v_per_rad", gain_heading_v_per_rad),
        ):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{label} = {value!r}: must be a finite non-negative number")
        self.gain_distance_v_per_m = gain_distance_v_per_m
        self.max_forward_v = max_forward_v
        self.gain_heading_v_per_rad = gain_heading_v_per_rad

    @classmethod
    def batched(cls, controllers, run_sets=None):
        """The batch engine's form of ``controllers`` (one parameter set each; run ``i``
        uses ``controllers[run_sets[i]]``): :class:`ProportionalBatch`."""
        return ProportionalBatch(controllers, run_sets)

    def reset(self) -> None:
        """Stateless: nothing to reset."""

    def __call__(self, inputs) -> np.ndarray:
        d_t, phi_t = float(inputs[0]), float(inputs[2])
        forward = min(self.gain_distance_v_per_m * max(d_t, 0.0), self.max_forward_v)
        forward *= max(math.cos(phi_t), 0.0)
        turn = self.gain_heading_v_per_rad * phi_t
        return np.array((forward - turn, forward + turn))


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
        groups = run_groups(runs, self.run_sets)
        g = self.gains[0 if groups is None else groups]
        g = np.broadcast_to(g, (len(inputs), 3))
        d_t, phi_t = inputs[:, 0], inputs[:, 2]
        forward = g[:, 0] * np.where(0.0 > d_t, 0.0, d_t)
        forward = np.where(g[:, 1] < forward, g[:, 1], forward)  # min(forward, max_v)
        cos = np.cos(phi_t)
        forward = forward * np.where(0.0 > cos, 0.0, cos)
        turn = g[:, 2] * phi_t
        return np.stack([forward - turn, forward + turn], axis=1)
