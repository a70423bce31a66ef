"""The stages of one step, in one place: angle wrapping, the obstacles' motion law,
footprint clearance, the pose update, the sonar rays, perception and the run metrics'
per-row terms, each on arrays of many runs (the angle wrapping, the clearance formula
and the target inputs are :mod:`world.geometry`'s, re-exported).

The lockstep batch engine (:mod:`world.batch_world`) is made of these functions. The
pymunk engine calls the same stages for one run: the motion law on floats
(:func:`law_centre` and its kin take floats and arrays alike), and where speed needs a
form of its own, the float form sits beside the array form (:func:`target_input` /
:func:`target_inputs`, :func:`nearest_obstacle` / :func:`ideal_obstacle_inputs`,
:func:`sonar_obstacle_input` / :func:`sonar_obstacle_inputs`,
:func:`world.geometry.rectangle_clearance` / :func:`footprint_clearances`). The two
forms do the same operations in the same order, but libm's and numpy's ``hypot``,
``atan2`` and ``sin`` may differ in the last bit, so the engines are checked against each
other by outcomes and by values within a stated tolerance (paths within 1e-9 m:
tests/test_batch.py, tests/test_tangent.py), not bit for bit; the contact rule's
nanometre (:data:`CONTACT_CLEARANCE_M`) keeps those bits from deciding an outcome.

Shapes: ``n`` runs, ``M`` obstacle columns per run (absent obstacles have a NaN radius
and are masked by the callers), ``B`` sonar rays. Lengths in m, angles in rad, times
in s.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from fuzzynav.world.geometry import (
    rectangle_clearances,
    target_input,
    target_inputs,
    wrap_angle_scalar,
    wrap_angles,
)

#: The sweep's sample spacing in relative motion (m): the footprint-to-surface clearance
#: changes by at most the relative displacement of robot and obstacle, so the true
#: minimum over a step lies at most half this below the smallest sample, and no contact
#: deeper than that is missed (:meth:`world.arena.Arena._sweep`).
SWEEP_SPACING_M = 0.005
#: The contact rule of both engines: the robot touches an obstacle when its
#: footprint-to-surface clearance is at most this (m). Not 0: the engines compute the
#: same clearance with libm's and numpy's functions, which may differ in the last bit,
#: and an obstacle whose path is tangent to the robot's sits at 0 +- 1e-16 m, where
#: those bits decided the outcome; a nanometre (the engines' path tolerance) is far from
#: both.
CONTACT_CLEARANCE_M = 1e-9
#: The most samples in one step's sweep of one obstacle (100 m/s at a 1 s period is
#: 20,000 samples at 5 mm: bounded, vectorised).
SWEEP_MAX_SAMPLES = 50_000

__all__ = [
    "CONTACT_CLEARANCE_M",
    "advance_pose",
    "arc_poses",
    "disturbance_values",
    "footprint_clearances",
    "ideal_obstacle_inputs",
    "line_deviation",
    "nearest_obstacle",
    "obstacle_centres",
    "obstacle_law",
    "obstacle_path_bound",
    "law_centre",
    "law_velocity",
    "law_path_bound",
    "LAW_SIZE",
    "sonar_distances",
    "sonar_obstacle_input",
    "sonar_obstacle_inputs",
    "swept_clearances",
    "target_input",
    "target_inputs",
    "wrap_angles",
]


def obstacle_law(spec: Any) -> tuple[float, ...]:
    """An obstacle's motion law as both engines hold it, from its scenario entry: the
    paper's constant acceleration (Eq. 13-14) as ``p0x, p0y, v0x, v0y, a_x / 2,
    a_y / 2``. The law is written here once: :func:`law_centre`, :func:`law_velocity`
    and :func:`law_path_bound` read it, on plain floats (the arena's
    :class:`world.arena.Obstacle`) and on arrays (the batch engine, through
    :func:`obstacle_centres` and :func:`obstacle_path_bound`), so a scenario key that
    changes how obstacles move is this function, those three and the key's reading.

    Parameters
    ----------
    spec : world.scenario.ObstacleSpec
        Its ``position`` (m), ``velocity`` (m/s) and ``acceleration`` (m/s^2) at the
        law's start.

    Returns
    -------
    tuple of float
        The law's :data:`LAW_SIZE` numbers.
    """
    (px, py), (vx, vy), (ax, ay) = spec.position, spec.velocity, spec.acceleration
    return (float(px), float(py), float(vx), float(vy), 0.5 * float(ax), 0.5 * float(ay))


#: How many numbers an obstacle's law holds (:func:`obstacle_law`).
LAW_SIZE = 6


def law_centre(law: Iterable[Any], tau: Any) -> tuple[Any, Any]:
    """The centre ``p0 + v0 tau + (a / 2) tau^2`` at ``tau`` after the law's start.

    Parameters
    ----------
    law : sequence
        :func:`obstacle_law`'s numbers, floats or arrays alike (one per number).
    tau : float or numpy.ndarray
        The time since the law's start, s (broadcast against the law's numbers).

    Returns
    -------
    tuple
        ``(x, y)``, m, floats or arrays as given.
    """
    px, py, vx, vy, hax, hay = law
    return px + vx * tau + hax * tau * tau, py + vy * tau + hay * tau * tau


def law_velocity(law: Iterable[Any], tau: Any) -> tuple[Any, Any]:
    """The velocity ``v0 + a tau`` at ``tau`` after the law's start.

    Parameters
    ----------
    law : sequence
        As :func:`law_centre`.
    tau : float or numpy.ndarray
        The time since the law's start, s.

    Returns
    -------
    tuple
        ``(vx, vy)``, m/s.
    """
    _, _, vx, vy, hax, hay = law
    return vx + 2.0 * hax * tau, vy + 2.0 * hay * tau


def law_path_bound(law: Iterable[Any], tau: Any, dt: float) -> Any:
    """A bound on the length the obstacle travels in ``[tau, tau + dt]``: ``|v(tau)| dt
    + |a / 2| dt^2`` (how finely the swept test samples a step).

    Parameters
    ----------
    law : sequence
        As :func:`law_centre`.
    tau : float or numpy.ndarray
        The time since the law's start at the step's start, s.
    dt : float
        The step, s.

    Returns
    -------
    float or numpy.ndarray
        The bound, m.
    """
    vx, vy = law_velocity(law, tau)
    _, _, _, _, hax, hay = law
    # a square root by ** 0.5: the same operation on floats and on arrays
    return (vx * vx + vy * vy) ** 0.5 * dt + (hax * hax + hay * hay) ** 0.5 * dt * dt


def obstacle_centres(law: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every run's obstacles' centres at the run's time (:func:`law_centre`).

    Parameters
    ----------
    law : numpy.ndarray, (n, LAW_SIZE, M)
        Per obstacle its :func:`obstacle_law` (laws start at the run's start).
    t : numpy.ndarray, (n,)
        Each run's time since its start, s.

    Returns
    -------
    tuple of numpy.ndarray
        ``(cx, cy)``, each (n, M), m.
    """
    return law_centre(law.swapaxes(0, 1), t[:, None])


