"""fuzzynav's tracker (items 7 and 10 of docs/fuzzynav.md's design):
the nearest obstacle's centre and velocity, and where the target stands, in a frame of its
own dead reckoned with the turn's real lag (``turn_lag``).

- **Yield or pass first**: every ``store_s`` the nearest obstacle's centre is estimated
  and its velocity followed (:meth:`Tracker.track`); once it has been seen moving often
  enough, the robot stops or goes on at full speed, whichever keeps the predicted closest
  approach farther (:meth:`Tracker.dodge`, :func:`dodge_speed`,
  :func:`closest_approach_m`).
- **Doubted inputs**: a target reading that places it far from where the agreeing
  readings put it is doubted, and the tracked target steered by instead
  (:meth:`Tracker.check_target`).
"""

from __future__ import annotations

import math

from fuzzynav.controller.fuzzynav_robot import (
    _AXES,
    _HX,
    _HY,
    _V_PER_VOLT,
    _W_PER_VOLT,
    VOLTAGE_LIMIT_V,
    range_at_clearance,
)


def closest_approach_m(rel, obstacle_vel, robot_vel, horizon_s: float) -> float:
    """Smallest distance between an obstacle (``rel`` from the robot, moving at
    ``obstacle_vel``) and the robot (moving at ``robot_vel``) over ``[0, horizon_s]``,
    both at constant velocity: ``|rel + r t*|`` with ``r`` the relative velocity and
    ``t* = clip(-rel . r / |r|^2, 0, horizon_s)``."""
    rx, ry = obstacle_vel[0] - robot_vel[0], obstacle_vel[1] - robot_vel[1]
    r2 = rx * rx + ry * ry
    # Only an exactly zero relative velocity has no closest time: a tiny one (1e-8 m/s)
    # still moves the obstacle by its speed times the horizon.
    t = 0.0 if r2 == 0.0 else min(max(-(rel[0] * rx + rel[1] * ry) / r2, 0.0), horizon_s)
    return math.hypot(rel[0] + rx * t, rel[1] + ry * t)


def dodge_speed(
    speed_v: float, rel, obstacle_vel, heading_rad: float, horizon_s: float, safe_m: float
) -> float:
    """The speed command (V) against a moving obstacle: ``speed_v`` if the predicted
    closest approach along the heading stays at least ``safe_m``, else whichever of
    stopping or full speed keeps the obstacle farther (by more than 5 cm), else
    ``speed_v``. Reversing is not a candidate: nothing looks backwards."""
    c, s = math.cos(heading_rad), math.sin(heading_rad)

    def approach(v):
        mps = _V_PER_VOLT * v
        return closest_approach_m(rel, obstacle_vel, (mps * c, mps * s), horizon_s)

    best_v, best_m = speed_v, approach(speed_v)
    if best_m >= safe_m:
        return speed_v
    for candidate in (0.0, VOLTAGE_LIMIT_V):
        m = approach(candidate)
        if m > best_m + 0.05:
            best_v, best_m = candidate, m
    return best_v


