"""Small closed-form geometry used by the world, the sensors' tests and the metrics,
and every shape the viewer, the recordings and the figures draw.

Angles are radians, counter-clockwise positive; lengths are metres. The robot frame has
x forward and y to the left. Where both engines need a formula, its array form (the
batch engine's) and its float form (the pymunk engine's) sit side by side here
(:func:`rectangle_clearances` / :func:`rectangle_clearance`, :func:`target_inputs` /
:func:`target_input`, :func:`wrap_angles` / :func:`wrap_angle_scalar`).
"""

from __future__ import annotations

import math

import numpy as np

_hypot, _atan2 = math.hypot, math.atan2

#: A full turn: the default field of view, all around the robot.
FULL_CIRCLE_RAD = 2.0 * math.pi


def wrap_angle(angle_rad):
    """Wrap to the half-open interval (-pi, pi]; works on floats and arrays
    (:func:`wrap_angles`)."""
    wrapped = wrap_angles(np.asarray(angle_rad, dtype=float))
    return float(wrapped) if np.ndim(wrapped) == 0 else wrapped


def wrap_angles(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi]: the one definition; :func:`wrap_angle_scalar` is
    its form for one float (both engines; :mod:`world.kernels`).

    Parameters
    ----------
    angle : numpy.ndarray
        Angles, rad, any shape.

    Returns
    -------
    numpy.ndarray
        The wrapped angles, the shape of ``angle``.
    """
    wrapped = np.fmod(angle + math.pi, 2.0 * math.pi)
    wrapped = np.where(wrapped < 0.0, wrapped + 2.0 * math.pi, wrapped)
    wrapped = wrapped - math.pi
    return np.where(wrapped == -math.pi, math.pi, wrapped)


def wrap_angle_scalar(angle_rad: float) -> float:
    """:func:`wrap_angles` for one float (the pymunk engine's loop: no numpy call), the
    same operations in the same order (tests/test_world.py compares them bit for bit)."""
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


def to_world_frame(points, robot_xy, heading_rad: float) -> np.ndarray:
    """World coordinates of points given in the robot frame: :func:`to_robot_frame`'s
    inverse.

    Parameters
    ----------
    points : array_like, (2,) or (n, 2)
        Points in the robot frame (x forward, y left), metres.
    robot_xy : array_like, (2,)
        The robot's centre in the world, metres.
    heading_rad : float
        The robot's heading.

    Returns
    -------
    numpy.ndarray
        The points in the world, the shape of ``points``.
    """
    p = np.asarray(points, dtype=float)
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    x = robot_xy[0] + c * p[..., 0] - s * p[..., 1]
    y = robot_xy[1] + s * p[..., 0] + c * p[..., 1]
    return np.stack([x, y], axis=-1)


def rectangle_circle_clearance(
    robot_xy, heading_rad: float, length_m: float, width_m: float, circle_xy, radius_m: float
) -> float:
    """Distance between a rectangle centred on the robot and a circle's surface
    (:func:`rectangle_clearance` from a pose).

    Negative when they overlap (then it is minus the circle's penetration depth of its
    centre point, which is enough to decide contact).
    """
    return rectangle_clearance(
        math.cos(heading_rad), math.sin(heading_rad),
        circle_xy[0] - robot_xy[0], circle_xy[1] - robot_xy[1], radius_m,
        0.5 * length_m, 0.5 * width_m,
    )  # fmt: skip


def rectangle_circles_clearance(
    robot_xy,
    heading_rad: float,
    length_m: float,
    width_m: float,
    centres: np.ndarray,
    radii: np.ndarray,
) -> np.ndarray:
    """:func:`rectangle_circle_clearance` over (n, 2) centres and (n,) radii."""
    d = centres - np.asarray(robot_xy, dtype=float)
    return rectangle_clearances(
        math.cos(heading_rad), math.sin(heading_rad), d[:, 0], d[:, 1], radii,
        0.5 * length_m, 0.5 * width_m,
    )  # fmt: skip


def rectangle_clearance(
    c: float, s: float, dx: float, dy: float, radius: float, half_length_m: float,
    half_width_m: float,
) -> float:  # fmt: skip
    """:func:`rectangle_clearances` on floats: one obstacle of one run (the pymunk
    engine's per-step scene, :meth:`world.arena.Arena._scene`). The same operations in
    the same order; ``math.hypot`` may differ from numpy's in the last bit."""
    qx = abs(c * dx + s * dy) - half_length_m
    qy = abs(-s * dx + c * dy) - half_width_m
    inside = min(max(qx, qy), 0.0)
    return _hypot(max(qx, 0.0), max(qy, 0.0)) + inside - radius


def rectangle_clearances(c, s, dx, dy, radius, half_length_m, half_width_m):
    """The one footprint-to-surface formula of both engines, on arrays that broadcast:
    a rectangle with heading cosine ``c`` and sine ``s`` and a circle whose centre is
    ``(dx, dy)`` from the rectangle's (:func:`world.kernels.footprint_clearances`,
    :func:`world.kernels.swept_clearances`, :func:`rectangle_circles_clearance`); its
    form for floats is :func:`rectangle_clearance`, beside it.

    Parameters
    ----------
    c, s : numpy.ndarray
        The heading's cosine and sine.
    dx, dy : numpy.ndarray
        The circle's centre minus the rectangle's, m.
    radius : numpy.ndarray or float
        The circle's radius, m.
    half_length_m, half_width_m : float
        Half the rectangle's length and width, m.

    Returns
    -------
    numpy.ndarray
        The clearances, m, negative when they overlap.
    """
    qx = np.abs(c * dx + s * dy) - half_length_m
    qy = np.abs(-s * dx + c * dy) - half_width_m
    inside = np.where(qy > qx, qy, qx)
    inside = np.where(0.0 < inside, 0.0, inside)
    outside = np.hypot(np.where(0.0 > qx, 0.0, qx), np.where(0.0 > qy, 0.0, qy))
    return outside + inside - radius


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


def beam_cone_outlines(
    origins: np.ndarray,
    directions: np.ndarray,
    lengths: np.ndarray,
    half_width_rad: float,
    arc_points: int = 5,
) -> np.ndarray:
    """Closed outlines of beam cones: origin, an arc at the cone's length, origin.

    Parameters
    ----------
    origins : numpy.ndarray, (n, 2)
        Where each beam starts (any frame: the world, or the robot's for mounts).
    directions : numpy.ndarray, (n,)
        Each beam's axis, radians in the same frame.
    lengths : numpy.ndarray, (n,)
        How far each cone reaches from its origin, metres.
    half_width_rad : float
        The cone's half angle either side of the axis.
    arc_points : int
        Points on the far arc, from ``direction - half_width_rad`` (right edge) to
        ``direction + half_width_rad`` (left edge), evenly spaced; at least 2.

    Returns
    -------
    numpy.ndarray, (n, arc_points + 2, 2)
        Each cone as a closed polyline.
    """
    origins = np.asarray(origins, dtype=float)
    length = np.asarray(lengths, dtype=float)[:, None]
    angle = np.asarray(directions, dtype=float)[:, None] + np.linspace(
        -half_width_rad, half_width_rad, arc_points
    )
    arc = np.stack(
        [origins[:, 0:1] + length * np.cos(angle), origins[:, 1:2] + length * np.sin(angle)],
        axis=-1,
    )
    return np.concatenate([origins[:, None], arc, origins[:, None]], axis=1)


def beam_cones(
    origins: np.ndarray, directions: np.ndarray, lengths: np.ndarray, half_width_rad: float
) -> tuple[np.ndarray, np.ndarray]:
    """(left edge ends, right edge ends), each (n, 2): the far corners of beam cones
    from (n, 2) ``origins`` along ``directions`` (n,), ``lengths`` (n,) long and
    ``half_width_rad`` either side: :func:`beam_cone_outlines` with no arc between."""
    outline = beam_cone_outlines(origins, directions, lengths, half_width_rad, arc_points=2)
    return outline[:, 2], outline[:, 1]


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
    from every pose, centre to centre (:func:`target_inputs`)."""
    return target_inputs(pose[:, 0], pose[:, 1], pose[:, 2], target_xy)


def target_input(pose, target) -> tuple[float, float]:
    """:func:`target_inputs` on floats: ``(d_t, phi_t)`` of a target ``(x, y)`` seen
    from a pose ``(x, y, heading)`` (the pymunk engine's perception)."""
    dx, dy = target[0] - pose[0], target[1] - pose[1]
    return _hypot(dx, dy), wrap_angle_scalar(_atan2(dy, dx) - pose[2])


def target_inputs(x, y, heading, target) -> tuple[np.ndarray, np.ndarray]:
    """The target's distance and bearing from each robot, Eqs. 9-10: the batch engine's
    (:mod:`world.kernels`) and the drawings' (:func:`target_geometry`); its float form
    is :func:`target_input`, beside it.

    Parameters
    ----------
    x, y, heading : numpy.ndarray, (n,)
        The robots' poses, m and rad.
    target : numpy.ndarray, (n, 2)
        The targets, m.

    Returns
    -------
    tuple of numpy.ndarray
        ``(d_t, phi_t)``, each (n,): m and rad in (-pi, pi].
    """
    dx = target[:, 0] - x
    dy = target[:, 1] - y
    return np.hypot(dx, dy), wrap_angles(np.arctan2(dy, dx) - heading)


def circle_points(radius_m: float, segments: int) -> np.ndarray:
    """(segments + 1, 2): a closed circle of ``radius_m`` around the origin."""
    a = np.linspace(0.0, 2.0 * math.pi, segments + 1)
    return np.stack([radius_m * np.cos(a), radius_m * np.sin(a)], axis=-1)


# ---------------------------------------------------------------------------------------
# The robot's own shapes, in its frame (x forward, y left, z up from the ground).


def rounded_rectangle(
    length_m: float, width_m: float, offset_m: float, n_arc: int = 8
) -> np.ndarray:
    """Closed outline of a length x width rectangle grown by ``offset_m``: the points
    ``offset_m`` from the footprint (the safe ring), round at the corners.

    Parameters
    ----------
    length_m, width_m : float
        The rectangle, centred on the origin, length along x; ``(0, 0)`` gives a circle
        of radius ``offset_m`` (the paper's point robot).
    offset_m : float
        How far the outline lies from the rectangle.
    n_arc : int
        Segments per quarter-circle corner.

    Returns
    -------
    numpy.ndarray, (4 * (n_arc + 1) + 1, 2)
        The corners' arcs counter-clockwise from the front left, closed (the last point
        is the first).
    """
    hx, hy = 0.5 * length_m, 0.5 * width_m
    centres = np.array([(hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy)])
    starts = np.array([0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi])
    a = starts[:, None] + 0.5 * math.pi * np.arange(n_arc + 1) / n_arc
    x = centres[:, 0:1] + offset_m * np.cos(a)
    y = centres[:, 1:2] + offset_m * np.sin(a)
    points = np.stack([x, y], axis=-1).reshape(-1, 2)
    return np.vstack([points, points[:1]])


def footprint_exit_m(length_m: float, width_m: float, bearing_rad):
    """How far from the centre a ray at ``bearing_rad`` (robot frame) leaves a length x
    width footprint: where a bearing's line starts outside the robot.

    Parameters
    ----------
    length_m, width_m : float
        The footprint, centred on the robot; ``(0, 0)`` for the paper's point robot,
        which every ray leaves at 0.
    bearing_rad : float or array_like
        The ray's bearing from the heading.

    Returns
    -------
    float or numpy.ndarray
        The distance, metres, for each bearing.
    """
    c = np.abs(np.cos(np.asarray(bearing_rad, dtype=float)))
    s = np.abs(np.sin(np.asarray(bearing_rad, dtype=float)))
    with np.errstate(divide="ignore", invalid="ignore"):
        along = np.where(c > 1e-9, 0.5 * length_m / c, math.inf)
        across = np.where(s > 1e-9, 0.5 * width_m / s, math.inf)
    exit_m = np.minimum(along, across)
    return float(exit_m) if np.ndim(exit_m) == 0 else exit_m


def bearing_segments(
    pose,
    distance_m: float,
    bearing_rad: float,
    radius_m: float,
    start_m: float = 0.0,
    arc_segments: int = 8,
) -> np.ndarray:
    """A distance and a bearing drawn on the robot, as line segments in the world.

    Parameters
    ----------
    pose : (x, y, heading)
        The robot's pose (metres, radians).
    distance_m : float
        The distance (d_t, d_o), drawn along the bearing from ``start_m`` off the centre.
    bearing_rad : float
        The bearing from the heading (phi_t, phi_o).
    radius_m : float
        The radius of the heading's line and of the arc from the heading to the bearing.
    start_m : float
        Where the distance starts along the bearing (:func:`footprint_exit_m` for a
        footprint-to-surface distance).
    arc_segments : int
        Segments of the arc.

    Returns
    -------
    numpy.ndarray, (arc_segments + 2, 2, 2)
        Segment 0 the distance, 1 the heading's radius, then the arc.
    """
    x, y, heading = pose
    a = heading + bearing_rad
    seg = np.empty((arc_segments + 2, 2, 2))
    seg[0, 0] = (x + start_m * math.cos(a), y + start_m * math.sin(a))
    seg[0, 1] = (
        x + (start_m + distance_m) * math.cos(a),
        y + (start_m + distance_m) * math.sin(a),
    )
    seg[1, 0] = (x, y)
    seg[1, 1] = (x + radius_m * math.cos(heading), y + radius_m * math.sin(heading))
    angles = heading + np.linspace(0.0, bearing_rad, arc_segments + 1)
    arc = np.column_stack([x + radius_m * np.cos(angles), y + radius_m * np.sin(angles)])
    seg[2:, 0] = arc[:-1]
    seg[2:, 1] = arc[1:]
    return seg


#: The drawn Husky A200's wheels (m): radius, width, and the half wheelbase. Drawn only;
#: the LG model's wheel radius (husky.toml) is a fitted parameter, not the tyre's.
HUSKY_WHEEL_RADIUS_M = 0.165
HUSKY_WHEEL_WIDTH_M = 0.11
HUSKY_HALF_WHEELBASE_M = 0.256


def husky_body_boxes(length_m: float, width_m: float) -> dict[str, tuple[tuple, tuple]]:
    """The Husky's drawn body as boxes sized from its footprint.

    Parameters
    ----------
    length_m, width_m : float
        The footprint (husky.toml's ``[footprint]``).

    Returns
    -------
    dict
        ``{name: (dimensions (x, y, z), centre (x, y, z))}``, metres in the robot frame,
        for ``"body"`` (the yellow hull), ``"deck"`` (the top plate) and ``"bumper"``.
    """
    L, W = length_m, width_m
    return {
        "body": ((L, W * 0.78, 0.26), (0.0, 0.0, 0.25)),
        "deck": ((0.62 * L, 0.62 * W, 0.03), (-0.06 * L, 0.0, 0.39)),
        "bumper": ((0.06, W * 0.78, 0.12), (0.5 * L - 0.03, 0.0, 0.2)),
    }


def husky_wheel_centres(width_m: float) -> np.ndarray:
    """The drawn wheels' centres, inside the footprint and resting on the ground.

    Parameters
    ----------
    width_m : float
        The footprint's width; the wheels' centres lie 5.5 cm inside its sides.

    Returns
    -------
    numpy.ndarray, (4, 3)
        Front left, front right, rear left, rear right, metres in the robot frame.
    """
    signs = np.array([(1, 1), (1, -1), (-1, 1), (-1, -1)], dtype=float)
    return np.column_stack(
        [
            signs[:, 0] * HUSKY_HALF_WHEELBASE_M,
            signs[:, 1] * (0.5 * width_m - 0.055),
            np.full(4, HUSKY_WHEEL_RADIUS_M),
        ]
    )