def obstacle_path_bound(law: np.ndarray, t0: np.ndarray, dt: float) -> np.ndarray:
    """Every run's obstacles' :func:`law_path_bound` over one step.

    Parameters
    ----------
    law : numpy.ndarray, (n, LAW_SIZE, M)
        The obstacles' laws, as :func:`obstacle_centres`.
    t0 : numpy.ndarray, (n,)
        Each run's time at the step's start, s.
    dt : float
        The step, s.

    Returns
    -------
    numpy.ndarray, (n, M)
        The bound, m.
    """
    return law_path_bound(law.swapaxes(0, 1), t0[:, None], dt)


def footprint_clearances(x, y, heading, cx, cy, radius, half_length_m, half_width_m):
    """Footprint-to-surface clearance of every obstacle of every run, negative when they
    overlap: the arena's per-step formula (:meth:`world.arena.Arena._scene`,
    :func:`world.geometry.rectangle_circle_clearance`) on arrays.

    Parameters
    ----------
    x, y, heading : numpy.ndarray, (n,)
        The robots' poses, m and rad.
    cx, cy, radius : numpy.ndarray, (n, M)
        The obstacles' centres and radii, m.
    half_length_m, half_width_m : float
        Half the footprint's length and width (0 for the paper's point robot), m.

    Returns
    -------
    numpy.ndarray, (n, M)
        The clearances, m.
    """
    c = np.cos(heading)[:, None]
    s = np.sin(heading)[:, None]
    return rectangle_clearances(
        c, s, cx - x[:, None], cy - y[:, None], radius, half_length_m, half_width_m
    )


