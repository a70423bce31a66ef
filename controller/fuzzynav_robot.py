"""What fuzzynav knows of the robot: the voltage limit, the plant's gains (for dead
reckoning), the footprint's half-sizes and the sonar mounts, and the distance along a
bearing at which a point has a given clearance from the footprint.

The limit, the footprint and the mounts are the world's robot description
(:data:`fuzzynav.world.robot.HUSKY` by default; the simulation gives the controller its
own robot, :meth:`FuzzyNavController.set_robot`), never numbers of its own.

Shared by the echo memory (:mod:`fuzzynav.controller.fuzzynav_memory`), the tracker
(:mod:`fuzzynav.controller.fuzzynav_tracker`) and the controller
(:mod:`fuzzynav.controller.fuzzynav`; its design is in docs/fuzzynav.md).
"""

from __future__ import annotations

import math

from fuzzynav.world.robot import HUSKY

#: The default robot's voltage limit (the parts read the robot they are given).
VOLTAGE_LIMIT_V = HUSKY.voltage_limit_v
# Plant constants for dead reckoning (notes section 1), as measured at 12 V: 12 V both
# -> 0.617 m/s, (-12, +12) -> 0.62 rad/s.
_V_PER_VOLT = 0.617 / 12.0
_W_PER_VOLT = 0.62 / 12.0
#: The default robot's footprint half-sizes (length, width), m.
_HX, _HY = HUSKY.half_length_m, HUSKY.half_width_m


def mounts_of(sensor_mounts) -> tuple[tuple[float, float, float], ...]:
    """``(x, y, angle)`` of each sonar (robot frame) from the world's
    :class:`~fuzzynav.world.sensors.SensorMount` list: the robot's own mounts, not a copy
    (``--sonar-side 15`` moves them, and the memory must follow)."""
    return tuple((float(m.x_m), float(m.y_m), float(m.angle_rad)) for m in sensor_mounts)


# The default mounts, the world's (left, front, right).
_MOUNTS = mounts_of(HUSKY.mounts)
_AXES = frozenset(m[2] for m in _MOUNTS)


def range_at_clearance(
    bearing_rad: float, clearance_m: float, hx: float = _HX, hy: float = _HY
) -> float:
    """How far from the robot's centre, along ``bearing_rad``, a point is
    ``clearance_m`` from the footprint of half-sizes ``hx`` (along) and ``hy``
    (across), the default robot's if omitted.

    With ``u = (|cos|, |sin|)``, the point ``r u`` is ``sqrt(max(r ux - HX, 0)^2 +
    max(r uy - HY, 0)^2)`` from the rectangle: off a side, ``r = (H + d) / u``; off a
    corner, the larger root of ``r^2 - 2 r (ux HX + uy HY) + HX^2 + HY^2 - d^2 = 0``.
    (Placing it at d_o beyond the footprint's extent along the bearing puts it too near
    off a corner: the footprint's nearest point is the corner, not the ray's exit.)
    """
    ux, uy = abs(math.cos(bearing_rad)), abs(math.sin(bearing_rad))
    d = clearance_m
    if ux > 0.0:
        r = (hx + d) / ux
        if r * uy <= hy:
            return r
    if uy > 0.0:
        r = (hy + d) / uy
        if r * ux <= hx:
            return r
    b = ux * hx + uy * hy
    return b + math.sqrt(b * b - (hx * hx + hy * hy - d * d))
