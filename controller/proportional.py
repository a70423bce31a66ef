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

import numpy as np


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

    def reset(self) -> None:
        """Stateless: nothing to reset."""

    def __call__(self, inputs) -> np.ndarray:
        d_t, phi_t = float(inputs[0]), float(inputs[2])
        forward = min(self.gain_distance_v_per_m * max(d_t, 0.0), self.max_forward_v)
        forward *= max(math.cos(phi_t), 0.0)
        turn = self.gain_heading_v_per_rad * phi_t
        return np.array((forward - turn, forward + turn))