def advance_pose(x, y, heading, forward_speed_m_s, yaw_rate_rad_s, dt_s):
    """The poses after one step, as the arena moves the pymunk body
    (:meth:`world.arena.Arena.step`): the chord of the step's arc along the mid-step
    heading as the velocity, then Chipmunk's ``p + v dt`` and ``a + w dt``.

    Parameters
    ----------
    x, y, heading : numpy.ndarray, (n,)
        The poses at the step's start, m and rad.
    forward_speed_m_s, yaw_rate_rad_s : numpy.ndarray, (n,)
        The step-mean forward speed (m/s) and yaw rate (rad/s).
    dt_s : float
        The step, s.

    Returns
    -------
    tuple of numpy.ndarray
        ``(x, y, heading)`` at the step's end.
    """
    half_turn = 0.5 * yaw_rate_rad_s * dt_s
    with np.errstate(invalid="ignore", divide="ignore"):
        chord_scale = np.where(np.abs(half_turn) > 1e-9, np.sin(half_turn) / half_turn, 1.0)
    speed = forward_speed_m_s * chord_scale
    mid_heading = heading + half_turn
    vx = speed * np.cos(mid_heading)
    vy = speed * np.sin(mid_heading)
    return x + vx * dt_s, y + vy * dt_s, heading + yaw_rate_rad_s * dt_s


def sonar_distances(ox, oy, ux, uy, max_range_m, cx, cy, radius):
    """Echo distance of each ray against every circle, nearest over the circles, by
    Chipmunk's segment query (``cpShapeSegmentQuery``: a ray starting inside a circle
    hits at 0, else ``CircleSegmentQuery``'s quadratic).

    Parameters
    ----------
    ox, oy, ux, uy : numpy.ndarray, (n, B)
        The rays' origins (m) and unit directions.
    max_range_m : float
        The rays' length, m.
    cx, cy, radius : numpy.ndarray, (n, M)
        The circles (radius NaN for none), m.

    Returns
    -------
    numpy.ndarray, (n, B)
        The distances, m; inf where a ray meets nothing.
    """
    ax = ox[:, :, None]
    ay = oy[:, :, None]
    bx = ax + max_range_m * ux[:, :, None]
    by = ay + max_range_m * uy[:, :, None]
    cx = cx[:, None, :]
    cy = cy[:, None, :]
    r = radius[:, None, :]
    dax, day = ax - cx, ay - cy
    dbx, dby = bx - cx, by - cy
    da_da = dax * dax + day * day
    da_db = dax * dbx + day * dby
    db_db = dbx * dbx + dby * dby
    qa = da_da - 2.0 * da_db + db_db
    qb = da_db - da_da
    with np.errstate(invalid="ignore", divide="ignore"):
        det = qb * qb - qa * (da_da - r * r)
        t = (-qb - np.sqrt(det)) / qa
        hit = (det >= 0.0) & (0.0 <= t) & (t <= 1.0)
        alpha = np.where(hit, t, np.inf)
        alpha = np.where(np.sqrt(da_da) - r <= 0.0, 0.0, alpha)  # starts inside: 0
    return alpha.min(axis=2, initial=np.inf) * max_range_m


def swept_clearances(
    pose0, v, w, dt, law, radius, t0, half_length_m, half_width_m, path_m
) -> tuple[np.ndarray, np.ndarray]:
    """The footprint's clearance to one obstacle at the samples of one step's arc, for
    one run: the robot on its exact arc (constant v and w over the step), the obstacle
    by its law; both engines' sweep (:meth:`world.arena.Arena._sweep`).

    Parameters
    ----------
    pose0 : tuple of float
        ``(x, y, heading)`` at the step's start, m and rad.
    v, w : float
        The step-mean forward speed (m/s) and yaw rate (rad/s).
    dt : float
        The step, s.
    law : sequence of float
        The obstacle's law ``p0x, p0y, v0x, v0y, a_x / 2, a_y / 2``.
    radius : float
        The obstacle's radius, m.
    t0 : float
        The time at the step's start since the law's start, s.
    half_length_m, half_width_m : float
        Half the footprint's length and width, m.
    path_m : float
        The bound on the relative path over the step (how many samples), m.

    Returns
    -------
    tuple of numpy.ndarray
        The clearances (m) and their instants into the step (s).
    """
    n = min(SWEEP_MAX_SAMPLES, int(math.ceil(path_m / SWEEP_SPACING_M)) + 2)
    tau = np.linspace(0.0, dt, n)
    x, y, heading = arc_poses(pose0, v, w, tau)
    cx, cy = law_centre(law, t0 + tau)
    return (
        rectangle_clearances(
            np.cos(heading), np.sin(heading), cx - x, cy - y, radius, half_length_m, half_width_m
        ),
        tau,
    )