class Tracker:
    """The tracker's state, cleared by :meth:`reset`: its dead-reckoned frame
    (``track_pose``, ``track_w``), the nearest obstacle in it (``obs_centre``,
    ``obs_vel``, ``obs_sightings``) and the target in it (``target_est``, a doubted
    reading that keeps still: ``target_candidate`` and for how long, and whether the last
    reading was doubted: ``target_doubted``). Reads the controller's crisp parameters
    (``params``, shared)."""

    def __init__(self, params: dict):
        self.axes = _AXES  # the sonars' axes: the robot's (set_sensor_mounts)
        self.hx, self.hy = _HX, _HY  # the footprint's half-sizes: the robot's (set_robot)
        self.params = params
        self.reset()

    def reset(self) -> None:
        # Tracker of the nearest obstacle (ideal perception), in its own dead-reckoned
        # frame whose heading uses the turn's real lag (docs/fuzzynav.md's design, item 7).
        self.track_pose = [0.0, 0.0, 0.0]
        self.track_w = 0.0
        self.lose()
        # The target as placed by its readings (tracker frame), and a doubted reading
        # that keeps still (the target moved?) and for how long.
        self.target_est: tuple[float, float] | None = None
        self.target_candidate: tuple[float, float] | None = None
        self.target_candidate_s = 0.0
        self.target_doubted = False

    def advance(self, cl: float, cr: float, speed_mps: float, dt: float) -> None:
        """Dead reckoning over the last period from the last command ``(cl, cr)`` (V):
        the turn rate with the turn's lag, the speed ``speed_mps`` as the echo memory's
        odometry has it."""
        p = self.params
        self.track_w += (_W_PER_VOLT * 0.5 * (cr - cl) - self.track_w) * p["turn_lag"]
        tp = self.track_pose
        tp[0] += speed_mps * dt * math.cos(tp[2])
        tp[1] += speed_mps * dt * math.sin(tp[2])
        tp[2] += self.track_w * dt

    def lose(self) -> None:
        """No nearest obstacle (or a doubted one): the track restarts at the next."""
        self.obs_centre: tuple[float, float] | None = None  # estimated nearest centre
        self.obs_vel = (0.0, 0.0)  # its estimated velocity (m/s)
        self.obs_sightings = 0  # consecutive consistent sightings

    def dodge(self, speed: float) -> tuple[float, str]:
        """The speed command (V) against the tracked obstacle, and what it does
        ("yield", "pass first" or ""): a moving obstacle on a collision course makes the
        robot stop, or go on at full speed, when that keeps its predicted closest
        approach farther (yield or pass first)."""
        p = self.params
        dodge = ""
        if p["dodge_horizon_s"] > 0.0 and self.obs_sightings >= p["dodge_sightings"]:
            vx, vy = self.obs_vel
            if vx * vx + vy * vy > p["dodge_min_speed_mps"] ** 2:
                tp = self.track_pose
                centre = self.obs_centre
                assert centre is not None  # seen: obs_sightings > 0
                rel = (centre[0] - tp[0], centre[1] - tp[1])
                commanded = speed
                speed = dodge_speed(
                    speed, rel, (vx, vy), tp[2], p["dodge_horizon_s"], p["dodge_safe_m"]
                )
                if speed != commanded:
                    dodge = "yield" if speed == 0.0 else "pass first"
        return speed, dodge

    def new_target(self) -> None:
        """The target was moved on purpose (a user dragged it in the viewer): take the
        next reading as it is instead of doubting it until it settles."""
        self.target_est = None
        self.target_candidate = None
        self.target_doubted = False

    def check_target(self, d_t: float, phi_t: float) -> tuple[float, float]:
        """The target's distance and bearing to steer by: the reading, unless it is
        provably disturbed, else where the target was tracked.

        The target stands still, so a reading that places it (in the tracker's
        dead-reckoned frame) more than ``target_gate_m`` from where the agreeing readings
        put it is doubted, and the tracked position is steered by instead (s3 adds
        ``sin(2 t)`` to every input for 10 s: the target would seem to swing by a metre
        and a radian). A doubted reading that stays put for ``target_settle_s`` (within
        ``target_still_m`` of where it was first) is the target moved, and is taken: a
        disturbance does not keep still, a target that was moved does (one moved on
        purpose, as the viewer's drag, is announced with :meth:`new_target`).
        """
        p = self.params
        tp = self.track_pose
        mx = tp[0] + d_t * math.cos(tp[2] + phi_t)
        my = tp[1] + d_t * math.sin(tp[2] + phi_t)
        est = self.target_est
        self.target_doubted = False
        if est is None:
            self.target_est = (mx, my)
            return d_t, phi_t
        if (mx - est[0]) ** 2 + (my - est[1]) ** 2 < p["target_gate_m"] ** 2:
            k = p["target_filter"]
            self.target_est = (est[0] + k * (mx - est[0]), est[1] + k * (my - est[1]))
            self.target_candidate = None
            return d_t, phi_t
        cand = self.target_candidate
        if (
            cand is not None
            and (mx - cand[0]) ** 2 + (my - cand[1]) ** 2 < p["target_still_m"] ** 2
        ):
            self.target_candidate_s += p["control_period_s"]
        else:
            self.target_candidate = (mx, my)
            self.target_candidate_s = 0.0
        if self.target_candidate_s >= p["target_settle_s"]:
            self.target_est = (mx, my)
            self.target_candidate = None
            return d_t, phi_t
        self.target_doubted = True
        ex, ey = est[0] - tp[0], est[1] - tp[1]
        bearing = math.atan2(ey, ex) - tp[2]
        return math.hypot(ex, ey), math.atan2(math.sin(bearing), math.cos(bearing))

    def track(self, d_o: float, phi_o: float, store_dt: float) -> None:
        """Update the nearest obstacle's estimated centre and velocity (every store_s).

        The centre is placed at ``dodge_radius_m`` beyond the surface along the bearing
        (:func:`range_at_clearance` of ``d_o + radius``): for a static obstacle of another
        radius it then hardly slides as the robot passes. A jump of more than 0.3 m is
        another obstacle (or a disturbed input): the track restarts. An ultrasonic
        sighting's bearing is the sensor's axis, which says nothing of motion across the
        beam: it restarts the track too, so the dodge acts in ideal perception only.
        """
        p = self.params
        x, y, heading = self.track_pose
        rho = range_at_clearance(phi_o, d_o + p["dodge_radius_m"], self.hx, self.hy)
        cx, cy = x + rho * math.cos(heading + phi_o), y + rho * math.sin(heading + phi_o)
        prev = self.obs_centre
        if (
            prev is not None
            and phi_o not in self.axes
            and (cx - prev[0]) ** 2 + (cy - prev[1]) ** 2 < 0.3**2
        ):
            h = store_dt
            vx, vy = self.obs_vel
            self.obs_vel = (
                0.5 * vx + 0.5 * (cx - prev[0]) / h,
                0.5 * vy + 0.5 * (cy - prev[1]) / h,
            )
            self.obs_sightings += 1
        else:
            self.obs_vel = (0.0, 0.0)
            self.obs_sightings = 0
        self.obs_centre = (cx, cy)
