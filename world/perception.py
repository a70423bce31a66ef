"""Perception: from what the robot senses to the controller's four inputs.

The inputs are in the paper's order ``(d_t, d_o, phi_t, phi_o)``:

``d_t`` (m)
    Distance from the robot's centre to the target (the paper's radar, Eq. 7).
``d_o`` (m)
    Distance from the robot's body to the nearest obstacle's surface, or NaN ("nothing
    detected") beyond the paper's 3 m cutoff, so that the obstacle rules do not fire.
``phi_t`` (rad)
    Bearing of the target relative to the heading, wrapped to (-pi, pi] (Eq. 10);
    positive means the target is to the left.
``phi_o`` (rad)
    Bearing of the nearest obstacle relative to the heading, (-pi, pi]; NaN with d_o.

Two modes:

``ideal``
    The exact footprint-to-surface distance of the nearest obstacle and the bearing of
    its centre, all around the robot: what the paper's Simulink model had.
``ultrasonic``
    From the three range sensors: ``d_o`` is the smallest reading and ``phi_o`` is the
    mounting angle of the sensor that reads it (an ultrasonic sensor cannot say where in
    its cone the echo came from). Obstacles outside the beams are not seen.
"""

from __future__ import annotations

import math

import numpy as np

from world.arena import Arena
from world.geometry import wrap_angle_scalar
from world.sensors import RangeSensorArray

OBSTACLE_CUTOFF_M = 3.0
PERCEPTION_MODES = ("ideal", "ultrasonic")
INPUT_NAMES = ("d_t", "d_o", "phi_t", "phi_o")


def target_inputs(pose, target) -> tuple[float, float]:
    """(d_t, phi_t) of a target seen from a pose (x, y, heading)."""
    dx, dy = target[0] - pose[0], target[1] - pose[1]
    return math.hypot(dx, dy), wrap_angle_scalar(math.atan2(dy, dx) - pose[2])


def ideal_obstacle_inputs(arena: Arena, cutoff_m: float = OBSTACLE_CUTOFF_M
                          ) -> tuple[float, float, int]:
    """(d_o, phi_o, obstacle id) of the nearest obstacle by exact geometry; NaN, NaN, -1
    when none is within ``cutoff_m``."""
    centres, _, ids = arena.obstacle_arrays()
    if not ids:
        return math.nan, math.nan, -1
    clearances = arena.clearances()
    k = int(np.argmin(clearances))
    d_o = max(float(clearances[k]), 0.0)
    if d_o > cutoff_m:
        return math.nan, math.nan, -1
    x, y, heading = arena.pose
    phi_o = wrap_angle_scalar(math.atan2(centres[k, 1] - y, centres[k, 0] - x) - heading)
    return d_o, phi_o, ids[k]


def ultrasonic_obstacle_inputs(ranges_m: np.ndarray, mount_angles_rad,
                               cutoff_m: float = OBSTACLE_CUTOFF_M) -> tuple[float, float]:
    """(d_o, phi_o) from range readings; NaN, NaN when every reading is beyond the cutoff."""
    k = int(np.argmin(ranges_m))
    d_o = float(ranges_m[k])
    if not d_o <= cutoff_m:
        return math.nan, math.nan
    return d_o, float(mount_angles_rad[k])


class Perception:
    """Turns the arena (and the sensors' readings) into the controller's four inputs."""

    def __init__(self, mode: str, sensors: RangeSensorArray,
                 cutoff_m: float = OBSTACLE_CUTOFF_M):
        if mode not in PERCEPTION_MODES:
            raise ValueError(f"perception = {mode!r}: must be one of {', '.join(PERCEPTION_MODES)}")
        self.mode = mode
        self.sensors = sensors
        self.cutoff_m = cutoff_m
        self._mount_angles = [m.angle_rad for m in sensors.config.mounts]

    def inputs(self, arena: Arena, time_s: float) -> tuple[np.ndarray, np.ndarray]:
        """(inputs (4,), sensor ranges (3,)); the sensors are read in both modes so that
        their readings are always logged."""
        ranges = self.sensors.read(arena, time_s)
        pose = arena.pose
        d_t, phi_t = target_inputs(pose, arena.target)
        if self.mode == "ideal":
            d_o, phi_o, _ = ideal_obstacle_inputs(arena, self.cutoff_m)
        else:
            d_o, phi_o = ultrasonic_obstacle_inputs(ranges, self._mount_angles, self.cutoff_m)
        return np.array((d_t, d_o, phi_t, phi_o)), ranges