def arc_poses(pose0, v: float, w: float, tau):
    """The poses ``tau`` seconds into a step at constant forward speed ``v`` (m/s) and
    yaw rate ``w`` (rad/s) from ``pose0`` (x, y, heading): the robot's exact arc, as the
    sweep samples it (:func:`swept_clearances`; the arena's contact events).

    Parameters
    ----------
    pose0 : tuple of float
        ``(x, y, heading)`` at the step's start, m and rad.
    v, w : float
        The step-mean forward speed and yaw rate.
    tau : numpy.ndarray
        Instants into the step, s.

    Returns
    -------
    tuple of numpy.ndarray
        ``(x, y, heading)``, each the shape of ``tau``.
    """
    x0, y0, h0 = pose0
    heading = h0 + w * tau
    if abs(w) > 1e-12:
        x = x0 + (v / w) * (np.sin(heading) - math.sin(h0))
        y = y0 - (v / w) * (np.cos(heading) - math.cos(h0))
    else:
        x = x0 + v * tau * math.cos(h0)
        y = y0 + v * tau * math.sin(h0)
    return x, y, heading


def ideal_obstacle_inputs(
    x, y, heading, cx, cy, radius, present, clear, half_field, point_robot, cutoff_m
) -> tuple[np.ndarray, np.ndarray]:
    """The nearest obstacle's distance and bearing in ideal perception, Eqs. 7-12 or the
    footprint's clearance; its float form is :func:`nearest_obstacle`.

    Parameters
    ----------
    x, y, heading : numpy.ndarray, (n,)
        The robots' poses, m and rad.
    cx, cy, radius : numpy.ndarray, (n, M)
        The obstacles' centres and radii, m.
    present : numpy.ndarray, (n, M) bool
        Which columns hold an obstacle.
    clear : numpy.ndarray, (n, M)
        The footprint clearances (:func:`footprint_clearances`), m.
    half_field : numpy.ndarray, (n,)
        Half of each run's field of view, rad (inf: all around).
    point_robot : bool
        The paper's point robot: distances centre to centre (Eq. 8).
    cutoff_m : float
        Obstacles farther than this are not sensed, m.

    Returns
    -------
    tuple of numpy.ndarray
        ``(d_o, phi_o)``, each (n,), NaN where nothing is sensed.
    """
    n = x.size
    clear = np.where(present, clear, np.inf)
    if point_robot:
        clear = clear + np.where(present, radius, 0.0)  # Eq. 8, centre to centre
    limited = np.isfinite(half_field)
    if limited.any():  # obstacles outside the field are not sensed
        bearings = wrap_angles(np.arctan2(cy - y[:, None], cx - x[:, None]) - heading[:, None])
        outside = limited[:, None] & (np.abs(bearings) > half_field[:, None])
        clear = np.where(outside, np.inf, clear)
    k = np.argmin(clear, axis=1)
    rows_n = np.arange(n)
    nearest = clear[rows_n, k]
    nearest = np.where(0.0 > nearest, 0.0, nearest)
    seen = ~(nearest > cutoff_m)
    d_o = np.where(seen, nearest, np.nan)
    bearing = np.arctan2(cy[rows_n, k] - y, cx[rows_n, k] - x) - heading
    return d_o, np.where(seen, wrap_angles(bearing), np.nan)


