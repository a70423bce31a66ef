"""fuzzynav's bearing planner (item 2 of docs/fuzzynav.md's design):
the free bearing nearest the target's, past every remembered echo, and the side it passes on.

Each remembered point between ``plan_nearest_m`` and ``plan_horizon_m`` (and not beyond
the target) blocks the cone of bearings whose ray passes it nearer than the half-width +
``plan_margin_m`` (:func:`blocked_cones`); the goal block is fed the free bearing nearest
the target's (:func:`free_bearing`) instead of the target's own. The side is latched while
points are near and changes only for a shorter detour, as the design describes.
"""

from __future__ import annotations

import math

from fuzzynav.controller.fuzzynav_robot import _AXES, _HX, _HY


def blocked_cones(
    points_robot,
    radius_m: float,
    horizon_m: float,
    beyond_m: float,
    nearest_m: float = 0.0,
    rearmost_m: float = 0.0,
) -> list[tuple[float, float]]:
    """Bearings (rad, > 0 left) the robot's centre line may not take, one interval per point.

    A point at distance ``rho`` and bearing ``beta`` (robot frame) is passed at a lateral
    distance of at least ``radius_m`` by every heading outside
    ``beta -+ asin(radius_m / rho)``; a point nearer than ``radius_m`` blocks a half plane.
    Points farther than ``horizon_m``, farther than ``beyond_m`` (the target: what lies
    beyond it does not matter), nearer than ``nearest_m`` or behind ``x = rearmost_m``
    (robot frame, x ahead) are ignored. With ``rearmost_m < 0`` points beside the robot
    block bearings beyond 90 degrees, which a detour round a trap has to take.
    """
    cones = []
    limit = min(horizon_m, beyond_m)
    for bx, by in points_robot:
        rho = math.hypot(bx, by)
        if rho > limit or rho < nearest_m or bx < rearmost_m:
            continue
        beta = math.atan2(by, bx)
        half = math.asin(radius_m / rho) if rho > radius_m else 0.5 * math.pi
        cones.append((beta - half, beta + half))
    return cones


def free_bearing(
    cones: list[tuple[float, float]], phi_t: float, side: float
) -> tuple[float, float]:
    """The bearing nearest the target's that no cone blocks, and the side it passes on.

    Overlapping cones merge into one blocked interval. If ``phi_t`` is free it is
    returned with side 0; otherwise the interval's edge on ``side`` (+1: pass with the
    obstacles on the right, i.e. the left edge) is returned, or, with ``side`` 0, the
    nearer edge (the shorter detour).
    """
    lo = hi = phi_t
    blocked = False
    grown = True
    while grown:
        grown = False
        for a, b in cones:
            if a <= hi and b >= lo and (a < lo or b > hi or not blocked):
                if a < lo:
                    lo = a
                if b > hi:
                    hi = b
                blocked = grown = True
    if not blocked:
        return phi_t, 0.0
    if side == 0.0:
        side = 1.0 if hi - phi_t <= phi_t - lo else -1.0
    return (hi if side > 0 else lo), side


class BearingPlanner:
    """The planner's state: the side it passes on (``side``: +1 left, -1 right, 0 free),
    its bearing as an offset from the target's (``offset``, rad) and when it last changed
    side (``flip_t``). Reads the controller's crisp parameters (``params``, shared)."""

    def __init__(self, params: dict):
        self.params = params
        self.axes = _AXES  # the sonars' axes: the robot's (set_sensor_mounts)
        self.hx, self.hy = _HX, _HY  # the footprint's half-sizes: the robot's (set_robot)
        self.reset()

    def reset(self) -> None:
        self.side = 0.0  # side the bearing planner passes on (+1 left), 0 = free
        self.offset = 0.0  # planned bearing minus the target's (rad)
        self.flip_t = -math.inf

    def update(self, ahead, d_t: float, phi_t: float, phi_o: float, t: float, best_t: float):
        """Plan from the remembered points ``ahead`` (robot frame, not behind its rear
        edge) at time ``t``; ``best_t`` is when the target distance last improved (the
        progress watch). Sets ``side`` and ``offset``."""
        p = self.params
        # Bearing planner: the free bearing nearest the target's, passing every
        # remembered point at plan_margin_m off the flank; held between updates as
        # an offset from the target's bearing.
        # Points beside the robot (back to its rear edge) count as well: they bound
        # the detours of more than 90 degrees that lead out of a trap; without them
        # the side turned away from looked free and the robot turned back and forth.
        cones = blocked_cones(
            ahead,
            self.hy + p["plan_margin_m"],
            p["plan_horizon_m"],
            d_t + 0.3,
            p["plan_nearest_m"],
            -self.hx,
        )
        # The side is latched while remembered points are near (plan_latch_m), even
        # when the target's bearing is momentarily free, so that the planner and the
        # avoidance block never dither between two sides. Farther away it changes
        # side only for a detour shorter by plan_switch_rad.
        near_block = any(bx * bx + by * by < p["plan_latch_m"] ** 2 for bx, by in ahead)
        latched = self.side
        psi, side_now = free_bearing(cones, phi_t, latched)
        if side_now != 0.0 and latched == 0.0:
            latched = side_now
        elif side_now != 0.0 and (not near_block or abs(psi - phi_t) > p["plan_flip_rad"]):
            # near points hold the side, unless its detour has grown past
            # plan_flip_rad (the robot would turn back): then the other side, if it
            # is a real shortcut (a detour under plan_flip_rad) and the robot is
            # making progress, at most once per plan_flip_min_s; in any case once
            # the side has been held plan_flip_hold_s
            other, _ = free_bearing(cones, phi_t, -latched)
            held_s = t - self.flip_t
            # With points near, a detour is also charged the turn to its bearing
            # from the heading (both are bearings relative to it), so that a robot
            # turning on the spot towards one side does not see the other come out
            # shorter at each new echo and turn back (clutter, U-traps). Only with
            # all-around sensing (a nearest obstacle off the beam axes, ideal
            # perception): with the beams alone the flank of the side kept is
            # unseen, and runs came nearer obstacles (docs/fuzzynav-log.md).
            turn_w = (
                p["plan_turn_weight"]
                if near_block and phi_o == phi_o and phi_o not in self.axes
                else 0.0
            )
            if abs(other - phi_t) + turn_w * abs(other) + p["plan_switch_rad"] < abs(
                psi - phi_t
            ) + turn_w * abs(psi) and (
                not near_block
                or held_s > p["plan_flip_hold_s"]
                or (
                    held_s > p["plan_flip_min_s"]
                    and abs(other - phi_t) < p["plan_flip_rad"]
                    and t - best_t < p["plan_stuck_s"]
                )
            ):
                psi, latched = other, -latched
                self.flip_t = t
        elif side_now == 0.0 and not near_block:
            latched = 0.0
        self.side = latched
        self.offset = psi - phi_t
