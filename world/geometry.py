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


# ---------------------------------------------------------------------------------------
# What the viewer, the recordings and the figures draw, vectorised over poses: pose is
# (n, 3) rows of (x, y, heading). One place for each, so that they all draw the same.


def footprint_outlines(pose: np.ndarray, length_m: float, width_m: float) -> np.ndarray:
    """(n, 5, 2): the closed outline of a length x width footprint centred on each pose."""
    hl, hw = 0.5 * length_m, 0.5 * width_m
    corners = np.array([(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw), (hl, hw)])
    c, s = np.cos(pose[:, 2])[:, None], np.sin(pose[:, 2])[:, None]
    x = pose[:, 0:1] + c * corners[:, 0] - s * corners[:, 1]
    y = pose[:, 1:2] + s * corners[:, 0] + c * corners[:, 1]
    return np.stack([x, y], axis=-1)


def beam_geometries(pose: np.ndarray, mounts) -> tuple[np.ndarray, np.ndarray]:
    """(origins (n, k, 2), directions (n, k)) in the world of k sensors mounted at
    ``mounts`` (each with ``x_m``, ``y_m``, ``angle_rad`` in the robot frame) at every
    pose: ``RangeSensorArray.beam_geometry`` for many poses."""
    mx = np.array([m.x_m for m in mounts])
    my = np.array([m.y_m for m in mounts])
    ma = np.array([m.angle_rad for m in mounts])
    h = pose[:, 2:3]
    c, s = np.cos(h), np.sin(h)
    ox = pose[:, 0:1] + c * mx - s * my
    oy = pose[:, 1:2] + s * mx + c * my
    return np.stack([ox, oy], axis=-1), h + ma


def beam_cones(
    origins: np.ndarray, directions: np.ndarray, lengths: np.ndarray, half_width_rad: float
) -> tuple[np.ndarray, np.ndarray]:
    """(left edge ends, right edge ends), each (n, 2): the far corners of beam cones
    from (n, 2) ``origins`` along ``directions`` (n,), ``lengths`` (n,) long and
    ``half_width_rad`` either side."""
    length = np.asarray(lengths, dtype=float)[:, None]
    d = np.asarray(directions, dtype=float)[:, None]
    left = origins + length * np.hstack([np.cos(d + half_width_rad), np.sin(d + half_width_rad)])
    right = origins + length * np.hstack([np.cos(d - half_width_rad), np.sin(d - half_width_rad)])
    return left, right


def points_along(origins: np.ndarray, directions: np.ndarray, distances: np.ndarray) -> np.ndarray:
    """(n, 2): the points ``distances`` (n,) from (n, 2) ``origins`` along ``directions``
    (n,), e.g. where a range sensor's reading puts its echo on the beam's axis."""
    d = np.asarray(directions, dtype=float)[:, None]
    return origins + np.asarray(distances, dtype=float)[:, None] * np.hstack([np.cos(d), np.sin(d)])


def obstacle_bearings(pose: np.ndarray, obstacle_xy: np.ndarray) -> np.ndarray:
    """(n, n_obstacles): the bearing of each obstacle's centre (``obstacle_xy`` is
    (n, n_obstacles, 2)) from the heading, in (-pi, pi]."""
    dx = obstacle_xy[:, :, 0] - pose[:, 0:1]
    dy = obstacle_xy[:, :, 1] - pose[:, 1:2]
    return wrap_angle(np.arctan2(dy, dx) - pose[:, 2:3])


def target_geometry(pose: np.ndarray, target_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance d_t, bearing phi_t in (-pi, pi]) of the target (``target_xy`` (n, 2))
    from every pose, centre to centre."""
    dx = target_xy[:, 0] - pose[:, 0]
    dy = target_xy[:, 1] - pose[:, 1]
    return np.hypot(dx, dy), wrap_angle(np.arctan2(dy, dx) - pose[:, 2])


def circle_points(radius_m: float, segments: int) -> np.ndarray:
    """(segments + 1, 2): a closed circle of ``radius_m`` around the origin."""
    a = np.linspace(0.0, 2.0 * math.pi, segments + 1)
    return np.stack([radius_m * np.cos(a), radius_m * np.sin(a)], axis=-1)