def nearest_obstacle(
    scene, pose, cutoff_m: float, centre_to_centre: bool = False, half_field=None
) -> tuple[float, float, int]:
    """:func:`ideal_obstacle_inputs` on one run's floats (the pymunk engine's
    perception): ``(d_o, phi_o, index in scene)`` of the nearest obstacle sensed from
    ``pose``, NaN, NaN, -1 when none is within ``cutoff_m``.

    Parameters
    ----------
    scene : world.arena's per-step scene
        Its ``radii`` ([1]), centres ``xy`` ([2]) and footprint ``clearances`` ([3]).
    pose : tuple of float
        The robot's ``(x, y, heading)``.
    cutoff_m : float
        Obstacles farther than this are not sensed, m.
    centre_to_centre : bool
        The paper's point robot (Eq. 8): distances centre to centre.
    half_field : float, optional
        Half the field of view, rad (None: all around).
    """
    clearances = scene[3]
    if not clearances:
        return math.nan, math.nan, -1
    x, y, heading = pose
    if centre_to_centre:  # Eq. 8: a point robot's clearance plus the radius
        clearances = [c + r for c, r in zip(clearances, scene[1])]
    if half_field is not None:  # obstacles outside the field are not sensed
        clearances = [
            c
            if abs(wrap_angle_scalar(math.atan2(cy - y, cx - x) - heading)) <= half_field
            else math.inf
            for c, (cx, cy) in zip(clearances, scene[2])
        ]
    k = clearances.index(min(clearances))  # np.argmin's first minimum
    nearest = max(clearances[k], 0.0)
    if nearest > cutoff_m:
        return math.nan, math.nan, -1
    cx, cy = scene[2][k]
    return nearest, wrap_angle_scalar(math.atan2(cy - y, cx - x) - heading), k


def sonar_obstacle_input(ranges: list, mount_angles: list, cutoff_m: float):
    """:func:`sonar_obstacle_inputs` on one run's floats: ``(d_o, phi_o)``, the nearest
    reading and its mount's angle, NaN, NaN beyond ``cutoff_m``.

    Parameters
    ----------
    ranges : list of float
        The readings, m (inf: no echo).
    mount_angles : list of float
        The sensors' angles in the robot frame, rad.
    cutoff_m : float
        Readings beyond this are no obstacle, m.
    """
    k = ranges.index(min(ranges))  # np.argmin's first minimum
    if ranges[k] <= cutoff_m:
        return ranges[k], mount_angles[k]
    return math.nan, math.nan


def sonar_obstacle_inputs(ranges, mount_angle, cutoff_m) -> tuple[np.ndarray, np.ndarray]:
    """The nearest sonar reading and its mount's angle (ultrasonic perception); its
    float form is :func:`sonar_obstacle_input`.

    Parameters
    ----------
    ranges : numpy.ndarray, (n, S)
        The readings, m (inf: no echo).
    mount_angle : numpy.ndarray, (S,)
        The sonars' angles in the robot frame, rad.
    cutoff_m : float
        Readings beyond this are no obstacle, m.

    Returns
    -------
    tuple of numpy.ndarray
        ``(d_o, phi_o)``, each (n,), NaN where nothing is sensed.
    """
    k = np.argmin(ranges, axis=1)
    nearest = ranges[np.arange(len(ranges)), k]
    seen = nearest <= cutoff_m
    return np.where(seen, nearest, np.nan), np.where(seen, mount_angle[k], np.nan)


def disturbance_values(disturbance: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Each run's disturbance now, ``amplitude sin(omega t)`` inside its window, else 0
    (:meth:`world.scenario.Disturbance.value`).

    Parameters
    ----------
    disturbance : numpy.ndarray, (n, 4)
        ``amplitude, omega (rad/s), start (s), stop (s)``; a run without one has an
        empty window.
    t : numpy.ndarray, (n,)
        Each run's time, s.

    Returns
    -------
    numpy.ndarray, (n,)
        The values added to every input.
    """
    amp, omega, d_start, d_stop = disturbance.T
    on = (d_start <= t) & (t < d_stop)
    return np.where(on, amp * np.sin(omega * t), 0.0)


def line_deviation(x, y, start, seg, seg_len2) -> np.ndarray:
    """Each robot's distance from its start-target segment, the per-row term of MAD and
    RMSE (:func:`world.metrics.deviation_from_line`).

    Parameters
    ----------
    x, y : numpy.ndarray, (n,)
        The robots' positions, m.
    start : numpy.ndarray, (n, 2)
        The segments' starts, m.
    seg : numpy.ndarray, (n, 2)
        Target minus start, m.
    seg_len2 : numpy.ndarray, (n,)
        The segments' squared lengths, m^2.

    Returns
    -------
    numpy.ndarray, (n,)
        The distances, m.
    """
    px = x - start[:, 0]
    py = y - start[:, 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        along = np.clip((px * seg[:, 0] + py * seg[:, 1]) / seg_len2, 0.0, 1.0)
    along = np.where(seg_len2 == 0.0, 0.0, along)
    return np.hypot(x - (start[:, 0] + along * seg[:, 0]), y - (start[:, 1] + along * seg[:, 1]))
