"""Small closed-form geometry used by the world, the sensors' tests and the metrics.

Angles are radians, counter-clockwise positive; lengths are metres. The robot frame has
x forward and y to the left.
"""

from __future__ import annotations

import math

import numpy as np


def wrap_angle(angle_rad):
    """Wrap to the half-open interval (-pi, pi]; works on floats and arrays."""
    wrapped = np.mod(np.asarray(angle_rad, dtype=float) + math.pi, 2.0 * math.pi) - math.pi
    wrapped = np.where(wrapped == -math.pi, math.pi, wrapped)
    return float(wrapped) if np.ndim(wrapped) == 0 else wrapped


def wrap_angle_scalar(angle_rad: float) -> float:
    """Scalar :func:`wrap_angle` for the control loop (no numpy call overhead)."""
    wrapped = math.fmod(angle_rad + math.pi, 2.0 * math.pi)
    if wrapped < 0.0:
        wrapped += 2.0 * math.pi
    wrapped -= math.pi
    return math.pi if wrapped == -math.pi else wrapped


def to_robot_frame(point, robot_xy, heading_rad: float) -> tuple[float, float]:
    """Coordinates of a world point in the robot frame (x forward, y left)."""
    dx, dy = point[0] - robot_xy[0], point[1] - robot_xy[1]
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    return (c * dx + s * dy, -s * dx + c * dy)


def rectangle_circle_clearance(
    robot_xy, heading_rad: float, length_m: float, width_m: float, circle_xy, radius_m: float
) -> float:
    """Distance between a rectangle centred on the robot and a circle's surface.

    Negative when they overlap (then it is minus the circle's penetration depth of its
    centre point, which is enough to decide contact).
    """
    lx, ly = to_robot_frame(circle_xy, robot_xy, heading_rad)
    hx, hy = 0.5 * length_m, 0.5 * width_m
    qx, qy = abs(lx) - hx, abs(ly) - hy
    outside = math.hypot(max(qx, 0.0), max(qy, 0.0))
    inside = min(max(qx, qy), 0.0)
    return outside + inside - radius_m


def rectangle_circles_clearance(
    robot_xy,
    heading_rad: float,
    length_m: float,
    width_m: float,
    centres: np.ndarray,
    radii: np.ndarray,
) -> np.ndarray:
    """Vectorised :func:`rectangle_circle_clearance` over (n, 2) centres and (n,) radii."""
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    d = centres - np.asarray(robot_xy, dtype=float)
    lx = c * d[:, 0] + s * d[:, 1]
    ly = -s * d[:, 0] + c * d[:, 1]
    qx = np.abs(lx) - 0.5 * length_m
    qy = np.abs(ly) - 0.5 * width_m
    outside = np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0))
    inside = np.minimum(np.maximum(qx, qy), 0.0)
    return outside + inside - radii


def ray_circle_distance(origin, direction_rad: float, centre, radius_m: float) -> float:
    """Distance along a ray to the first crossing of a circle, or ``inf`` if it misses.

    A ray that starts inside the circle hits at distance 0.
    """
    ux, uy = math.cos(direction_rad), math.sin(direction_rad)
    fx, fy = origin[0] - centre[0], origin[1] - centre[1]
    c = fx * fx + fy * fy - radius_m * radius_m
    if c <= 0.0:
        return 0.0
    b = fx * ux + fy * uy
    disc = b * b - c
    if disc < 0.0 or b > 0.0:
        return math.inf
    return -b - math.sqrt(disc)


def point_segment_distance(points: np.ndarray, a, b) -> np.ndarray:
    """Distance of each of (n, 2) points from the segment a-b."""
    a = np.asarray(a, dtype=float)
    ab = np.asarray(b, dtype=float) - a
    denom = float(ab @ ab)
    ap = np.asarray(points, dtype=float) - a
    if denom == 0.0:
        return np.hypot(ap[:, 0], ap[:, 1])
    t = np.clip(ap @ ab / denom, 0.0, 1.0)
    closest = a + t[:, None] * ab
    diff = np.asarray(points, dtype=float) - closest
    return np.hypot(diff[:, 0], diff[:, 1])
